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


def test_ros_an_external_rclpy_plant_drives_the_nodes_in_lockstep_and_the_force_is_tracked():
    from geometry_msgs.msg import WrenchStamped
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    bins = ru.build_nodes()
    domain = ru.fresh_domain(190)
    env = ru.ros_env(domain)
    common = ["-p", "use_sim_time:=true", "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"]
    ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                   "-p", "scenario:=none", "-p", f"desired_force:={F_D}", *common], env)
    fc = ru.Proc([str(bins / "friction_compensation"), "--ros-args", "--params-file", "params/friction_compensation.yaml",
                  "-p", "enabled:=false", *common], env)  # this plant has no joint friction
    r = ru.RclpyDomain(domain, "external_plant")
    plant = Plant(str(ru.ROOT / "urdf/jk5.urdf"), [0.0, 0.3, 1.8, 0.0, 1.0, 0.0], table_below=0.02)
    try:
        rel = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
        w_pub = r.node.create_publisher(WrenchStamped, "/wrench", rel)
        js_pub = r.node.create_publisher(JointState, "/joint_states", rel)
        cmds = {}
        r.node.create_subscription(Float64MultiArray, "/joint_effort_cmd",
                                   lambda m: cmds.__setitem__(_answers(m), list(m.data[:6])), rel)
        # Discovery: both nodes read our topics and we read the command.
        assert r.spin_until(lambda: r.node.count_subscribers("/joint_states") >= 2
                            and r.node.count_subscribers("/wrench") >= 1
                            and r.node.count_publishers("/joint_effort_cmd") >= 1, 60), ctl.output()[-2000:]
        t0 = 1_000_000_000
        forces = []
        n_steps = 3000
        for k in range(n_steps):
            stamp = t0 + k * 1_000_000
            force, torque, f_c = plant.reading()
            w = WrenchStamped()
            w.header.frame_id = "ft_sensor"
            w.header.stamp.sec, w.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
            (w.wrench.force.x, w.wrench.force.y, w.wrench.force.z) = map(float, force)
            (w.wrench.torque.x, w.wrench.torque.y, w.wrench.torque.z) = map(float, torque)
            js = JointState(name=JOINTS, position=list(map(float, plant.q)), velocity=list(map(float, plant.v)),
                            effort=list(map(float, plant.tau_meas)))
            js.header.stamp = w.header.stamp
            # The first command may take seconds (discovery of the nodes' own pairings).
            deadline = time.time() + (60 if k == 0 else 10)
            sent = 0
            while stamp not in cmds and time.time() < deadline:
                if sent == 0 or time.time() - sent > 1.0:  # the same stamp again: the same command
                    w_pub.publish(w)
                    js_pub.publish(js)
                    sent = time.time()
                r.spin(0.0005)
            assert stamp in cmds, (k, ctl.output()[-3000:], fc.output()[-2000:])
            tau = np.array(cmds.pop(stamp))
            assert np.all(np.isfinite(tau)), tau
            plant.step(tau)
            forces.append(f_c[2])
            for old in [s for s in cmds if s is not None and s < stamp]:
                cmds.pop(old)
        assert max(abs(v) for v in plant.v) < 2.0, plant.v
    finally:
        r.close()
        assert ctl.stop() == 0, ctl.output()[-2000:]
        assert fc.stop() == 0, fc.output()[-2000:]
    forces = np.array(forces)
    first = int(np.argmax(forces > 1.0))
    assert forces[first] > 1.0, "the tool never reached the table"
    tail = forces[-500:]
    print(f"contact at step {first}; last 0.5 s force mean {tail.mean():.3f} N, "
          f"min {tail.min():.3f}, max {tail.max():.3f}; peak {forces.max():.2f} N")
    assert abs(tail.mean() - F_D) < 0.5 and tail.max() - tail.min() < 1.0, (tail.mean(), tail.min(), tail.max())
    assert forces.max() < 50.0, "force limit reached"
    assert "force above force_limit" not in ctl.output()
