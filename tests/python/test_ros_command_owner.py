"""One owner of the torque command (issue 41, item 1), with real processes and real rclpy on
a private loopback domain.

`naic launch -p naic_controller:mode:=scheduled` runs the chain; once the arm presses on the
surface, a foreign rclpy node (not friction_compensation) publishes the issue's attack on
`/joint_effort_cmd`: [30, 0, 0, 0, 0, 0] N m at 1 kHz for 1 s.

* With the driver's default `command_source` (friction_compensation) no joint moves: the
  largest |q̇| of every joint over the attack stays at its at-rest level (the second before
  it); every foreign command is counted (`foreign_commands` of its report) and the foreign
  node is logged once, by name, on /rosout; the force sensor keeps reading what it read in
  steady contact before the attack (the chain keeps tracking force).
* The control (`command_source:=*`, every writer accepted, as before issue 41): the same
  attack reaches the arm: periods whose applied torque (`/joint_states` effort) is the
  attack's, so the first test's check that no period applied it is one the attack can fail.
  How many periods it wins depends on the race with friction_compensation's command of the
  same period (the driver applies the newest): joint 1 reached 0.15 rad/s where the attack won
  most of them, 0.024–0.029 rad/s where it won 140 of about 1200 (a clean-clone run, and
  again on the same machine), so the control counts applied periods, not the motion they
  cause.
"""
import json
import os
import sys
import time

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
from geometry_msgs.msg import WrenchStamped  # noqa: E402
from rcl_interfaces.msg import Log  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

FOREIGN = "naic_foreign_commander"
ATTACK = [30.0, 0.0, 0.0, 0.0, 0.0, 0.0]
N_ATTACK = 1000  # 1 s at 1 kHz
# "At rest": over the attack each joint's largest |q̇| stays within this of its largest
# |q̇| in the second before [rad/s]. The issue measured 0.16 rad/s on joint 1 with the
# attack applied (and <= 0.007 at rest); the control below shows the same.
REST_MARGIN = 0.01


@pytest.fixture(scope="module")
def bins():
    return ru.build_nodes()


def _attack(bins, tmp_path, driver_source=None):
    """Run the chain, wait for steady contact, attack; returns what was seen."""
    domain = ru.fresh_domain(55)
    report = tmp_path / "driver_report.json"
    args = [str(bins / "naic"), "launch", "-p", "naic_controller:mode:=scheduled",
            "-p", f"jk5_sim_driver:latency_report:={report}"]
    if driver_source:
        args += ["-p", f"jk5_sim_driver:command_source:={driver_source}"]
    launch = ru.Proc(args, ru.ros_env(domain))
    r = ru.RclpyDomain(domain, FOREIGN)
    js, fz, logs = [], [], []
    stamp = lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec  # noqa: E731
    r.node.create_subscription(JointState, "/joint_states", lambda m: js.append((stamp(m), list(m.velocity), list(m.effort))), 2000)
    r.node.create_subscription(WrenchStamped, "/wrench", lambda m: fz.append((stamp(m), m.wrench.force.z)), 2000)
    r.node.create_subscription(Log, "/rosout", lambda m: logs.append((m.name, m.msg)), 100)
    pub = r.node.create_publisher(Float64MultiArray, "/joint_effort_cmd", 10)
    try:
        # Steady contact: the sensor's f_z (raw, sensor frame: not f_d itself) above 2 N and
        # within 1 N of its mean for 2 s.
        def steady():
            t = time.time()
            last = [f for s, f in fz if s >= t - 2.0]
            if len(last) < 1000:
                return False
            m = sum(last) / len(last)
            return abs(m) > 2.0 and all(abs(f - m) < 1.0 for f in last)
        assert r.spin_until(steady, 90), (f"no steady contact; last f_z {[round(f, 2) for _, f in fz[-5:]]}\n"
                                          f"{launch.output()[-3000:]}")
        # The driver must have matched this writer, or the attack would be lost in
        # discovery rather than refused: the driver's reader is listed, and a new writer
        # is matched on the driver's side up to one Fast DDS heartbeat (3 s) later.
        assert r.spin_until(lambda: any(i.node_name == "jk5_sim_driver"
                                        for i in r.node.get_subscriptions_info_by_topic("/joint_effort_cmd")), 20)
        r.spin(4.0)
        t0 = time.time()
        nxt = t0
        msg = Float64MultiArray(data=ATTACK)
        for _ in range(N_ATTACK):
            while time.time() < nxt:
                r.ex.spin_once(timeout_sec=0)
            pub.publish(msg)
            nxt += 1e-3
        t1 = time.time()
        r.spin(1.0)
        assert launch.p.poll() is None, launch.output()[-3000:]
    finally:
        launch.stop(timeout=20)
        r.close()
    rep = json.loads(report.read_text())
    before = [v for s, v, _ in js if t0 - 1.0 <= s < t0]
    during = [v for s, v, _ in js if t0 <= s < t1 + 0.2]
    # Periods whose applied torque is the attack's: one joint at 30 N m, the others at 0
    # (friction_compensation's command is never that).
    applied = sum(1 for s, _, e in js if t0 <= s < t1 + 0.2 and len(e) == len(ATTACK)
                  and sorted(abs(x) for x in e) == sorted(abs(x) for x in ATTACK))
    f_before = [f for s, f in fz if t0 - 1.0 <= s < t0]
    f_during = [f for s, f in fz if t0 <= s < t1 + 0.2]
    assert len(before) > 200 and len(during) > 200, (len(before), len(during))
    peak = lambda vs: [max(abs(v[j]) for v in vs) for j in range(6)]  # noqa: E731
    mean = lambda xs: sum(xs) / len(xs)  # noqa: E731
    return dict(report=rep, qd_before=peak(before), qd_during=peak(during), applied=applied, f_before=mean(f_before),
                f_during=mean(f_during), f_during_worst=max(abs(f - mean(f_before)) for f in f_during),
                attack_s=t1 - t0, logs=logs, output=launch.output())


