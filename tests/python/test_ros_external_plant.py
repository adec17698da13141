"""An external plant written from docs/nodes.md ("Driving the nodes from your own plant")
alone, importing no naic code: rclpy and Pinocchio step the JK5 URDF (rigid body, no joint
friction) against a spring-damper table in lockstep with `naic_controller` and
`friction_compensation` (`use_sim_time`), publishing `/wrench` (the sensor reading of the
contract: tool weight and contact force in `ft_sensor`, plus a bias) and `/joint_states`
with one stamp per step, and applying the `/joint_effort_cmd` whose label names that stamp.
The force the plant itself computes must settle at the set point. Loopback only.
"""
import math
import os
import sys
import time

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402  (processes and domains only)

pytest.importorskip("rclpy")
pin = pytest.importorskip("pinocchio")

JOINTS = [f"joint{i}" for i in range(1, 7)]
# From docs/nodes.md: the tool beyond the sensor, in the ft_sensor frame.
TOOL_MASS, TOOL_COM, TIP = 0.424, np.array([0.0, 0.0, 0.015]), np.array([0.0, 0.0, 0.169])
G = np.array([0.0, 0.0, -9.81])
BIAS = np.array([0.3, -0.2, 0.5, 0.01, -0.02, 0.005])  # a sensor bias the tare must remove
K_TABLE, C_TABLE = 5000.0, 50.0  # N/m, N s/m
DT, SUBSTEPS = 1e-3, 10
F_D = 10.0


class Plant:
    """JK5 from the URDF (Pinocchio ABA, semi-implicit Euler), table below the tip."""

    def __init__(self, urdf, q0, table_below):
        self.m = pin.buildModelFromUrdf(urdf)
        self.d = self.m.createData()
        self.tip = self.m.getFrameId("tip")
        self.sensor = self.m.getFrameId("ft_sensor")
        self.q, self.v = np.array(q0, float), np.zeros(6)
        pin.framesForwardKinematics(self.m, self.d, self.q)
        self.table_z = self.d.oMf[self.tip].translation[2] - table_below
        self.tau_meas = np.zeros(6)

    def contact(self):
        """F_c: the force the table exerts on the tip (base frame)."""
        pin.forwardKinematics(self.m, self.d, self.q, self.v)
        pin.updateFramePlacements(self.m, self.d)
        z = self.d.oMf[self.tip].translation[2]
        vz = pin.getFrameVelocity(self.m, self.d, self.tip, pin.LOCAL_WORLD_ALIGNED).linear[2]
        pen = self.table_z - z
        fz = max(0.0, K_TABLE * pen - C_TABLE * vz) if pen > 0 else 0.0
        return np.array([0.0, 0.0, fz])

    def reading(self):
        """The sensor reading of the contract: R^T (F_c + m g) + b_F, r_tip x R^T F_c + c x R^T m g + b_tau."""
        f_c = self.contact()
        r = self.d.oMf[self.sensor].rotation
        f_s, w_s = r.T @ f_c, r.T @ (TOOL_MASS * G)
        force = f_s + w_s + BIAS[:3]
        torque = np.cross(TIP, f_s) + np.cross(TOOL_COM, w_s) + BIAS[3:]
        return force, torque, f_c

    def step(self, tau):
        h = DT / SUBSTEPS
        for _ in range(SUBSTEPS):
            f_c = self.contact()
            j = pin.computeFrameJacobian(self.m, self.d, self.q, self.tip, pin.LOCAL_WORLD_ALIGNED)
            tau_c = j[:3].T @ f_c
            a = pin.aba(self.m, self.d, self.q, self.v, tau + tau_c)
            self.v = self.v + h * a
            self.q = pin.integrate(self.m, self.q, h * self.v)
        self.tau_meas = np.array(tau)


def _answers(msg):
    label = msg.layout.dim[0].label if msg.layout.dim else ""
    for kv in label.split(";"):
        if kv.startswith("stamp_ns="):
            return int(kv[len("stamp_ns="):])
    return None


