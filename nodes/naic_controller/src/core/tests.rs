use super::*;
use naic_ros::msgs::JOINT_NAMES;
use naic_core::{
    model::Model,
    pipeline::{
        control::{force_law::Mode, Phase},
        sense::Signal,
    },
    N_JOINTS,
};
use naic_ros::{
    alloc_check::counted,
    msgs::{Header, Time, Vector3 as V3, Wrench},
};

const MS: i64 = 1_000_000;
/// A plausible JK5 pose (the flat scenario's start).
const Q0: JointVec = [0.0, 0.3, 1.8, 0.0, 1.0, 0.0];

fn model() -> Model {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../urdf/jk5.urdf");
    Model::from_urdf_file(root).unwrap()
}

fn base(model: &Model) -> ControllerParams {
    let mut cp = ControllerParams::paper_defaults(model, Mode::Naic, naic_core::pipeline::control::force_law::DEFAULT_GAMMA);
    cp.control.force_limit.latch = true;
    cp
}

fn settings(time: TimeBase) -> Settings {
    Settings { desired_force: 10.0, force_limit: 50.0, approach_depth: 0.05, time, actuation_timeout_ns: 20 * 1_000_000, robot_compensates_gravity: false }
}

fn params(time: TimeBase) -> Params {
    let m = model();
    let rp = ReferenceParams::new("base_link", base(&m).control.force_axis, 10.0);
    Params::new(Controller::new(m.clone(), base(&m)).unwrap(), settings(time), None, rp, JOINT_NAMES.map(String::from)).unwrap()
}

fn js(stamp: i64, order: [usize; N_JOINTS]) -> JointState {
    JointState {
        header: Header { stamp: Time::from_nanos(stamp), frame_id: String::new() },
        name: order.iter().map(|&j| JOINT_NAMES[j].to_string()).collect(),
        position: order.iter().map(|&j| Q0[j]).collect(),
        velocity: order.iter().map(|&j| 0.003 * j as f64).collect(), // below the tare's rest bound
        effort: vec![0.0; 6],
    }
}

fn wrench(stamp: i64, fz: f64) -> WrenchStamped {
    WrenchStamped {
        header: Header { stamp: Time::from_nanos(stamp), frame_id: "ft_sensor".into() },
        wrench: Wrench { force: V3 { x: 0.1, y: 0.2, z: fz }, torque: V3 { x: 0.01, y: 0.02, z: 0.03 } },
    }
}

const ORDER: [usize; N_JOINTS] = [0, 1, 2, 3, 4, 5];

/// One step under the allocation check.
fn run(p: &Params, s: &State, inbox: Inbox, now: i64) -> (State, Outbox) {
    let mut ws = p.controller.workspace();
    let ((s, o), n) = counted(|| step(p, s, &inbox, now, &mut ws));
    assert_eq!(n, 0, "the step allocated");
    (s, o)
}

/// What `controller::step` gives on these measurements from state `s` (the first cycle
/// with no scenario: the reference stage starts at rest at the start pose, heading for the
/// start moved `approach_depth` along n).
fn direct(p: &Params, s: &State, m: &RawMeasurements) -> ControllerState {
    let mut ws = p.controller.workspace();
    dynamics::forward_kinematics(p.controller.model(), &mut ws.data, &Vector6::from(Q0));
    let pose = *ws.data.frame_se3(p.tip);
    let r = Reference {
        p_d: pose.trans,
        r_d: UnitQuaternion::from_matrix(&pose.rot),
        v_d: Vector6::zeros(),
        a_d: Vector6::zeros(),
        f_d: 10.0,
    };
    controller::step(&p.controller, &s.ctl, m, &r, &mut ws).0
}

fn dq() -> JointVec {
    std::array::from_fn(|j| 0.003 * j as f64)
}

#[test]
fn lockstep_pairs_each_joint_state_with_the_wrench_of_its_stamp() {
    let p = params(TimeBase::Sim);
    let s0 = State::new(&p);
    let (s, _) = run(&p, &s0, Inbox { wrench: Some(&wrench(1000, 1.0)), ..Default::default() }, 0);
    // The joint state of 2000 arrives, its wrench has not: wait (no cycle yet).
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(2000, ORDER)), ..Default::default() }, MS);
    assert_eq!((o.effort, o.report, o.wait_until_ns), (None, None, Some(MS + PAIR_TIMEOUT_NS)));
    assert_eq!(s.cycles, 0);
    let (s, o) = run(&p, &s, Inbox { wrench: Some(&wrench(2000, 2.0)), ..Default::default() }, 2 * MS);
    assert_eq!(o.wait_until_ns, None);
    assert_eq!(o.effort.unwrap().1, 2000);
    assert_eq!(o.report.unwrap().stamp_ns, 2000);
    // Exactly the controller's step on the wrench of stamp 2000, timed by the stamps.
    let m = RawMeasurements { t: 0.0, q: Q0, dq: dq(), joints_stamp: 0.0, wrench: [0.1, 0.2, 2.0, 0.01, 0.02, 0.03], wrench_stamp: 0.0 };
    assert_eq!(s.ctl, direct(&p, &s0, &m));
}

