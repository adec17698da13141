#!/usr/bin/env python3
"""Slide the tool 10 cm along a surface at 10 mm/s while pressing 5 → 10 → 5 N.

Drives naic_controller from your own rclpy code through its reference topics:
  /naic/target_pose    (geometry_msgs/PoseStamped, base frame): where the tip should go
  /naic/desired_wrench (geometry_msgs/WrenchStamped, base frame): the force the tool applies
and checks the result on /naic/params. The controller treats both as a reference: it
limits speed and acceleration, holds the last target if this script stops, and refuses
any frame but the base frame.

Steps:
  1. the start tip pose, by forward kinematics of /joint_states (Pinocchio on the URDF);
  2. `naic record` starts recording a bag (the naic topics and /naic/desired_wrench);
  3. approach: targets descending at --approach-speed until the controller reports contact;
  4. 5 N until the force settles, then the slide with 5 N, 10 N and 5 N thirds;
  5. the bag is closed and `naic plot` draws it; a JSON summary is printed (and written).

The chain: `naic launch -p naic_controller:scenario:=none` (simulated arm on the flat
scenario's table, surface at z = 0.08 m), or your robot (docs/deploy.md). Simulated time:
`naic launch --lockstep -p naic_controller:scenario:=none` and --use-sim-time here.

    python3 examples/slide_with_force_profile.py --out runs/slide
"""
import argparse
import json
import math
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from naic_msgs.msg import NaicParams
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

ROOT = pathlib.Path(__file__).resolve().parents[1]
JOINTS = [f"joint{i}" for i in range(1, 7)]
TOPICS = ("/naic/target_pose", "/naic/desired_wrench")


def args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="runs/slide", help="directory for the bag, the figure and summary.json")
    ap.add_argument("--naic", default=str(ROOT / "target/release/naic"), help="the naic binary (record, plot)")
    ap.add_argument("--urdf", default=str(ROOT / "urdf/jk5.urdf"))
    ap.add_argument("--base-frame", default="base_link")
    ap.add_argument("--tip-frame", default="tip")
    ap.add_argument("--length", type=float, default=0.10, help="slide length [m]")
    ap.add_argument("--speed", type=float, default=0.010, help="slide speed [m/s]")
    ap.add_argument("--direction", type=float, nargs=3, default=[1.0, 0.0, 0.0], help="slide direction, base frame")
    ap.add_argument("--forces", type=float, nargs=3, default=[5.0, 10.0, 5.0], help="force of each third [N]")
    ap.add_argument("--approach-speed", type=float, default=0.02, help="descent speed until contact [m/s]")
    ap.add_argument("--rate", type=float, default=50.0, help="target publishing rate [Hz]")
    ap.add_argument("--settle", type=float, default=2.0, help="time at the first force before sliding [s]")
    ap.add_argument("--use-sim-time", action="store_true", help="follow /clock (naic launch --lockstep)")
    ap.add_argument("--timeout", type=float, default=120.0, help="give up after this long (wall clock) [s]")
    return ap.parse_args()


class Slide:
    def __init__(self, a):
        self.a = a
        self.n = rclpy.create_node("naic_slide_example")
        if a.use_sim_time:
            self.n.set_parameters([Parameter("use_sim_time", value=True)])
        self.pose_pub = self.n.create_publisher(PoseStamped, "/naic/target_pose", 10)
        self.wrench_pub = self.n.create_publisher(WrenchStamped, "/naic/desired_wrench", 10)
        self.js = None
        self.params = []
        self.n.create_subscription(JointState, "/joint_states", self._js, 10)
        self.n.create_subscription(NaicParams, "/naic/params", self.params.append, 1000)
        self.t_wall = time.time()

    def _js(self, m):
        self.js = m

    def now(self):
        return self.n.get_clock().now().nanoseconds * 1e-9

    def spin(self, cond=lambda: False, seconds=None):
        """Spin until cond() or `seconds` of node time (simulated with --use-sim-time) passed."""
        t0 = self.now()
        while not cond():
            if seconds is not None and self.now() - t0 >= seconds:
                return True
            if time.time() - self.t_wall > self.a.timeout:
                raise TimeoutError("gave up: the chain is not running (is naic launch up?)")
            rclpy.spin_once(self.n, timeout_sec=0.005)
        return True

    def missing_topics(self):
        """Reference topics naic_controller does not subscribe (rclpy graph API)."""
        return [t for t in TOPICS
                if "naic_controller" not in {i.node_name for i in self.n.get_subscriptions_info_by_topic(t)}]

    def start_pose(self):
        """Tip position and orientation (x, y, z, w) from /joint_states, by name."""
        import pinocchio as pin
        self.spin(lambda: self.js is not None)
        model = pin.buildModelFromUrdf(self.a.urdf)
        data = model.createData()
        by_name = dict(zip(self.js.name, self.js.position))
        q = np.array([by_name[j] for j in JOINTS])
        pin.framesForwardKinematics(model, data, q)
        m = data.oMf[model.getFrameId(self.a.tip_frame)]
        quat = pin.Quaternion(m.rotation)
        return np.array(m.translation), [quat.x, quat.y, quat.z, quat.w]

    def send(self, p, quat, force):
        stamp = self.n.get_clock().now().to_msg()
        ps = PoseStamped()
        ps.header.stamp, ps.header.frame_id = stamp, self.a.base_frame
        ps.pose.position.x, ps.pose.position.y, ps.pose.position.z = (float(v) for v in p)
        (ps.pose.orientation.x, ps.pose.orientation.y, ps.pose.orientation.z, ps.pose.orientation.w) = quat
        w = WrenchStamped()
        w.header.stamp, w.header.frame_id = stamp, self.a.base_frame
        # The wrench the tool applies to the surface: pushing down (force axis -z).
        w.wrench.force.z = -float(force)
        self.pose_pub.publish(ps)
        self.wrench_pub.publish(w)


