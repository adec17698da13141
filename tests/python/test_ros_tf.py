"""/tf, /tf_static and /robot_description (issue 39 item 4), as RViz and Foxglove read them:
real rclpy (tf2_msgs/msg/TFMessage) on a private loopback-only domain. The transforms
chained from base_link to tip must equal Pinocchio's forward kinematics of the same URDF at
the joint state of the same stamp (1e-6 m), and a subscriber that joins late must still get
/tf_static and /robot_description (transient local). From the controller process and from
`naic launch --composed`.
"""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
pin = pytest.importorskip("pinocchio")

URDF = ru.ROOT / "urdf" / "jk5.urdf"
PROBE = ru.ROOT / "tests" / "ros" / "tf_probe.py"


def pose(t):
    x, y, z, w = t["r"]
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.array(t["p"]))


def chain(transforms, child):
    """base → `child` through the transforms (each link has one parent)."""
    by_child = {t["child"]: t for t in transforms}
    m, at = pin.SE3.Identity(), child
    while at in by_child:
        t = by_child[at]
        m = pose(t) * m
        at = t["parent"]
    return m, at


def check(out):
    assert out["tf_ok"], out
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    tip = model.getFrameId("tip")
    assert out["static"], "no /tf_static for a late joiner"
    assert sorted(t["child"] for t in out["static"]) == ["ft_sensor", "tip"], out["static"]
    assert "<robot" in out["description"] and 'name="tip"' in out["description"], out["description"][:200]
    for m in out["tf"]:
        assert sorted(t["child"] for t in m["transforms"]) == [f"link{i}" for i in range(1, 7)]
        q = np.array([m["q"][model.names[i]] for i in range(1, model.njoints)])
        pin.framesForwardKinematics(model, data, q)
        got, root = chain(m["transforms"] + out["static"], "tip")
        assert root == "base_link"
        want = data.oMf[tip]
        assert np.linalg.norm(got.translation - want.translation) < 1e-6, (got, want)
        assert np.linalg.norm(pin.log3(got.rotation.T @ want.rotation)) < 1e-6
    # tf_rate 100 Hz: /tf stamps at least 10 ms apart (the joint states come every 5 ms or 1 ms).
    assert out["tf_periods_ns"] and min(out["tf_periods_ns"]) >= 10_000_000, out["tf_periods_ns"]


def test_ros_tf_from_the_controller_matches_pinocchio_and_late_joiners_get_the_static_topics():
    bins = ru.build_nodes()
    domain = ru.fresh_domain(230)
    ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                   "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"], ru.ros_env(domain))
    out = ru.run_in_overlay([PROBE, "publish"], domain, ru.naic_msgs_env(), 180, stop=ctl)
    check(out)


def test_ros_tf_from_naic_launch_composed():
    bins = ru.build_nodes()
    domain = ru.fresh_domain(240)
    launch = ru.Proc([str(bins / "naic"), "launch", "--composed"], ru.ros_env(domain))
    out = ru.run_in_overlay([PROBE, "listen"], domain, ru.naic_msgs_env(), 180, stop=launch)
    check(out)
