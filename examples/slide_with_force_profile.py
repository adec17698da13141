#!/usr/bin/env python3
"""Slide the tool 10 cm along a surface at 10 mm/s while pressing 5 → 10 → 5 N.

Drives naic_controller from your own rclpy code through its reference topics:
  /naic/target_pose    (geometry_msgs/PoseStamped, base frame): where the tip should go
  /naic/desired_wrench (geometry_msgs/WrenchStamped, base frame): the force the tool applies
and checks the result on /naic/params. The controller treats both as a reference: it
limits speed and acceleration, holds the last target if this script stops, and refuses
a header.frame_id that is not a frame of the robot model (this script uses the base frame).

Steps:
  0. the controller settings of this profile (CONTROLLER_PARAMS, set on naic_controller by
     its parameter service; --keep-params leaves the node's as they are);
  1. the start tip pose, by forward kinematics of /joint_states (Pinocchio on the URDF);
  2. `naic record` starts recording a bag (the naic topics, /naic/target_pose and
     /naic/desired_wrench);
  3. approach: targets descending at --approach-speed until the controller reports contact;
  4. 5 N until the force settles, then the slide with 5 N, 10 N and 5 N thirds;
  5. the bag is closed and `naic plot` draws it; the force error while sliding is read
     from the bag's /naic/params (every cycle, as `naic bag export-csv` writes it) and a
     JSON summary is printed (and written).

The chain: `naic launch -p naic_controller:scenario:=none` (simulated arm on the flat
scenario's table, surface at z = 0.08 m), or your robot (docs/deploy.md). Simulated time:
`naic launch --lockstep -p naic_controller:scenario:=none` and --use-sim-time here.

    python3 examples/slide_with_force_profile.py --out runs/slide
"""
import argparse
import csv
import json
import math
import re
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from naic_msgs.msg import NaicParams
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

ROOT = pathlib.Path(__file__).resolve().parents[1]
JOINTS = [f"joint{i}" for i in range(1, 7)]
TOPICS = ("/naic/target_pose", "/naic/desired_wrench")
# naic_controller settings for this profile (docs/nodes.md, "The rclpy example"):
# - mode: scheduled, naic's stiffness-scheduled force law (docs/controller.md). With the
#   paper's laws the joints breaking away in their Stribeck friction range at the start of
#   the slide reached the contact force as 0.3-0.7 N bursts (NAIC); the scheduled law's
#   integral and damping hold the error at 0.26-0.30 N over eleven slide starts in process.
# - max_force_rate: the force reference moves at 5 N/s. At the default 100 N/s each 5 N step
#   reaches the force loop as a step (50 ms).
CONTROLLER_PARAMS = {"mode": "scheduled", "max_force_rate": 5.0}


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
    ap.add_argument("--keep-params", action="store_true", help="leave naic_controller's parameters as they are")
    return ap.parse_args()


class Slide:
    def __init__(self, a):
        self.a = a
        self.n = rclpy.create_node("naic_slide_example")
        if a.use_sim_time:
            self.n.set_parameters([Parameter("use_sim_time", value=True)])
        # Reliable with a history of 1000 (1 s at 1 kHz): a subscriber that falls behind for
        # a moment (naic record on a loaded machine) gets the lost samples re-sent; with the
        # default 10 a recorder starved for over 10 ms lost some.
        self.pose_pub = self.n.create_publisher(PoseStamped, "/naic/target_pose", 1000)
        self.wrench_pub = self.n.create_publisher(WrenchStamped, "/naic/desired_wrench", 1000)
        self.js = None
        self.last = None
        # The newest /naic/params only (the contact phase): the force error is read from the
        # bag afterwards, so a slow Python loop never falls behind a 1 kHz topic.
        self.n.create_subscription(NaicParams, "/naic/params", self._params, 1)
        self.t_wall = time.time()

    def _params(self, m):
        self.last = m

    def in_contact(self):
        return self.last is not None and self.last.phase == NaicParams.PHASE_CONTACT

    def set_controller_params(self, values):
        """Set naic_controller's parameters through its SetParameters service."""
        cli = self.n.create_client(SetParameters, "/naic_controller/set_parameters")
        self.spin(lambda: cli.service_is_ready())
        req = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        fut = cli.call_async(req)
        self.spin(lambda: fut.done())
        bad = [f"{k}: {r.reason}" for k, r in zip(values, fut.result().results) if not r.successful]
        if bad:
            sys.exit("naic_controller refused " + "; ".join(bad))
        self.n.destroy_client(cli)

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
        sub = self.n.create_subscription(JointState, "/joint_states", lambda m: setattr(self, "js", m), 1)
        self.spin(lambda: self.js is not None)
        self.n.destroy_subscription(sub)
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


