"""The node chain on several hosts: jk5_sim_driver, naic_controller and friction_compensation
in three network namespaces and rclpy in a fourth, joined by a bridge on private addresses
(tests/ros/netns.py creates and removes them), with ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET:
discovery and data go over the hosts' eth0 and the bridge, not loopback. The hosts have no
default route and no link but their port on the test's bridge, so no packet leaves them.

Needs root and iproute2; skips with the reason otherwise.
"""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import multihost as mh  # noqa: E402
import netns  # noqa: E402
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")

SIM_SECONDS = 3.5


@pytest.fixture(scope="module")
def hosts():
    why = netns.unavailable()
    if why:
        pytest.skip(f"multi-host test needs network namespaces: {why}")
    bins = mh.build()
    h = netns.Hosts(mh.HOSTS)
    try:
        yield h, bins
    finally:
        h.close()  # asserts that no namespace of the test is left


def test_ros_multihost_hosts_are_isolated(hosts):
    h, _ = hosts
    summary = h.check_isolated()
    print(summary)


def test_ros_multihost_lockstep_chain_tracks_force_and_equals_one_host(hosts):
    """Lockstep (simulated time): the three nodes on three hosts discover each other and
    rclpy on a fourth, NAIC makes contact and holds 10 N, and every /naic/params sample is
    the same, bit for bit, as with all four processes on one host."""
    h, bins = hosts
    before = h.bridge_bytes()
    multi = mh.run(h, "multi", bins, ru.fresh_domain(10), lockstep=True, until_sim=SIM_SECONDS)
    crossed = h.bridge_bytes() - before
    single = mh.run(h, "single", bins, ru.fresh_domain(20), lockstep=True, until_sim=SIM_SECONDS)
    for name, r in (("multi", multi), ("single", single)):
        p = r["probe"]
        assert p["discovered_after_s"] is not None, f"{name}: rclpy saw only {p['nodes']}"
        assert p["resumed"], f"{name}: could not resume the driver over the bridge: {p}"
        assert len(p["params"]) > 0.9 * SIM_SECONDS * 1000, f"{name}: {len(p['params'])} /naic/params samples"
    # Data crossed the bridge: 1 kHz of joint states, wrenches, commands and reports.
    assert crossed > 2_000_000, f"only {crossed} bytes crossed the bridge"
    a = {int(k): v for k, v in multi["probe"]["params"].items()}
    b = {int(k): v for k, v in single["probe"]["params"].items()}
    common = sorted(set(a) & set(b))
    assert len(common) > 0.9 * SIM_SECONDS * 1000, (len(a), len(b))
    diff = [(k, a[k], b[k]) for k in common if a[k] != b[k]]
    assert not diff, f"{len(diff)} of {len(common)} samples differ between 3 hosts and 1, first: {diff[:3]}"
    # The chain tracks force: contact, median of the last simulated second within 1 N of 10 N.
    last_s = [a[k] for k in common if k > common[-1] - 1_000_000_000]
    assert all(v[0] == 1 for v in last_s), "not in contact during the last second"
    forces = sorted(v[2] for v in last_s)
    assert forces[len(forces) // 2] == pytest.approx(10.0, abs=1.0), forces[:: max(1, len(forces) // 10)]
    assert not any(v[7] for v in a.values()), [v for v in a.values() if v[7]][:3]
    print(f"3 hosts: discovery {multi['probe']['discovered_after_s']:.2f} s, {crossed / 1e6:.1f} MB over the bridge, "
          f"{len(common)} identical samples; median force {forces[len(forces) // 2]:.3f} N")


def test_ros_multihost_realtime_chain_latency_and_missed_cycles(hosts):
    """Real time, one host then three, in the same run: the driver's chain statistics
    (stamp of each /joint_states → matching /joint_effort_cmd) for both. Printed, and the
    chain must have run closed-loop on the hosts; the numbers go to BENCHMARKS.md via
    `python tests/ros/multihost.py` (speed is measured by benchmarks, not asserted here)."""
    h, bins = hosts
    res = {}
    for layout, offset in (("single", 30), ("multi", 40)):
        r = mh.run(h, layout, bins, ru.fresh_domain(offset), lockstep=False, seconds=8.0, warmup=4.0)
        lat, p = r["latency"], r["probe"]
        assert p["discovered_after_s"] is not None, f"{layout}: rclpy saw only {p['nodes']}"
        assert p["joint_states"] > 1000 and len(p["params"]) > 1000, (layout, p["joint_states"], len(p["params"]))
        assert lat["cycles"] > 6000, lat
        # Closed loop: most states were answered by a command carrying their stamp.
        assert lat["samples"] > 0.5 * lat["cycles"], lat
        res[layout] = lat
    s, m = res["single"], res["multi"]
    print("chain latency median / p99 [us], missed per min: "
          f"1 host {s['median_us']:.0f} / {s['p99_us']:.0f}, {s['missed_per_min']:.1f}; "
          f"3 hosts {m['median_us']:.0f} / {m['p99_us']:.0f}, {m['missed_per_min']:.1f}")


_STATIC_PEER_PROBE = """
import json, sys, time, rclpy
from rclpy.parameter_client import AsyncParameterClient
rclpy.init()
n = rclpy.create_node("naic_static_peer_probe")
names = lambda: [x for x, _ in n.get_node_names_and_namespaces()]
t0 = time.time()
while time.time() - t0 < float(sys.argv[1]) and "naic_controller" not in names():
    rclpy.spin_once(n, timeout_sec=0.05)
seen, listed = "naic_controller" in names(), False
if seen:
    c = AsyncParameterClient(n, "naic_controller")
    if c.wait_for_services(10.0):
        f = c.list_parameters()
        rclpy.spin_until_future_complete(n, f, timeout_sec=10)
        listed = bool(f.done() and "desired_force" in f.result().result.names)
print(json.dumps({"seen": seen, "listed": listed}))
"""


def test_ros_multihost_rclpy_static_peers_reach_a_naic_node(hosts):
    """The naic nodes cannot be given static peers (RustDDS 0.15), but an rclpy host can
    name a naic host in ROS_STATIC_PEERS: with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (no
    multicast on the rclpy side) it then discovers naic_controller on another host and uses
    its parameter services, because RustDDS answers unicast discovery. Without the static
    peer the same rclpy process finds nothing (the control)."""
    import json
    import subprocess
    h, bins = hosts
    env = mh.subnet_env(ru.fresh_domain(50))
    ctl = ru.Proc(h.exec_prefix("ctl") + [str(bins / "naic_controller"), "--ros-args", "-p", "realtime_priority:=0"], env)
    got = {}
    try:
        for label, peers, wait in (("without", None, 8.0), ("with", h.addr["ctl"], 30.0)):
            e = {**env, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
            if peers:
                e["ROS_STATIC_PEERS"] = peers
            r = subprocess.run(h.exec_prefix("py") + [sys.executable, "-c", _STATIC_PEER_PROBE, str(wait)],
                               env=e, capture_output=True, text=True, timeout=120)
            assert r.returncode == 0, r.stderr[-2000:]
            got[label] = json.loads(r.stdout.strip().splitlines()[-1])
        assert ctl.alive(), ctl.output()[-2000:]
    finally:
        assert ctl.stop(timeout=15) == 0, ctl.output()[-2000:]
    assert got["without"] == {"seen": False, "listed": False}, got
    assert got["with"] == {"seen": True, "listed": True}, got
