"""`naic launch` supervision (issue 13, item 4), checked with real processes and real rclpy
on a private loopback domain: the nodes under `naic launch` are killed with SIGKILL one at
a time (tests/ros/launch_probe.py watches /joint_states, /joint_effort_cmd, /naic/params).

* every death is reported with its exit status;
* while naic_controller or friction_compensation is dead the driver keeps publishing and
  holds the arm: no command computed from a state of the outage arrives, the applied
  torque is the driver's hold, not the last command, and the arm does not fall;
* with --respawn (or `respawn: true` in the launch file) the dead node is started again
  and the chain resumes (commands and /naic/params computed from new states); without it
  the node stays dead and the launch keeps running;
* when the driver dies the launcher stops the others and exits 4; Ctrl-C / SIGTERM stop
  the nodes in reverse start order, the driver last; exit 3 tells a node died.
"""
import json
import os
import re
import signal
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")

# The arm "does not fall": over an outage the joints move less than this [rad] from where
# they were when the node died, and settle (last 0.2 s of the outage slower than FALL_SPEED).
# Without the hold, gravity alone moves joint 2 of the JK5 by more than 0.3 rad in 0.5 s.
FALL_RAD = 0.05
FALL_SPEED = 0.2


@pytest.fixture(scope="module")
def bins():
    return ru.build_nodes()


@pytest.fixture(scope="module")
def overlay():
    return ru.naic_msgs_env()


def _probe(bins, overlay, args, plan, timeout=300):
    """Start `naic launch ARGS`, run the probe with PLAN against it; returns (probe result,
    launch Proc) with the launch still running unless the plan ended it."""
    domain = ru.fresh_domain(30)
    launch = ru.Proc([str(bins / "naic"), "launch", *args], ru.ros_env(domain))
    env = ru.overlay_env(ru.ros_env(domain), overlay)
    try:
        out = subprocess.run([sys.executable, str(ru.ROOT / "tests/ros/launch_probe.py"), str(launch.p.pid),
                              json.dumps(plan)], env=env, capture_output=True, text=True, timeout=timeout)
    except BaseException:
        launch.stop(timeout=15)
        raise
    if out.returncode != 0:
        launch.stop(timeout=15)
        pytest.fail(f"probe failed:\n{out.stderr[-3000:]}\nlaunch:\n{launch.output()[-3000:]}")
    res = json.loads(out.stdout.strip().splitlines()[-1])
    if res["error"]:
        launch.stop(timeout=15)
        pytest.fail(f"{res['error']}\nlaunch:\n{launch.output()[-3000:]}")
    return res, launch


