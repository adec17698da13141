"""What the ros2 CLI shows (issue 39 item 5): every log line of a node is also published on
/rosout (rcl_interfaces/msg/Log with level, node name, file, function, line), stderr kept.
Real rclpy subscribes /rosout, makes naic_controller reject a parameter set and must
receive its warning. Loopback only, private domain.
"""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")


def test_ros_a_rejected_parameter_sets_warning_reaches_rosout():
    from rcl_interfaces.msg import Log
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    bins = ru.build_nodes()
    domain = ru.fresh_domain(200)
    ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                   "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"], ru.ros_env(domain))
    r = ru.RclpyDomain(domain, "rosout_probe")
    logs = []
    try:
        # What `ros2 topic echo /rosout` asks for (reliable, volatile).
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                         durability=DurabilityPolicy.VOLATILE)
        r.node.create_subscription(Log, "/rosout", logs.append, qos)
        client = ru.param_client(r.node, "naic_controller", 60.0)
        # The node's /rosout writer must be matched before the warning is logged.
        assert r.spin_until(lambda: any(i.node_name == "naic_controller"
                                        for i in r.node.get_publishers_info_by_topic("/rosout")), 60), ctl.output()[-2000:]
        # Our reader may be matched by the node's writer later than rclpy sees the writer
        # (a volatile reader gets only what is written after): set again until one arrives.
        for _ in range(15):
            res = r.wait(client.set_parameters([Parameter("learning_rate", value=-1.0)]), 30.0)
            assert not res.results[0].successful, res
            if r.spin_until(lambda: any("rejected set of learning_rate" in m.msg for m in logs), 2):
                break
        assert any("rejected set of learning_rate" in m.msg for m in logs), ([m.msg for m in logs], ctl.output()[-2000:])
    finally:
        r.close()
        assert ctl.stop() == 0, ctl.output()[-2000:]
    m = next(m for m in logs if "rejected set of learning_rate" in m.msg)
    assert m.level == Log.WARN and m.name == "naic_controller", (m.level, m.name)
    assert m.file.endswith(".rs") and m.line > 0 and m.function.startswith("naic_ros"), (m.file, m.line, m.function)
    assert m.stamp.sec > 0
    # stderr is kept.
    assert "rejected set of learning_rate" in ctl.output()


def test_ros_topic_info_shows_valid_type_hashes_equal_to_rclpys():
    """`ros2 topic info -v` reads an endpoint's type hash from its discovery USER_DATA
    (`typehash=RIHS01_…;`). Every naic topic of a running chain must show a valid hash, and
    for the standard types the one rclpy's own endpoints of that type announce (rosidl's).
    Each node of the chain has one `/parameter_events` publisher, as an rclcpp node."""
    from geometry_msgs.msg import WrenchStamped
    from rcl_interfaces.msg import Log, ParameterEvent
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    bins = ru.build_nodes()
    domain = ru.fresh_domain(205)
    env = ru.ros_env(domain)
    launch = ru.Proc([str(bins / "naic"), "launch", "-p", "naic_controller:realtime_priority:=0",
                      "-p", "naic_controller:cpu_affinity:=-1", "-p", "friction_compensation:realtime_priority:=0",
                      "-p", "friction_compensation:cpu_affinity:=-1", "-p", "jk5_sim_driver:realtime_priority:=0",
                      "-p", "jk5_sim_driver:cpu_affinity:=-1"], env)
    r = ru.RclpyDomain(domain, "type_hash_probe")
    topics = {"/joint_states": JointState, "/wrench": WrenchStamped, "/naic/effort": Float64MultiArray,
              "/joint_effort_cmd": Float64MultiArray, "/naic/params": None, "/clock": None,
              "/rosout": Log, "/parameter_events": ParameterEvent}
    try:
        # rclpy's own endpoints of the standard types: the reference hashes (rosidl's).
        for t, ty in topics.items():
            if ty is not None:
                r.node.create_subscription(ty, t, lambda m: None, 10)

        def naic_pubs():
            got = {}
            for t in topics:
                for i in r.node.get_publishers_info_by_topic(t):
                    if i.node_name != "type_hash_probe":
                        got[t] = str(i.topic_type_hash)
            return got
        assert r.spin_until(lambda: len(naic_pubs()) == len(topics), 60), (naic_pubs(), launch.output()[-2000:])
        got = naic_pubs()
        # Every endpoint of every naic node on every topic the graph lists (/tf, /rosout,
        # /parameter_events, the reference topics, ...), publishers and subscriptions.
        naic_nodes = {"jk5_sim_driver", "naic_controller", "friction_compensation"}
        required = {"/tf", "/tf_static", "/robot_description", "/rosout", "/parameter_events"}

        def every_endpoint():
            every = {}
            for t, _ in r.node.get_topic_names_and_types():
                for i in r.node.get_publishers_info_by_topic(t) + r.node.get_subscriptions_info_by_topic(t):
                    if i.node_name in naic_nodes:
                        every.setdefault(t, set()).add(str(i.topic_type_hash))
            return every
        # rclpy names an endpoint's node once that participant's ros_discovery_info is in.
        r.spin_until(lambda: required <= set(every_endpoint()), 30)
        every = every_endpoint()
        ours = {t: str(i.topic_type_hash) for t in topics for i in r.node.get_subscriptions_info_by_topic(t)
                if i.node_name == "type_hash_probe"}
        # One /parameter_events publisher per node, as rclcpp (issue 39); once rclpy has every
        # node's ros_discovery_info (it names an endpoint's node from it).
        def event_pubs_now():
            return {n: sum(1 for i in r.node.get_publishers_info_by_topic("/parameter_events") if i.node_name == n)
                    for n in naic_nodes}
        r.spin_until(lambda: all(event_pubs_now().values()), 30)
        event_pubs = event_pubs_now()
    finally:
        r.close()
        assert launch.stop(timeout=15) == 0, launch.output()[-3000:]
    print(got)
    print({t: sorted(h) for t, h in every.items()})
    assert required <= set(every), sorted(every)
    bad = {t: h for t, h in every.items() if not all(x.startswith("RIHS01_") and len(x) == 7 + 64 for x in h)}
    assert not bad, bad
    for t, h in got.items():
        assert h.startswith("RIHS01_") and len(h) == 7 + 64, (t, h)
        if t in ours:
            assert h == ours[t], (t, h, ours[t])
    assert set(ours) == {t for t, ty in topics.items() if ty is not None}, ours
    assert event_pubs == {n: 1 for n in naic_nodes}, f"/parameter_events publishers per node: {event_pubs}"


