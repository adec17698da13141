"""The node chain on several "hosts": network namespaces joined by a bridge (netns.py).

Layouts, both with ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET (DDS over eth0, not loopback):
  multi:  jk5_sim_driver, naic_controller, friction_compensation and rclpy in four hosts;
  single: the same four processes in one host (the reference, same settings).

Used by tests/python/test_ros_multihost.py, and as a benchmark (root, iproute2):

    python tests/ros/multihost.py --seconds 30     # prints JSON: latency and missed cycles, both layouts

The binaries: cargo build --release -p jk5_sim_driver -p naic_controller -p friction_compensation.
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(__file__))
import netns  # noqa: E402
import rostest_util as ru  # noqa: E402

ROOT = ru.ROOT
PROBE = pathlib.Path(__file__).with_name("multihost_probe.py")
HOSTS = ["drv", "ctl", "fc", "py", "one"]
LAYOUTS = {
    "multi": {"jk5_sim_driver": "drv", "naic_controller": "ctl", "friction_compensation": "fc", "probe": "py"},
    "single": {"jk5_sim_driver": "one", "naic_controller": "one", "friction_compensation": "one", "probe": "one"},
}


def build():
    """The three node binaries (built with `naic`, as the other node tests do, so the
    dependencies are compiled once with the same features)."""
    return ru.build_nodes()


def subnet_env(domain):
    """DDS on the hosts' subnet: SUBNET discovery (multicast on eth0), never loopback-only."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    # ROS_LOCALHOST_ONLY=1 would make naic_ros loopback-only; ROS_STATIC_PEERS is not ours here.
    for k in ("ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS"):
        env.pop(k, None)
    return env


def node_args(node, lockstep, latency_report=None, warmup=2.0):
    args = ["--ros-args", "--params-file", f"params/{node}.yaml"]
    if lockstep:
        args += ["-p", "use_sim_time:=true"]
        if node == "jk5_sim_driver":
            args += ["-p", "lockstep:=true", "-p", "paused:=true"]
    elif latency_report and node == "jk5_sim_driver":
        args += ["-p", f"latency_report:={latency_report}", "-p", f"latency_warmup:={warmup}"]
    return args


def run(hosts, layout, bins, domain, lockstep, until_sim=4.0, seconds=10.0, warmup=5.0):
    """Start the three nodes and the probe in `layout`; returns {probe, latency, logs}.
    Lockstep: the probe resumes the paused driver and records up to `until_sim` simulated
    seconds. Real time: the driver's chain statistics skip `warmup` s (discovery, approach,
    contact), then the chain runs `seconds` more; the probe records /naic/params meanwhile."""
    where = LAYOUTS[layout]
    env = subnet_env(domain)
    penv = ru.with_naic_msgs(env)
    tmp = tempfile.mkdtemp(prefix="naic-multihost-")
    report = os.path.join(tmp, "latency.json")
    procs = {}
    try:
        for node in ru.NODES:
            cmd = hosts.exec_prefix(where[node]) + [str(bins / node)] + node_args(node, lockstep, report, warmup)
            procs[node] = ru.Proc(cmd, env)
        t0 = time.time()
        pargs = ["--until-sim", str(until_sim)] if lockstep else ["--seconds", str(seconds)]
        probe = subprocess.run(hosts.exec_prefix(where["probe"]) + [sys.executable, str(PROBE), *pargs],
                               env=penv, cwd=ROOT, capture_output=True, text=True, timeout=240)
        if not lockstep:
            # The chain statistics cover [warmup, stop): make that `seconds` long.
            left = t0 + warmup + seconds - time.time()
            if left > 0:
                time.sleep(left)
        alive = {n: p.alive() for n, p in procs.items()}
    finally:
        codes = {n: p.stop(timeout=15) for n, p in procs.items()}
    logs = {n: p.output() for n, p in procs.items()}
    assert probe.returncode == 0, f"probe failed ({layout}):\n{probe.stderr[-3000:]}"
    assert all(alive.values()), f"a node died ({layout}): {alive}\n" + "\n".join(v[-1500:] for v in logs.values())
    assert all(c == 0 for c in codes.values()), f"exit codes ({layout}): {codes}"
    latency = None
    if not lockstep:
        with open(report) as f:
            latency = json.load(f)
    shutil.rmtree(tmp, ignore_errors=True)
    return {"probe": json.loads(probe.stdout.strip().splitlines()[-1]), "latency": latency, "logs": logs}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=30.0, help="measured seconds per layout")
    ap.add_argument("--rounds", type=int, default=1, help="alternate single/multi this many times")
    a = ap.parse_args()
    why = netns.unavailable()
    if why:
        sys.exit(f"multihost: {why}")
    bins = build()
    hosts = netns.Hosts(HOSTS)
    try:
        isolation = hosts.check_isolated()
        out = {"bench": "multihost chain", "isolation": isolation, "seconds": a.seconds, "runs": []}
        for r in range(a.rounds):
            for layout in ("single", "multi"):
                res = run(hosts, layout, bins, ru.fresh_domain(r * 2 + (layout == "multi")), False, seconds=a.seconds)
                out["runs"].append({"layout": layout, **res["latency"],
                                    "discovered_after_s": res["probe"]["discovered_after_s"]})
        for layout in ("single", "multi"):
            runs = [x for x in out["runs"] if x["layout"] == layout]
            out[layout] = {k: sum(x[k] for x in runs) / len(runs) for k in ("median_us", "p99_us", "missed_per_min")}
        s, m = out["single"]["missed_per_min"], out["multi"]["missed_per_min"]
        out["missed_ratio_multi_over_single"] = m / s if s > 0 else (0.0 if m == 0 else float("inf"))
        out["loadavg_at_end"] = open("/proc/loadavg").read().strip()
        print(json.dumps(out, indent=2))
    finally:
        hosts.close()


if __name__ == "__main__":
    main()