def _check_held(res, ev):
    """The driver held the arm while ev's node was dead: it kept publishing, nothing
    commanded from a state of the outage reached the wire before a new process existed,
    the applied torque is not the last command, and the joints neither sagged nor kept
    moving. Judged up to the start of the new process (nothing can command the arm before)."""
    t_kill = ev["t_kill_ns"]
    before = [c for c in res["cmds"] if c[1] is not None and c[1] < t_kill]
    assert before, f"{ev['node']}: no command before the kill"
    last_cmd = before[-1][2]
    t_new = ev.get("t_respawn_ns") or ev["t_end_ns"]
    during = [c for c in res["cmds"] if c[1] is not None and t_kill + 50_000_000 < c[1] < t_new]
    assert not during, f"{ev['node']} killed: {len(during)} commands computed before a new process existed"
    t_end = t_new
    # States published during the outage (driver stamps are this host's wall clock).
    js = sorted((s for s in res["js"] if t_kill + 100_000_000 <= s[1] < t_end), key=lambda s: s[1])
    assert len(js) >= 10, f"{ev['node']} killed: only {len(js)} driver states seen during the outage"
    gaps = [(b[1] - a[1]) * 1e-9 for a, b in zip(js, js[1:])]
    assert max(gaps) < 1.0, f"{ev['node']} killed: the driver stopped publishing for {max(gaps):.2f} s"
    kept = [s for s in js if max(abs(a - b) for a, b in zip(s[4], last_cmd)) <= 1e-9]
    assert not kept, f"{ev['node']} killed: the driver kept applying the last command in {len(kept)} states"
    # Sag: from the state 0.3 s into the outage (motion at the kill damped out) to its end.
    settled = [s for s in js if s[1] >= t_kill + 300_000_000]
    assert len(settled) >= 5 and t_end - t_kill > 1e9, f"{ev['node']}: outage too short to judge ({(t_end - t_kill) * 1e-9:.2f} s)"
    q0 = settled[0][2]
    moved = max(abs(a - b) for s in settled for a, b in zip(s[2], q0))
    tail = [s for s in js if s[1] >= js[-1][1] - 200_000_000]
    speed = max(abs(v) for s in tail for v in s[3])
    print(f"{ev['node']} dead {(t_end - t_kill) * 1e-9:.2f} s: joints moved at most {moved:.4f} rad, "
          f"|qdot| <= {speed:.4f} rad/s at the end; {len(js)} states seen")
    at_kill = min(js, key=lambda x: abs(x[1] - t_kill))
    per_joint = [round(max(abs(s[2][i] - q0[i]) for s in settled), 4) for i in range(len(q0))]
    assert moved < FALL_RAD, (f"{ev['node']} killed: the arm moved {moved:.3f} rad while held (per joint {per_joint}; "
                              f"joint speeds at the kill {[round(v, 3) for v in at_kill[3]]})")
    assert speed < FALL_SPEED, f"{ev['node']} killed: still moving at {speed:.3f} rad/s"


# A respawn delay long enough to see the driver hold the arm (a respawned node is back
# within about 0.2 s of its start).
DELAY = 2.0


def test_ros_launch_respawn_holds_the_arm_and_the_chain_resumes(bins, overlay, tmp_path):
    """--respawn (the launch file only sets the delay): both chain nodes are respawned."""
    lf = tmp_path / "launch.yaml"
    lf.write_text(f"naic_controller: {{respawn_delay: {DELAY}}}\nfriction_compensation: {{respawn_delay: {DELAY}}}\n")
    plan = [["naic_controller", "respawn"], ["friction_compensation", "respawn"], ["jk5_sim_driver", "dead"]]
    res, launch = _probe(bins, overlay, ["--respawn", "--launch-file", str(lf)], plan)
    try:
        launch.p.wait(timeout=30)  # the driver's death ends the launch
    except subprocess.TimeoutExpired:
        pass
    rc = launch.stop(timeout=15)
    out = launch.output()
    assert rc == 4, f"naic launch exit {rc} after the driver died:\n{out[-3000:]}"
    assert "panicked" not in out
    for ev in res["events"][:2]:
        node = ev["node"]
        assert f"naic launch: {node} exited (signal: 9 (SIGKILL))" in out, out[-3000:]
        assert ev["t_respawn_ns"] and ev["new_pid"] and ev["new_pid"] != ev["pid"], ev
        assert f"naic launch: respawned (1) {node} (pid {ev['new_pid']})" in out, out[-3000:]
        _check_held(res, ev)
        # The chain resumed: commands computed from states after the restart, and the
        # controller's report on /naic/params.
        assert ev["resumed"], f"{node}: the chain did not resume after the respawn"
        t = ev["t_respawn_ns"]
        assert sum(1 for c in res["cmds"] if c[1] is not None and c[1] > t) > 100
        assert sum(1 for p in res["params"] if p[1] > t) > 100
    drv = res["events"][2]
    assert "naic launch: jk5_sim_driver exited (signal: 9 (SIGKILL))" in out, out[-3000:]
    assert drv["children_end"] == {}, f"nodes left running after the driver died: {drv['children_end']}"
    # The others were stopped in reverse start order.
    tail = out[out.index("jk5_sim_driver exited"):]
    assert tail.index("stopping naic_controller") < tail.index("stopping friction_compensation"), tail[-2000:]
    assert "not stop cleanly" not in tail, tail[-2000:]