#[test]
fn before_the_first_wrench_a_joint_state_waits_for_discovery() {
    // Discovery matched /joint_states before /wrench: the first cycle waits for the first
    // wrench (seconds if need be) instead of holding on a missing one, so a lockstep run
    // does not depend on the order in which the driver's writers were matched.
    let p = params(TimeBase::Sim);
    let s = State::new(&p);
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, MS);
    assert_eq!((o.effort, o.report, o.wait_until_ns), (None, None, Some(MS + FIRST_PAIR_TIMEOUT_NS)));
    let (s, o) = run(&p, &s, Inbox::default(), MS + PAIR_TIMEOUT_NS);
    assert_eq!(o.wait_until_ns, Some(MS + FIRST_PAIR_TIMEOUT_NS), "still waiting after the usual timeout");
    let (_, o) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 3_000 * MS);
    let r = o.report.unwrap();
    assert!(r.fault.is_none() && r.status.phase != Phase::Hold, "{r:?}");
}

#[test]
fn a_wrench_that_never_comes_is_stale_by_the_stamps() {
    let p = params(TimeBase::Sim);
    let s = State::new(&p);
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, 0);
    assert!(o.report.is_some());
    // 20 ms of simulated time later, no new wrench: after the pairing timeout the cycle
    // runs on the old wrench, which is 20 ms old in simulated time (> wrench_timeout).
    let later = js(20 * MS, ORDER);
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&later), ..Default::default() }, MS);
    let until = o.wait_until_ns.unwrap();
    let (_, o) = run(&p, &s, Inbox::default(), until);
    let r = o.report.unwrap();
    assert_eq!(r.status.phase, Phase::Hold);
    assert!(matches!(r.fault, Some(FaultReport::Sensor(Fault::Stale { signal: Signal::Wrench, .. }))), "{:?}", r.fault);
    assert!(o.effort.is_some(), "the hold torque is published");
}

#[test]
fn a_repeated_stamp_gets_the_same_answer_and_nothing_advances() {
    for time in [TimeBase::Sim, TimeBase::Wall] {
        let p = params(time);
        let s = State::new(&p);
        let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
        let (s, first) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, 0);
        let (s2, again) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, 3 * MS);
        assert_eq!(s2, s, "{time:?}: the state advanced on a repeated stamp");
        assert_eq!(again.effort, first.effort);
        // The report again in simulated time only (in real time stamps never repeat).
        assert_eq!(again.report, if time.is_sim() { first.report } else { None });
    }
}

#[test]
fn wall_time_judges_staleness_by_arrival() {
    let p = params(TimeBase::Wall);
    let s0 = State::new(&p);
    // Stamps from another host's clock (far off): only the arrival times count.
    let (s, _) = run(&p, &s0, Inbox { wrench: Some(&wrench(-5_000 * MS, 1.0)), ..Default::default() }, 100 * MS);
    let (s1, o) = run(&p, &s, Inbox { joint_states: Some(&js(7_000 * MS, ORDER)), ..Default::default() }, 101 * MS);
    assert_eq!(o.report.unwrap().fault, None, "a 1 ms old wrench is fresh whatever its stamp");
    let t = (101 * MS - 7_000 * MS) as f64 * 1e-9;
    let m = RawMeasurements { t, q: Q0, dq: dq(), joints_stamp: t, wrench: [0.1, 0.2, 1.0, 0.01, 0.02, 0.03], wrench_stamp: (100 * MS - 7_000 * MS) as f64 * 1e-9 };
    assert_eq!(s1.ctl, direct(&p, &s0, &m));
    // 20 ms without a wrench (wrench_timeout 10 ms): hold.
    let (_, o) = run(&p, &s1, Inbox { joint_states: Some(&js(7_001 * MS, ORDER)), ..Default::default() }, 120 * MS);
    assert!(matches!(o.report.unwrap().fault, Some(FaultReport::Sensor(Fault::Stale { .. }))));
}

