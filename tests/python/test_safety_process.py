"""Process faults over DDS (issue 7, items 2 and 4): the chain runs as three processes on a
private, loopback-only domain; naic_controller and then friction_compensation are killed
(SIGKILL, no clean-up) and restarted mid-run. Measured from what rclpy sees on the wire:

* the driver's 20 ms command watchdog: after the last command, the applied torque
  (/joint_states effort) switches to the driver's own hold within 20 ms + a few cycles,
  and never keeps the old torque;
* the restarted node takes over without a torque step above friction_compensation's
  torque_rate_limit, both on /joint_effort_cmd and in the torque the driver applies;
* no process panics; the survivors exit 0 on SIGINT;
* when `naic record` exists, a recording running through the faults keeps every message
  it received (its bag holds what it reports and has no gap beyond the outages).
"""
import math
import os
import subprocess
import sys
import time

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

RATE_LIMIT = 1.0  # params/friction_compensation.yaml torque_rate_limit [N m per cycle]
COMMAND_TIMEOUT = 0.020  # params/jk5_sim_driver.yaml command_timeout [s]


def _stamp_ns(m):
    return m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec


def _src_ns(m):
    for kv in (m.layout.dim[0].label if m.layout.dim else "").split(";"):
        if kv.startswith("stamp_ns="):
            return int(kv[len("stamp_ns="):])
    return None


