#!/usr/bin/env python3
"""Move the arm through several tool orientations and identify the tool from them.

Drives naic_controller through /naic/target_pose (geometry_msgs/PoseStamped, base frame)
from your own rclpy code, records /joint_states and /wrench with `naic record` while the arm
holds still in each orientation, then runs `naic tool identify` on the bag and prints the
tool section of the robot file (mass, centre of mass in the sensor frame) with the standard
error of each parameter (docs/deploy.md, "The tool on the sensor").

Steps:
  1. the start tip pose, by forward kinematics of /joint_states (Pinocchio on the URDF);
  2. `naic record` starts recording /joint_states and /wrench;
  3. the tip rises --lift above its start and turns through --poses orientations: the start
     orientation and tilts of --tilt about the tool's x and y axes and both diagonals; in
     each it holds until every joint is slower than --still (rad/s) for --hold seconds
     (the static poses `naic tool identify` uses);
  4. the bag is closed; `naic tool identify --bag … --out tool.yaml` fits the tool.

The arm stays in free space: do not run it with the tool near anything. The chain:
`naic launch -p naic_controller:scenario:=none` (simulated arm), or your robot
(docs/deploy.md). Simulated time: `naic launch --lockstep -p naic_controller:scenario:=none`
and --use-sim-time here.

    python3 examples/tool_poses.py --out runs/tool

The controller runs the stiffness-scheduled law here (CONTROLLER_PARAMS, set on
naic_controller through its SetParameters service before the first move): with the paper's
law (`mode: naic`) the arm in free space does not settle: on the in-process
lockstep chain its fastest joint reached 0.09-0.14 rad/s in every second of a 12 s hold
at each of three orientations, while with `scheduled` it stayed at 0.007-0.009 rad/s
(nodes/naic_controller's in-process chain, true joint speeds).
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
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

ROOT = pathlib.Path(__file__).resolve().parents[1]
JOINTS = [f"joint{i}" for i in range(1, 7)]
# The law that holds the arm still in free space (the module docstring says why).
CONTROLLER_PARAMS = {"mode": "scheduled"}


def args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="runs/tool", help="directory for the bag and tool.yaml")
    ap.add_argument("--naic", default=str(ROOT / "target/release/naic"), help="the naic binary (record, tool identify)")
    ap.add_argument("--urdf", default=str(ROOT / "urdf/jk5.urdf"))
    ap.add_argument("--base-frame", default="base_link")
    ap.add_argument("--tip-frame", default="tip")
    ap.add_argument("--poses", type=int, default=8, help="orientations (at least 6 for a confident fit)")
    ap.add_argument("--tilt", type=float, default=0.5, help="tilt of the tool from its start orientation [rad]")
    ap.add_argument("--lift", type=float, default=0.05, help="rise above the start position first [m]")
    ap.add_argument("--hold", type=float, default=1.5, help="time held still in each orientation [s]")
    ap.add_argument("--still", type=float, default=0.01, help="still: every joint slower than this [rad/s] (naic tool identify's --velocity-bound)")
    ap.add_argument("--rate", type=float, default=50.0, help="target publishing rate [Hz]")
    ap.add_argument("--use-sim-time", action="store_true", help="follow /clock (naic launch --lockstep)")
    ap.add_argument("--timeout", type=float, default=300.0, help="give up after this long (wall clock) [s]")
    return ap.parse_args()


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz]


def axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    s = math.sin(angle / 2)
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]


def orientations(start, n, tilt):
    """The start orientation, then tilts about directions of the tool's own x-y plane (tip
    frame), evenly spread: gravity then points in n directions of the sensor frame."""
    out = [start]
    for k in range(n - 1):
        phi = 2 * math.pi * k / (n - 1)
        out.append(quat_mul(start, axis_angle([math.cos(phi), math.sin(phi), 0.0], tilt)))
    return out


class Poses:
    def __init__(self, a):
        self.a = a
        self.n = rclpy.create_node("naic_tool_poses_example")
        if a.use_sim_time:
            self.n.set_parameters([Parameter("use_sim_time", value=True)])
        self.pose_pub = self.n.create_publisher(PoseStamped, "/naic/target_pose", 1000)
        self.js = None
        self.n.create_subscription(JointState, "/joint_states", lambda m: setattr(self, "js", m), 10)
        self.t_wall = time.time()

    def now(self):
        return self.n.get_clock().now().nanoseconds * 1e-9

    def spin(self, cond=lambda: False, seconds=None):
        t0 = self.now()
        while not cond():
            if seconds is not None and self.now() - t0 >= seconds:
                return True
            if time.time() - self.t_wall > self.a.timeout:
                raise TimeoutError("gave up: the chain is not running or the arm never came to rest")
            rclpy.spin_once(self.n, timeout_sec=0.005)
        return True

    def set_controller_params(self, values):
        """Set naic_controller's parameters through its SetParameters service."""
        from rcl_interfaces.srv import SetParameters
        cli = self.n.create_client(SetParameters, "/naic_controller/set_parameters")
        self.spin(lambda: cli.service_is_ready())
        req = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        fut = cli.call_async(req)
        self.spin(lambda: fut.done())
        bad = [(k, r.reason) for k, r in zip(values, fut.result().results) if not r.successful]
        if bad:
            raise RuntimeError(f"naic_controller refused {bad}")

    def start_pose(self):
        import pinocchio as pin
        self.spin(lambda: self.js is not None)
        model = pin.buildModelFromUrdf(self.a.urdf)
        data = model.createData()
        by_name = dict(zip(self.js.name, self.js.position))
        pin.framesForwardKinematics(model, data, np.array([by_name[j] for j in JOINTS]))
        m = data.oMf[model.getFrameId(self.a.tip_frame)]
        q = pin.Quaternion(m.rotation)
        return np.array(m.translation), [q.x, q.y, q.z, q.w]

    def send(self, p, quat):
        ps = PoseStamped()
        ps.header.stamp, ps.header.frame_id = self.n.get_clock().now().to_msg(), self.a.base_frame
        ps.pose.position.x, ps.pose.position.y, ps.pose.position.z = (float(v) for v in p)
        (ps.pose.orientation.x, ps.pose.orientation.y, ps.pose.orientation.z, ps.pose.orientation.w) = quat
        self.pose_pub.publish(ps)

    def still(self):
        v = dict(zip(self.js.name, self.js.velocity)) if self.js is not None else {}
        return len(v) >= len(JOINTS) and all(abs(v[j]) < self.a.still for j in JOINTS)

    def hold(self, p, quat):
        """Send the target until the arm has been still for --hold seconds."""
        period, since, shown = 1.0 / self.a.rate, None, time.time()
        while True:
            self.send(p, quat)
            self.spin(seconds=period)
            if time.time() - shown > 10 and self.js is not None:
                shown = time.time()
                v = max(abs(x) for x in self.js.velocity)
                print(f"  waiting for rest: fastest joint {v:.4f} rad/s (still below {self.a.still})", file=sys.stderr)
            if self.still():
                since = self.now() if since is None else since
                if self.now() - since >= self.a.hold:
                    return
            else:
                since = None