def test_ros_robot_description_reaches_a_late_joiner():
    """/robot_description (std_msgs/String, transient local, as robot_state_publisher offers
    it): an rclpy subscriber that joins seconds after naic_controller started receives the
    URDF text, equal to the file, with the type hash rclpy's own String endpoints announce."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    bins = ru.build_nodes()
    domain = ru.fresh_domain(210)
    ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                   "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"], ru.ros_env(domain))
    r = ru.RclpyDomain(domain, "late_joiner")
    got = []
    try:
        # Late: the node has published its description before this subscriber exists.
        assert r.spin_until(lambda: any(i.node_name == "naic_controller"
                                        for i in r.node.get_publishers_info_by_topic("/robot_description")), 60), \
            ctl.output()[-2000:]
        r.spin(2.0)
        assert any("started" in l for l in ctl.output().splitlines()), ctl.output()[-2000:]
        qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        r.node.create_subscription(String, "/robot_description", got.append, qos)
        assert r.spin_until(lambda: got, 30), ctl.output()[-2000:]
        theirs = [str(i.topic_type_hash) for i in r.node.get_publishers_info_by_topic("/robot_description")
                  if i.node_name == "naic_controller"]
        ours = [str(i.topic_type_hash) for i in r.node.get_subscriptions_info_by_topic("/robot_description")
                if i.node_name == "late_joiner"]
    finally:
        r.close()
        assert ctl.stop() == 0, ctl.output()[-2000:]
    assert got[0].data == (ru.ROOT / "urdf/jk5.urdf").read_text()
    assert len(got) == 1
    assert theirs and theirs == ours and theirs[0].startswith("RIHS01_"), (theirs, ours)


def test_ros_parameter_events_are_volatile_as_rclcpp_offers_them():
    """`/parameter_events` as rclcpp offers it (reliable, volatile): a subscriber that joins
    after the node started and after a parameter was set receives none of those old events,
    whether it asks for volatile (`ros2 topic echo` against a volatile publisher) or
    transient local; the next set reaches the volatile one (the control: the subscriber
    works). The node has one publisher of the topic, as an rclcpp node (ros2-client's own
    writer carries naic's events: crates/vendor/ros2-client/PATCHED.md), and it announces
    VOLATILE."""
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    bins = ru.build_nodes()
    domain = ru.fresh_domain(215)
    ctl = ru.Proc([str(bins / "naic_controller"), "--ros-args", "--params-file", "params/naic_controller.yaml",
                   "-p", "realtime_priority:=0", "-p", "cpu_affinity:=-1"], ru.ros_env(domain))
    r = ru.RclpyDomain(domain, "late_events")
    vol, tl = [], []
    try:
        client = ru.param_client(r.node, "naic_controller", 60.0)
        # An old event: a set before the late subscribers exist (start-up events are older still).
        res = r.wait(client.set_parameters([Parameter("learning_rate", value=0.02)]), 30.0)
        assert res.results[0].successful, res
        r.spin(1.0)
        mk = lambda d: QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,  # noqa: E731
                                  history=HistoryPolicy.KEEP_LAST, durability=d)
        r.node.create_subscription(ParameterEvent, "/parameter_events",
                                   lambda m: vol.append(m) if m.node == "/naic_controller" else None,
                                   mk(DurabilityPolicy.VOLATILE))
        r.node.create_subscription(ParameterEvent, "/parameter_events",
                                   lambda m: tl.append(m) if m.node == "/naic_controller" else None,
                                   mk(DurabilityPolicy.TRANSIENT_LOCAL))
        r.spin(4.0)
        old_vol, old_tl = list(vol), list(tl)
        pubs = [i for i in r.node.get_publishers_info_by_topic("/parameter_events") if i.node_name == "naic_controller"]
        # The control: a set now reaches the volatile subscriber (matched by then; set again
        # until one arrives in case the match is late on a loaded machine).
        for k in range(10):
            res = r.wait(client.set_parameters([Parameter("learning_rate", value=0.03 + 0.001 * k)]), 30.0)
            assert res.results[0].successful, res
            if r.spin_until(lambda: len(vol) > len(old_vol), 2):
                break
    finally:
        r.close()
        assert ctl.stop() == 0, ctl.output()[-2000:]
    print(f"late subscribers got {len(old_vol)} (volatile) and {len(old_tl)} (transient local) old events; "
          f"publishers of naic_controller: {[(i.qos_profile.durability.name) for i in pubs]}")
    assert not old_vol and not old_tl, ([m.changed_parameters for m in old_vol], [m.changed_parameters for m in old_tl])
    assert vol[len(old_vol):] and vol[-1].changed_parameters[0].name == "learning_rate", vol
    assert len(pubs) == 1, f"naic_controller has {len(pubs)} /parameter_events publishers (rclcpp: 1): {pubs}"
    assert pubs[0].qos_profile.durability == DurabilityPolicy.VOLATILE, pubs
