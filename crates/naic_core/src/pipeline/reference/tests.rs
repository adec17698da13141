use super::*;
use proptest::prelude::*;

const DT: f64 = 1e-3;
const ID: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

fn params() -> ReferenceParams {
    ReferenceParams::new("base_link", ForceAxis::base(2, -1.0), 10.0)
}

fn start() -> ReferenceState {
    let p = Vector3::new(0.4, 0.0, 0.3);
    ReferenceState::new(p, UnitQuaternion::identity(), (p, UnitQuaternion::identity()))
}

fn pose(stamp: f64, p: [f64; 3]) -> TargetPose<'static> {
    TargetPose { frame_id: "base_link", stamp, position: p, orientation: ID }
}

fn push(stamp: f64, newtons: f64) -> DesiredWrench<'static> {
    // Pushing down (force axis −z): the tool applies −z force to the surface.
    DesiredWrench { frame_id: "base_link", stamp, force: [0.0, 0.0, -newtons], torque: [0.0; 3] }
}

/// Run `steps` control cycles from `t`, with `inbox(k, t)` giving each cycle's samples.
fn run(
    p: &ReferenceParams,
    s: &mut ReferenceState,
    t: &mut f64,
    steps: usize,
    mut inbox: impl FnMut(usize, f64) -> Inbox<'static>,
) -> Vec<ReferenceOutputs> {
    let mut out = Vec::with_capacity(steps);
    for k in 0..steps {
        let (n, o) = step(p, s, &inbox(k, *t), *t);
        *s = n;
        out.push(o);
        *t += DT;
    }
    out
}

#[test]
fn nothing_published_holds_the_start_goal_and_the_force_parameter() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    let out = run(&p, &mut s, &mut t, 100, |_, _| Inbox::default());
    let last = out.last().unwrap();
    assert_eq!(last.reference.p_d, Vector3::new(0.4, 0.0, 0.3));
    assert_eq!(last.reference.v_d, Vector6::zeros());
    assert_eq!(last.reference.f_d, 10.0);
    assert_eq!((last.report.pose_source, last.report.force_source), (Source::Default, Source::Default));
    assert!(last.report.target_age.is_infinite() && !last.report.target_stale);
}

#[test]
fn a_50_hz_stream_sliding_at_10_mm_per_s_gives_a_smooth_10_mm_per_s_reference() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    let x0 = 0.4;
    // A target every 20 ms, 0.2 mm apart, for 2 s, then nothing.
    let out = run(&p, &mut s, &mut t, 3000, |k, _| Inbox {
        target: (k % 20 == 0 && k <= 2000).then(|| pose(k as f64 * DT, [x0 + 0.01 * k as f64 * DT, 0.0, 0.3])),
        wrench: None,
    });
    // Between 0.3 s and 2 s the reference moves at 10 mm/s within 0.1 mm/s at every cycle
    // (steps of the raw stream would be 0 and 10 mm/s alternating ... with 20 ms pauses).
    for (k, o) in out.iter().enumerate().take(2000).skip(300) {
        let vx = o.reference.v_d[0];
        assert!((vx - 0.01).abs() < 1e-4, "cycle {k}: v_x = {vx}");
        assert_eq!(o.report.pose_source, Source::Topic);
    }
    // It lags the stream by SPAN sample intervals (the interpolation), not more.
    let lag = (x0 + 0.01 * 1.5) - out[1500].reference.p_d[0];
    assert!(lag > 0.0 && lag < 0.01 * 0.020 * SPAN + 1e-6, "lag {lag} m");
    // The stream stopped at t = 2 s: the last target (x0 + 20 mm) is held, at rest, stale.
    let last = out.last().unwrap();
    assert!((last.reference.p_d[0] - (x0 + 0.02)).abs() < 1e-9, "{}", last.reference.p_d[0]);
    assert!(last.reference.v_d.norm() < 1e-12);
    assert!(last.report.target_stale && !out[2100].report.target_stale);
    assert_eq!(last.report.goal_position, Vector3::new(x0 + 0.02, 0.0, 0.3));
}

