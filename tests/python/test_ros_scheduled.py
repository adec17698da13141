"""The stiffness-scheduled force law (mode "scheduled", issue 12) in the node suite, checked
with real rclpy on Jazzy: the mode is switched at run time through the parameter service,
/naic/params reports it, and its k_e_hat field carries the online stiffness estimate of the
flat surface (2000 N/m in the simulated driver's flat scenario).

Lockstep (`naic launch --lockstep`, simulated time) so that a loaded machine cannot shake the
loop; traffic stays on loopback (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) on a private domain.
"""
import os
import sys
import textwrap

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros"))
import rostest_util as ru  # noqa: E402

pytest.importorskip("rclpy")

K_E_FLAT = 2000.0  # N/m, naic_sim's flat scenario (crates/naic_sim/src/scenario.rs)
# The estimate sees the encoders' tip position through the controller's model and the tared,
# quantised (1/16 N) F/T force while the tool slides at 0.09 m/s. Measured here: median
# 1998 N/m, 5-95 % 1998-1999 N/m, confidence 0.99. The stated tolerance is 2 %.
K_E_TOL = 0.02


# The start of both rclpy probes: a node that keeps every /naic/params sample in `got`, and
# `st`, a message's stamp in seconds. NODE is the probe's node name.
PROBE_HEAD = """
import json, time, rclpy
from naic_msgs.msg import NaicParams
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
rclpy.init()
import rostest_util; rostest_util.observer_priority()  # tests/ros on PYTHONPATH
n = rclpy.create_node(NODE)
got = []
qos = QoSProfile(depth=100000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
n.create_subscription(NaicParams, "/naic/params", got.append, qos)
st = lambda m: m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
"""


@pytest.fixture(scope="module")
def bins():
    return ru.build_nodes()


