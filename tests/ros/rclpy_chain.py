"""The rclpy reference chain of `naic bench chain`: the same three-process topology and
messages as the Rust nodes, with trivial computation, so the measured difference is the
middleware + client library.

  python rclpy_chain.py driver --duration 60 --report out.json [--rate 1000] [--warmup 2]
  python rclpy_chain.py controller
  python rclpy_chain.py friction

driver: publishes /joint_states, /wrench, /clock at `rate` (absolute-deadline sleeps in a
thread); stamps with the wall clock; on each /joint_effort_cmd takes the `stamp_ns=` of the
dimension label and records arrival − stamp. A cycle is missed when the command for the
previous state has not arrived by the next tick. controller: /joint_states → /naic/effort.
friction: /naic/effort → /joint_effort_cmd (label passed through). Same conventions as the
Rust driver (nodes/jk5_sim_driver).
"""
import argparse
import json
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

PUB_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
SUB_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST)
SUB_RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
JOINTS = [f"joint{i}" for i in range(1, 7)]


def stamp_of(msg):
    if not msg.layout.dim:
        return None
    for kv in msg.layout.dim[0].label.split(";"):
        if kv.startswith("stamp_ns="):
            return int(kv[len("stamp_ns="):])
    return None


def effort(data, stamp_ns):
    m = Float64MultiArray(data=data)
    m.layout.dim = [MultiArrayDimension(label=f"joints;stamp_ns={stamp_ns}", size=6, stride=6)]
    return m


def run_driver(a):
    node = rclpy.create_node("jk5_sim_driver")
    js_pub = node.create_publisher(JointState, "/joint_states", PUB_QOS)
    w_pub = node.create_publisher(WrenchStamped, "/wrench", PUB_QOS)
    c_pub = node.create_publisher(Clock, "/clock", PUB_QOS)
    lock = threading.Lock()
    st = {"lat": [], "last_src": None, "started": False}
    t_start = time.time()

    def on_cmd(m):
        now = time.time_ns()
        s = stamp_of(m)
        with lock:
            st["last_src"] = s
            if s is not None:
                st["started"] = True
                if time.time() - t_start > a.warmup:
                    st["lat"].append(now - s)

    node.create_subscription(Float64MultiArray, "/joint_effort_cmd", on_cmd, SUB_RELIABLE)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    stop = threading.Event()
    counters = {"cycles": 0, "missed": 0}

    def loop():
        period = 1.0 / a.rate
        nxt = time.monotonic()
        js = JointState(name=JOINTS, position=[0.0] * 6, velocity=[0.0] * 6, effort=[0.0] * 6)
        ws = WrenchStamped()
        ws.header.frame_id = "ft_sensor"
        last_pub = None
        t_sim = 0
        while not stop.is_set():
            nxt += period
            d = nxt - time.monotonic()
            if d > 0:
                time.sleep(d)
            with lock:
                if st["started"] and last_pub is not None and time.time() - t_start > a.warmup:
                    if st["last_src"] != last_pub:
                        counters["missed"] += 1
            ns = time.time_ns()
            sec, nsec = divmod(ns, 1_000_000_000)
            js.header.stamp.sec, js.header.stamp.nanosec = sec, nsec
            ws.header.stamp = js.header.stamp
            t_sim += int(period * 1e9)
            clk = Clock()
            clk.clock.sec, clk.clock.nanosec = divmod(t_sim, 1_000_000_000)
            w_pub.publish(ws)
            js_pub.publish(js)
            c_pub.publish(clk)
            last_pub = ns
            counters["cycles"] += 1

    th = threading.Thread(target=loop, daemon=True)
    th.start()
    t_end = time.time() + a.duration
    while time.time() < t_end:
        ex.spin_once(timeout_sec=0.05)
    stop.set()
    th.join()
    with lock:
        lat = sorted(st["lat"])
    dur = a.duration - a.warmup

    def q(f):
        return lat[round((len(lat) - 1) * f)] / 1e3 if lat else float("nan")

    rep = {"samples": len(lat), "cycles": counters["cycles"], "median_us": q(0.5), "p99_us": q(0.99),
           "max_us": lat[-1] / 1e3 if lat else float("nan"), "missed_cycles": counters["missed"],
           "missed_per_min": counters["missed"] / (dur / 60.0), "duration_s": dur}
    with open(a.report, "w") as f:
        json.dump(rep, f)
    node.destroy_node()


def run_relay(name, sub_topic, sub_type, pub_topic, make):
    node = rclpy.create_node(name)
    pub = node.create_publisher(Float64MultiArray, pub_topic, PUB_QOS)
    node.create_subscription(sub_type, sub_topic, lambda m: pub.publish(make(m)), SUB_QOS)
    if name == "naic_controller":
        node.create_subscription(WrenchStamped, "/wrench", lambda m: None, SUB_QOS)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["driver", "controller", "friction"])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--warmup", type=float, default=2.0)
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--report", default="rclpy_chain.json")
    a = ap.parse_args()
    rclpy.init()
    try:
        if a.role == "driver":
            run_driver(a)
        elif a.role == "controller":
            run_relay("naic_controller", "/joint_states", JointState, "/naic/effort",
                      lambda m: effort([0.0] * 6, m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec))
        else:
            run_relay("friction_compensation", "/naic/effort", Float64MultiArray, "/joint_effort_cmd",
                      lambda m: effort(list(m.data), stamp_of(m) or 0))
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