class Chain:
    """naic_controller + friction_compensation (use_sim_time) and this plant, in lockstep."""

    def __init__(self, domain_offset, plant, ctl_args=()):
        from geometry_msgs.msg import WrenchStamped
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray
        self.WrenchStamped, self.JointState = WrenchStamped, JointState
        bins = ru.build_nodes()
        env = ru.ros_env(ru.fresh_domain(domain_offset))
        domain = env["ROS_DOMAIN_ID"]
        common = ["-p", "use_sim_time:=true", "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"]
        self.ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                            "-p", "scenario:=none", "-p", f"desired_force:={F_D}", *ctl_args, *common], env)
        self.fc = ru.Proc([str(bins / "friction_compensation"), "--ros-args", "--params-file",
                           "params/friction_compensation.yaml", "-p", "enabled:=false", *common], env)  # no joint friction here
        self.r = ru.RclpyDomain(int(domain), "external_plant")
        self.plant = plant
        rel = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
        self.w_pub = self.r.node.create_publisher(WrenchStamped, "/wrench", rel)
        self.js_pub = self.r.node.create_publisher(JointState, "/joint_states", rel)
        self.cmds = {}
        self.r.node.create_subscription(Float64MultiArray, "/joint_effort_cmd",
                                        lambda m: self.cmds.__setitem__(_answers(m), list(m.data[:6])), rel)
        self.k = 0
        self.forces = []
        # Discovery: both nodes read our topics and we read the command.
        assert self.r.spin_until(lambda: self.r.node.count_subscribers("/joint_states") >= 2
                                 and self.r.node.count_subscribers("/wrench") >= 1
                                 and self.r.node.count_publishers("/joint_effort_cmd") >= 1, 60), self.ctl.output()[-2000:]

    def run(self, n_steps):
        """n_steps lockstep steps of 1 ms: publish the wrench and the state of one stamp, wait
        for the command whose label names that stamp, apply it."""
        r, plant = self.r, self.plant
        for _ in range(n_steps):
            stamp = 1_000_000_000 + self.k * 1_000_000
            force, torque, f_c = plant.reading()
            w = self.WrenchStamped()
            w.header.frame_id = "ft_sensor"
            w.header.stamp.sec, w.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
            (w.wrench.force.x, w.wrench.force.y, w.wrench.force.z) = map(float, force)
            (w.wrench.torque.x, w.wrench.torque.y, w.wrench.torque.z) = map(float, torque)
            js = self.JointState(name=JOINTS, position=list(map(float, plant.q)), velocity=list(map(float, plant.v)),
                                 effort=list(map(float, plant.tau_meas)))
            js.header.stamp = w.header.stamp
            # The first command may take seconds (discovery of the nodes' own pairings).
            deadline = time.time() + (60 if self.k == 0 else 10)
            sent = 0
            while stamp not in self.cmds and time.time() < deadline:
                if sent == 0 or time.time() - sent > 1.0:  # the same stamp again: the same command
                    self.w_pub.publish(w)
                    self.js_pub.publish(js)
                    sent = time.time()
                r.spin(0.0005)
            assert stamp in self.cmds, (self.k, self.ctl.output()[-3000:], self.fc.output()[-2000:])
            tau = np.array(self.cmds.pop(stamp))
            assert np.all(np.isfinite(tau)), tau
            plant.step(tau)
            self.forces.append(f_c[2])
            for old in [s for s in self.cmds if s is None or s < stamp]:
                self.cmds.pop(old)
            self.k += 1
        assert max(abs(v) for v in plant.v) < 2.0, plant.v

    def call(self, srv):
        """A std_srvs/srv/Trigger call on the controller (the chain waits: lockstep)."""
        from std_srvs.srv import Trigger
        c = self.r.node.create_client(Trigger, f"/naic_controller/{srv}")
        assert self.r.spin_until(c.service_is_ready, 60), f"{srv} never ready"
        return self.r.wait(c.call_async(Trigger.Request()), 30.0)

    def close(self):
        self.r.close()
        assert self.ctl.stop() == 0, self.ctl.output()[-2000:]
        assert self.fc.stop() == 0, self.fc.output()[-2000:]