def test_ros_scheduled_mode_reports_the_flat_stiffness_estimate(bins):
    """The driver starts paused (simulated t = 0, free space). The probe switches the
    controller to 'scheduled' through the parameter service, sees /naic/params report it,
    resumes the driver and reads /naic/params (naic_msgs built with colcon) until simulated
    t = 4.5 s (first contact at 1.49 s, the flat scenario's 10 -> 20 N step at 3 s)."""
    domain = ru.fresh_domain(70)
    # Started in the paper's mode (the default is scheduled), so that the switch is seen.
    launch = ru.Proc([str(bins / "naic"), "launch", "--lockstep", "-p", "jk5_sim_driver:paused:=true",
                      "-p", "naic_controller:mode:=naic"], ru.ros_env(domain))
    overlay = ru.naic_msgs_env()
    script = PROBE_HEAD.replace("NODE", '"naic_scheduled_probe"') + textwrap.dedent("""
        from rclpy.parameter import Parameter
        from rclpy.parameter_client import AsyncParameterClient
        ctl = AsyncParameterClient(n, "naic_controller")
        drv = AsyncParameterClient(n, "jk5_sim_driver")
        t0 = time.time()
        assert ctl.wait_for_services(30.0) and drv.wait_for_services(30.0)
        # Paused, the driver republishes the start state every 20 ms and the controller answers.
        while not got and time.time() - t0 < 60:
            rclpy.spin_once(n, timeout_sec=0.05)
        assert got, "no /naic/params while paused"
        first = dict(t=st(got[-1]), mode=got[-1].mode)
        f = ctl.set_parameters([Parameter("mode", value="scheduled")])
        rclpy.spin_until_future_complete(n, f, timeout_sec=10)
        g = ctl.get_parameters(["mode"])
        rclpy.spin_until_future_complete(n, g, timeout_sec=10)
        # The scheduled law's approach and force-observer parameters are served, and a bad
        # value is refused with a reason.
        names = ["use_expected_surface", "expected_surface", "approach_band", "approach_band_speed", "force_observer"]
        h = ctl.get_parameters(names)
        rclpy.spin_until_future_complete(n, h, timeout_sec=10)
        bad = ctl.set_parameters([Parameter("approach_band_speed", value=0.0)])
        rclpy.spin_until_future_complete(n, bad, timeout_sec=10)
        hv = [v.bool_value if v.type == 1 else v.double_value for v in h.result().values]
        badr = bad.result().results[0]
        # While paused the controller re-sends the report of the same (start) sample; the
        # new mode shows from the first new sample on.
        got.clear()
        r = drv.set_parameters([Parameter("paused", value=False)])
        rclpy.spin_until_future_complete(n, r, timeout_sec=10)
        seen = []
        while time.time() - t0 < 180:
            rclpy.spin_once(n, timeout_sec=0.01)
            seen += [(st(m), m.mode, m.phase, m.measured_force, m.k_e_hat, m.k_e_confidence, m.b_d, m.m_d, m.desired_force, m.model_gain, m.gravity_scale) for m in got]
            got.clear()
            if seen and seen[-1][0] > 4.5:
                break
        print(json.dumps(dict(first=first, ok=[x.successful for x in f.result().results + r.result().results],
                              mode_param=g.result().values[0].string_value, seen=seen,
                         approach=dict(zip(names, hv)), bad=[badr.successful, badr.reason])))
    """)
    m = ru.run_in_overlay(["-c", script], domain, overlay, 300, stop=launch, pythonpath=[ru.ROOT / "tests/ros"])
    assert m["first"]["mode"] == "naic"
    # The switch happened at the start, in free space (paused driver, simulated t = 0).
    assert m["first"]["t"] < 0.1, m["first"]
    assert m["ok"] == [True, True] and m["mode_param"] == "scheduled", (m["ok"], m["mode_param"])
    # Defaults: no expected surface (a speed limit alone), the core's band, speed and observer.
    assert m["approach"] == dict(use_expected_surface=False, expected_surface=0.0, approach_band=0.01,
                                 approach_band_speed=0.005, force_observer=200.0), m["approach"]
    assert m["bad"][0] is False and "approach_band_speed" in m["bad"][1], m["bad"]
    seen = m["seen"]
    assert seen and seen[-1][0] > 4.5, seen[-3:]
    # Every new sample after the switch is handled by the scheduled law.
    new = [s for s in seen if s[0] > 0.0]
    assert new and all(s[1] == "scheduled" for s in new), sorted({s[1] for s in new})
    sched = new
    # The paper laws report no estimate; in free space neither does the scheduled law's.
    contact = [s for s in sched if s[2] == 1]
    assert contact, "never in contact"
    t_c = contact[0][0]
    assert 1.2 < t_c < 2.0, t_c
    late = [s for s in contact if s[0] > t_c + 0.5]
    assert len(late) > 500, len(late)
    k = sorted(s[4] for s in late)
    conf = sorted(s[5] for s in late)
    k_med, k_lo, k_hi = k[len(k) // 2], k[len(k) // 20], k[-(len(k) // 20) - 1]
    stats = dict(k_median=k_med, k_p5=k_lo, k_p95=k_hi, conf_median=conf[len(conf) // 2], n=len(late))
    print("k_e_hat on flat over DDS (lockstep):", stats)
    assert abs(k_med - K_E_FLAT) < K_E_TOL * K_E_FLAT, stats
    # 90 % of the late samples within the tolerance too (no drift, no windup).
    assert abs(k_lo - K_E_FLAT) < K_E_TOL * K_E_FLAT and abs(k_hi - K_E_FLAT) < K_E_TOL * K_E_FLAT, stats
    assert 0.0 <= conf[0] and conf[-1] <= 1.0 and stats["conf_median"] > 0.5, stats
    # The law tracks the reported f_d: median |f_ext - f_d| below 0.5 N over the late samples.
    f_late = sorted(abs(s[3] - s[8]) for s in late)
    assert f_late and f_late[len(f_late) // 2] < 0.5, f_late[:: max(1, len(f_late) // 10)]
    # The scheduled damping is near critical for k_e = 2000 N/m and m_d = 0.1 kg
    # (2 sqrt(k m) = 28 N s/m; the delay floor at this stiffness is 2 N s/m).
    assert min(s[6] for s in late) > 20.0
    # The model's gain along the force axis (scheduled::gain): 1 until the
    # approach has taught it, then held over the contact. Measured in process on flat with the
    # exact model: 0.98 (the joints' friction reads as a little less gain); a value off 1 shows
    # that the field is carried and that the estimate ran in the node.
    free = [s for s in sched if s[0] < 0.05]
    assert free and all(s[9] == 1.0 for s in free), free[:3]
    g = {s[9] for s in contact}
    assert len(g) == 1 and 0.9 <= min(g) < 1.0, sorted(g)[:5]
    # The factor on the model's gravity (gravity_scale): 1 until the
    # static reading in the approach, then ramped to 1/g where the frozen gain is below the
    # light side's 0.93 and the static reading F_s below 0.96 (the gate), or to 1/F_s
    # where F_s is above the heavy side's 1.1; held in contact. The exact model reads F_s
    # 0.984-0.985 in process, so its factor is 1 whatever the gain reads: over this chain the
    # gain reads 0.91 (with the gain alone gating the light side the exact model's gravity
    # would be over-compensated by 9.6 %, factor 1.096).
    scale = [s[10] for s in sched]
    g_c = min(g)
    expect = 1.0
    print("gravity_scale over DDS (lockstep):", dict(first=scale[0], contact=contact[0][10], last=scale[-1], model_gain=g_c))
    assert scale[0] == 1.0 and all(1.0 <= x <= expect + 1e-9 for x in scale), (scale[0], min(scale), max(scale), expect)
    assert all(abs(s[10] - expect) < 1e-9 for s in contact), (sorted({s[10] for s in contact})[:5], expect)


def test_ros_scheduled_tracks_flat_in_real_time(bins):
    """Issue 12's DDS check in real time (not lockstep): `naic launch` with the scheduled law
    from the start, three processes on the wall clock; rclpy reads /naic/params until 6 s
    after the first contact. Measured on a quiet 2-core machine (docs/controller.md, "On the
    real-time DDS chain"): overshoot 2.3-3.5 %, the force error's SD over the last 2 s 0.063 N
    (the sensor's own noise), k_e_hat 2000 N/m. The bounds below are the issue's "tracks f_d"
    with room for a loaded machine, where the chain is late by a cycle now and then (7.9 %
    overshoot was seen at load 12): not a timing test."""
    domain = ru.fresh_domain(71)
    launch = ru.Proc([str(bins / "naic"), "launch", "-p", "naic_controller:mode:=scheduled"], ru.ros_env(domain))
    overlay = ru.naic_msgs_env()
    script = PROBE_HEAD.replace("NODE", '"naic_scheduled_realtime_probe"') + textwrap.dedent("""
        seen, t0, t_contact = [], time.time(), None
        while time.time() - t0 < 120:
            rclpy.spin_once(n, timeout_sec=0.01)
            seen += [(st(m), m.mode, m.phase, m.measured_force, m.desired_force, m.k_e_hat, m.model_gain, m.gravity_scale) for m in got]
            got.clear()
            if t_contact is None:
                t_contact = next((s[0] for s in seen if s[2] == 1), None)
            elif seen[-1][0] > t_contact + 6.0:
                break
        print(json.dumps(dict(seen=seen)))
    """)
    m = ru.run_in_overlay(["-c", script], domain, overlay, 300, stop=launch, pythonpath=[ru.ROOT / "tests/ros"])
    seen = sorted(m["seen"])
    assert len(seen) > 1000, f"only {len(seen)} /naic/params samples"
    assert all(s[1] == "scheduled" for s in seen), sorted({s[1] for s in seen})
    contact = [s for s in seen if s[2] == 1]
    assert contact, "never in contact"
    t_c = contact[0][0]
    assert seen[-1][0] > t_c + 5.0, (t_c, seen[-1][0])
    f_d = contact[-1][4]
    assert f_d == 10.0, f_d
    rise = [s[3] for s in contact if s[0] < t_c + 1.0]
    late = [s for s in contact if s[0] > t_c + 1.0]
    assert len(late) > 1000, len(late)
    err = sorted(abs(s[3] - s[4]) for s in late)
    k = sorted(s[5] for s in late)
    stats = dict(peak=max(rise), err_median=err[len(err) // 2], err_p99=err[len(err) * 99 // 100],
                 k_median=k[len(k) // 2], n=len(late))
    print("scheduled on flat over DDS in real time:", stats)
    # Tracks f_d: no bounce at contact (1.2 f_d, the acrylic bound), the median error
    # a few sensor counts (1/16 N each), 99 % of the samples within 1 N, k_e_hat within 5 %.
    assert stats["peak"] <= 1.2 * f_d, stats
    assert stats["err_median"] < 0.2 and stats["err_p99"] < 1.0, stats
    assert abs(stats["k_median"] - K_E_FLAT) < 0.05 * K_E_FLAT, stats
    # The model gain and the gravity factor in contact: held, and the factor 1 for the exact
    # model (its static reading is above the light side's gate 0.96 and below the heavy side's
    # 1.1; as in lockstep).
    g = {s[6] for s in contact}
    scale = {s[7] for s in contact}
    print("model_gain / gravity_scale in real time:", sorted(g), sorted(scale))
    assert len(g) == 1 and len(scale) == 1, (sorted(g)[:5], sorted(scale)[:5])
    (g,), (scale,) = g, scale
    assert scale == 1.0, (g, scale)