#[test]
fn samples_that_come_late_do_not_make_the_reference_brake() {
    // As the node takes them: each sample in a step of its own at the previous cycle's
    // time (no motion), then the cycle; a 50 Hz stream at 10 mm/s whose samples arrive
    // 0-4 ms after their 20 ms slot. With the goal reaching each target one interval
    // after it arrived, it stood still until the next sample (every sample: it arrived a
    // cycle after the previous segment's end) and the reference braked by a_max dt for
    // every cycle of the delay: 1 m/s^2 bursts of acceleration at 50 Hz.
    let (p, mut s) = (params(), start());
    let x0 = 0.4;
    let mut vx = Vec::new();
    for k in 1..2000usize {
        let t = k as f64 * DT;
        let slot = k / 20;
        if k % 20 == slot % 5 {
            let stamp = slot as f64 * 0.02;
            let sample = Inbox { target: Some(pose(stamp, [x0 + 0.01 * stamp, 0.0, 0.3])), wrench: None };
            let (n, o) = step(&p, &s, &sample, t - DT);
            assert_eq!(o.report.target, Verdict::Accepted);
            s = n;
        }
        let (n, o) = step(&p, &s, &Inbox::default(), t);
        s = n;
        vx.push((t, o.reference.v_d[0]));
    }
    // Within 1.5 mm/s of the stream's speed (with the goal over one interval: 7-13 mm/s).
    for &(t, v) in vx.iter().filter(|x| x.0 > 0.3) {
        assert!((v - 0.01).abs() < 0.0015, "t = {t}: v_x = {v}");
    }
}

#[test]
fn a_far_target_is_reached_at_the_speed_and_acceleration_limits() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    // One sample, 10 cm away: trapezoid at 0.1 m/s, 1 m/s² → 1.1 s.
    let out = run(&p, &mut s, &mut t, 1200, |k, _| Inbox { target: (k == 0).then(|| pose(0.0, [0.5, 0.0, 0.3])), wrench: None });
    let peak = out.iter().map(|o| o.reference.v_d.norm()).fold(0.0, f64::max);
    assert!((peak - 0.1).abs() < 1e-9, "peak speed {peak}");
    let amax = out.iter().map(|o| o.reference.a_d.norm()).fold(0.0, f64::max);
    assert!(amax <= 1.0 + 1e-9 && amax > 0.99, "peak acceleration {amax}");
    let arrived = out.iter().position(|o| (o.reference.p_d[0] - 0.5).abs() < 1e-9 && o.reference.v_d.norm() < 1e-9);
    let t_arrive = arrived.expect("never arrived") as f64 * DT;
    assert!((t_arrive - 1.1).abs() < 0.01, "arrived after {t_arrive} s");
    assert!(out.iter().all(|o| o.reference.p_d[0] <= 0.5 + 1e-12), "overshoot");
}

#[test]
fn rotation_is_limited_and_arrives() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
    let o = [q.i, q.j, q.k, q.w];
    let target = TargetPose { frame_id: "base_link", stamp: 0.0, position: [0.4, 0.0, 0.3], orientation: o };
    let out = run(&p, &mut s, &mut t, 4000, |k, _| Inbox { target: (k == 0).then_some(target), wrench: None });
    let peak = out.iter().map(|o| o.reference.v_d.fixed_rows::<3>(3).norm()).fold(0.0, f64::max);
    assert!((peak - 0.5).abs() < 1e-9, "peak angular speed {peak}");
    // π/2 at 0.5 rad/s, 5 rad/s²: 0.1 + π − 0.1·... ≈ 3.24 s; done before 4 s.
    assert!(out.last().unwrap().reference.r_d.angle_to(&q) < 1e-9);
    let most = out.iter().map(|o| o.reference.r_d.angle_to(&UnitQuaternion::identity())).fold(0.0, f64::max);
    assert!(most <= std::f64::consts::FRAC_PI_2 + 1e-9, "overshoot to {most} rad");
}

