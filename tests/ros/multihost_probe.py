"""The rclpy side of the multi-host test (tests/ros/multihost.py): run in its own network
namespace, it discovers the three nodes across the bridge, optionally resumes a paused
lockstep driver, records /naic/params and counts /joint_states, and prints one JSON object.

    python multihost_probe.py --until-sim 4.0       # lockstep: record up to 4 simulated s
    python multihost_probe.py --seconds 10          # real time: record 10 wall-clock s

Needs naic_msgs on PYTHONPATH/LD_LIBRARY_PATH (tests/ros/build_naic_msgs.sh --env).
"""
import argparse
import json
import time

import rclpy
from naic_msgs.msg import NaicParams
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

import rostest_util as ru  # this directory

NODES = {"jk5_sim_driver", "naic_controller", "friction_compensation"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--until-sim", type=float, help="lockstep: resume the driver, record up to this simulated time [s]")
    ap.add_argument("--seconds", type=float, help="real time: record this long [s]")
    ap.add_argument("--timeout", type=float, default=90.0)
    a = ap.parse_args()
    rclpy.init()
    n = rclpy.create_node("naic_multihost_probe")
    t_start = time.time()
    out = {"discovered_after_s": None, "nodes": []}

    def spin_until(cond, timeout):
        return ru.spin_node_until(n, cond, timeout)

    names = lambda: {x for x, _ in n.get_node_names_and_namespaces()}  # noqa: E731
    if spin_until(lambda: NODES <= names(), 30):
        out["discovered_after_s"] = time.time() - t_start
    out["nodes"] = sorted(names())

    trace = {}

    def on_params(m):
        ns = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        trace[ns] = [m.phase, m.desired_force, m.measured_force, m.m_d, m.b_d, m.sigma, m.e_f, m.fault]

    joint_states = [0]
    qos = QoSProfile(depth=100000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
    n.create_subscription(NaicParams, "/naic/params", on_params, qos)
    if a.until_sim is None:
        # Real time only: in lockstep the chain outruns a Python reader of every message.
        n.create_subscription(JointState, "/joint_states", lambda m: joint_states.__setitem__(0, joint_states[0] + 1), 100)
    spin_until(lambda: n.count_publishers("/naic/params") > 0, 30)

    if a.until_sim is not None:
        # The paused lockstep driver republishes its start state; once a report arrives this
        # reader is matched, and the driver is resumed (the run starts from the same state).
        spin_until(lambda: bool(trace), 30)
        out["matched_while_paused"] = bool(trace)
        c = AsyncParameterClient(n, "jk5_sim_driver")
        out["driver_services"] = c.wait_for_services(30.0)
        f = c.set_parameters([Parameter("paused", value=False)])
        rclpy.spin_until_future_complete(n, f, timeout_sec=10)
        out["resumed"] = bool(f.done() and f.result().results[0].successful)
        spin_until(lambda: trace and max(trace) >= a.until_sim * 1e9, a.timeout)
        trace = {k: v for k, v in trace.items() if k <= a.until_sim * 1e9}
    else:
        trace.clear()
        joint_states[0] = 0
        spin_until(lambda: False, a.seconds)
    out["joint_states"] = joint_states[0]
    out["params"] = {str(k): v for k, v in sorted(trace.items())}
    print(json.dumps(out))
    n.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