#[test]
fn a_wrench_sent_again_with_its_old_stamp_goes_stale_by_the_wall_clock() {
    // A sensor driver that keeps republishing its last sample (frozen stamp): arriving
    // every millisecond does not make it fresh.
    let p = params(TimeBase::Wall);
    let mut s = State::new(&p);
    let frozen = wrench(3 * MS, 1.0);
    for k in 0..20 {
        (s, _) = run(&p, &s, Inbox { wrench: Some(&frozen), ..Default::default() }, (100 + k) * MS);
    }
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(50 * MS, ORDER)), ..Default::default() }, 120 * MS);
    let f = o.report.unwrap().fault;
    assert!(matches!(f, Some(FaultReport::Sensor(Fault::Stale { signal: Signal::Wrench, age })) if (age - 0.020).abs() < 1e-9), "{f:?}");
    // A new stamp is fresh again at once.
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(4 * MS, 1.0)), ..Default::default() }, 121 * MS);
    let (_, o) = run(&p, &s, Inbox { joint_states: Some(&js(51 * MS, ORDER)), ..Default::default() }, 121 * MS);
    assert_eq!(o.report.unwrap().fault, None);
}

#[test]
fn another_joint_order_gives_the_same_cycle() {
    let p = params(TimeBase::Wall);
    let go = |order| {
        let s = State::new(&p);
        let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
        run(&p, &s, Inbox { joint_states: Some(&js(0, order)), ..Default::default() }, MS)
    };
    let (a, oa) = go(ORDER);
    let (b, ob) = go([4, 2, 0, 5, 1, 3]);
    assert_eq!((a.ctl, oa.effort), (b.ctl, ob.effort));
    // A layout without joint5: reported, and the controller holds.
    let mut bad = js(0, ORDER);
    bad.name[4] = "wrist".into();
    let s = State::new(&p);
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
    let (_, o) = run(&p, &s, Inbox { joint_states: Some(&bad), ..Default::default() }, MS);
    assert_eq!(o.events.missing_joint, Some(4));
    assert_eq!(o.report.unwrap().status.phase, Phase::Hold);
}

#[test]
fn faults_are_reported_per_event_and_once_per_second() {
    let p = params(TimeBase::Wall);
    let mut s = State::new(&p);
    let mut reported = vec![];
    // No wrench at all for 2.5 s of 1 ms cycles: one fault event, reported at 0, 1, 2 s.
    for k in 0..2500 {
        let (n, o) = run(&p, &s, Inbox { joint_states: Some(&js(k * MS, ORDER)), ..Default::default() }, k * MS);
        s = n;
        if let Some((_, count)) = o.events.fault {
            reported.push((k, count));
        }
    }
    assert_eq!(reported.iter().map(|r| r.1).collect::<Vec<_>>(), vec![1, 1, 1], "{reported:?}");
    assert_eq!(s.cycles, 2500);
}

#[test]
fn the_parameter_change_policy_of_the_core_applies() {
    let mut p = params(TimeBase::Wall);
    let mut s = State::new(&p);
    // Learned weights and a latched force limit.
    s.ctl.control.law.m_d *= 0.5;
    s.ctl.control.retract_hold = Some(0.02);
    let cp = *p.controller.params();
    // Only the desired force: the weights stay, and so does the latch (a parameter set is
    // no acknowledgement of the over-force event).
    let more = Settings { desired_force: 15.0, ..p.settings };
    let rp = p.reference_params.clone();
    let o = set_params(&mut p, &mut s, cp, more, rp.clone()).unwrap();
    assert!(!o.restarted);
    assert_eq!(p.settings.desired_force, 15.0);
    assert!(s.ctl.control.retracting(), "a new set point must not end the retraction");
    assert_eq!(s.ctl.control.law.m_d, 0.5 * cp.control.force_axis.along(&cp.control.impedance.m_d));
    // Another mode: the weights restart from the parameters; the latch still stays.
    let mut aic = cp;
    aic.control.force_law.mode = Mode::Aic;
    let o = set_params(&mut p, &mut s, aic, more, rp).unwrap();
    assert!(o.restarted);
    assert!(s.ctl.control.retracting(), "a restart must not end the retraction");
    assert_eq!(p.controller.params().control.force_law.mode, Mode::Aic);
    assert_eq!(s.ctl.control.law.m_d, cp.control.force_axis.along(&cp.control.impedance.m_d));
    // The next cycle reports the new mode and set point, still force-limited.
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
    let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, MS);
    let r = o.report.unwrap();
    assert_eq!((r.status.mode, r.status.f_d), (Mode::Aic, 15.0));
    assert!(matches!(r.fault, Some(FaultReport::ForceLimit(_))), "{:?}", r.fault);
    // The explicit reset ends it, once; a second call is refused with a reason.
    let (s, o) = run(&p, &s, Inbox { reset_force_limit: true, ..Default::default() }, 2 * MS);
    assert_eq!(o.reset_force_limit, Some(TriggerAnswer { success: true, message: FORCE_LIMIT_RESET }));
    assert!(!s.ctl.control.retracting() && o.effort.is_none(), "the reset alone commands nothing");
    let (s, o) = run(&p, &s, Inbox { reset_force_limit: true, ..Default::default() }, 3 * MS);
    let a = o.reset_force_limit.unwrap();
    assert!(!a.success && a.message.contains("no force-limit retraction"), "{a:?}");
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(MS, 1.0)), ..Default::default() }, 4 * MS);
    let (_, o) = run(&p, &s, Inbox { joint_states: Some(&js(MS, ORDER)), ..Default::default() }, 5 * MS);
    assert_eq!(o.report.unwrap().fault, None);
}