#[test]
fn samples_that_cannot_be_used_are_refused_as_values_and_change_nothing() {
    let p = params();
    let s0 = start();
    let bad: [(TargetPose, fn(&Rejection) -> bool); 6] = [
        (TargetPose { frame_id: "world", ..pose(0.0, [0.5, 0.0, 0.3]) }, |r| *r == Rejection::Frame),
        (TargetPose { frame_id: "", ..pose(0.0, [0.5, 0.0, 0.3]) }, |r| *r == Rejection::Frame),
        (pose(0.0, [f64::NAN, 0.0, 0.3]), |r| matches!(r, Rejection::NonFinite { field: Field::Position, index: 0 })),
        (TargetPose { orientation: [0.0; 4], ..pose(0.0, [0.5, 0.0, 0.3]) }, |r| matches!(r, Rejection::NotUnitQuaternion { .. })),
        (TargetPose { orientation: [0.0, 0.0, f64::INFINITY, 1.0], ..pose(0.0, [0.5, 0.0, 0.3]) }, |r| {
            matches!(r, Rejection::NonFinite { field: Field::Orientation, index: 2 })
        }),
        (pose(0.0, [0.5, 0.0, 30.0]), |r| matches!(r, Rejection::OutsideWorkspace { axis: 2, .. })),
    ];
    for (tp, want) in bad {
        let (s, o) = step(&p, &s0, &Inbox { target: Some(tp), wrench: None }, 0.0);
        match o.report.target {
            Verdict::Rejected(r) => assert!(want(&r), "{tp:?}: {r:?}"),
            v => panic!("{tp:?} not refused: {v:?}"),
        }
        assert_eq!(s.goal, s0.goal);
        assert_eq!(s.rejected_targets, 1);
        assert_eq!(o.report.pose_source, Source::Default);
        assert!(!r_str(&o.report.target).is_empty());
    }
    // Out of order: a stamp older than the target taken.
    let (s, _) = step(&p, &s0, &Inbox { target: Some(pose(5.0, [0.45, 0.0, 0.3])), wrench: None }, 0.0);
    let (s2, o) = step(&p, &s, &Inbox { target: Some(pose(4.0, [0.5, 0.0, 0.3])), wrench: None }, DT);
    assert!(matches!(o.report.target, Verdict::Rejected(Rejection::OutOfOrder { .. })), "{:?}", o.report.target);
    assert_eq!(s2.goal.p1, Vector3::new(0.45, 0.0, 0.3));
    // A slightly denormalised quaternion (float32 arithmetic) is fine and normalised.
    let tp = TargetPose { orientation: [0.0, 0.0, 0.0, 1.004], ..pose(0.0, [0.5, 0.0, 0.3]) };
    let (s, o) = step(&p, &s0, &Inbox { target: Some(tp), wrench: None }, 0.0);
    assert_eq!(o.report.target, Verdict::Accepted);
    assert!((s.goal.r1.quaternion().norm() - 1.0).abs() < 1e-15);
}

fn r_str(v: &Verdict) -> String {
    match v {
        Verdict::Rejected(r) => r.to_string(),
        _ => String::new(),
    }
}

#[test]
fn desired_wrench_sets_the_force_along_the_axis_rate_limited_and_held_when_stale() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    // Default 10 N, then 5 N published at t = 0.1 s (100 N/s: 50 ms ramp), then 15 N once.
    let out = run(&p, &mut s, &mut t, 1500, |k, t| Inbox {
        target: None,
        wrench: match k {
            100..=200 => Some(push(t, 5.0)),
            300 => Some(push(t, 15.0)),
            _ => None,
        },
    });
    assert_eq!(out[50].reference.f_d, 10.0);
    assert_eq!(out[50].report.force_source, Source::Default);
    assert!((out[125].reference.f_d - 7.5).abs() < 0.11, "{}", out[125].reference.f_d);
    assert_eq!(out[160].reference.f_d, 5.0);
    assert_eq!(out[160].report.force_source, Source::Topic);
    assert!(out.windows(2).all(|w| (w[1].reference.f_d - w[0].reference.f_d).abs() <= 100.0 * DT + 1e-12));
    // 15 N held after the stream went quiet; stale after the timeout.
    assert_eq!(out[1499].reference.f_d, 15.0);
    assert!(out[1499].report.wrench_stale && !out[700].report.wrench_stale);
    // Off-range, wrong frame and NaN are refused; the force stays.
    let bad = [
        (push(2.0, 150.0), "outside"),
        (push(2.0, -3.0), "outside"),
        (DesiredWrench { frame_id: "tool0", ..push(2.0, 5.0) }, "not a frame of the robot model"),
        (DesiredWrench { torque: [0.0, f64::NAN, 0.0], ..push(2.0, 5.0) }, "wrench.torque[1]"),
    ];
    for (w, msg) in bad {
        let (n, o) = step(&p, &s, &Inbox { target: None, wrench: Some(w) }, t);
        assert!(r_str(&o.report.wrench).contains(msg), "{w:?}: {:?}", o.report.wrench);
        assert_eq!(o.reference.f_d, 15.0);
        assert_eq!(n.rejected_wrenches, s.rejected_wrenches + 1);
    }
}