def stamp_s(m):
    return m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec


def main():
    a = args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rclpy.init()
    s = Slide(a)
    s.spin(lambda: s.n.count_subscribers("/naic/target_pose") > 0 or time.time() - s.t_wall > 10)
    missing = s.missing_topics()
    if missing:
        sys.exit(f"naic_controller does not subscribe {', '.join(missing)}: this naic has no reference topics yet")
    p0, quat = s.start_pose()
    d = np.array(a.direction, float)
    d /= np.linalg.norm(d)
    bag = out / "slide.mcap"
    bag.unlink(missing_ok=True)
    # The naic topics and the force reference (naic record has no PoseStamped type yet, so
    # the pose targets are not in the bag; /naic/params holds what the controller did).
    rec = subprocess.Popen([a.naic, "record", "--out", str(bag), "--topics", "/joint_states", "/wrench",
                            "/joint_effort_cmd", "/naic/effort", "/naic/params", "/clock", "/naic/desired_wrench",
                            "--type", "/naic/desired_wrench=geometry_msgs/msg/WrenchStamped"], cwd=ROOT)
    period = 1.0 / a.rate
    try:
        s.spin(seconds=1.0)  # the recorder discovers the topics
        # Approach: descend at approach_speed until contact, pressing the first force.
        t0, p = s.now(), p0.copy()
        while not (s.params and s.params[-1].phase == NaicParams.PHASE_CONTACT):
            p = p0 + np.array([0.0, 0.0, -a.approach_speed * (s.now() - t0)])
            s.send(p, quat, a.forces[0])
            s.spin(seconds=period)
        # In contact the force axis is force-controlled: keep the target 5 mm into the surface.
        p_contact = p + np.array([0.0, 0.0, -0.005])
        t_settle = s.now()
        while s.now() - t_settle < a.settle:
            s.send(p_contact, quat, a.forces[0])
            s.spin(seconds=period)
        # Slide, one third of the length per force.
        duration = a.length / a.speed
        s.params.clear()
        t_slide = s.now()
        while (t := s.now() - t_slide) <= duration:
            third = min(2, int(3 * t / duration))
            s.send(p_contact + d * a.speed * t, quat, a.forces[third])
            s.spin(seconds=period)
        t_end = s.now()
        sliding = [m for m in s.params if t_slide <= stamp_s(m) <= t_end]
        s.spin(seconds=0.5)
    finally:
        rec.send_signal(signal.SIGINT)
        rec.wait(timeout=30)
    plot = subprocess.run([a.naic, "plot", str(bag), "--out", str(out), "--urdf", a.urdf], cwd=ROOT,
                          capture_output=True, text=True)
    err = [m.measured_force - m.desired_force for m in sliding]
    summary = {
        "bag": str(bag),
        "figure": str(out / "slide.svg"),
        "plot_ok": plot.returncode == 0,
        "slide_samples": len(sliding),
        "slide_duration_s": t_end - t_slide,
        "phases_in_contact": sum(m.phase == NaicParams.PHASE_CONTACT for m in sliding),
        "max_abs_force_error_n": max((abs(e) for e in err), default=math.nan),
        "rms_force_error_n": math.sqrt(sum(e * e for e in err) / len(err)) if err else math.nan,
        "desired_forces_seen": sorted({round(m.desired_force, 3) for m in sliding if m.desired_force in a.forces}),
        "faults": sorted({m.fault for m in sliding if m.fault}),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary))
    if not summary["plot_ok"]:
        sys.exit(f"naic plot failed: {plot.stderr.strip()}")
    s.n.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
