//! The node's core: one pure step `(params, state, inbox, now) -> (state, outbox)`.
//!
//! Pipeline stages 4 and 5 (`naic_core::pipeline::feedforward` at the joint velocity the
//! core's sense stage filtered, then `pipeline::actuate`) plus what the node adds around
//! them: joints read by name, the lockstep pairing of a command with the `/joint_states`
//! sample of its stamp, the replay of a repeated stamp, the take-over after a gap
//! (the rate limit restarts from the measured joint torque), and freshness of the joint
//! velocity on the node's time base. No I/O, no clock, no allocation: the shell copies
//! messages into the [`Inbox`], passes the wall time, and publishes the [`Outbox`].

use naic_core::{
    friction::FrictionModel,
    pipeline::{
        actuate, feedforward,
        sense::{self, RawMeasurements, SenseParams, SenseState},
    },
    JointVec, N_JOINTS,
};
use naic_ros::msgs::JOINT_NAMES;
use naic_ros::{
    joints::{finite, JointMap, Layout},
    msgs::{self, EffortError, Float64MultiArray, JointState},
    replay::Replay,
    throttle::Throttle,
    timebase::TimeBase,
};

/// Everything the step reads and never changes (rebuilt on a parameter change).
#[derive(Clone, Debug)]
pub struct Params<const N: usize = N_JOINTS> {
    /// The friction model (`None`: none, a robot file's `friction: none`; the command then
    /// passes through the actuation guard only).
    pub friction: Option<FrictionModel>,
    /// Add the feedforward (false: the actuation guard only).
    pub enabled: bool,
    pub time: TimeBase,
    /// Joint velocity older than this is not used [ns].
    pub joint_state_timeout_ns: i64,
    /// After a gap in the commands longer than this, the rate limit restarts from the
    /// measured joint torque [ns].
    pub takeover_gap_ns: i64,
    /// After a take-over the command is blended from the measured torque over this time
    /// [ns] ([`actuate::Blend`]), ahead of the rate limit; 0: the rate limit alone.
    pub takeover_blend_ns: i64,
    pub actuate: actuate::ActuateParams<N>,
    /// The velocity filter (the controller's sense stage; the wrench is not used here).
    pub sense: SenseParams<N>,
    /// The arm's joint names in joint order: `/joint_states` is read by them, and
    /// `/joint_effort_cmd` carries the torques in their order.
    pub joints: [String; N],
}

/// The JK5's joint names ([`JOINT_NAMES`]) as [`Params::joints`].
pub fn jk5_joints() -> [String; N_JOINTS] {
    JOINT_NAMES.map(String::from)
}

/// A command waiting for the joint state of its stamp (lockstep).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pending<const N: usize> {
    tau: JointVec<N>,
    /// The velocity the command names for the feedforward (the scheduled law's; `None`:
    /// the measured one).
    dq_ff: Option<JointVec<N>>,
    src: Option<i64>,
    /// Give up waiting at this wall time [ns] (then: no feedforward this cycle).
    until_ns: i64,
}

/// All the node remembers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<const N: usize = N_JOINTS> {
    joints: JointMap<N>,
    sense: SenseState<N>,
    /// Filtered joint velocity, its wall-clock arrival and its stamp [ns].
    dq: JointVec<N>,
    dq_rx_ns: i64,
    dq_stamp_ns: Option<i64>,
    /// Torque the driver applies now (`/joint_states` effort).
    effort_meas: Option<JointVec<N>>,
    actuate: actuate::ActuateState<N>,
    /// The take-over blend under way, if any.
    blend: Option<actuate::Blend<N>>,
    /// When the last command went out (node time base) [ns].
    last_pub_ns: i64,
    replay: Replay<JointVec<N>>,
    pending: Option<Pending<N>>,
    warn: Throttle,
    /// Commands published.
    pub published: u64,
    /// Take-overs (the first command and each one after a gap longer than `takeover_gap`).
    pub takeovers: u64,
}