def sliding_rows(bag, naic, t0, t1):
    """/naic/params of the bag between stamps t0 and t1 [s] (naic bag export-csv)."""
    out = bag.parent / "csv"
    r = subprocess.run([naic, "bag", "export-csv", str(bag), "--out", str(out)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"naic bag export-csv failed: {r.stderr.strip()}")
    with open(out / "naic_params.csv", newline="") as f:
        return [row for row in csv.DictReader(f) if t0 <= float(row["stamp_s"]) <= t1]


def main():
    a = args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rclpy.init()
    s = Slide(a)
    # Both subscriptions (discovery announces them one by one; a loaded machine takes seconds).
    s.spin(lambda: not s.missing_topics() or time.time() - s.t_wall > 30)
    missing = s.missing_topics()
    if missing:
        sys.exit(f"naic_controller does not subscribe {', '.join(missing)}: this naic has no reference topics yet")
    if not a.keep_params:
        s.set_controller_params(CONTROLLER_PARAMS)
    p0, quat = s.start_pose()
    d = np.array(a.direction, float)
    d /= np.linalg.norm(d)
    bag = out / "slide.mcap"
    bag.unlink(missing_ok=True)
    # The naic topics and both references (/naic/params holds what the controller did).
    rec_log = open(out / "record.log", "w")  # the recorder's report, incl. messages it lost
    rec = subprocess.Popen([a.naic, "record", "--out", str(bag), "--topics", "/joint_states", "/wrench",
                            "/joint_effort_cmd", "/naic/effort", "/naic/params", "/clock", "/naic/desired_wrench",
                            "/naic/target_pose"], cwd=ROOT, stderr=rec_log)
    period = 1.0 / a.rate
    try:
        s.spin(seconds=1.0)  # the recorder discovers the topics
        # Approach: descend at approach_speed until contact, pressing the first force.
        t0, p = s.now(), p0.copy()
        while not s.in_contact():
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
        t_slide = s.now()
        while (t := s.now() - t_slide) <= duration:
            third = min(2, int(3 * t / duration))
            s.send(p_contact + d * a.speed * t, quat, a.forces[third])
            s.spin(seconds=period)
        t_end = s.now()
        s.spin(seconds=0.5)
        # The recorder may run behind a lockstep chain that is faster than real time: give
        # it 2 s of wall time to take what is on its way before it is stopped.
        t_wait = time.time()
        s.spin(lambda: time.time() - t_wait > 2.0)
    finally:
        rec.send_signal(signal.SIGINT)
        rec.wait(timeout=60)  # it catches up with the stop for up to 35 s (naic record)
        rec_log.close()
    rec_text = (out / "record.log").read_text()
    sys.stderr.write(rec_text)
    lost = {m.group(1): int(m.group(2))
            for m in re.finditer(r"naic record: (\S+): (\d+) messages published but not recorded", rec_text)}
    plot = subprocess.run([a.naic, "plot", str(bag), "--out", str(out), "--urdf", a.urdf], cwd=ROOT,
                          capture_output=True, text=True)
    sliding = sliding_rows(bag, a.naic, t_slide, t_end)
    err = [float(m["measured_force"]) - float(m["desired_force"]) for m in sliding]
    f_d = [float(m["desired_force"]) for m in sliding]
    summary = {
        "bag": str(bag),
        "figure": str(out / "slide.svg"),
        "plot_ok": plot.returncode == 0,
        "slide_samples": len(sliding),
        "recorder_lost": lost,
        "slide_duration_s": t_end - t_slide,
        "phases_in_contact": sum(int(m["phase"]) == NaicParams.PHASE_CONTACT for m in sliding),
        "max_abs_force_error_n": max((abs(e) for e in err), default=math.nan),
        "rms_force_error_n": math.sqrt(sum(e * e for e in err) / len(err)) if err else math.nan,
        "max_abs_force_error_after_1s_n": max((abs(e) for m, e in zip(sliding, err)
                                               if float(m["stamp_s"]) >= t_slide + 1.0), default=math.nan),
        "desired_forces_seen": sorted({round(f, 3) for f in f_d if f in a.forces}),
        "faults": sorted({m["fault"] for m in sliding if m["fault"]}),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary))
    if not summary["plot_ok"]:
        sys.exit(f"naic plot failed: {plot.stderr.strip()}")
    s.n.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
