use super::*;
use naic_core::{
    model::Model,
    pipeline::{
        control::{force_law::Mode, Phase},
        sense::Signal,
    },
};
use naic_ros::{
    alloc_check::counted,
    msgs::{Header, Time, Vector3 as V3, Wrench},
};

const MS: i64 = 1_000_000;
/// A plausible JK5 pose (the flat scenario's start).
const Q0: [f64; 6] = [0.0, 0.3, 1.8, 0.0, 1.0, 0.0];

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
    Settings { desired_force: 10.0, force_limit: 50.0, approach_depth: 0.05, time }
}

fn params(time: TimeBase) -> Params {
    let m = model();
    Params::new(Controller::new(m.clone(), base(&m)).unwrap(), settings(time), None).unwrap()
}

fn js(stamp: i64, order: [usize; 6]) -> JointState {
    JointState {
        header: Header { stamp: Time::from_nanos(stamp), frame_id: String::new() },
        name: order.iter().map(|&j| JOINT_NAMES[j].to_string()).collect(),
        position: order.iter().map(|&j| Q0[j]).collect(),
        velocity: order.iter().map(|&j| 0.01 * j as f64).collect(),
        effort: vec![0.0; 6],
    }
}

fn wrench(stamp: i64, fz: f64) -> WrenchStamped {
    WrenchStamped {
        header: Header { stamp: Time::from_nanos(stamp), frame_id: "ft_sensor".into() },
        wrench: Wrench { force: V3 { x: 0.1, y: 0.2, z: fz }, torque: V3 { x: 0.01, y: 0.02, z: 0.03 } },
    }
}

const ORDER: [usize; 6] = [0, 1, 2, 3, 4, 5];

/// One step under the allocation check.
fn run(p: &Params, s: &State, inbox: Inbox, now: i64) -> (State, Outbox) {
    let mut ws = p.controller.workspace();
    let ((s, o), n) = counted(|| step(p, s, &inbox, now, &mut ws));
    assert_eq!(n, 0, "the step allocated");
    (s, o)
}

/// What `controller::step` gives on these measurements from state `s` (the reference
/// with no scenario: the start pose, as the core computes it).
fn direct(p: &Params, s: &State, m: &RawMeasurements) -> ControllerState {
    let mut ws = p.controller.workspace();
    dynamics::forward_kinematics(p.controller.model(), &mut ws.data, &Vector6::from(Q0));
    let pose = *ws.data.frame_se3(p.tip);
    let r = Reference {
        p_d: pose.trans + Vector3::new(0.0, 0.0, -0.05),
        r_d: UnitQuaternion::from_matrix(&pose.rot),
        v_d: Vector6::zeros(),
        a_d: Vector6::zeros(),
        f_d: 10.0,
    };
    controller::step(&p.controller, &s.ctl, m, &r, &mut ws).0
}

fn dq() -> [f64; 6] {
    std::array::from_fn(|j| 0.01 * j as f64)
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
    assert_eq!(o.events.missing_joint, Some("joint5"));
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
    // Only the desired force: the latch opens, the weights stay.
    let more = Settings { desired_force: 15.0, ..p.settings };
    let o = set_params(&mut p, &mut s, cp, more).unwrap();
    assert!(o.resumed && !o.restarted);
    assert_eq!(p.settings.desired_force, 15.0);
    assert!(!s.ctl.control.retracting());
    assert_eq!(s.ctl.control.law.m_d, 0.5 * cp.control.impedance.m_d[cp.control.force_axis.axis]);
    // Another mode: the weights restart from the parameters.
    let mut aic = cp;
    aic.control.force_law.mode = Mode::Aic;
    let o = set_params(&mut p, &mut s, aic, more).unwrap();
    assert!(o.restarted && !o.resumed);
    assert_eq!(p.controller.params().control.force_law.mode, Mode::Aic);
    assert_eq!(s.ctl.control.law.m_d, cp.control.impedance.m_d[cp.control.force_axis.axis]);
    // The next cycle reports the new mode and set point.
    let (s, _) = run(&p, &s, Inbox { wrench: Some(&wrench(0, 1.0)), ..Default::default() }, 0);
    let (_, o) = run(&p, &s, Inbox { joint_states: Some(&js(0, ORDER)), ..Default::default() }, MS);
    let r = o.report.unwrap();
    assert_eq!((r.status.mode, r.status.f_d), (Mode::Aic, 15.0));
}

#[test]
fn the_force_limit_fault_text_names_the_limit_and_the_retraction() {
    let t = FaultReport::ForceLimit(50.0).to_string();
    assert!(t.contains("force_limit (50 N)") && t.contains("retract"), "{t}");
}
