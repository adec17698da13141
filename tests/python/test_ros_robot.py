"""Another arm over DDS (issue 37): `naic launch --robot params/robots/panda.yaml --lockstep`
runs the three node processes on the 7-joint Franka Panda (the simulated driver steps
naic_sim's Panda on the flat scenario placed relative to the robot file's start joints),
and real rclpy (Jazzy) sees:

- 7 joint names on `/joint_states`, the robot file's (`joint1`..`joint7` of urdf/panda.urdf);
- 7 values on `/joint_effort_cmd` (JointGroupEffortController's convention: the robot
  file's joint order, the source stamp in the dimension label);
- the chain in contact holding 10 N: the mean of `/naic/params` measured_force over
  WINDOW_S simulated seconds within TOLERANCE_N of 10 N, in contact and without a fault
  (from simulated second 3 on, or a second after the probe's first sample if it joined later:
  the chain runs from the launch on, at most at wall-clock speed).

All DDS traffic stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) on a
test-private ROS_DOMAIN_ID.
"""
import json
import os
import subprocess
import sys
import textwrap

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")

PANDA = "params/robots/panda.yaml"
JOINTS = [f"joint{i}" for i in range(1, 8)]
# The mean force's tolerance [N]: the in-process chain of the same cores
# (nodes/naic_controller/tests/panda_in_process.rs) holds 9.989 N in its second second.
TOLERANCE_N = 0.2
WINDOW_S = 2.0


@pytest.fixture(scope="module")
def bins():
    return ru.build_nodes()


# Records /naic/params, /joint_states and /joint_effort_cmd until /naic/params has argv[1]
# simulated seconds from max(3 s, first sample + 1 s) on, then prints one JSON object.
PROBE = textwrap.dedent("""
    import json, sys, rclpy
    from naic_msgs.msg import NaicParams
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    window_ns = int(float(sys.argv[1]) * 1e9)
    rclpy.init()
    import rostest_util; rostest_util.observer_priority()
    n = rclpy.create_node("naic_robot_probe")
    stamp = lambda h: h.stamp.sec * 1_000_000_000 + h.stamp.nanosec
    params, names, cmd_lens = {}, set(), {}
    first, last = [None], [0]
    def on_params(m):
        params[stamp(m.header)] = [m.phase, m.measured_force, m.desired_force, m.fault]
        first[0] = stamp(m.header) if first[0] is None else first[0]
        last[0] = max(last[0], stamp(m.header))
    def start_ns():
        return max(3_000_000_000, first[0] + 1_000_000_000)
    def on_state(m):
        names.add(tuple(m.name))
    def on_cmd(m):
        cmd_lens[len(m.data)] = cmd_lens.get(len(m.data), 0) + 1
    qos = QoSProfile(depth=100000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
    n.create_subscription(NaicParams, "/naic/params", on_params, qos)
    n.create_subscription(JointState, "/joint_states", on_state, qos)
    n.create_subscription(Float64MultiArray, "/joint_effort_cmd", on_cmd, qos)
    ok = rostest_util.spin_node_until(n, lambda: first[0] is not None and last[0] >= start_ns() + window_ns, 120)
    lo = start_ns() if first[0] is not None else 0
    print(json.dumps({"reached_end": ok, "window_ns": [lo, lo + window_ns],
                      "params": {str(k): v for k, v in params.items() if lo <= k <= lo + window_ns},
                      "names": [list(x) for x in names], "cmd_lens": cmd_lens}))
""")


def test_ros_robot_panda_launch_lockstep_has_seven_joints_and_holds_10_n(bins):
    domain = ru.fresh_domain(210)
    env = ru.overlay_env(ru.ros_env(domain), ru.naic_msgs_env(), ru.ROOT / "tests/ros")
    # Simulated time at most wall time, so the rclpy probe (started with the launch) sees a
    # window of contact.
    launch = ru.Proc([str(bins / "naic"), "launch", "--robot", PANDA, "--lockstep", "--real-time-factor", "1.0"],
                     ru.ros_env(domain))
    try:
        probe = subprocess.run([sys.executable, "-c", PROBE, str(WINDOW_S)], env=env, cwd=ru.ROOT,
                               capture_output=True, text=True, timeout=300)
        alive = launch.alive()
    finally:
        rc = launch.stop(timeout=20)
    log = launch.output()
    assert probe.returncode == 0, probe.stderr[-3000:] + log[-3000:]
    assert alive and rc == 0, (alive, rc, log[-3000:])
    assert "panicked" not in log
    m = json.loads(probe.stdout.strip().splitlines()[-1])
    assert m["reached_end"], f"/naic/params never covered its {WINDOW_S} s window: {log[-3000:]}"
    # Seven names, the robot file's, and seven torques per command.
    assert m["names"] == [JOINTS], m["names"]
    assert set(m["cmd_lens"]) == {"7"}, m["cmd_lens"]
    # 10 N held on flat.
    lo, hi = (x * 1e-9 for x in m["window_ns"])
    window = list(m["params"].values())
    assert len(window) > 1500, f"only {len(window)} /naic/params samples in {lo:.3f}-{hi:.3f} s"
    assert all(v[0] == 1 for v in window), "not in contact all the window"
    assert not any(v[3] for v in window), [v[3] for v in window if v[3]][:3]
    assert all(v[2] == 10.0 for v in window)
    mean = sum(v[1] for v in window) / len(window)
    worst = max(abs(v[1] - 10.0) for v in window)
    print(f"Panda over DDS, lockstep: mean force {mean:.3f} N over {len(window)} samples in {lo:.3f}-{hi:.3f} s "
          f"(largest |f - 10 N| {worst:.3f} N); tolerance {TOLERANCE_N} N")
    assert abs(mean - 10.0) < TOLERANCE_N, f"mean contact force {mean:.3f} N"


def test_ros_robot_launch_refuses_a_bad_robot_file_before_any_node_starts(bins, tmp_path):
    bad = tmp_path / "arm.yaml"
    bad.write_text("urdf: ../nothere.urdf\ntip_frame: tip\nsensor_frame: ft_sensor\n")
    out = subprocess.run([str(bins / "naic"), "launch", "--robot", str(bad), "--duration", "1"], cwd=ru.ROOT,
                         capture_output=True, text=True, timeout=60, env=ru.ros_env(ru.fresh_domain(211)))
    assert out.returncode == 2, out.stderr
    assert "--robot" in out.stderr and "arm.yaml" in out.stderr and "`urdf`" in out.stderr, out.stderr
    assert "started" not in out.stderr, out.stderr
