"""examples/slide_with_force_profile.py against the node chain (lockstep, loopback only):
rclpy slides the tool 10 cm at 10 mm/s with 5 → 10 → 5 N through /naic/target_pose and
/naic/desired_wrench, records with `naic record` and draws with `naic plot`.
"""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")


def test_example_slides_with_the_force_profile(tmp_path):
    bins = ru.build_nodes()
    domain = ru.fresh_domain(70)
    launch = ru.Proc([str(bins / "naic"), "launch", "--lockstep", "--real-time-factor", "1", "-p",
                      "naic_controller:scenario:=none"],
                     ru.ros_env(domain))
    try:
        r = ru.RclpyDomain(domain, "naic_example_graph")
        try:
            assert r.spin_until(lambda: "naic_controller" in {n for n, _ in r.node.get_node_names_and_namespaces()}, 30), \
                launch.output()[-3000:]
        finally:
            r.close()
    except BaseException:
        launch.stop(timeout=15)
        raise
    # The example waits for naic_controller's reference subscriptions itself (and the
    # discovery rule of run_slide_example applies to it).
    s = ru.run_slide_example(bins, launch, domain, tmp_path, 400)
    # 1 kHz of /naic/params for 10 s of sliding, every message in the bag. (Behind the
    # lockstep chain on a loaded machine naic record lost 28-47 % of them until it wrote the
    # bag on its own thread with 10 s of history on both sides, docs/bags.md.) Checked first:
    # what follows reads the bag.
    ru.assert_bag_complete(s, "/naic/params", s["slide_samples"] <= 9000,
                           f"the bag has {s['slide_samples']} sliding samples of ~10 000")
    # 10 cm at 10 mm/s: 10 s of sliding, 1 kHz of /naic/params in the bag, in contact throughout.
    assert s["slide_duration_s"] == pytest.approx(10.0, abs=0.1), s
    assert s["phases_in_contact"] == s["slide_samples"], s
    assert s["desired_forces_seen"] == [5.0, 10.0], s
    assert not s["faults"], s
    print(f"slide over DDS: max |e_f| {s['max_abs_force_error_n']:.3f} N, RMS {s['rms_force_error_n']:.3f} N, "
          f"{s['slide_samples']} sliding samples, naic record's reported losses {s['recorder_lost']}")
    # Issue #16's goal: |e_f| <= 0.5 N while sliding (the example runs the scheduled law).
    assert s["max_abs_force_error_n"] <= 0.5, s
    assert s["rms_force_error_n"] <= 0.15, s
    # The bag is a real MCAP with the topics (read with the reference mcap reader), and the figure exists.
    from mcap.reader import make_reader
    with open(s["bag"], "rb") as f:
        summary = make_reader(f).get_summary()
    topics = {c.topic for c in summary.channels.values()}
    assert {"/naic/params", "/joint_states", "/naic/desired_wrench", "/naic/target_pose"} <= topics, topics
    targets = sum(n for cid, n in summary.statistics.channel_message_counts.items()
                  if summary.channels[cid].topic == "/naic/target_pose")
    # 50 Hz of simulated time when rclpy keeps up with the chain; on the loaded 2-core
    # machine its loop managed 8.5 Hz (227 targets, docs/nodes.md, "The rclpy example").
    assert targets > 100, targets
    assert os.path.getsize(s["figure"]) > 1000