#[test]
fn the_force_limit_fault_text_names_the_limit_and_the_retraction() {
    let t = FaultReport::ForceLimit(50.0).to_string();
    assert!(t.contains("force_limit (50 N)") && t.contains("retract"), "{t}");
}

// ---- scenario none: the reference topics ----

fn pose_msg(stamp: i64, frame: &str, p: [f64; 3], q: UnitQuaternion<f64>) -> PoseStamped {
    use naic_ros::msgs::{Point, Pose, Quaternion};
    PoseStamped {
        header: Header {
            stamp: Time::from_nanos(stamp),
            frame_id: frame.into(),
        },
        pose: Pose {
            position: Point {
                x: p[0],
                y: p[1],
                z: p[2],
            },
            orientation: Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        },
    }
}

fn desired(stamp: i64, fz: f64) -> WrenchStamped {
    WrenchStamped {
        header: Header {
            stamp: Time::from_nanos(stamp),
            frame_id: "base_link".into(),
        },
        ..wrench(stamp, fz)
    }
}

/// One 1 kHz cycle at `k` ms in simulated time (the wrench of the stamp first), with the
/// reference samples of `extra` taken just before it; returns the report and the events.
fn cycle_at(p: &Params, s: &State, k: i64, extra: Inbox) -> (State, Report, Events) {
    let (s, o) = run(p, s, extra, k * MS);
    let ev = o.events;
    let (s, _) = run(
        p,
        &s,
        Inbox {
            wrench: Some(&wrench(k * MS, 0.0)),
            ..Default::default()
        },
        k * MS,
    );
    let (s, o) = run(
        p,
        &s,
        Inbox {
            joint_states: Some(&js(k * MS, ORDER)),
            ..Default::default()
        },
        k * MS,
    );
    (s, o.report.expect("a cycle ran"), ev)
}

/// The start tip pose as the core takes it.
fn start_pose(p: &Params) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let mut ws = p.controller.workspace();
    dynamics::forward_kinematics(p.controller.model(), &mut ws.data, &Vector6::from(Q0));
    let pose = *ws.data.frame_se3(p.tip);
    (pose.trans, UnitQuaternion::from_matrix(&pose.rot))
}

#[test]
fn a_target_pose_moves_the_reference_within_the_speed_limit() {
    let p = params(TimeBase::Sim);
    let (p0, r0) = start_pose(&p);
    let mut s = State::new(&p);
    let (s1, r, _) = cycle_at(&p, &s, 0, Inbox::default());
    s = s1;
    assert_eq!(r.reference.source, "start");
    assert_eq!(
        Vector3::from(r.reference.position),
        p0,
        "at rest at the start pose"
    );
    // One target 10 cm along +x of the start, in the base frame.
    let goal = p0 + Vector3::new(0.1, 0.0, 0.0);
    let msg = pose_msg(MS, "base_link", goal.into(), r0);
    let mut prev = Vector3::from(r.reference.position);
    let (mut fastest, mut last) = (0.0f64, r);
    for k in 1..2000 {
        let extra = if k == 1 {
            Inbox {
                target_pose: Some(&msg),
                ..Default::default()
            }
        } else {
            Inbox::default()
        };
        let (n, r, ev) = cycle_at(&p, &s, k, extra);
        assert_eq!((ev.target_rejected, ev.wrench_rejected), (None, None));
        s = n;
        let x = Vector3::from(r.reference.position);
        fastest = fastest.max((x - prev).norm() / 1e-3);
        prev = x;
        last = r;
    }
    let vmax = p.reference_params.linear.max_speed;
    assert!(
        fastest <= vmax * (1.0 + 1e-9),
        "reference speed {fastest} m/s above max_speed {vmax}"
    );
    assert!(
        fastest > 0.99 * vmax,
        "the speed limit was never reached: {fastest} m/s"
    );
    assert_eq!(last.reference.source, "target_pose");
    let err = (Vector3::from(last.reference.position) - goal).norm();
    assert!(
        err < 1e-9,
        "after 2 s the reference is {err} m from the target"
    );
    assert_eq!(last.reference.rejected, 0);
}