impl<const N: usize> Default for State<N> {
    fn default() -> Self {
        Self {
            joints: JointMap::default(),
            sense: SenseState::default(),
            dq: [0.0; N],
            dq_rx_ns: i64::MIN,
            dq_stamp_ns: None,
            effort_meas: None,
            actuate: actuate::ActuateState::default(),
            blend: None,
            last_pub_ns: i64::MIN,
            replay: Replay::default(),
            pending: None,
            warn: Throttle::default(),
            published: 0,
            takeovers: 0,
        }
    }
}

/// The messages of one step (any of them may be absent). A new input topic is a new field.
#[derive(Clone, Copy, Debug, Default)]
pub struct Inbox<'a> {
    pub joint_states: Option<&'a JointState>,
    /// `/naic/effort`, the controller's torque.
    pub command: Option<&'a Float64MultiArray>,
}

/// Something for the shell to log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A `/naic/effort` command was refused (rate-limited: one per second).
    BadCommand(EffortError),
    /// `/joint_states` lacks the arm's joint of this index ([`Params::joints`]): no
    /// feedforward until it has it.
    MissingJoint(usize),
}

/// What one step produces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outbox<const N: usize = N_JOINTS> {
    /// `/joint_effort_cmd`: N torques (in [`Params::joints`] order) and the `/joint_states`
    /// stamp they answer.
    pub command: Option<(JointVec<N>, Option<i64>)>,
    /// Lockstep: a command waits for the joint state of its stamp; step again with each
    /// `/joint_states` sample until this wall time [ns], then with an empty inbox.
    pub wait_until_ns: Option<i64>,
    pub event: Option<Event>,
}

/// One step at wall time `now_ns`.
pub fn step<const N: usize>(p: &Params<N>, s: &State<N>, inbox: &Inbox, now_ns: i64) -> (State<N>, Outbox<N>) {
    let mut s = *s;
    let mut out = Outbox { command: None, wait_until_ns: None, event: None };
    if let Some(js) = inbox.joint_states {
        absorb(p, &mut s, js, now_ns, &mut out);
    }
    if let Some(m) = inbox.command {
        let mut tau = [0.0; N];
        let mut dq_ff = [0.0; N];
        let named = msgs::effort_values(m, &mut tau).and_then(|()| msgs::effort_friction_velocity(m, &mut dq_ff));
        let named = match named {
            Ok(named) => named,
            Err(e) => {
                if s.warn.ready(now_ns) {
                    out.event = Some(Event::BadCommand(e));
                }
                return (s, out);
            }
        };
        let src = msgs::effort_source_stamp(m);
        if let Some(tau) = src.and_then(|st| s.replay.get(st)) {
            // A repeated stamp: the same answer, no state advances.
            out.command = Some((tau, src));
            s.pending = None;
            return (s, out);
        }
        let first = s.dq_stamp_ns.is_none() && s.effort_meas.is_none();
        let wait = if first { naic_ros::timebase::FIRST_PAIR_TIMEOUT_NS } else { p.joint_state_timeout_ns };
        s.pending = Some(Pending { tau, dq_ff: named.then_some(dq_ff), src, until_ns: now_ns.saturating_add(wait) });
    }
    let Some(cmd) = s.pending else { return (s, out) };
    let sim = p.time.is_sim() && cmd.src.is_some();
    if sim && s.dq_stamp_ns.is_none_or(|d| Some(d) < cmd.src) && now_ns < cmd.until_ns {
        // The joint state this command was computed from is on its way (published first).
        out.wait_until_ns = Some(cmd.until_ns);
        return (s, out);
    }
    s.pending = None;
    let fresh = if sim { s.dq_stamp_ns == cmd.src } else { now_ns.saturating_sub(s.dq_rx_ns) <= p.joint_state_timeout_ns };
    // At the velocity the controller names (the scheduled law's, `/naic/effort`'s second
    // row), else at the measured one.
    let dq = cmd.dq_ff.as_ref().unwrap_or(&s.dq);
    let tau = match (&p.friction, p.enabled && fresh) {
        (Some(f), true) => feedforward::step(f, dq, &cmd.tau),
        _ => cmd.tau,
    };
    // Smooth take-over (first command, or after a gap in which the driver held the arm
    // itself): the rate limit starts from the torque the arm has now.
    let t_ns = if sim { cmd.src.unwrap_or_default() } else { now_ns };
    if !s.actuate.started || t_ns.saturating_sub(s.last_pub_ns) > p.takeover_gap_ns {
        match s.effort_meas {
            Some(e) => {
                s.actuate = actuate::ActuateState { tau_prev: e, started: true };
                s.blend = Some(actuate::Blend { from: e, t0_ns: t_ns });
                s.takeovers += 1;
            }
            // Not yet known what the arm gets: publish nothing (the driver holds).
            None => return (s, out),
        }
    }
    let tau = match s.blend {
        Some(b) => {
            let (tau, done) = b.apply(&tau, t_ns, p.takeover_blend_ns);
            if done {
                s.blend = None;
            }
            tau
        }
        None => tau,
    };
    let (a, r) = actuate::step(&p.actuate, &s.actuate, &tau);
    s.actuate = a;
    if finite(&r.tau).is_some() {
        out.command = Some((r.tau, cmd.src));
        s.last_pub_ns = t_ns;
        match cmd.src {
            Some(st) => s.replay.store(st, r.tau),
            None => s.replay.clear(),
        }
        s.published += 1;
    }
    (s, out)
}