#[test]
fn a_gap_in_the_control_loop_does_not_make_the_reference_jump() {
    let (p, mut s, mut t) = (params(), start(), 0.0);
    run(&p, &mut s, &mut t, 300, |k, _| Inbox { target: (k == 0).then(|| pose(0.0, [0.5, 0.0, 0.3])), wrench: None });
    let before = s.p;
    let (n, o) = step(&p, &s, &Inbox::default(), t + 2.0);
    assert!((n.p - before).norm() <= p.linear.max_speed * p.max_step + 1e-15);
    assert!(o.reference.a_d.norm() <= p.linear.max_accel + 1e-9);
    // Time going backwards or NaN: no motion.
    let (n2, _) = step(&p, &n, &Inbox::default(), t);
    assert_eq!(n2.p, n.p);
    let (n3, _) = step(&p, &n, &Inbox::default(), f64::NAN);
    assert_eq!((n3.p, n3.t), (n.p, n.t));
}

#[test]
fn parameters_are_validated_with_names() {
    let mut p = params();
    assert!(p.validate().is_ok());
    p.linear.max_speed = 0.0;
    assert!(p.validate().unwrap_err().to_string().contains("max_speed"));
    let mut p = params();
    p.max_force_rate = f64::INFINITY;
    assert!(p.validate().is_ok());
    p.default_force = 500.0;
    assert!(p.validate().unwrap_err().to_string().contains("desired_force"));
    let mut p = params();
    p.timeout = f64::NAN;
    assert!(p.validate().unwrap_err().to_string().contains("reference_timeout"));
}

/// One cycle of random input: a time step (sometimes negative, huge or NaN) and maybe samples.
#[derive(Clone, Debug)]
struct Cycle {
    dt: f64,
    target: Option<([f64; 3], [f64; 4], u8, f64)>,
    wrench: Option<([f64; 3], u8, f64)>,
}

fn num() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -2.0..2.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => -1e9..1e9f64,
    ]
}

fn cycle() -> impl Strategy<Value = Cycle> {
    let dt = prop_oneof![8 => 0.0..0.003f64, 1 => -0.01..0.0f64, 1 => 0.0..5.0f64, 1 => Just(f64::NAN)];
    // Mostly unit quaternions (random rotations), sometimes anything.
    let unit = prop::array::uniform3(-4.0..4.0f64).prop_map(|w| {
        let q = UnitQuaternion::from_scaled_axis(Vector3::from(w));
        [q.i, q.j, q.k, q.w]
    });
    let orientation = prop_oneof![4 => unit, 1 => prop::array::uniform4(num())];
    let position = prop_oneof![6 => prop::array::uniform3(-1.0..1.0f64), 1 => prop::array::uniform3(num())];
    let target = proptest::option::weighted(0.3, (position, orientation, 0..5u8, num()));
    let wrench = proptest::option::weighted(0.2, (prop::array::uniform3(-200.0..200.0f64), 0..5u8, num()));
    (dt, target, wrench).prop_map(|(dt, target, wrench)| Cycle { dt, target, wrench })
}