#[test]
fn a_target_in_another_frame_is_refused_counted_and_logged_rate_limited() {
    let p = params(TimeBase::Sim);
    let (p0, r0) = start_pose(&p);
    let (s, first, _) = cycle_at(&p, &State::new(&p), 0, Inbox::default());
    let away: [f64; 3] = (p0 + Vector3::new(0.05, 0.0, 0.0)).into();
    let tool = pose_msg(MS, "tool0", away, r0);
    let (s, r, ev) = cycle_at(
        &p,
        &s,
        1,
        Inbox {
            target_pose: Some(&tool),
            ..Default::default()
        },
    );
    assert_eq!(ev.target_rejected, Some((Rejection::Frame, 1)));
    assert_eq!((r.reference.rejected, r.reference.source), (1, "start"));
    // Again 10 ms later: counted, not logged (one message per second).
    let tool = pose_msg(11 * MS, "tool0", away, r0);
    let (s, r, ev) = cycle_at(
        &p,
        &s,
        11,
        Inbox {
            target_pose: Some(&tool),
            ..Default::default()
        },
    );
    assert_eq!((ev.target_rejected, r.reference.rejected), (None, 2));
    // A NaN force on /naic/desired_wrench: refused too, the force stays the parameter.
    let mut bad = desired(12 * MS, -5.0);
    bad.wrench.force.z = f64::NAN;
    let (_, r, _) = cycle_at(
        &p,
        &s,
        12,
        Inbox {
            desired_wrench: Some(&bad),
            ..Default::default()
        },
    );
    assert_eq!(r.reference.rejected, 3);
    assert_eq!(r.status.f_d, first.status.f_d);
    // The refused target never moved the goal: still heading down along n from the start.
    let x = Vector3::from(r.reference.position);
    assert!(x.x == p0.x && x.z < p0.z, "{x:?} vs start {p0:?}");
}

#[test]
fn a_stream_that_stops_is_held_and_reported_stale() {
    let p = params(TimeBase::Sim);
    let (p0, r0) = start_pose(&p);
    let (mut s, _, _) = cycle_at(&p, &State::new(&p), 0, Inbox::default());
    // A 50 Hz stream for 0.2 s sliding +x at 10 mm/s, then silence.
    let mut last = None;
    let mut held = None;
    for k in 1..1500 {
        let msg = (k % 20 == 0 && k <= 200).then(|| {
            pose_msg(
                k * MS,
                "base_link",
                (p0 + Vector3::new(1e-5 * k as f64, 0.0, 0.0)).into(),
                r0,
            )
        });
        let (n, r, _) = cycle_at(
            &p,
            &s,
            k,
            Inbox {
                target_pose: msg.as_ref(),
                ..Default::default()
            },
        );
        s = n;
        if k == 300 {
            assert!(
                !r.reference.stale,
                "stale 0.1 s after the last sample (timeout 0.5 s)"
            );
        }
        if k == 1000 {
            held = Some(r.reference.position);
        }
        last = Some(r);
    }
    let last = last.unwrap();
    assert!(
        last.reference.stale,
        "not stale 1.3 s after the last sample"
    );
    assert_eq!(last.reference.source, "target_pose");
    assert_eq!(
        Some(last.reference.position),
        held,
        "the held reference moved"
    );
    assert!(
        (last.reference.position[0] - (p0.x + 2e-3)).abs() < 1e-9,
        "held at {:?}",
        last.reference.position
    );
}

#[test]
fn desired_force_is_the_default_until_a_desired_wrench_arrives() {
    let p = params(TimeBase::Sim);
    let (mut s, _, _) = cycle_at(&p, &State::new(&p), 0, Inbox::default());
    for k in 1..100 {
        let (n, r, _) = cycle_at(&p, &s, k, Inbox::default());
        assert_eq!(
            r.status.f_d, 10.0,
            "cycle {k}: not the desired_force parameter"
        );
        s = n;
    }
    // Push 5 N down onto the table (force axis -z: force -5 N along z in the base frame).
    let w = desired(100 * MS, -5.0);
    let mut fd = Vec::new();
    for k in 100..300 {
        let extra = if k == 100 {
            Inbox {
                desired_wrench: Some(&w),
                ..Default::default()
            }
        } else {
            Inbox::default()
        };
        let (n, r, _) = cycle_at(&p, &s, k, extra);
        s = n;
        fd.push(r.status.f_d);
    }
    // 100 N/s: 10 → 5 N in 50 ms, never faster.
    assert!(
        fd.windows(2).all(|w| (w[1] - w[0]).abs() <= 0.1 + 1e-12),
        "force reference stepped"
    );
    assert!((fd[25] - 7.5).abs() < 0.15, "{}", fd[25]);
    assert_eq!(*fd.last().unwrap(), 5.0);
}

