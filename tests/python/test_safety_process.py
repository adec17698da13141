"""Process faults over DDS (issue 7, items 2 and 4): the chain runs as three processes on a
private, loopback-only domain; naic_controller and then friction_compensation are killed
(SIGKILL, no clean-up) and restarted mid-run. Measured from what rclpy sees on the wire:

* the driver's 20 ms command watchdog: after the last command, the applied torque
  (/joint_states effort) switches to the driver's own hold within 20 ms + a cycle or two,
  and never keeps the old torque;
* the restarted node takes over without a torque step above friction_compensation's
  torque_rate_limit, both on /joint_effort_cmd and in the torque the driver applies;
* the arm stays calm through both take-overs (joint speeds far below the controller's
  plausibility limit), and the controller reports the friction node's outage: its force law
  is held meanwhile instead of adapting against the driver's hold;
* no process panics; the survivors exit 0 on SIGINT;
* when `naic record` exists, a recording running through the faults keeps every message
  it received (its bag holds what it reports and has no gap beyond the outages).
"""
import bisect
import pathlib
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

def _rate_limit():
    """torque_rate_limit per joint [N m per cycle] from params/friction_compensation.yaml (the node's default)."""
    import yaml
    path = pathlib.Path(__file__).resolve().parents[2] / "params" / "friction_compensation.yaml"
    doc = yaml.safe_load(path.read_text())
    v = doc["friction_compensation"]["ros__parameters"]["torque_rate_limit"]
    # One number fills every joint; a list gives one per joint (the JK5's six here).
    lim = [float(x) for x in v] if isinstance(v, list) else [float(v)] * 6
    assert len(lim) == 6 and all(x > 0 for x in lim), lim
    return lim


def _excess(a, b, lim):
    """Largest |a_j - b_j| - lim_j over the joints (> 0: some joint moved by more than its limit)."""
    return max(abs(x - y) - l for x, y, l in zip(a, b, lim))


RATE_LIMIT = _rate_limit()
COMMAND_TIMEOUT = 0.020  # params/jk5_sim_driver.yaml command_timeout [s]
TAKEOVER_GAP = 0.020  # friction_compensation takeover_gap default [s]
# The driver runs at its default 1 kHz, the rate the controller's gains are made for. (At
# 250 Hz, which this test once used so that its rclpy reader would drop fewer samples, the
# default NAIC chain is unstable: joints at 3-8 rad/s and torques at the effort limits from
# the start, and the rate-limit check failed on a quiet machine in 5 of 6 runs.) Samples
# this reader drops are allowed for: commands are compared by the states they answer.
RATE = 1000.0
PERIOD_NS = int(1e9 / RATE)


def _stamp_ns(m):
    return m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec


def _src_ns(m):
    for kv in (m.layout.dim[0].label if m.layout.dim else "").split(";"):
        if kv.startswith("stamp_ns="):
            return int(kv[len("stamp_ns="):])
    return None


# NAIC_TAKEOVER_OBSERVERS=best_effort: rclpy and `naic record` subscribe best effort
# (`rclpy:best_effort` or `record:best_effort`: only that one). An experiment's switch
# (docs/notes/2026-12-dds-test-forensics.md, "Reliable observers"); the tests then judge from what a lossy reader saw,
# so keep it off for the suite. Default: reliable, as `ros2 topic echo`.
_OBSERVERS = os.environ.get("NAIC_TAKEOVER_OBSERVERS", "reliable")
if _OBSERVERS not in ("reliable", "best_effort", "rclpy:best_effort", "record:best_effort"):
    raise ValueError(f"NAIC_TAKEOVER_OBSERVERS={_OBSERVERS!r}: use 'reliable' (the default), 'best_effort', "
                     "'rclpy:best_effort' or 'record:best_effort'")
RCLPY_BEST_EFFORT = _OBSERVERS in ("best_effort", "rclpy:best_effort")
RECORD_BEST_EFFORT = _OBSERVERS in ("best_effort", "record:best_effort")