def test_ros_launch_without_respawn_keeps_the_driver_holding(bins, overlay, tmp_path):
    """Launch file: naic_controller respawns, friction_compensation does not. Killing
    friction_compensation leaves it dead and the arm held; killing the controller respawns
    it (its /naic/params again) while the driver keeps holding (nothing sends commands).
    SIGTERM then stops the rest, controller before driver; exit 3 (a node died)."""
    lf = tmp_path / "launch.yaml"
    lf.write_text(f"naic_controller: {{respawn: true, respawn_delay: {DELAY}}}\nfriction_compensation: {{respawn: false}}\n")
    plan = [["friction_compensation", "dead"], ["naic_controller", "respawn"]]
    res, launch = _probe(bins, overlay, ["--launch-file", str(lf)], plan)
    try:
        fc, ctl = res["events"]
        assert fc["new_pid"] is None, f"friction_compensation was respawned: {fc}"
        assert launch.alive(), launch.output()[-3000:]
        assert "friction_compensation" not in ctl["children_end"], ctl["children_end"]
        _check_held(res, fc)
        # The controller came back (its report flows) but the arm stays held: no commands.
        assert ctl["t_respawn_ns"], ctl
        t = ctl["t_respawn_ns"]
        assert sum(1 for p in res["params"] if p[1] > t) > 100, "no /naic/params from the respawned controller"
        assert not any(c[1] is not None and c[1] > fc["t_kill_ns"] + 50_000_000 for c in res["cmds"])
    except BaseException:
        launch.stop(timeout=15)  # a failed check must not leave the chain running for later tests
        raise
    launch.p.send_signal(signal.SIGTERM)
    launch.p.wait(timeout=30)
    rc = launch.stop()
    out = launch.output()
    assert rc == 3, f"exit {rc}:\n{out[-3000:]}"
    assert "friction_compensation exited (signal: 9 (SIGKILL))" in out and "not respawned" in out, out[-3000:]
    stop = out[out.rindex("naic launch: stopping\n"):]
    i_ctl, i_drv = stop.index("stopping naic_controller"), stop.index("stopping jk5_sim_driver")
    assert i_ctl < i_drv, stop
    # Each stopped before the next was asked: the controller's last line before the driver's.
    assert stop.index("[naic_controller] [INFO] [naic_controller]: stopped after") < i_drv, stop
    assert re.search(r"\[jk5_sim_driver\] .*stopped after", stop[i_drv:]), stop
    assert "panicked" not in out


def test_ros_launch_node_refusing_its_configuration_stops_the_launch(bins):
    out = subprocess.run([str(bins / "naic"), "launch", "-p", "naic_controller:learning_rate:=-1.0"], cwd=ru.ROOT,
                         capture_output=True, text=True, timeout=60, env=ru.ros_env(ru.fresh_domain(35)))
    assert out.returncode == 2, out.stderr[-3000:]
    assert "naic_controller exited (exit status: 2)" in out.stderr and "learning_rate" in out.stderr, out.stderr[-3000:]
    assert "stopping jk5_sim_driver" in out.stderr


@pytest.mark.parametrize("text,needle", [
    ("jk5_sim_driver: {respawn: true}\n", "respawn is not supported"),
    ("naic_controler: {respawn: true}\n", "unknown node 'naic_controler'"),
    ("naic_controller: {respawn: yes please}\n", "respawn"),
])
def test_ros_launch_bad_launch_file_names_the_problem(bins, tmp_path, text, needle):
    f = tmp_path / "launch.yaml"
    f.write_text(text)
    out = subprocess.run([str(bins / "naic"), "launch", "--launch-file", str(f)], cwd=ru.ROOT,
                         capture_output=True, text=True, timeout=60, env=ru.ros_env(ru.fresh_domain(36)))
    assert out.returncode == 2, out.stderr
    assert str(f) in out.stderr and needle in out.stderr and "naic launch: started" not in out.stderr, out.stderr