/// One 1 kHz cycle at `k` ms of wall time (stamps = arrival): the wrench with `fz`, a
/// `/joint_effort_cmd` answering the state of `answered` ms if given, then the joint state.
fn wall_cycle(p: &Params, s: &State, k: i64, fz: f64, answered: Option<i64>) -> (State, Outbox) {
    let (s, _) = run(p, s, Inbox { wrench: Some(&wrench(k * MS, fz)), ..Default::default() }, k * MS);
    let cmd = answered.map(|a| naic_ros::msgs::effort_msg(&[0.0; N_JOINTS], Some(a * MS)));
    let (s, _) = run(p, &s, Inbox { actuated: cmd.as_ref(), ..Default::default() }, k * MS);
    run(p, &s, Inbox { joint_states: Some(&js(k * MS, ORDER)), ..Default::default() }, k * MS)
}

/// Free space with every command applied, then pushing with `fz` until contact; returns the
/// state in contact and the cycle it was reached at (`None`: this sign is not a push).
fn into_contact(p: &Params, fz: f64) -> Option<(State, i64)> {
    let mut s = State::new(p);
    for k in 1..=400 {
        let f = if k <= 300 { 0.0 } else { fz };
        let (next, o) = wall_cycle(p, &s, k, f, Some(k - 1));
        s = next;
        if o.report.unwrap().status.phase == Phase::Contact {
            return Some((s, k));
        }
    }
    None
}

#[test]
fn without_joint_effort_cmd_the_force_law_is_held_and_restarts_when_commands_return() {
    // friction_compensation killed: the controller keeps running on the joint states while
    // the driver holds the arm; a law that went on adapting (NAIC: m_d to its floor, sigma
    // beyond the eq-9 bound) shook the arm when a restarted friction node applied it.
    let p = params(TimeBase::Wall);
    let (fz, (mut s, k0)) = [-15.0, 15.0]
        .into_iter()
        .find_map(|f| into_contact(&p, f).map(|c| (f, c)))
        .expect("neither sign of the wrench made contact");
    let law = |s: &State| s.ctl.control;
    // Commands applied: the law adapts (the precondition of the check below).
    let mut changed = 0;
    let mut k = k0;
    for _ in 0..30 {
        k += 1;
        let (next, o) = wall_cycle(&p, &s, k, fz, Some(k - 1));
        assert_eq!(o.report.unwrap().fault, None);
        changed += (law(&next) != law(&s)) as u32;
        s = next;
    }
    assert!(changed >= 25, "the law changed in only {changed} of 30 cycles in contact");
    // No more /joint_effort_cmd: for actuation_timeout (20 ms) nothing changes, then the law
    // is in the state of a safe hold (configured weights) and it is reported; the rest of
    // the controller (filters) goes on.
    let cp = p.controller.params().control;
    assert_ne!(law(&s), law(&s).hold(&cp), "the precondition: a law that has adapted");
    let last = k - 1; // the newest state a command answered
    let mut lost = 0;
    for _ in 0..60 {
        k += 1;
        let (next, o) = wall_cycle(&p, &s, k, fz, None);
        let r = o.report.unwrap();
        let lag = k - last;
        if lag > 20 {
            assert_eq!(law(&next), law(&next).hold(&cp), "{lag} ms after the last applied command: not the hold's law");
            assert_eq!(law(&next).law, law(&s).hold(&cp).law, "{lag} ms: the weights moved");
            assert_ne!(next.ctl.sense, s.ctl.sense, "the sense stage stopped");
            match r.fault {
                Some(FaultReport::NotActuated(ms)) => assert!((ms - lag as f64).abs() < 1e-6, "{ms} vs {lag}"),
                f => panic!("{lag} ms without a command: report {f:?}"),
            }
            lost += matches!(o.events.actuation, Some(Actuation::Lost(ms)) if ms == 21.0) as u32;
        } else {
            assert_eq!(r.fault, None, "{lag} ms");
            assert_eq!(o.events.actuation, None);
        }
        s = next;
    }
    assert_eq!(lost, 1, "the loss is logged once");
    assert!(FaultReport::NotActuated(25.0).to_string().contains("no /joint_effort_cmd for 25 ms"));
    // Commands reach the arm again: the hold ends, contact is re-detected (still pushing).
    k += 1;
    let (next, o) = wall_cycle(&p, &s, k, fz, Some(k - 1));
    let r = o.report.unwrap();
    assert_eq!((r.fault, o.events.actuation, r.status.phase), (None, Some(Actuation::Restored), Phase::Contact));
    assert_ne!(law(&next), law(&next).hold(&cp));
    // In simulated time (lockstep) the supervision is off: the same gap changes nothing.
    let ps = params(TimeBase::Sim);
    let mut s = State::new(&ps);
    for k in 1..=100 {
        let answered = (k < 50).then_some(k - 1);
        let (next, o) = wall_cycle(&ps, &s, k, 0.0, answered);
        assert!(o.report.unwrap().fault.is_none() && o.events.actuation.is_none(), "sim time, {k} ms");
        s = next;
    }
}

