"""Does rclpy's graph go back? (docs/notes/2026-12-dds-test-forensics.md, "The graph that went back"; issue 13.)

    python tests/ros/graph_flip_probe.py [--trials N] [--three-processes] [--bins DIR]

Each trial starts `naic launch --composed --lockstep -p naic_controller:scenario:=none` (or
the three processes) on a fresh private domain (loopback only), waits 1 s, then runs a new
rclpy participant in a subprocess, made as examples/slide_with_force_profile.py makes its
own (use_sim_time, publishers of both reference topics). That observer polls its graph every
2 ms for 4 s: is `naic_controller` listed as subscriber of /naic/target_pose and of
/naic/desired_wrench? A trial "went back" when both were listed and then, while the chain
still ran, not. Prints one JSON line per trial and the count. Unpatched rustdds (without
"Late joiners of a KeepLast writer", crates/vendor/rustdds/PATCHED.md) went back in 7 of
20 trials with the composed chain.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
import rostest_util as ru  # noqa: E402

TOPICS = ("/naic/target_pose", "/naic/desired_wrench")

OBSERVER = r'''
import json, sys, time
import rclpy
from rclpy.parameter import Parameter
from geometry_msgs.msg import PoseStamped, WrenchStamped
TOPICS = %r
rclpy.init()
n = rclpy.create_node("naic_slide_example")
n.set_parameters([Parameter("use_sim_time", value=True)])
n.create_publisher(PoseStamped, TOPICS[0], 1000)
n.create_publisher(WrenchStamped, TOPICS[1], 1000)
def state():
    return "".join("Y" if "naic_controller" in {i.node_name for i in n.get_subscriptions_info_by_topic(t)} else "n"
                   for t in TOPICS)
t0, states = time.time(), []
while time.time() - t0 < %f:
    rclpy.spin_once(n, timeout_sec=0.002)
    s = state()
    if not states or states[-1][1] != s:
        states.append((round(time.time() - t0, 4), s))
print(json.dumps(states))
'''


def trial(bins, three, seconds):
    domain = ru.fresh_domain()
    env = ru.ros_env(domain)
    args = [str(bins / "naic"), "launch", "--lockstep", "-p", "naic_controller:scenario:=none"]
    launch = ru.Proc(args if three else args[:2] + ["--composed"] + args[2:], env)
    try:
        time.sleep(1.0)
        out = subprocess.run([sys.executable, "-c", OBSERVER % (TOPICS, seconds)], env=env, capture_output=True,
                             text=True, timeout=seconds + 60)
        running = launch.p.poll() is None
    finally:
        launch.stop(timeout=15)
    if out.returncode != 0 or not running:
        return {"domain": domain, "error": (out.stderr or launch.output())[-500:], "chain_running": running}
    states = json.loads(out.stdout.strip().splitlines()[-1])
    went_back = any(a[1] == "YY" and b[1] != "YY" for a, b in zip(states, states[1:]))
    return {"domain": domain, "went_back": went_back, "states": states[:8], "load": os.getloadavg()[0]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--three-processes", action="store_true", help="naic launch without --composed")
    ap.add_argument("--bins", default=str(ru.ROOT / "target/release"), help="folder of the naic binaries")
    ap.add_argument("--seconds", type=float, default=4.0, help="how long each observer polls")
    a = ap.parse_args()
    import pathlib
    back = errors = 0
    for _ in range(a.trials):
        r = trial(pathlib.Path(a.bins), a.three_processes, a.seconds)
        back += bool(r.get("went_back"))
        errors += "error" in r
        print(json.dumps(r), flush=True)
    print(json.dumps({"trials": a.trials, "went_back": back, "errors": errors}), flush=True)


if __name__ == "__main__":
    main()