Q0 = [0.0, 0.3, 1.8, 0.0, 1.0, 0.0]


def test_ros_an_external_rclpy_plant_drives_the_nodes_in_lockstep_and_the_force_is_tracked():
    c = Chain(190, Plant(str(ru.ROOT / "urdf/jk5.urdf"), Q0, table_below=0.02))
    try:
        c.run(3000)
    finally:
        c.close()
    forces = np.array(c.forces)
    first = int(np.argmax(forces > 1.0))
    assert forces[first] > 1.0, "the tool never reached the table"
    tail = forces[-500:]
    print(f"contact at step {first}; last 0.5 s force mean {tail.mean():.3f} N, "
          f"min {tail.min():.3f}, max {tail.max():.3f}; peak {forces.max():.2f} N")
    assert abs(tail.mean() - F_D) < 0.5 and tail.max() - tail.min() < 1.0, (tail.mean(), tail.min(), tail.max())
    assert forces.max() < 50.0, "force limit reached"
    assert "force above force_limit" not in c.ctl.output()


def test_ros_zero_wrench_at_rest_removes_a_drifted_bias_and_is_refused_in_contact():
    """Issue 39's zeroing goal: the sensor's bias drifts by 0.8 N / 0.02 N m after the
    start-up tare; with the tool at rest in free space rclpy calls ~/zero_wrench: success,
    and afterwards the controller's measured force in free space (what it would track) is
    within 0.05 N of the true 0, with the new bias in /naic/params. In contact the call is
    refused with a reason and the force goes on tracking 10 N.

    The residual bias is read from the plant, not from naic: in contact the controller
    drives its measured force to 10 N, so the table's true force differs from 10 N by the
    bias the controller did not remove."""
    plant = Plant(str(ru.ROOT / "urdf/jk5.urdf"), Q0, table_below=0.2)  # out of reach first
    c = Chain(195, plant)
    mean = lambda n: float(np.mean(c.forces[-n:]))  # noqa: E731
    drift = np.array([0.3, -0.2, 0.8, 0.02, -0.01, 0.005])
    bias0 = BIAS.copy()
    try:
        # Free space: the start-up tare, then at rest 5 cm below the start (approach_depth).
        for _ in range(30):  # up to 6 s of simulated time
            c.run(200)
            if max(abs(v) for v in plant.v) < 1e-3:
                break
        assert max(abs(v) for v in plant.v) < 1e-3, plant.v
        BIAS[:] += drift  # the sensor's bias drifts
        res = c.call("zero_wrench")
        assert res.success and "re-taring" in res.message, res
        c.run(400)  # the tare: 100 samples at rest
        # A table rises under the resting tool, 2 mm into it: contact, tracking 10 N.
        pin.framesForwardKinematics(plant.m, plant.d, plant.q)
        plant.table_z = plant.d.oMf[plant.tip].translation[2] + 0.002
        c.run(3000)
        residual = mean(500) - F_D
        # In contact: refused with a reason, tracking undisturbed.
        before = np.array(c.forces[-500:])
        res = c.call("zero_wrench")
        assert not res.success and "in contact" in res.message, res
        c.run(1000)
        after = np.array(c.forces[-1000:])
        assert abs(after.mean() - before.mean()) < 0.02 and np.ptp(after) < 0.1, (after.mean(), before.mean(), np.ptp(after))
        # The precondition: the same drift again, not zeroed (in contact), moves the true
        # force by more than 0.5 N, so a zeroing that did nothing fails above.
        BIAS[:] += drift
        c.run(1500)
        unzeroed = mean(500) - F_D
    finally:
        BIAS[:] = bias0
        c.close()
    print(f"true force - 10 N: {residual:+.4f} N after ~/zero_wrench; {unzeroed:+.3f} N after a drift not zeroed")
    assert abs(unzeroed) > 0.5, unzeroed
    assert abs(residual) <= 0.05, residual
    log = c.ctl.output()
    assert "~/zero_wrench: refused: in contact" in log and "F/T tare done at rest" in log, log[-3000:]