#[test]
fn zero_wrench_re_tares_at_rest_in_free_space_and_is_refused_otherwise() {
    let m = model();
    let mut cp = base(&m);
    cp.tare_at_rest = true;
    let rp = ReferenceParams::new("base_link", cp.control.force_axis, 10.0);
    let p = Params::new(Controller::new(m.clone(), cp).unwrap(), settings(TimeBase::Wall), None, rp, JOINT_NAMES.map(String::from)).unwrap();
    let zero = |s: &State, now| run(&p, s, Inbox { zero_wrench: true, ..Default::default() }, now);
    let s = State::new(&p);
    let (s, o) = zero(&s, 0);
    assert_eq!(o.zero_wrench.map(|a| (a.success, a.message)), Some((false, ZERO_REFUSED_NO_CYCLE)));
    // The start-up tare (joints at rest: at most 0.015 rad/s), then free space.
    let mut s = s;
    let mut k = 0;
    while !s.ctl.tare.done(cp.tare_samples) {
        k += 1;
        assert!(k < 1000, "the tare never finished");
        let (n, o) = wall_cycle(&p, &s, k, 0.0, Some(k - 1));
        assert!(o.report.unwrap().wrench_bias.is_none() || n.ctl.tare.done(cp.tare_samples));
        s = n;
    }
    let (s2, o) = wall_cycle(&p, &s, k + 1, 0.0, Some(k));
    assert!(o.report.unwrap().wrench_bias.is_some(), "the bias is reported once tared");
    // At rest in free space: accepted, the tare starts again (the next cycles hold the arm).
    let (s3, o) = zero(&s2, (k + 1) * MS);
    assert_eq!(o.zero_wrench.map(|a| a.success), Some(true));
    assert!(!s3.ctl.tare.done(cp.tare_samples) && o.effort.is_none());
    let (s4, o) = wall_cycle(&p, &s3, k + 2, 0.0, Some(k + 1));
    assert!(o.report.unwrap().wrench_bias.is_none(), "no bias while taring");
    let (_, o) = zero(&s4, (k + 2) * MS);
    assert_eq!(o.zero_wrench.map(|a| a.message), Some(ZERO_REFUSED_TARING));
    // Moving (a joint at 0.05 rad/s for 5 cycles: past the velocity median): refused,
    // nothing changes.
    let mut s5 = s2;
    for j in 0..5 {
        let t = (k + 2 + j) * MS;
        let moving = JointState { velocity: vec![0.0, 0.0, 0.05, 0.0, 0.0, 0.0], ..js(t, ORDER) };
        let (n, _) = run(&p, &s5, Inbox { wrench: Some(&wrench(t, 0.0)), ..Default::default() }, t);
        let (n, _) = run(&p, &n, Inbox { joint_states: Some(&moving), ..Default::default() }, t);
        s5 = n;
    }
    let (s6, o) = zero(&s5, (k + 7) * MS);
    assert_eq!(o.zero_wrench.map(|a| (a.success, a.message)), Some((false, ZERO_REFUSED_MOVING)));
    assert_eq!(s6.ctl.tare, s5.ctl.tare);
    // A force above the contact threshold (pushing 15 N): refused as contact.
    let mut s7 = s2;
    for j in 0..3 {
        let t = k + 3 + j;
        let (n, _) = wall_cycle(&p, &s7, t, -15.0, Some(t - 1));
        s7 = n;
    }
    let (s8, o) = zero(&s7, (k + 6) * MS);
    let a = o.zero_wrench.unwrap();
    assert!(!a.success && a.message.contains("in contact"), "{a:?}");
    assert_eq!(s8.ctl.tare, s7.ctl.tare);
}