def _has_record(bins):
    return subprocess.run([str(bins / "naic"), "record", "--help"], capture_output=True).returncode == 0


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    bins = ru.build_nodes()
    domain = ru.fresh_domain(40)
    env = ru.ros_env(domain)
    ctl_args = [str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml"]
    fc_args = [str(bins / "friction_compensation"), "--ros-args", "--params-file",
               "params/friction_compensation.yaml"]
    procs = {"naic_controller": [ru.Proc(ctl_args, env)], "friction_compensation": [ru.Proc(fc_args, env)]}
    rec = None
    bag = tmp_path_factory.mktemp("rec") / "faults.mcap"
    if _has_record(bins):
        rec = ru.Proc([str(bins / "naic"), "record", "--topics", "/joint_effort_cmd", "/joint_states",
                       "--out", str(bag)], env)
    r = ru.RclpyDomain(domain, "safety_process_test")
    cmds, js = [], []  # (receive time, msg)
    r.node.create_subscription(Float64MultiArray, "/joint_effort_cmd", lambda m: cmds.append((time.time(), m)), 1000)
    r.node.create_subscription(JointState, "/joint_states", lambda m: js.append((time.time(), m)), 1000)
    time.sleep(1.0)
    procs["jk5_sim_driver"] = [ru.Proc([str(bins / "jk5_sim_driver"), "--ros-args", "--params-file",
                                        "params/jk5_sim_driver.yaml"], env)]
    events = {}
    try:
        assert r.spin_until(lambda: len(cmds) > 500, 30), "chain did not start:\n" + "\n".join(
            p[-1].output()[-2000:] for p in procs.values())
        r.spin(2.0)
        for node, args in (("naic_controller", ctl_args), ("friction_compensation", fc_args)):
            n_before = len(cmds)
            procs[node][-1].p.kill()  # SIGKILL: no clean shutdown
            procs[node][-1].p.wait()
            events[node] = {"kill": time.time(), "cmd_index": n_before}
            r.spin(1.0)
            events[node]["restart"] = time.time()
            events[node]["cmds_while_dead"] = sum(1 for t, _ in cmds if events[node]["kill"] + 0.1 < t < time.time())
            procs[node].append(ru.Proc(args, env))
            assert r.spin_until(lambda: any(t > events[node]["restart"] for t, _ in cmds), 30), \
                f"{node} did not take over:\n{procs[node][-1].output()[-3000:]}"
            events[node]["resumed"] = next(t for t, _ in cmds if t > events[node]["restart"])
            r.spin(3.0)
    finally:
        r.close()
        codes = {}
        if rec:
            codes["record"] = rec.stop(timeout=20)
        for name in ("jk5_sim_driver", "naic_controller", "friction_compensation"):
            codes[name] = procs[name][-1].stop(timeout=15)
    logs = {name: "\n".join(p.output() for p in ps) for name, ps in procs.items()}
    if rec:
        logs["record"] = rec.output()
    return {"cmds": cmds, "js": js, "events": events, "codes": codes, "logs": logs, "bag": bag if rec else None}


def test_process_fault_nothing_panics_and_survivors_exit_cleanly(run):
    for name, out in run["logs"].items():
        assert "panicked" not in out, f"{name} panicked:\n{out[-3000:]}"
    assert all(c == 0 for c in run["codes"].values()), (run["codes"], {k: v[-2000:] for k, v in run["logs"].items()})


def test_process_fault_driver_watchdog_holds_within_20ms(run):
    """After the last command before each kill, the driver applies its own hold (not the
    old torque) within command_timeout plus a few 1 kHz cycles, measured in driver stamps."""
    js = [m for _, m in run["js"]]
    for node, ev in run["events"].items():
        before = [m for t, m in run["cmds"] if t < ev["kill"] + 0.2]
        assert before, node
        last = before[-1]
        last_tau = list(last.data)
        src = _src_ns(last)
        assert src is not None, "commands carry their source stamp"
        def same(m):
            return max(abs(a - b) for a, b in zip(m.effort, last_tau)) <= 1e-9
        after = [m for m in js if _stamp_ns(m) > src]
        # The first state on which the driver had applied the last command, then the first
        # on which it no longer does (its own hold).
        i_applied = next((i for i, m in enumerate(after) if same(m)), None)
        assert i_applied is not None, f"{node}: the last command was never applied"
        first_hold = next((m for m in after[i_applied:] if not same(m)), None)
        assert first_hold is not None, f"{node} killed: the driver kept applying the old torque"
        delay = (_stamp_ns(first_hold) - src) * 1e-9
        print(f"{node}: old torque applied until {delay * 1e3:.1f} ms after its source state")
        # The old torque may be applied for at most the timeout + loop latency + 2 cycles (+ scheduling
        # slack on a loaded 2-core machine).
        assert delay <= COMMAND_TIMEOUT + 0.015, f"{node}: hold after {delay * 1e3:.1f} ms"
        # And while the node is dead the driver holds: effort is the hold (damping only on this plant),
        # never the old command.
        dead = [m for t, m in run["js"] if ev["kill"] + 0.1 < t < ev["restart"]]
        assert len(dead) > 100, f"driver stopped publishing while {node} was dead"
        assert all(max(abs(a - b) for a, b in zip(m.effort, last_tau)) > 1e-9 for m in dead)
        assert ev["cmds_while_dead"] == 0, ev
    assert "holding the arm" in run["logs"]["jk5_sim_driver"]
    assert "commands resumed" in run["logs"]["jk5_sim_driver"]


def test_process_fault_takeover_has_no_torque_step_above_the_rate_limit_on_the_wire(run):
    cmds = [m for _, m in run["cmds"]]
    worst = 0.0
    for a, b in zip(cmds, cmds[1:]):
        assert all(math.isfinite(x) for x in b.data)
        worst = max(worst, max(abs(x - y) for x, y in zip(a.data, b.data)))
    assert worst <= RATE_LIMIT + 1e-9, f"largest step between consecutive /joint_effort_cmd: {worst:.3f} N m"


def test_process_fault_takeover_applied_torque_has_no_step_above_the_rate_limit(run):
    """The torque the driver actually applies (/joint_states effort) around each outage:
    old command → hold → new command. The step into the first new command must be within
    the rate limit of the hold torque the arm had."""
    js = run["js"]
    for node, ev in run["events"].items():
        window = [m for t, m in js if ev["restart"] - 0.3 < t < ev["resumed"] + 0.5]
        steps = [max(abs(x - y) for x, y in zip(a.effort, b.effort)) for a, b in zip(window, window[1:])]
        assert steps, node
        assert max(steps) <= RATE_LIMIT + 1e-6, f"{node} restart: applied torque stepped {max(steps):.3f} N m"


def test_process_fault_recording_keeps_everything_it_received(run):
    if run["bag"] is None:
        pytest.skip("`naic record` is not on this branch yet")
    from mcap.reader import make_reader
    log = run["logs"]["record"]
    with open(run["bag"], "rb") as f:
        counts, last_t, gaps = {}, {}, {}
        for _, ch, msg in make_reader(f).iter_messages():
            counts[ch.topic] = counts.get(ch.topic, 0) + 1
            if ch.topic in last_t:
                gaps[ch.topic] = max(gaps.get(ch.topic, 0.0), (msg.log_time - last_t[ch.topic]) * 1e-9)
            last_t[ch.topic] = msg.log_time
    n = sum(counts.values())
    assert f"wrote {n} messages" in log, log[-2000:]
    # Everything rclpy saw while the recorder ran is in the bag (within discovery at the edges).
    seen = len(run["cmds"])
    assert counts.get("/joint_effort_cmd", 0) >= 0.98 * seen, (counts, seen)
    # /joint_states never stopped (the driver kept publishing through both outages).
    assert gaps["/joint_states"] < 0.2, gaps