def main():
    a = args()
    if a.poses < 3:
        sys.exit("--poses: at least 3 (6 or more for a confident fit)")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rclpy.init()
    s = Poses(a)
    s.set_controller_params(CONTROLLER_PARAMS)
    p0, q0 = s.start_pose()
    target = p0 + np.array([0.0, 0.0, a.lift])
    bag = out / "tool_poses.mcap"
    bag.unlink(missing_ok=True)
    rec_log = open(out / "record.log", "w")
    rec = subprocess.Popen([a.naic, "record", "--out", str(bag), "--topics", "/joint_states", "/wrench", "/clock"],
                           cwd=ROOT, stderr=rec_log)
    try:
        s.spin(seconds=1.0)  # the recorder discovers the topics
        for k, quat in enumerate(orientations(q0, a.poses, a.tilt)):
            s.hold(target, quat)
            print(f"pose {k + 1}/{a.poses} held", file=sys.stderr)
        t_wait = time.time()
        s.spin(lambda: time.time() - t_wait > 2.0)
    finally:
        rec.send_signal(signal.SIGINT)
        rec.wait(timeout=60)
        rec_log.close()
    ident = subprocess.run([a.naic, "tool", "identify", "--bag", str(bag), "--urdf", a.urdf, "--out", str(out / "tool.yaml")],
                           cwd=ROOT, capture_output=True, text=True)
    sys.stderr.write(ident.stderr)
    if ident.returncode != 0:
        sys.exit(f"naic tool identify failed: {ident.stderr.strip()}")
    print(ident.stdout, file=sys.stderr)
    print(json.dumps({"bag": str(bag), "tool_yaml": str(out / "tool.yaml"), "report": ident.stdout}))
    s.n.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