/// Reference samples in other frames of the model (issue 39 item 3): a target pose and a
/// desired wrench given in the tip frame land where the same sample in the base frame
/// would; an empty frame is the base frame; an unknown frame is refused and nothing moves.
#[test]
fn reference_samples_in_other_frames_of_the_model_are_expressed_in_the_base_frame() {
    let p = params(TimeBase::Sim);
    let (p0, r0) = start_pose(&p);
    let (mut s, _, _) = cycle_at(&p, &State::new(&p), 0, Inbox::default());
    // 4 cm along the tip's own z axis (the tool axis), orientation kept: in the tip frame
    // that is position (0, 0, 0.04) and the identity.
    let msg = pose_msg(MS, "tip", [0.0, 0.0, 0.04], UnitQuaternion::identity());
    // 5 N pushing along the force axis (-z of the base), written in the tip frame.
    let f_tip = r0.inverse() * Vector3::new(0.0, 0.0, -5.0);
    let mut w = desired(MS, 0.0);
    w.header.frame_id = "tip".into();
    (w.wrench.force.x, w.wrench.force.y, w.wrench.force.z) = (f_tip.x, f_tip.y, f_tip.z);
    let mut last = None;
    for k in 1..2000 {
        let extra = if k == 1 { Inbox { target_pose: Some(&msg), desired_wrench: Some(&w), ..Default::default() } } else { Inbox::default() };
        let (n, r, ev) = cycle_at(&p, &s, k, extra);
        assert_eq!((ev.target_rejected, ev.wrench_rejected), (None, None), "cycle {k}");
        s = n;
        last = Some(r);
    }
    let r = last.unwrap();
    let goal = p0 + r0 * Vector3::new(0.0, 0.0, 0.04);
    let err = (Vector3::from(r.reference.position) - goal).norm();
    assert!(err < 1e-9, "reference {err} m from the tip-frame target");
    assert!((r.status.f_d - 5.0).abs() < 1e-9, "f_d {}", r.status.f_d);
    assert_eq!((r.reference.source, r.reference.rejected), ("target_pose", 0));
    // The empty frame is the base frame.
    let here: [f64; 3] = Vector3::from(r.reference.position).into();
    let (s, r, ev) = cycle_at(&p, &s, 2000, Inbox { target_pose: Some(&pose_msg(2000 * MS, "", here, r0)), ..Default::default() });
    assert_eq!((ev.target_rejected, r.reference.rejected), (None, 0));
    // A frame the model does not have: refused, counted, the goal unchanged.
    let (_, r2, ev) = cycle_at(&p, &s, 2001, Inbox { target_pose: Some(&pose_msg(2001 * MS, "camera_link", [0.0; 3], r0)), ..Default::default() });
    assert_eq!(ev.target_rejected, Some((Rejection::Frame, 1)));
    assert!(Rejection::Frame.to_string().contains("not a frame of the robot model"));
    assert_eq!(r2.reference.position, r.reference.position);
}

/// `robot_compensates_gravity` (a Franka arm): the published torque is the same cycle's
/// minus the model's `G(q)` at the measured q, and nothing else of the cycle changes.
#[test]
fn a_robot_that_compensates_gravity_gets_the_torque_without_g() {
    let p = params(TimeBase::Sim);
    let mut pg = p.clone();
    pg.settings.robot_compensates_gravity = true;
    let (mut s, mut sg) = (State::new(&p), State::new(&pg));
    for k in 1..=3 {
        let stamp = k * MS;
        let w = Inbox { wrench: Some(&wrench(stamp, 1.0)), ..Default::default() };
        s = run(&p, &s, w, stamp).0;
        sg = run(&pg, &sg, w, stamp).0;
        let j = Inbox { joint_states: Some(&js(stamp, ORDER)), ..Default::default() };
        let (n, o) = run(&p, &s, j, stamp);
        let (ng, og) = run(&pg, &sg, j, stamp);
        assert_eq!(n.ctl, ng.ctl, "the controller's state does not depend on it");
        let (tau, tau_g) = (o.effort.unwrap().0, og.effort.unwrap().0);
        let model = p.controller.model();
        let mut data = naic_core::model::Data6::try_new(model).unwrap();
        let g = naic_core::dynamics::gravity_torques(model, &mut data, &nalgebra::SVector::<f64, 6>::from(Q0));
        for i in 0..6 {
            assert!((tau[i] - g[i] - tau_g[i]).abs() < 1e-9, "joint {i}: {} - {} != {}", tau[i], g[i], tau_g[i]);
        }
        assert!(g.iter().any(|x| x.abs() > 1.0), "the JK5's gravity at Q0 is not small: {g:?}");
        (s, sg) = (n, ng);
    }
}
