"""Soak test of the 1 kHz chain (issue 7, item 6): the three node processes plus N extra
rclpy subscriber processes on /joint_states, /wrench and /joint_effort_cmd, for M minutes.

Reports as one JSON line (stdout, and --out FILE): the driver's missed cycles and chain
latency (its own latency report), each node's resident memory (VmRSS) sampled over time
with a least-squares slope and first/last/max, what each subscriber received, and whether
any node panicked or died. Loopback only (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) on a
private ROS_DOMAIN_ID.

    .venv/bin/python tests/soak/soak.py --minutes 10 --subscribers 5 --out runs/soak.json

`--composed` soaks `naic launch --composed` instead (the three nodes in one process).

CI runs only a 20 s smoke version (tests/python/test_safety_soak.py).
"""
import argparse
import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "ros"))
import rostest_util as ru  # noqa: E402

SUBSCRIBER = r"""
import json, signal, sys, time
import rclpy
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
rclpy.init()
n = rclpy.create_node(sys.argv[1])
counts = {"/joint_states": 0, "/wrench": 0, "/joint_effort_cmd": 0}
first = {}
def cb(topic):
    def f(_m):
        counts[topic] += 1
        first.setdefault(topic, time.time())
    return f
n.create_subscription(JointState, "/joint_states", cb("/joint_states"), 100)
n.create_subscription(WrenchStamped, "/wrench", cb("/wrench"), 100)
n.create_subscription(Float64MultiArray, "/joint_effort_cmd", cb("/joint_effort_cmd"), 100)
stop = []
signal.signal(signal.SIGINT, lambda *a: stop.append(1))
signal.signal(signal.SIGTERM, lambda *a: stop.append(1))
while not stop:
    rclpy.spin_once(n, timeout_sec=0.1)
end = time.time()
print(json.dumps({"counts": counts, "rate_hz": {k: counts[k] / max(1e-9, end - first[k]) for k in first}}), flush=True)
"""


def rss_kib(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def slope_per_min(samples):
    """Least-squares slope of (t [s], rss [KiB]) in KiB per minute."""
    if len(samples) < 3:
        return None
    n = len(samples)
    mt = sum(t for t, _ in samples) / n
    mr = sum(r for _, r in samples) / n
    den = sum((t - mt) ** 2 for t, _ in samples)
    return 60.0 * sum((t - mt) * (r - mr) for t, r in samples) / den if den > 0 else None


def soak(seconds, subscribers, sample_every=5.0, warmup=5.0, log=sys.stderr, composed=False):
    """`composed`: the three nodes in one process (`naic launch --composed`)."""
    bins = ru.build_nodes()
    domain = ru.fresh_domain(17)
    env = ru.ros_env(domain)
    report = pathlib.Path(tempfile.mkdtemp(prefix="naic_soak_")) / "latency.json"
    nodes = {} if composed else {
        "naic_controller": ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file",
                                    "params/naic_controller.yaml"], env),
        "friction_compensation": ru.Proc([str(bins / "friction_compensation"), "--ros-args", "--params-file",
                                          "params/friction_compensation.yaml"], env),
    }
    subs = [subprocess.Popen([sys.executable, "-c", SUBSCRIBER, f"soak_sub{i}"], env=env, cwd=ru.ROOT,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             preexec_fn=ru._die_with_parent) for i in range(subscribers)]
    time.sleep(2.0)  # let the controller and subscribers come up before the first state
    if composed:
        nodes["naic_composed"] = ru.Proc([str(bins / "naic"), "launch", "--composed", "-p",
                                          f"jk5_sim_driver:latency_report:={report}", "-p",
                                          f"jk5_sim_driver:latency_warmup:={warmup}"], env)
    else:
        nodes["jk5_sim_driver"] = ru.Proc([str(bins / "jk5_sim_driver"), "--ros-args", "--params-file",
                                           "params/jk5_sim_driver.yaml", "-p", f"latency_report:={report}",
                                           "-p", f"latency_warmup:={warmup}"], env)
    rss = {name: [] for name in nodes}
    t0 = time.time()
    died = {}
    while time.time() - t0 < seconds:
        time.sleep(min(sample_every, max(0.0, seconds - (time.time() - t0))))
        t = time.time() - t0
        for name, p in nodes.items():
            if not p.alive():
                died.setdefault(name, round(t, 1))
                continue
            r = rss_kib(p.p.pid)
            if r is not None:
                rss[name].append((t, r))
        print(f"soak t={t:6.0f}s rss_kib={ {k: v[-1][1] if v else None for k, v in rss.items()} }", file=log, flush=True)
    stop_order = ["naic_composed"] if composed else ["jk5_sim_driver", "naic_controller", "friction_compensation"]
    codes = {name: nodes[name].stop(timeout=15) for name in stop_order}
    sub_out = []
    for s in subs:
        s.send_signal(signal.SIGINT)
        try:
            out, _ = s.communicate(timeout=40)
            sub_out.append(json.loads(out.strip().splitlines()[-1]) if out.strip() else {"error": "no output"})
        except (subprocess.TimeoutExpired, json.JSONDecodeError) as e:
            s.kill()
            sub_out.append({"error": str(e)})
    latency = json.loads(report.read_text()) if report.exists() else None
    mem = {}
    for name, samples in rss.items():
        after = [(t, r) for t, r in samples if t >= warmup + 10.0] or samples
        mem[name] = {
            "samples": len(samples),
            "rss_first_kib": after[0][1] if after else None,
            "rss_last_kib": after[-1][1] if after else None,
            "rss_max_kib": max((r for _, r in samples), default=None),
            "slope_kib_per_min": slope_per_min(after),
            # Second half only: growth that continues rather than a start-up plateau.
            "slope_second_half_kib_per_min": slope_per_min(after[len(after) // 2:]),
            "series_s_kib": [[round(t, 1), r] for t, r in samples],
        }
    logs = {name: p.output() for name, p in nodes.items()}
    return {
        "duration_s": round(time.time() - t0, 1),
        "subscribers": subscribers,
        "composed": composed,
        "domain": domain,
        "chain": latency,
        "memory": mem,
        "subscriber_received": sub_out,
        "exit_codes": codes,
        "died": died,
        "panicked": [n for n, out in logs.items() if "panicked" in out],
        "machine": {"nproc": os.cpu_count(), "cpu": _cpu_model()},
    }, logs


def _cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--subscribers", type=int, default=5)
    ap.add_argument("--sample-every", type=float, default=5.0, help="RSS sampling period [s]")
    ap.add_argument("--out", type=pathlib.Path, help="also write the JSON here")
    ap.add_argument("--composed", action="store_true", help="the three nodes in one process (naic launch --composed)")
    a = ap.parse_args()
    if not (a.minutes > 0 and 0 <= a.subscribers <= 50 and a.sample_every > 0):
        print("soak: error: --minutes must be > 0, --subscribers in 0..=50, --sample-every > 0", file=sys.stderr)
        return 2
    res, _ = soak(a.minutes * 60.0, a.subscribers, a.sample_every, composed=a.composed)
    line = json.dumps(res)
    print(line)
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(line + "\n")
    return 0 if not res["panicked"] and not res["died"] else 1


if __name__ == "__main__":
    sys.exit(main())