def _has_record(bins):
    return subprocess.run([str(bins / "naic"), "record", "--help"], capture_output=True).returncode == 0


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    bins = ru.build_nodes()
    domain = ru.fresh_domain(40)
    env = ru.ros_env(domain)
    ctl_args = [str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml"]
    fc_args = [str(bins / "friction_compensation"), "--ros-args", "--params-file",
               "params/friction_compensation.yaml", *ru.takeover_blend_override()]
    procs = {"naic_controller": [ru.Proc(ctl_args, env)], "friction_compensation": [ru.Proc(fc_args, env)]}
    rec = None
    bag = tmp_path_factory.mktemp("rec") / "faults.mcap"
    if _has_record(bins):
        rec = ru.Proc([str(bins / "naic"), "record", "--topics", "/joint_effort_cmd", "/joint_states",
                       "--out", str(bag), *(["--best-effort"] if RECORD_BEST_EFFORT else [])], env)
    # NAIC_TAKEOVER_DUMP=DIR: every node thread's CPU time every 20 ms, written to DIR with
    # every state and command rclpy saw (docs/notes/2026-12-dds-test-forensics.md, "The take-over failure, caught";
    # docs/figures/nodes/takeover_dump.py reads them). Off by default.
    samples, stop_sampler = [], []
    if os.environ.get("NAIC_TAKEOVER_DUMP"):
        import glob
        import threading

        def _sampler():
            while not stop_sampler:
                now = time.time()
                for name, ps in list(procs.items()):
                    for pr in ps:
                        for st in glob.glob(f"/proc/{pr.p.pid}/task/*/stat"):
                            try:
                                txt = open(st).read()
                            except OSError:
                                continue
                            f = txt[txt.rindex(")") + 2:].split()  # fields from 3 (state) on
                            samples.append((now, name, pr.p.pid, int(st.split("/")[4]), txt[txt.index("(") + 1:txt.rindex(")")],
                                            int(f[11]) + int(f[12]), int(f[36]), int(f[38]), int(f[37])))
                time.sleep(0.02)
        threading.Thread(target=_sampler, daemon=True).start()
    r = ru.RclpyDomain(domain, "safety_process_test")
    cmds, js = [], []  # (receive time, msg)
    qos = 1000  # reliable, keep last 1000
    if RCLPY_BEST_EFFORT:
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
    r.node.create_subscription(Float64MultiArray, "/joint_effort_cmd", lambda m: cmds.append((time.time(), m)), qos)
    r.node.create_subscription(JointState, "/joint_states", lambda m: js.append((time.time(), m)), qos)
    time.sleep(1.0)
    procs["jk5_sim_driver"] = [ru.Proc([str(bins / "jk5_sim_driver"), "--ros-args", "--params-file",
                                        "params/jk5_sim_driver.yaml", "-p", f"rate:={RATE}"], env)]
    events = {}
    try:
        assert r.spin_until(lambda: len(cmds) > 200, 30), "chain did not start:\n" + "\n".join(
            p[-1].output()[-2000:] for p in procs.values())
        r.spin(2.0)
        for node, args in (("naic_controller", ctl_args), ("friction_compensation", fc_args)):
            n_before = len(cmds)
            procs[node][-1].p.kill()  # SIGKILL: no clean shutdown
            procs[node][-1].p.wait()
            events[node] = {"kill": time.time(), "cmd_index": n_before}
            r.spin(1.0)
            events[node]["restart"] = time.time()
            # Commands computed from states of the outage (by source stamp: this reader may lag).
            events[node]["cmds_while_dead"] = sum(
                1 for _, m in cmds if (events[node]["kill"] + 0.05) * 1e9 < _src_ns(m) < time.time() * 1e9)
            procs[node].append(ru.Proc(args, env))
            assert r.spin_until(lambda: any(t > events[node]["restart"] for t, _ in cmds), 30), \
                f"{node} did not take over:\n{procs[node][-1].output()[-3000:]}"
            events[node]["resumed"] = next(t for t, _ in cmds if t > events[node]["restart"])
            if rec and node == "friction_compensation":
                # naic record's own rediscovery of the restarted node, seconds after rclpy's
                # under load (docs/nodes.md): wait for its "new publisher" line, so that the
                # bag can hold commands of both processes; the recording test fails if it
                # never came.
                new_pub = "naic record: /joint_effort_cmd: receiving from a new publisher"
                if r.spin_until(lambda: rec.output().count(new_pub) >= 2, 30):
                    events[node]["recorder_matched"] = time.time()
            r.spin(3.0)
    finally:
        r.close()
        codes = {}
        if rec:
            codes["record"] = rec.stop(timeout=45)
        for name in ("jk5_sim_driver", "naic_controller", "friction_compensation"):
            codes[name] = procs[name][-1].stop(timeout=15)
    logs = {name: "\n".join(p.output() for p in ps) for name, ps in procs.items()}
    if rec:
        logs["record"] = rec.output()
    stop_sampler.append(True)
    run = {"cmds": cmds, "js": js, "events": events, "codes": codes, "logs": logs, "bag": bag if rec else None}
    if os.environ.get("NAIC_TAKEOVER_DUMP"):
        _dump(pathlib.Path(os.environ["NAIC_TAKEOVER_DUMP"]), run, samples)
    return run


def _dump(d, run, samples):
    """The run as CSV files in `d`: js.csv (stamp [s], q, dq, effort), cmd.csv (receive time,
    source stamp [s], the six torques), threads.csv (time, node, pid, tid, name, CPU ticks,
    CPU, policy, rt priority), events.txt and each node's log."""
    d.mkdir(parents=True, exist_ok=True)
    with open(d / "js.csv", "w") as f:
        for _, m in run["js"]:
            f.write(",".join(map(str, [_stamp_ns(m) * 1e-9, *m.position, *m.velocity, *m.effort])) + "\n")
    with open(d / "cmd.csv", "w") as f:
        for t, m in run["cmds"]:
            f.write(",".join(map(str, [t, _src_ns(m) * 1e-9, *m.data[:6]])) + "\n")
    with open(d / "threads.csv", "w") as f:
        for x in samples:
            f.write(",".join(map(str, x)) + "\n")
    (d / "events.txt").write_text(repr(run["events"]) + "\n")
    for k, v in run["logs"].items():
        (d / f"log_{k}.txt").write_text(v)


def test_process_fault_nothing_panics_and_survivors_exit_cleanly(run):
    for name, out in run["logs"].items():
        assert "panicked" not in out, f"{name} panicked:\n{out[-3000:]}"
    assert all(c == 0 for c in run["codes"].values()), (run["codes"], {k: v[-2000:] for k, v in run["logs"].items()})


def test_process_fault_driver_watchdog_holds_within_20ms(run):
    """After the last command before each kill, the driver applies its own hold (not the
    old torque) within command_timeout plus a few 1 kHz cycles, measured in driver stamps."""
    js = [m for _, m in run["js"]]
    measured = 0
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
        # (This reader can miss states under load: then count from the source state, later.)
        i_applied = next((i for i, m in enumerate(after) if same(m)), None)
        first_hold = next((m for m in after[i_applied or 0:] if not same(m)), None)
        assert first_hold is not None, f"{node} killed: the driver kept applying the old torque"
        # The command arrived before the first state that shows it applied: the watchdog
        # counts from its arrival.
        if i_applied is not None:
            delay = (_stamp_ns(first_hold) - _stamp_ns(after[i_applied])) * 1e-9
            print(f"{node}: old torque applied for {delay * 1e3:.1f} ms after the last command")
            # Nominally the timeout + a cycle (measured 18-22 ms); the bound leaves room for the
            # driver thread being descheduled on a loaded 2-core machine (seen once: 41 ms at load 15).
            assert delay <= COMMAND_TIMEOUT + 0.025, f"{node}: hold after {delay * 1e3:.1f} ms"
            measured += 1
        else:
            print(f"{node}: the state applying the last command was not received (dropped under load)")
        # And while the node is dead the driver holds: effort is the hold (damping only on this plant),
        # never the old command.
        # Driver stamps are this host's wall clock: select by stamp (this reader may lag).
        dead = [m for _, m in run["js"] if _stamp_ns(first_hold) <= _stamp_ns(m) < ev["restart"] * 1e9]
        # (~250 states at 250 Hz; this reader may drop many under load, the bag in the
        # recording test checks continuity.)
        assert len(dead) >= 10, f"driver stopped publishing while {node} was dead"
        assert all(max(abs(a - b) for a, b in zip(m.effort, last_tau)) > 1e-9 for m in dead)
        assert ev["cmds_while_dead"] == 0, ev
    assert measured >= 1, "the watchdog delay could not be measured for any outage"
    assert "holding the arm" in run["logs"]["jk5_sim_driver"]
    assert "commands resumed" in run["logs"]["jk5_sim_driver"]


def _effort_limits():
    """Effort limits of joint1..joint6 from urdf/jk5.urdf (friction_compensation's saturation)."""
    import xml.etree.ElementTree as ET
    joints = {j.get("name"): j for j in ET.parse(ru.ROOT / "urdf/jk5.urdf").getroot().iter("joint")}
    return [float(joints[f"joint{i}"].find("limit").get("effort")) for i in range(1, 7)]


def test_process_fault_every_command_moves_by_at_most_the_rate_limit(run):
    """Every /joint_effort_cmd, over the whole run with both outages, is within the rate
    limit of the previous command, or (after a gap: a restarted node, or the driver holding
    meanwhile) within the rate limit of the torque the driver applied in a state the node
    can have re-seeded from: its newest /joint_states when the command went out, i.e. one
    from the command's source state (two cycles of slack before it) to the command's
    arrival here (under load the node can take a command late, and then re-seeds from a
    state well after its source: seen 20+ ms). The first command after each restart is
    checked by the second rule explicitly."""
    js_sorted = sorted((m for _, m in run["js"]), key=_stamp_ns)
    stamps = [_stamp_ns(m) for m in js_sorted]
    lim = _effort_limits()

    def from_applied(cmd, t_rx):
        """Smallest excess of `cmd` over the rate limit from the applied torque of a state
        the node can have re-seeded from; None when this reader has no such state."""
        src = _src_ns(cmd)
        lo = bisect.bisect_left(stamps, src - 2 * PERIOD_NS)
        hi = bisect.bisect_right(stamps, t_rx * 1e9)
        if lo >= hi:
            return None
        return min(_excess(cmd.data, [min(max(e, -l), l) for e, l in zip(st.effort, lim)], RATE_LIMIT)
                   for st in js_sorted[lo:hi])

    cmds = run["cmds"]
    bad, unverified, from_state = [], 0, 0
    for (_, a), (t_b, b) in zip(cmds, cmds[1:]):
        assert all(math.isfinite(x) for x in b.data)
        assert all(abs(x) <= l + 1e-9 for x, l in zip(b.data, lim)), list(b.data)
        # Commands carry distinct, increasing source stamps; this reader may miss some under
        # load, so b is k commands after a at most, each step within the rate limit.
        k = max(1, round((_src_ns(b) - _src_ns(a)) / PERIOD_NS))
        if _excess(a.data, b.data, [k * l for l in RATE_LIMIT]) <= 1e-9:
            continue
        jump = from_applied(b, t_b)
        if jump is None:
            unverified += 1
            continue
        from_state += 1
        if jump > 1e-6:
            bad.append((round(jump, 3), _src_ns(b), list(a.data), list(b.data)))
    firsts = [next((t, m) for t, m in cmds if t > ev["restart"]) for ev in run["events"].values()]
    checked = 0
    for k, (t, cmd) in enumerate(firsts):
        jump = from_applied(cmd, t)
        if jump is None:
            print(f"restart {k}: source state not received by this reader (dropped under load)")
            continue
        checked += 1
        print(f"restart {k}: first command {jump:+.3f} N m beyond the per-joint rate limit from the applied torque")
        assert jump <= 1e-6, f"restart {k}: first command {jump:.3f} N m beyond the rate limit from the applied torque"
    if checked == 0:
        pytest.skip("this reader dropped the source states of both restarts (loaded machine): not verified")
    print(f"{len(cmds)} commands; {from_state} re-seeded from the applied torque; {unverified} unverifiable")
    assert not bad, f"{len(bad)} commands jumped (excess, source stamp, previous, command): {bad[:3]}"
    assert unverified <= max(5, len(cmds) // 200), unverified


def test_process_fault_takeovers_keep_the_arm_calm_and_the_outage_is_reported(run):
    """From each kill to 1.5 s after the restart the joints stay far below the controller's
    plausibility limit (6.28 rad/s). Before the controller held its force law while its
    commands did not reach the arm, the friction node's take-over after a 1 s outage spun
    joint 4 at 8-10 rad/s (NAIC had walked m_d to its 0.05 kg floor and sigma to 0.29
    against the driver's hold); since, about 0.6 rad/s on a quiet machine. (Outside those
    windows NAIC's measured-velocity friction feedforward can make the wrist chatter on a
    loaded machine, once 6.5 rad/s: printed, not part of this check.)"""
    js = [(_stamp_ns(m) * 1e-9, m) for _, m in run["js"]]
    assert len(js) > 5000, len(js)
    for node, ev in run["events"].items():
        window = [(t, m) for t, m in js if ev["kill"] <= t <= ev["restart"] + 1.5]
        assert len(window) > 500, (node, len(window))
        # The fastest joint, and when: relative to the kill and to the restart, so that a
        # failure says which joint spun and in which phase (docs/nodes.md, loaded runs on 34a4b57).
        fastest, joint, t_max = max((abs(v), j, t) for t, m in window for j, v in enumerate(m.velocity))
        where = f"joint {joint + 1} at kill {t_max - ev['kill']:+.3f} s, restart {t_max - ev['restart']:+.3f} s"
        print(f"{node}: largest joint speed from the kill to 1.5 s after the restart: {fastest:.2f} rad/s ({where})")
        assert fastest < 2.0, f"{node}: a joint reached {fastest:.2f} rad/s around the take-over ({where})"
    print(f"largest joint speed over the run: {max(max(abs(v) for v in m.velocity) for _, m in js):.2f} rad/s")
    log = run["logs"]["naic_controller"]
    assert "no /joint_effort_cmd answering the joint states" in log, log[-3000:]
    assert "answers the joint states again" in log, log[-3000:]


def test_process_fault_takeover_torque_report(run):
    """The applied torque over the 300 ms after each restarted node's first command, printed
    (the numbers of docs/notes/2026-12-dds-test-forensics.md, "The take-over blend"; the default is no blend, compare
    with NAIC_TAKEOVER_BLEND=0.1 and with a window before each kill,
    NAIC_TAKEOVER_WINDOW=before). Asserts only that the
    window is there and that the arm got finite torques within its effort limits."""
    lim = _effort_limits()
    js = sorted((m for _, m in run["js"]), key=_stamp_ns)
    for node, ev in run["events"].items():
        first = next(m for t, m in run["cmds"] if t > ev["restart"])
        t0 = int((ev["kill"] - 0.4) * 1e9) if os.environ.get("NAIC_TAKEOVER_WINDOW") == "before" else _src_ns(first)
        w = [m for m in js if t0 <= _stamp_ns(m) <= t0 + 300_000_000]
        assert len(w) > 250, (node, len(w))
        eff = [list(m.effort) for m in w]
        assert all(math.isfinite(x) and abs(x) <= l + 1e-9 for e in eff for x, l in zip(e, lim)), node
        steps = [max(abs(a - b) for a, b in zip(e1, e0)) for e0, e1 in zip(eff, eff[1:])]
        peak = [round(max(abs(e[j]) for e in eff), 1) for j in range(6)]
        fastest = max(max(abs(v) for v in m.velocity) for m in w)
        print(f"{node}: takeover_blend {os.environ.get('NAIC_TAKEOVER_BLEND', 'default')}: peak |tau| per joint {peak} "
              f"N m, largest change between applied states {max(steps):.2f} N m, {sum(x > 5.0 for x in steps)} "
              f"changes > 5 N m, largest joint speed {fastest:.2f} rad/s")


def test_process_fault_recording_keeps_everything_it_received(run):
    if run["bag"] is None:
        pytest.skip("`naic record` is not on this branch yet")
    import re
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    log = run["logs"]["record"]
    # One pass: counts and gaps per topic, and the source stamp of every command (only the
    # commands are decoded).
    decode, bag_src = DecoderFactory().decoder_for, set()
    fc = run["events"]["friction_compensation"]
    cut = (fc["kill"] + fc["restart"]) / 2 * 1e9  # between the two friction processes
    with open(run["bag"], "rb") as f:
        counts, last_t, gaps = {}, {}, {}
        for schema, ch, msg in make_reader(f).iter_messages():
            counts[ch.topic] = counts.get(ch.topic, 0) + 1
            # By publish time (the DDS source timestamp): when the publisher sent it. The
            # log time is when the recorder took it, which a starved recorder delays.
            if ch.topic in last_t:
                gaps[ch.topic] = max(gaps.get(ch.topic, 0.0), (msg.publish_time - last_t[ch.topic]) * 1e-9)
            last_t[ch.topic] = msg.publish_time
            if ch.topic == "/joint_effort_cmd":
                bag_src.add(_src_ns(decode(ch.message_encoding, schema)(msg.data)))
    n = sum(counts.values())
    assert f"wrote {n} messages" in log, log[-2000:]
    # Every command rclpy saw from a friction node the recorder had matched (between the
    # first and last command the bag has from that process) is in the bag, or the recorder
    # said how many it did not record: nothing is lost silently. Before a restarted node is
    # matched the recorder cannot see it; at 1 kHz on a loaded machine that edge held
    # thousands of commands, so counting all of rclpy's would judge discovery, not the bag.
    m = re.search(r"/joint_effort_cmd: (\d+) messages published but not recorded", log)
    lost = int(m.group(1)) if m else 0
    # How long after rclpy the recorder had the restarted friction node: the first of its
    # commands in the bag against rclpy's first, by source stamp (what the recorder missed
    # while it had not matched it).
    first_src = min((x for x in bag_src if x >= cut), default=None)
    rclpy_first_src = min((_src_ns(m) for _, m in run["cmds"] if _src_ns(m) >= cut), default=None)
    rematch = "never" if first_src is None else f"{(first_src - rclpy_first_src) * 1e-9:.2f} s of commands later"
    print(f"naic record's first command of the restarted friction node: {rematch} than rclpy's")
    assert "recorder_matched" in fc, (f"naic record did not receive from the restarted friction node within 30 s of "
                                      f"rclpy (no second 'new publisher' line for /joint_effort_cmd):\n{log[-1500:]}")
    print(f"naic record's 'new publisher' line for the restarted friction node came "
          f"{fc['recorder_matched'] - fc['resumed']:.2f} s after rclpy's first command of it")
    missing, judged = 0, 0
    for part in (lambda x: x < cut, lambda x: x >= cut):
        recorded = [x for x in bag_src if part(x)]
        assert recorded, (f"the bag has no command from one of the friction node's processes (the restarted "
                          f"one's first: {rematch} than rclpy's):\n{log[-1500:]}")
        lo, hi = min(recorded), max(recorded)
        mine = [_src_ns(c) for _, c in run["cmds"] if lo <= _src_ns(c) <= hi]
        judged += len(mine)
        missing += sum(1 for x in mine if x not in bag_src)
    print(f"/joint_effort_cmd: {counts.get('/joint_effort_cmd', 0)} recorded, {lost} reported lost; of {judged} "
          f"commands rclpy saw while the recorder had their publisher, {missing} not in the bag")
    assert judged > 2000, judged
    # The recorder counts the gaps in each matched publisher's sequence numbers, so every
    # command of a matched process that is not in the bag is in its report.
    assert missing <= lost, (missing, lost, judged)
    # /joint_states never stopped (the driver kept publishing through both outages; 1 s
    # leaves room for scheduling stalls of a loaded machine, the outages last over 1 s).
    assert gaps["/joint_states"] < 1.0, gaps