/// Mostly the base frame.
const FRAMES: [&str; 5] = ["base_link", "base_link", "base_link", "world", ""];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// For any sequence of samples and time steps: the reference is finite, its speed,
    /// acceleration and force rate never exceed the limits, and it stays near the workspace.
    #[test]
    fn limits_hold_for_any_input_sequence(cycles in prop::collection::vec(cycle(), 1..400)) {
        let p = params();
        let mut s = start();
        let mut now = 0.0f64;
        let mut prev: Option<(f64, ReferenceOutputs)> = None;
        let mut accepted = 0;
        for c in &cycles {
            let t = now + c.dt;
            if t.is_finite() { now = t; }
            // Stamps: mostly the current time (in order), sometimes anything.
            let stamp = |st: f64| if st.is_finite() && st.abs() < 2.0 { now } else { st };
            let inbox = Inbox {
                target: c.target.map(|(pos, o, f, st)| TargetPose { frame_id: FRAMES[f as usize], stamp: stamp(st), position: pos, orientation: o }),
                wrench: c.wrench.map(|(force, f, st)| DesiredWrench { frame_id: FRAMES[f as usize], stamp: stamp(st), force, torque: [0.0; 3] }),
            };
            let t_prev = s.t;
            let (n, o) = step(&p, &s, &inbox, t);
            accepted += usize::from(o.report.target == Verdict::Accepted);
            let r = &o.reference;
            prop_assert!(r.p_d.iter().chain(r.v_d.iter()).chain(r.a_d.iter()).all(|x| x.is_finite()), "{r:?}");
            prop_assert!(r.r_d.coords.iter().all(|x| x.is_finite()) && (r.r_d.coords.norm() - 1.0).abs() < 1e-9);
            let (v, w) = (r.v_d.fixed_rows::<3>(0).norm(), r.v_d.fixed_rows::<3>(3).norm());
            prop_assert!(v <= p.linear.max_speed * (1.0 + 1e-9), "speed {v}");
            prop_assert!(w <= p.angular.max_speed * (1.0 + 1e-9), "angular speed {w}");
            prop_assert!(r.a_d.fixed_rows::<3>(0).norm() <= p.linear.max_accel * (1.0 + 1e-6) + 1e-9);
            prop_assert!(r.a_d.fixed_rows::<3>(3).norm() <= p.angular.max_accel * (1.0 + 1e-6) + 1e-9);
            prop_assert!(r.f_d >= p.force_min && r.f_d <= p.force_max, "f_d {}", r.f_d);
            // Per step, judged against the time that step was allowed to advance.
            let dt_eff = match t_prev { Some(tp) if t.is_finite() => (t - tp).clamp(0.0, p.max_step), _ => 0.0 };
            if let Some((_, po)) = &prev {
                let pr = &po.reference;
                prop_assert!((r.p_d - pr.p_d).norm() <= p.linear.max_speed * dt_eff * (1.0 + 1e-9) + 1e-15);
                prop_assert!((r.v_d - pr.v_d).fixed_rows::<3>(0).norm() <= p.linear.max_accel * dt_eff * (1.0 + 1e-9) + 1e-15);
                prop_assert!((r.v_d - pr.v_d).fixed_rows::<3>(3).norm() <= p.angular.max_accel * dt_eff * (1.0 + 1e-9) + 1e-15);
                prop_assert!(r.r_d.angle_to(&pr.r_d) <= p.angular.max_speed * dt_eff * (1.0 + 1e-9) + 1e-12);
                prop_assert!((r.f_d - pr.f_d).abs() <= p.max_force_rate * dt_eff * (1.0 + 1e-9) + 1e-12);
            }
            // Goals are inside the box; momentum can carry the reference past a goal that
            // turned by at most the braking distance v²/(2a) plus one step.
            let slack = p.linear.max_speed.powi(2) / (2.0 * p.linear.max_accel) + p.linear.max_speed * p.max_step;
            prop_assert!((0..3).all(|i| r.p_d[i] >= p.workspace.min[i] - slack && r.p_d[i] <= p.workspace.max[i] + slack));
            prev = Some((t, o));
            s = n;
        }
        // Not vacuous: long sequences move the reference (P(no accepted target) ~ 1e-6).
        prop_assert!(cycles.len() < 150 || accepted > 0, "no target accepted in {} cycles", cycles.len());
    }
}