def test_ros_a_foreign_commander_moves_no_joint_and_is_counted_and_named(bins, tmp_path):
    a = _attack(bins, tmp_path)
    print(f"attack {a['attack_s']:.2f} s; |qdot| peak before {[round(x, 4) for x in a['qd_before']]}, "
          f"during {[round(x, 4) for x in a['qd_during']]}; f_z mean before {a['f_before']:.2f} N, during "
          f"{a['f_during']:.2f} N (worst deviation from before {a['f_during_worst']:.2f} N); "
          f"foreign_commands {a['report'].get('foreign_commands')}")
    assert a["applied"] == 0, f"{a['applied']} periods applied the foreign command's torque"
    for j in range(6):
        assert a["qd_during"][j] <= a["qd_before"][j] + REST_MARGIN, (
            f"joint {j + 1} moved under the foreign commands: |qdot| up to {a['qd_during'][j]:.4f} rad/s, "
            f"{a['qd_before'][j]:.4f} before")
    # Every foreign command the driver received was refused and counted. The command reader
    # is best effort (keep last 10): a sample DDS dropped before it reached the reader is
    # neither applied nor seen, so the count is at most what was sent; on loopback, with the
    # writer matched beforehand, the goal is all of them.
    n = a["report"]["foreign_commands"]
    assert n == N_ATTACK, f"{n} of {N_ATTACK} foreign commands counted"
    named = [m for node, m in a["logs"] if node == "jk5_sim_driver" and FOREIGN in m and "ignoring" in m]
    assert len(named) == 1, f"expected one /rosout line naming {FOREIGN}, got {named}"
    # The chain kept tracking the force: the sensor reads what it read in steady contact
    # before (within 1 N of that mean at every sample, the band the contact was steady in).
    assert a["f_during_worst"] < 1.0 and abs(a["f_during"] - a["f_before"]) < 0.3, (
        f"force tracking lost: f_z mean {a['f_during']:.2f} N during, {a['f_before']:.2f} N before; "
        f"worst deviation {a['f_during_worst']:.2f} N")


def test_ros_the_same_attack_moves_the_arm_when_every_writer_is_accepted(bins, tmp_path):
    """The control: with `command_source:=*` (what the driver did before issue 41) the attack
    reaches the arm."""
    a = _attack(bins, tmp_path, driver_source="*")
    print(f"control: {a['applied']} periods applied the attack's torque; |qdot_1| peak before "
          f"{a['qd_before'][0]:.4f}, during {a['qd_during'][0]:.4f} rad/s; "
          f"foreign_commands {a['report'].get('foreign_commands')}")
    assert a["applied"] > 0, (
        "no period applied the attack's torque even with every writer accepted: the test above could not fail")
    assert a["report"]["foreign_commands"] == 0