/// Take one `/joint_states` sample: the filtered velocity and the measured torque.
fn absorb<const N: usize>(p: &Params<N>, s: &mut State<N>, js: &JointState, now_ns: i64, out: &mut Outbox<N>) {
    let stamp = js.header.stamp.to_nanos();
    if s.dq_stamp_ns == Some(stamp) {
        // The same state published again (lockstep, paused): the median filter takes
        // each state once, as the controller's does.
        s.dq_rx_ns = now_ns;
        return;
    }
    let (j, layout) = s.joints.sample_named(js, &p.joints);
    if let Layout::Missing(i) = layout {
        out.event = Some(Event::MissingJoint(i));
    }
    if let (Some(q), Some(v)) = (finite(&j.q), finite(&j.dq)) {
        let raw = RawMeasurements { t: 0.0, q, dq: v, joints_stamp: 0.0, wrench: [0.0; 6], wrench_stamp: 0.0 };
        let (ss, r) = sense::step(&p.sense, &s.sense, &raw);
        s.sense = ss;
        match r {
            Ok(sensed) => {
                s.dq = sensed.dq;
                s.dq_rx_ns = now_ns;
                s.dq_stamp_ns = Some(stamp);
            }
            // Implausible joint data: no feedforward.
            Err(_) => (s.dq_rx_ns, s.dq_stamp_ns) = (i64::MIN, None),
        }
    }
    if let Some(e) = finite(&j.effort) {
        s.effort_meas = Some(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_core::{friction::FrictionParams, model::Model};
    use naic_ros::{
        alloc_check::counted,
        msgs::{effort_msg, Header, Time, JOINT_NAMES},
    };

    const MS: i64 = 1_000_000;

    fn params(time: TimeBase) -> Params {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let robot = Model::from_urdf_file(root.join("urdf/jk5.urdf")).unwrap();
        let friction = FrictionParams::from_yaml_file(root.join("params/friction_jk5.yaml")).unwrap().to_model().unwrap();
        Params {
            friction: Some(friction),
            enabled: true,
            time,
            joint_state_timeout_ns: 20 * MS,
            takeover_gap_ns: 20 * MS,
            takeover_blend_ns: 0,
            actuate: actuate::ActuateParams { effort_limit: [100.0; 6], max_delta: [10.0; 6] },
            joints: jk5_joints(),
            sense: SenseParams {
                wrench_max: [f64::INFINITY; 6],
                joint_timeout: 1.0,
                wrench_timeout: 1.0,
                median_window: 1,
                ..SenseParams::for_model(&robot)
            },
        }
    }

    /// Joint state at `stamp`, joints listed in `order`, velocity `dq`, effort `effort`.
    fn js(stamp: i64, order: [usize; N_JOINTS], dq: JointVec, effort: JointVec) -> JointState {
        JointState {
            header: Header { stamp: Time::from_nanos(stamp), frame_id: String::new() },
            name: order.iter().map(|&j| JOINT_NAMES[j].to_string()).collect(),
            position: vec![0.1; 6],
            velocity: order.iter().map(|&j| dq[j]).collect(),
            effort: order.iter().map(|&j| effort[j]).collect(),
        }
    }

    const ORDER: [usize; N_JOINTS] = [0, 1, 2, 3, 4, 5];

    fn run(p: &Params, s: &State, inbox: Inbox, now: i64) -> (State, Outbox) {
        let ((s, o), n) = counted(|| step(p, s, &inbox, now));
        assert_eq!(n, 0, "the step allocated");
        (s, o)
    }

    #[test]
    fn another_joint_order_gives_the_same_torques() {
        let mut p = params(TimeBase::Wall);
        p.actuate.max_delta = [1000.0; 6];
        let dq = [0.5, -0.4, 0.3, -0.2, 0.1, 1.0];
        let effort = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let cmd = effort_msg(&[1.5, 2.5, 3.5, 4.5, 5.5, 6.5], None);
        let mut answers = vec![];
        for order in [ORDER, [5, 3, 1, 0, 2, 4], [3, 4, 5, 0, 1, 2]] {
            let s = State::default();
            let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(1, order, dq, effort)), ..Default::default() }, 0);
            let (_, o) = run(&p, &s, Inbox { command: Some(&cmd), ..Default::default() }, MS);
            answers.push(o.command.unwrap().0);
        }
        assert_eq!(answers[0], answers[1]);
        assert_eq!(answers[0], answers[2]);
        // The feedforward is there (joint 6 turns at 1 rad/s) and on the right joint.
        let ff = feedforward::step(p.friction.as_ref().unwrap(), &dq, &[1.5, 2.5, 3.5, 4.5, 5.5, 6.5]);
        assert_eq!(answers[0], ff);
        assert!(ff[5] > 6.5 + 0.01, "{ff:?}");
    }

    #[test]
    fn take_over_starts_from_the_measured_effort_and_again_after_a_gap() {
        let mut p = params(TimeBase::Wall);
        p.enabled = false;
        let far = effort_msg(&[50.0; 6], None);
        let s = State::default();
        // No measured torque yet: nothing goes out.
        let (s, o) = run(&p, &s, Inbox { command: Some(&far), ..Default::default() }, 0);
        assert_eq!(o.command, None);
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(1, ORDER, [0.0; 6], [3.0; 6])), ..Default::default() }, MS);
        let (s, o) = run(&p, &s, Inbox { command: Some(&far), ..Default::default() }, 2 * MS);
        assert_eq!(o.command.unwrap().0, [13.0; 6], "measured 3 + rate limit 10");
        let (s, o) = run(&p, &s, Inbox { command: Some(&far), ..Default::default() }, 3 * MS);
        assert_eq!(o.command.unwrap().0, [23.0; 6]);
        // A gap longer than takeover_gap (the driver held the arm): restart from its torque.
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(2, ORDER, [0.0; 6], [-4.0; 6])), ..Default::default() }, 30 * MS);
        let (s, o) = run(&p, &s, Inbox { command: Some(&far), ..Default::default() }, 30 * MS);
        assert_eq!(o.command.unwrap().0, [6.0; 6], "measured -4 + 10");
        assert_eq!(s.published, 3);
    }

    #[test]
    fn a_take_over_blends_from_the_measured_effort_to_the_command() {
        let mut p = params(TimeBase::Wall);
        p.enabled = false;
        p.takeover_blend_ns = 10 * MS;
        p.actuate.max_delta = [1000.0; 6]; // the blend alone
        let at = |v: f64| effort_msg(&[v; 6], None);
        let cmd = |s: &State, v: f64, t: i64| run(&p, s, Inbox { command: Some(&at(v)), ..Default::default() }, t);
        let (s, _) = run(&p, &State::default(), Inbox { joint_states: Some(&js(1, ORDER, [0.0; 6], [3.0; 6])), ..Default::default() }, MS);
        let (s, o) = cmd(&s, 53.0, 2 * MS);
        assert_eq!(o.command.unwrap().0, [3.0; 6], "the take-over starts at the arm's torque");
        let (s, o) = cmd(&s, 53.0, 7 * MS);
        assert_eq!(o.command.unwrap().0, [28.0; 6], "halfway through the blend");
        let (s, o) = cmd(&s, 43.0, 7 * MS);
        assert_eq!(o.command.unwrap().0, [23.0; 6], "halfway: half of the command's change");
        let (s, o) = cmd(&s, 53.0, 12 * MS);
        assert_eq!(o.command.unwrap().0, [53.0; 6], "the command itself once the blend is over");
        let (s, o) = cmd(&s, 53.0, 13 * MS);
        assert_eq!(o.command.unwrap().0, [53.0; 6]);
        assert_eq!(s.takeovers, 1);
        // After a gap (the driver held the arm) a new blend starts from its torque.
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(2, ORDER, [0.0; 6], [-7.0; 6])), ..Default::default() }, 40 * MS);
        let (s, o) = cmd(&s, 53.0, 40 * MS);
        assert_eq!(o.command.unwrap().0, [-7.0; 6]);
        let (s, o) = cmd(&s, 53.0, 45 * MS);
        assert_eq!(o.command.unwrap().0, [23.0; 6]);
        assert_eq!(s.takeovers, 2);
    }

    #[test]
    fn lockstep_pairs_the_command_with_its_joint_state_and_replays_a_repeated_stamp() {
        let p = params(TimeBase::Sim);
        let dq = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let s = State::default();
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(1000, ORDER, [0.0; 6], [0.0; 6])), ..Default::default() }, 0);
        // The command for stamp 2000 arrives before the joint state of 2000: wait for it.
        let cmd = effort_msg(&[1.0; 6], Some(2000));
        let (s, o) = run(&p, &s, Inbox { command: Some(&cmd), ..Default::default() }, MS);
        assert_eq!((o.command, o.wait_until_ns), (None, Some(21 * MS)));
        let (s, o) = run(&p, &s, Inbox { joint_states: Some(&js(2000, ORDER, dq, [0.0; 6])), ..Default::default() }, 2 * MS);
        let (tau, src) = o.command.unwrap();
        assert_eq!(src, Some(2000));
        assert_eq!(tau, feedforward::step(p.friction.as_ref().unwrap(), &dq, &[1.0; 6]), "the velocity of stamp 2000 was used");
        // The same stamp again (the driver published its state again): the same answer,
        // nothing advances, also when the command's values differ.
        let again = effort_msg(&[9.0; 6], Some(2000));
        let (s2, o) = run(&p, &s, Inbox { command: Some(&again), ..Default::default() }, 40 * MS);
        assert_eq!(o.command, Some((tau, Some(2000))));
        assert_eq!(s2, s);
        // Gaps are judged in simulated time: 30 ms of wall time later, stamp 3000 ns is
        // no gap (rate limit continues from the last output, not from the measured effort).
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(3000, ORDER, [0.0; 6], [-50.0; 6])), ..Default::default() }, 70 * MS);
        let (_, o) = run(&p, &s, Inbox { command: Some(&effort_msg(&[1.0; 6], Some(3000))), ..Default::default() }, 70 * MS);
        assert_eq!(o.command.unwrap().0, feedforward::step(p.friction.as_ref().unwrap(), &[0.0; 6], &[1.0; 6]), "not restarted from -50");
    }

    #[test]
    fn a_command_that_names_a_velocity_gets_its_feedforward_there() {
        // The scheduled law sends the velocity of its friction feedforward as /naic/effort's
        // second row: the node evaluates the friction at it, not at the measured velocity.
        let p = params(TimeBase::Sim);
        let measured = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let named = [0.5, -0.5, 0.0, 0.0, 0.0, 0.0];
        let want = feedforward::step(p.friction.as_ref().unwrap(), &named, &[1.0; 6]);
        // The arm has that torque now, so the take-over's rate limit passes it unchanged.
        let (s, _) = run(&p, &State::default(), Inbox { joint_states: Some(&js(2000, ORDER, measured, want)), ..Default::default() }, MS);
        let mut cmd = effort_msg(&[1.0; 6], Some(2000));
        naic_ros::msgs::set_effort_msg(&mut cmd, &[1.0; 6], Some(2000), Some(&named[..]));
        let (_, o) = run(&p, &s, Inbox { command: Some(&cmd), ..Default::default() }, MS);
        let tau = o.command.unwrap().0;
        assert_eq!(tau, want);
        // The same command without the second row: the measured velocity, another torque.
        let (_, o) = run(&p, &s, Inbox { command: Some(&effort_msg(&[1.0; 6], Some(2000))), ..Default::default() }, MS);
        assert_ne!(o.command.unwrap().0, want, "the named velocity made no difference");
        // A named velocity that is not finite: the command is refused, with the reason.
        let mut bad = cmd.clone();
        bad.data[7] = f64::NAN;
        let (_, o) = run(&p, &s, Inbox { command: Some(&bad), ..Default::default() }, MS);
        assert_eq!(o.command, None);
        assert!(matches!(o.event, Some(Event::BadCommand(EffortError::NonFinite(_)))), "{:?}", o.event);
    }

    #[test]
    fn before_the_first_joint_state_a_command_waits_for_discovery() {
        // Discovery matched /naic/effort before /joint_states: the first command waits for
        // its joint state (seconds if need be), so a lockstep run does not depend on it.
        let p = params(TimeBase::Sim);
        let cmd = effort_msg(&[1.0; 6], Some(2000));
        let (s, o) = run(&p, &State::default(), Inbox { command: Some(&cmd), ..Default::default() }, MS);
        assert_eq!((o.command, o.wait_until_ns), (None, Some(MS + naic_ros::timebase::FIRST_PAIR_TIMEOUT_NS)));
        let dq = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let (_, o) = run(&p, &s, Inbox { joint_states: Some(&js(2000, ORDER, dq, [0.0; 6])), ..Default::default() }, 2_000 * MS);
        assert_eq!(o.command, Some((feedforward::step(p.friction.as_ref().unwrap(), &dq, &[1.0; 6]), Some(2000))));
    }

    #[test]
    fn a_joint_state_that_never_comes_gives_the_command_without_feedforward() {
        let p = params(TimeBase::Sim);
        let s = State::default();
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(1000, ORDER, [0.0; 6], [0.0; 6])), ..Default::default() }, 0);
        let (s, o) = run(&p, &s, Inbox { command: Some(&effort_msg(&[1.0; 6], Some(2000))), ..Default::default() }, 0);
        let until = o.wait_until_ns.unwrap();
        let (_, o) = run(&p, &s, Inbox::default(), until);
        assert_eq!(o.command, Some(([1.0; 6], Some(2000))), "stale velocity: no feedforward");
    }

    #[test]
    fn stale_or_missing_joints_leave_the_feedforward_out() {
        let p = params(TimeBase::Wall);
        let dq = [1.0; 6];
        let cmd = effort_msg(&[1.0; 6], None);
        let s = State::default();
        let (s, _) = run(&p, &s, Inbox { joint_states: Some(&js(1, ORDER, dq, [1.0; 6])), ..Default::default() }, 0);
        let (_, o) = run(&p, &s, Inbox { command: Some(&cmd), ..Default::default() }, 25 * MS);
        assert_eq!(o.command.unwrap().0, [1.0; 6], "velocity older than joint_state_timeout");
        let mut bad = js(2, ORDER, dq, [1.0; 6]);
        bad.name[2] = "elbow".into();
        let (s, o) = step(&p, &State::default(), &Inbox { joint_states: Some(&bad), ..Default::default() }, 0);
        assert_eq!(o.event, Some(Event::MissingJoint(2)));
        let (_, o) = run(&p, &s, Inbox { command: Some(&cmd), ..Default::default() }, MS);
        assert_eq!(o.command, None, "no measured torque known: nothing published");
    }

    #[test]
    fn bad_commands_are_reported_once_per_second() {
        let p = params(TimeBase::Wall);
        let mut bad = effort_msg(&[1.0; 6], None);
        bad.data[1] = f64::NAN;
        let s = State::default();
        let (s, o) = run(&p, &s, Inbox { command: Some(&bad), ..Default::default() }, 0);
        assert!(matches!(o.event, Some(Event::BadCommand(EffortError::NonFinite(_)))));
        let (s, o) = run(&p, &s, Inbox { command: Some(&bad), ..Default::default() }, 500 * MS);
        assert_eq!(o.event, None);
        let (_, o) = run(&p, &s, Inbox { command: Some(&bad), ..Default::default() }, 1100 * MS);
        assert!(o.event.is_some() && o.command.is_none());
    }
}
