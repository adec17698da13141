"""rclpy probe for /tf, /tf_static and /robot_description (issue 39 item 4), run in the
naic_msgs/tf2_msgs overlay by tests/python/test_ros_tf.py.

    tf_probe.py publish   # publishes /joint_states itself (a naic_controller alone)
    tf_probe.py listen    # a chain publishes them (naic launch --composed)

Collects /tf (reliable, volatile, as tf2_ros's TransformListener) with the /joint_states of
the same stamps, then, as a late joiner, a new node subscribes /tf_static and
/robot_description transient local (as tf2_ros's static listener and RViz do) and must get
them. Prints one JSON line: the transforms of up to 5 /tf messages, the joint states of their
stamps, the static transforms and the description's length and robot name.
"""
import json
import sys
import time

import rclpy
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

mode = sys.argv[1]
rclpy.init()
node = rclpy.create_node("tf_probe")
reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                      durability=DurabilityPolicy.VOLATILE)
latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
tfs, states = [], {}


def stamp(h):
    return h.stamp.sec * 1_000_000_000 + h.stamp.nanosec


def on_js(m):
    states[stamp(m.header)] = dict(zip(m.name, m.position))


node.create_subscription(TFMessage, "/tf", tfs.append, reliable)
node.create_subscription(JointState, "/joint_states", on_js, reliable)
pub = node.create_publisher(JointState, "/joint_states", 10) if mode == "publish" else None
# Not the model's joint order, not at zero: /tf must follow the names.
q = {"joint1": 0.3, "joint2": -0.4, "joint3": 1.7, "joint4": 0.2, "joint5": 0.9, "joint6": -1.1}


def spin_until(cond, timeout):
    t0 = time.time()
    next_pub = 0.0
    while time.time() - t0 < timeout and not cond():
        if pub is not None and time.time() >= next_pub:
            m = JointState()
            m.header.stamp = node.get_clock().now().to_msg()
            m.name = list(reversed(q))
            m.position = [q[n] for n in m.name]
            m.velocity = [0.0] * 6
            m.effort = [0.0] * 6
            pub.publish(m)
            next_pub = time.time() + 0.005
        rclpy.spin_once(node, timeout_sec=0.002)
    return cond()


def paired():
    return [t for t in tfs if stamp(t.transforms[0].header) in states]


ok = spin_until(lambda: len(paired()) >= 5, 60)
out = {"tf_ok": ok, "n_tf": len(tfs)}
out["tf"] = [{"stamp": stamp(m.transforms[0].header), "q": states[stamp(m.transforms[0].header)],
              "transforms": [{"parent": t.header.frame_id, "child": t.child_frame_id,
                              "p": [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
                              "r": [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                                    t.transform.rotation.w]} for t in m.transforms]}
             for m in paired()[:5]]
stamps = sorted(stamp(m.transforms[0].header) for m in tfs)
out["tf_periods_ns"] = [b - a for a, b in zip(stamps, stamps[1:])][:50]

# A late joiner: a new node, after /tf_static and /robot_description were published.
late = rclpy.create_node("tf_probe_late")
static, desc = [], []
late.create_subscription(TFMessage, "/tf_static", static.append, latched)
late.create_subscription(String, "/robot_description", desc.append, latched)
t0 = time.time()
while time.time() - t0 < 30 and not (static and desc):
    rclpy.spin_once(late, timeout_sec=0.01)
    rclpy.spin_once(node, timeout_sec=0.0)
out["static"] = [{"parent": t.header.frame_id, "child": t.child_frame_id,
                  "p": [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
                  "r": [t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w]}
                 for m in static[:1] for t in m.transforms]
out["description"] = desc[0].data if desc else ""
late.destroy_node()
node.destroy_node()
rclpy.shutdown()
print(json.dumps(out))
