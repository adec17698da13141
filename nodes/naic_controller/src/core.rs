//! The node's core: one pure step `(params, state, inbox, now) -> (state, outbox)`.
//!
//! Around `naic_core::pipeline::controller::update` it adds what the node needs: joints read
//! by name, the wrench paired with the joint state of the same stamp in simulated time
//! (lockstep), the replay of a repeated stamp, the time base (wall clock or stamps), the
//! position reference (a scenario's trajectory, or the start pose moved along n), the
//! parameter-change policy (`naic_core::pipeline::param_change`, in [`set_params`]) and
//! the rate-limited reports. No I/O, no clock, no allocation in [`step`]: the shell copies
//! messages into the [`Inbox`], passes the wall time, and publishes the [`Outbox`].

use naic_core::{
    dynamics,
    model::FrameId,
    pipeline::{
        controller::{self, Controller, ControllerParams, ControllerState, Reference, Status, Workspace},
        param_change, ConfigError,
        reference::{self as refstage, DesiredWrench, ReferenceParams, ReferenceState, Rejection, Source, TargetPose, Verdict},
        control::Phase,
        estimate::{NotAtRest, TareState, TARE_REST_VELOCITY},
        sense::{Fault, RawMeasurements},
    },
    JointVec, N_JOINTS,
};
use naic_ros::{
    joints::{finite, JointMap, JointSample, Layout},
    msgs::{self, Float64MultiArray, JointState, PoseStamped, WrenchStamped},
    replay::Replay,
    throttle::Throttle,
    timebase::{TimeBase, FIRST_PAIR_TIMEOUT_NS},
};
use nalgebra::{UnitQuaternion, Vector3, Vector6};

use crate::reference::ScenarioReference;

/// Lockstep: how long a joint state waits for the wrench of its stamp [ns] (wall clock).
/// The wait only costs time when the wrench never comes; giving up too early makes the
/// run depend on the machine's load (a cycle then runs on the previous wrench).
/// Before any wrench has arrived: [`naic_ros::timebase::FIRST_PAIR_TIMEOUT_NS`].
pub const PAIR_TIMEOUT_NS: i64 = 50_000_000;

/// The node's settings besides the controller's own parameters (from the ROS parameters).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// `f_d` [N]: the force set point (part of the reference).
    pub desired_force: f64,
    /// [N], for the report.
    pub force_limit: f64,
    /// With no scenario: free-space target = start tip position moved this far along n [m].
    pub approach_depth: f64,
    pub time: TimeBase,
    /// Wall-clock time base: when the newest `/joint_effort_cmd` answers a joint state
    /// older than this [ns], the torque is not reaching the arm (friction_compensation is
    /// down and the driver holds the arm itself): the force law is in the state of a safe
    /// hold (`ControlState::hold`) until it does again.
    pub actuation_timeout_ns: i64,
    /// The arm's torque interface adds its own gravity compensation (libfranka's, so
    /// franka_ros2's effort interface): the published torque leaves the model's `G(q)` out.
    pub robot_compensates_gravity: bool,
}

/// Everything the step reads and never changes (changed by [`set_params`] only).
#[derive(Clone)]
pub struct Params<const N: usize = N_JOINTS> {
    pub controller: Controller<N>,
    pub settings: Settings,
    /// The scenario's position reference (`None`: the start pose moved along n).
    pub reference: Option<ScenarioReference>,
    /// With no scenario: the reference stage's settings (`/naic/target_pose`,
    /// `/naic/desired_wrench`; built once from the ROS parameters, see `config::reference_params`).
    pub reference_params: ReferenceParams,
    tip: FrameId,
    /// The arm's joint names in joint order (`/joint_states` is read by them).
    pub joints: [String; N],
}

impl<const N: usize> Params<N> {
    pub fn new(
        controller: Controller<N>,
        settings: Settings,
        reference: Option<ScenarioReference>,
        reference_params: ReferenceParams,
        joints: [String; N],
    ) -> Result<Params<N>, ConfigError> {
        let tip = controller.model().frame_id(controller::TIP_FRAME).ok_or_else(|| ConfigError::Model("the URDF has no 'tip' frame".into()))?;
        reference_params.validate()?;
        Ok(Params { controller, settings, reference, reference_params, tip, joints })
    }
}

/// Why `/naic/params` reports a fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultReport {
    /// The sense stage rejected the cycle: safe hold.
    Sensor(Fault),
    /// Above `force_limit` [N]: retracting, then latched off the surface.
    ForceLimit(f64),
    /// No `/joint_effort_cmd` answers the joint states of the last [ms]: the driver holds
    /// the arm, and the force law is in the state of a safe hold.
    NotActuated(f64),
}

impl std::fmt::Display for FaultReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FaultReport::Sensor(x) => x.fmt(f),
            FaultReport::ForceLimit(l) => write!(
                f,
                "force above force_limit ({l} N): retracting, then holding off the surface until ~/reset_force_limit is called"
            ),
            FaultReport::NotActuated(ms) => write!(
                f,
                "no /joint_effort_cmd for {ms:.0} ms (friction_compensation down?): the driver holds the arm; force control restarts in free space (contact re-detected) when commands reach it again"
            ),
        }
    }
}

/// One cycle's report (`/naic/params`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    /// The `/joint_states` stamp it answers [ns].
    pub stamp_ns: i64,
    pub status: Status,
    pub fault: Option<FaultReport>,
    pub reference: ActiveReference,
    /// The F/T bias the tare removes (sensor frame; `None` while a tare is in progress).
    pub wrench_bias: Option<[f64; 6]>,
}

/// The reference this cycle followed (`/naic/params` `reference_*`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActiveReference {
    /// "scenario", "start" (no target accepted yet) or "target_pose".
    pub source: &'static str,
    /// p_d [m], base frame.
    pub position: [f64; 3],
    /// A reference stream went quiet for longer than `reference_timeout`: its last target is held.
    pub stale: bool,
    /// Samples refused on the two reference topics since start.
    pub rejected: u32,
}

/// The answer to one joint state: the torque (when finite) and the report.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Answer<const N: usize> {
    tau: Option<JointVec<N>>,
    friction_velocity: Option<JointVec<N>>,
    report: Report,
}

/// The newest `/wrench`: reading (F, τ) in the sensor frame, stamp and arrival [ns].
#[derive(Clone, Copy, Debug, PartialEq)]
struct WrenchIn {
    w: [f64; 6],
    stamp_ns: i64,
    /// Arrival of the first sample with this stamp: a sensor driver that keeps sending its
    /// last sample (frozen stamp) is stale by the wall clock too.
    rx_ns: i64,
}

/// A joint state waiting for the wrench of its stamp (lockstep).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pending<const N: usize> {
    joints: JointSample<N>,
    until_ns: i64,
}

/// All the node remembers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<const N: usize = N_JOINTS> {
    pub ctl: ControllerState<N>,
    joints: JointMap<N>,
    wrench: Option<WrenchIn>,
    pending: Option<Pending<N>>,
    /// Stamp of the first joint state: controller time 0 [ns].
    t0_ns: Option<i64>,
    /// Tip pose at start (the reference without a scenario).
    start: Option<(Vector3<f64>, UnitQuaternion<f64>)>,
    was_force_limited: bool,
    prev_fault_count: u32,
    /// Newest `/joint_states` stamp a `/joint_effort_cmd` answered [ns] (`None`: none seen;
    /// a chain without friction_compensation, or before its first command).
    actuated_src_ns: Option<i64>,
    /// The last cycle's torque did not reach the arm.
    not_actuated: bool,
    fault_log: Throttle,
    replay: Replay<Answer<N>>,
    /// The reference stage (scenario none), from the first valid joint state on.
    pub reference: Option<ReferenceState>,
    /// Controller time of the last cycle [s]: reference samples are taken at it.
    last_t: f64,
    reference_log: Throttle,
    tare_log: Throttle,
    /// The last cycle's joint velocity and force along n (for `~/zero_wrench`'s checks).
    last_dq: Option<JointVec<N>>,
    last_f_ext: f64,
    /// Controller cycles run (replays not counted).
    pub cycles: u64,
}

impl<const N: usize> State<N> {
    pub fn new(p: &Params<N>) -> State<N> {
        State {
            ctl: p.controller.initial_state(),
            joints: JointMap::default(),
            wrench: None,
            pending: None,
            t0_ns: None,
            start: None,
            was_force_limited: false,
            prev_fault_count: 0,
            actuated_src_ns: None,
            not_actuated: false,
            fault_log: Throttle::default(),
            replay: Replay::default(),
            reference: None,
            last_t: 0.0,
            reference_log: Throttle::default(),
            tare_log: Throttle::default(),
            last_dq: None,
            last_f_ext: 0.0,
            cycles: 0,
        }
    }
}

/// The messages of one step (any may be absent). A new input topic is a new field.
#[derive(Clone, Copy, Debug, Default)]
pub struct Inbox<'a> {
    pub joint_states: Option<&'a JointState>,
    pub wrench: Option<&'a WrenchStamped>,
    /// `/naic/target_pose` (scenario none).
    pub target_pose: Option<&'a PoseStamped>,
    /// `/naic/desired_wrench` (scenario none).
    pub desired_wrench: Option<&'a WrenchStamped>,
    /// `/joint_effort_cmd`: the torque friction_compensation sent the driver; its source
    /// stamp says which joint state it answers (actuation supervision).
    pub actuated: Option<&'a Float64MultiArray>,
    /// A call of `~/reset_force_limit` (`std_srvs/srv/Trigger`): the operator acknowledges
    /// an over-force event. The only way a force-limit retraction ends (a parameter set
    /// never ends it: `naic_core::pipeline::param_change`).
    pub reset_force_limit: bool,
    /// A call of `~/zero_wrench` (`std_srvs/srv/Trigger`): re-tare the F/T sensor from the
    /// next `tare_samples` readings at rest; refused in contact, while moving, during a
    /// force-limit retraction, a fault or a tare.
    pub zero_wrench: bool,
}

/// The core's answer to a `std_srvs/srv/Trigger` call: success and the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriggerAnswer {
    pub success: bool,
    pub message: &'static str,
}

/// `~/reset_force_limit` done: the retraction ended.
pub const FORCE_LIMIT_RESET: &str =
    "force limit reset: force control resumes in free space (contact is re-detected; the learned weights are kept)";
/// `~/zero_wrench` accepted.
pub const ZERO_WRENCH_STARTED: &str = "re-taring from the next tare_samples readings at rest (the arm is held meanwhile; force control resumes after it); the new bias is in /naic/params wrench_bias and the log";
/// `~/zero_wrench` refusals (nothing changes).
pub const ZERO_REFUSED_NO_CYCLE: &str = "refused: no control cycle yet (no /joint_states and /wrench received)";
pub const ZERO_REFUSED_TARING: &str = "refused: a tare is in progress already (wrench_bias is empty until it is done)";
pub const ZERO_REFUSED_FAULT: &str = "refused: holding on a sensor fault (see /naic/params fault); zero when the data is valid again";
pub const ZERO_REFUSED_RETRACTING: &str = "refused: force-limit retraction in progress or latched; call ~/reset_force_limit first";
pub const ZERO_REFUSED_CONTACT: &str =
    "refused: in contact (or a measured force above the contact threshold): lift the tool off the surface, then zero; force control continues unchanged";
pub const ZERO_REFUSED_MOVING: &str =
    "refused: the arm moves (a joint faster than 0.02 rad/s, the tare's rest bound); zero when it is at rest";

/// `~/reset_force_limit` without a force-limit retraction: nothing changed.
pub const NO_FORCE_LIMIT_TO_RESET: &str =
    "refused: no force-limit retraction is in progress or latched (nothing to reset; the controller is unchanged)";

/// Things for the shell to log (each at most once per step).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Events {
    /// `/joint_states` lacks the arm's joint of this index ([`Params::joints`]): the
    /// controller holds.
    pub missing_joint: Option<usize>,
    /// The start tip position was taken [m].
    pub start_tip: Option<[f64; 3]>,
    /// The force limit was just exceeded: measured force [N].
    pub force_limited: Option<f64>,
    /// Holding on a fault (a new fault event, or once per second): fault, events so far.
    pub fault: Option<(Fault, u32)>,
    /// The controller produced a non-finite torque: not published.
    pub non_finite_torque: bool,
    /// The torque stopped reaching the arm, or reaches it again.
    pub actuation: Option<Actuation>,
    /// A `/naic/target_pose` sample was refused (rate-limited): why, refusals so far.
    pub target_rejected: Option<(Rejection, u32)>,
    /// A `/naic/desired_wrench` sample was refused (rate-limited): why, refusals so far.
    pub wrench_rejected: Option<(Rejection, u32)>,
    /// A reference sample came before the first joint state (no start pose yet): ignored.
    pub reference_too_early: bool,
    /// The tare waits for rest (rate-limited): why its window last started again, restarts so far.
    pub tare_waiting: Option<(NotAtRest, u32)>,
    /// The tare is done: the sensor bias (force [N], torque [N·m], sensor frame).
    pub tared: Option<[f64; 6]>,
}

/// A change of the actuation supervision (logged once per change).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Actuation {
    /// No `/joint_effort_cmd` answered the joint states of this long [ms]: held.
    Lost(f64),
    /// Commands reach the arm again: force control restarts from the hold.
    Restored,
}

/// What one step produces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outbox<const N: usize = N_JOINTS> {
    /// `/naic/effort`: torque and the `/joint_states` stamp it answers.
    pub effort: Option<(JointVec<N>, i64)>,
    /// With the effort, the joint velocity the friction node is to evaluate its
    /// feedforward at (`ControlOutputs::dq_ff`: the scheduled law's); `None`: the measured one.
    pub friction_velocity: Option<JointVec<N>>,
    /// `/naic/params`.
    pub report: Option<Report>,
    /// The answer to [`Inbox::reset_force_limit`].
    pub reset_force_limit: Option<TriggerAnswer>,
    /// The answer to [`Inbox::zero_wrench`].
    pub zero_wrench: Option<TriggerAnswer>,
    /// Lockstep: a joint state waits for the wrench of its stamp; step again with each
    /// `/wrench` sample until this wall time [ns], then with an empty inbox.
    pub wait_until_ns: Option<i64>,
    pub events: Events,
}

/// One step at wall time `now_ns`; `ws` is scratch memory only.
pub fn step<const N: usize>(p: &Params<N>, s: &State<N>, inbox: &Inbox, now_ns: i64, ws: &mut Workspace<N>) -> (State<N>, Outbox<N>) {
    let mut s = *s;
    let mut out = Outbox::default();
    if let Some(w) = inbox.wrench {
        let (f, t) = (&w.wrench.force, &w.wrench.torque);
        let stamp_ns = w.header.stamp.to_nanos();
        let rx_ns = match s.wrench {
            Some(prev) if prev.stamp_ns == stamp_ns => prev.rx_ns,
            _ => now_ns,
        };
        s.wrench = Some(WrenchIn { w: [f.x, f.y, f.z, t.x, t.y, t.z], stamp_ns, rx_ns });
    }
    if inbox.reset_force_limit {
        out.reset_force_limit = Some(match param_change::reset_force_limit(&s.ctl) {
            Some(ctl) => {
                s.ctl = ctl;
                s.was_force_limited = false;
                TriggerAnswer { success: true, message: FORCE_LIMIT_RESET }
            }
            None => TriggerAnswer { success: false, message: NO_FORCE_LIMIT_TO_RESET },
        });
    }
    if inbox.zero_wrench {
        out.zero_wrench = Some(zero_wrench(p, &mut s));
    }
    if let Some(src) = inbox.actuated.and_then(msgs::effort_source_stamp) {
        s.actuated_src_ns = Some(s.actuated_src_ns.map_or(src, |a| a.max(src)));
    }
    if inbox.target_pose.is_some() || inbox.desired_wrench.is_some() {
        take_reference_samples(p, &mut s, inbox, now_ns, &mut out, ws);
    }
    if let Some(js) = inbox.joint_states {
        let stamp = js.header.stamp.to_nanos();
        if let Some(a) = s.replay.get(stamp) {
            // A repeated stamp: the same command, and in simulated time the same report
            // (a paused or waiting driver keeps /naic/params alive for late subscribers).
            out.effort = a.tau.map(|t| (t, stamp));
            out.friction_velocity = a.friction_velocity;
            out.report = p.settings.time.is_sim().then_some(a.report);
            s.pending = None;
            return (s, out);
        }
        let (joints, layout) = s.joints.sample_named(js, &p.joints);
        if let Layout::Missing(i) = layout {
            out.events.missing_joint = Some(i);
        }
        let wait = if s.wrench.is_some() { PAIR_TIMEOUT_NS } else { FIRST_PAIR_TIMEOUT_NS };
        // (In wall-clock time nothing waits: see below.)
        s.pending = Some(Pending { joints, until_ns: now_ns.saturating_add(wait) });
    }
    let Some(pd) = s.pending else { return (s, out) };
    let js_stamp = pd.joints.stamp_ns;
    if p.settings.time.is_sim() && s.wrench.is_none_or(|w| w.stamp_ns < js_stamp) && now_ns < pd.until_ns {
        // Simulated time: the driver publishes the wrench of a state just before its
        // joint states; take that one (not the previous one) so the loop is deterministic.
        out.wait_until_ns = Some(pd.until_ns);
        return (s, out);
    }
    s.pending = None;
    cycle(p, &mut s, &pd.joints, now_ns, ws, &mut out);
    (s, out)
}

/// `~/zero_wrench`: start a new tare when the arm is in free space and at rest, else refuse.
fn zero_wrench<const N: usize>(p: &Params<N>, s: &mut State<N>) -> TriggerAnswer {
    let refuse = |message| TriggerAnswer { success: false, message };
    let ctl = &s.ctl;
    let cp = p.controller.params();
    let Some(dq) = s.last_dq.filter(|_| s.cycles > 0) else { return refuse(ZERO_REFUSED_NO_CYCLE) };
    if !ctl.tare.done(cp.tare_samples) {
        return refuse(ZERO_REFUSED_TARING);
    }
    if ctl.fault.is_some() || ctl.control.phase == Phase::Hold {
        return refuse(ZERO_REFUSED_FAULT);
    }
    if ctl.control.retracting() {
        return refuse(ZERO_REFUSED_RETRACTING);
    }
    // Contact as the law detects it: its enter threshold (a drifted bias below it is what
    // zeroing is for).
    let threshold = naic_core::pipeline::control::law::contact_threshold(&cp.control);
    if ctl.control.phase == Phase::Contact || !(s.last_f_ext.abs() <= threshold) {
        return refuse(ZERO_REFUSED_CONTACT);
    }
    if dq.iter().any(|v| !(v.abs() <= TARE_REST_VELOCITY)) {
        return refuse(ZERO_REFUSED_MOVING);
    }
    s.ctl.tare = TareState::default();
    TriggerAnswer { success: true, message: ZERO_WRENCH_STARTED }
}

/// One controller cycle on the joint state `j`.
fn cycle<const N: usize>(p: &Params<N>, s: &mut State<N>, j: &JointSample<N>, now_ns: i64, ws: &mut Workspace<N>, out: &mut Outbox<N>) {
    let time = p.settings.time;
    let t0 = *s.t0_ns.get_or_insert(j.stamp_ns);
    let sec = |ns: i64| (ns - t0) as f64 * 1e-9;
    // Time base: simulated stamps with use_sim_time, else the wall clock (the clocks of
    // other hosts may differ: staleness by arrival).
    let t = sec(time.at(j.stamp_ns, now_ns));
    let m = RawMeasurements {
        t,
        q: j.q,
        dq: j.dq,
        joints_stamp: t,
        wrench: s.wrench.map_or([f64::NAN; 6], |w| w.w),
        wrench_stamp: s.wrench.map_or(f64::NEG_INFINITY, |w| sec(time.at(w.stamp_ns, w.rx_ns))),
    };
    // Reference: hold the start orientation; the free-space target is the start position
    // moved `approach_depth` along n (above force_limit the core backs off from it).
    let model = p.controller.model();
    if s.start.is_none() && finite(&j.q).is_some() {
        dynamics::forward_kinematics(model, &mut ws.data, &nalgebra::SVector::<f64, N>::from(j.q));
        let pose = ws.data.frame_se3(p.tip);
        s.start = Some((pose.trans, UnitQuaternion::from_matrix(&pose.rot)));
        out.events.start_tip = Some([pose.trans.x, pose.trans.y, pose.trans.z]);
    }
    let (p0, r0) = s.start.unwrap_or((Vector3::zeros(), UnitQuaternion::identity()));
    let n = p.controller.params().control.force_axis.n;
    let f_d = p.settings.desired_force;
    let (reference, active) = match &p.reference {
        // The scenario's trajectory; the force set point is the parameter.
        Some(sr) => {
            let r = Reference { f_d, ..sr.at(m.t) };
            (r, ActiveReference { source: "scenario", position: r.p_d.into(), stale: false, rejected: 0 })
        }
        // The real-robot setting: the reference stage, from the start pose towards the
        // free-space target (start moved `approach_depth` along n) until a target arrives.
        None => {
            let rs = match s.reference {
                Some(rs) => Some(rs),
                None if s.start.is_some() => Some(ReferenceState::new(p0, r0, (p0 + n * p.settings.approach_depth, r0))),
                None => None,
            };
            match rs {
                Some(rs) => {
                    let (next, o) = refstage::step(&p.reference_params, &rs, &refstage::Inbox::default(), m.t);
                    s.reference = Some(next);
                    let rep = &o.report;
                    let source = if rep.pose_source == Source::Topic { "target_pose" } else { "start" };
                    let active = ActiveReference {
                        source,
                        position: o.reference.p_d.into(),
                        stale: rep.target_stale || rep.wrench_stale,
                        rejected: rep.rejected_targets.saturating_add(rep.rejected_wrenches),
                    };
                    (o.reference, active)
                }
                // No valid joint state yet: the sense stage holds anyway.
                None => (
                    Reference { p_d: p0, r_d: r0, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d },
                    ActiveReference { source: "start", position: p0.into(), stale: false, rejected: 0 },
                ),
            }
        }
    };
    s.last_t = m.t;
    // Actuation supervision (wall clock only: in lockstep the driver cannot step without a
    // command, and a slow DDS reader must not change a deterministic run).
    let lag_ns = s.actuated_src_ns.filter(|_| !time.is_sim()).map(|a| j.stamp_ns.saturating_sub(a));
    let not_actuated = lag_ns.is_some_and(|l| l > p.settings.actuation_timeout_ns);
    let tare_samples = p.controller.params().tare_samples;
    let was_tared = s.ctl.tare.done(tare_samples);
    let o = controller::update(&p.controller, &mut s.ctl, &m, &reference, ws);
    if not_actuated {
        // The torque does not reach the arm: the force error says nothing about the law, and
        // a law that went on adapting against the driver's hold (NAIC: m_d to its floor, σ
        // past the eq-9 bound) shook the arm when commands came back. The driver holds the
        // arm, so the law is where the controller's own safe hold leaves it: configured
        // weights, free space next, contact re-detected.
        s.ctl.control = s.ctl.control.hold(&p.controller.params().control);
    }
    if not_actuated != s.not_actuated {
        out.events.actuation = Some(if not_actuated { Actuation::Lost(lag_ns.unwrap_or(0) as f64 * 1e-6) } else { Actuation::Restored });
    }
    s.not_actuated = not_actuated;
    if !was_tared {
        if s.ctl.tare.done(tare_samples) {
            out.events.tared = Some(s.ctl.tare.bias());
        } else if let Some(why) = s.ctl.tare.not_at_rest.filter(|_| s.ctl.tare.restarts > 0) {
            if s.tare_log.ready(now_ns) {
                out.events.tare_waiting = Some((why, s.ctl.tare.restarts));
            }
        }
    }
    s.cycles += 1;
    let st = o.status;
    s.last_dq = Some(o.dq);
    s.last_f_ext = if st.f_ext.is_finite() { st.f_ext } else { 0.0 };
    if st.force_limited && !s.was_force_limited {
        out.events.force_limited = Some(st.f_ext);
    }
    s.was_force_limited = st.force_limited;
    if let Some(f) = st.fault {
        if st.fault_count != s.prev_fault_count {
            s.fault_log.reset();
        }
        if s.fault_log.ready(now_ns) {
            out.events.fault = Some((f, st.fault_count));
        }
    }
    s.prev_fault_count = st.fault_count;
    // A torque interface that compensates gravity itself gets the torque without G(q) (the
    // measured q of this cycle; the hold's own G(q) too: every published torque is the same
    // law minus the robot's part).
    let mut tau = o.tau;
    if p.settings.robot_compensates_gravity {
        if let Some(q) = finite(&j.q) {
            let g = dynamics::gravity_torques(p.controller.model(), &mut ws.data, &nalgebra::SVector::<f64, N>::from(q));
            for (t, gi) in tau.iter_mut().zip(g.iter()) {
                *t -= gi;
            }
        }
    }
    // Never publish a non-finite torque: skip the cycle (the driver holds after 20 ms).
    let tau = finite(&tau);
    out.effort = tau.map(|t| (t, j.stamp_ns));
    out.friction_velocity = o.dq_ff.filter(|_| tau.is_some());
    out.events.non_finite_torque = tau.is_none();
    let fault = match (st.fault, st.force_limited) {
        (Some(f), _) => Some(FaultReport::Sensor(f)),
        (None, true) => Some(FaultReport::ForceLimit(p.settings.force_limit)),
        (None, false) => lag_ns.filter(|_| not_actuated).map(|l| FaultReport::NotActuated(l as f64 * 1e-6)),
    };
    let wrench_bias = s.ctl.tare.done(tare_samples).then(|| s.ctl.tare.bias());
    let report = Report { stamp_ns: j.stamp_ns, status: st, fault, reference: active, wrench_bias };
    s.replay.store(j.stamp_ns, Answer { tau, friction_velocity: out.friction_velocity, report });
    out.report = Some(report);
}

/// Where a reference sample's `header.frame_id` is, resolved against the robot model
/// (issue 39 item 3): the base frame (its name or empty), another frame of the model (its
/// pose in the base frame at the last measured joint position), or not a frame of the model
/// (the stage then refuses the sample as [`Rejection::Frame`]; the shell names the frames
/// that exist). Allocation-free.
enum SampleFrame {
    Base,
    Model(nalgebra::Isometry3<f64>),
    Unknown,
}

fn resolve_frame<const N: usize>(p: &Params<N>, s: &State<N>, frame_id: &str, ws: &mut Workspace<N>) -> SampleFrame {
    if frame_id.is_empty() || frame_id == p.reference_params.base_frame {
        return SampleFrame::Base;
    }
    let model = p.controller.model();
    match (model.frame_id(frame_id), s.ctl.last_q) {
        (Some(id), Some(q)) => {
            dynamics::forward_kinematics(model, &mut ws.data, &nalgebra::SVector::<f64, N>::from(q));
            SampleFrame::Model(ws.data.frame_placement(id))
        }
        _ => SampleFrame::Unknown,
    }
}

/// The reference topics' samples into the reference stage, at the last cycle's controller
/// time (the next cycle moves the reference). A sample in another frame of the model is
/// expressed in the base frame first (pose: `ᵇT_f · pose`; wrench: force and torque rotated
/// by `ᵇR_f`), with the model's kinematics at the last measured joint position, so the stage
/// forms the reference in the base frame as before. Refusals are counted by the stage and
/// reported here rate-limited.
fn take_reference_samples<const N: usize>(p: &Params<N>, s: &mut State<N>, inbox: &Inbox, now_ns: i64, out: &mut Outbox<N>, ws: &mut Workspace<N>) {
    if p.reference.is_some() {
        return; // a scenario's trajectory: the shell does not subscribe the topics
    }
    let Some(rs) = s.reference else {
        if s.reference_log.ready(now_ns) {
            out.events.reference_too_early = true;
        }
        return;
    };
    let base = p.reference_params.base_frame.as_str();
    let secs = |h: &naic_ros::msgs::Header| h.stamp.to_nanos() as f64 * 1e-9;
    let target = inbox.target_pose.map(|m| {
        let (x, o) = (&m.pose.position, &m.pose.orientation);
        let (position, orientation) = ([x.x, x.y, x.z], [o.x, o.y, o.z, o.w]);
        let sample = |frame_id, position, orientation| TargetPose { frame_id, stamp: secs(&m.header), position, orientation };
        match resolve_frame(p, s, &m.header.frame_id, ws) {
            SampleFrame::Base => sample(base, position, orientation),
            SampleFrame::Unknown => sample(&m.header.frame_id, position, orientation),
            SampleFrame::Model(t) => {
                // A non-unit quaternion is left for the stage to refuse (its norm kept).
                let q = nalgebra::Quaternion::new(o.w, o.x, o.y, o.z);
                let qb = t.rotation.quaternion() * q;
                let pb = t * nalgebra::Point3::new(x.x, x.y, x.z);
                sample(base, [pb.x, pb.y, pb.z], [qb.i, qb.j, qb.k, qb.w])
            }
        }
    });
    let wrench = inbox.desired_wrench.map(|m| {
        let (f, t) = (&m.wrench.force, &m.wrench.torque);
        let (force, torque) = ([f.x, f.y, f.z], [t.x, t.y, t.z]);
        let sample = |frame_id, force, torque| DesiredWrench { frame_id, stamp: secs(&m.header), force, torque };
        // The base-frame force goes to the stage, which takes its component along today's
        // force axis (±x/y/z of the base frame). When the force axis becomes any unit vector
        // (naic_core pipeline/control/, the force-law work), it plugs in here unchanged:
        // the stage's `ReferenceParams::n()` is the only place the axis is read.
        match resolve_frame(p, s, &m.header.frame_id, ws) {
            SampleFrame::Base => sample(base, force, torque),
            SampleFrame::Unknown => sample(&m.header.frame_id, force, torque),
            SampleFrame::Model(tf) => {
                let r = tf.rotation;
                let (fb, tb) = (r * Vector3::from(force), r * Vector3::from(torque));
                sample(base, fb.into(), tb.into())
            }
        }
    });
    let (next, o) = refstage::step(&p.reference_params, &rs, &refstage::Inbox { target, wrench }, s.last_t);
    s.reference = Some(next);
    let r = &o.report;
    let (tr, wr) = (r.target, r.wrench);
    if (matches!(tr, Verdict::Rejected(_)) || matches!(wr, Verdict::Rejected(_))) && s.reference_log.ready(now_ns) {
        if let Verdict::Rejected(e) = tr {
            out.events.target_rejected = Some((e, r.rejected_targets));
        }
        if let Verdict::Rejected(e) = wr {
            out.events.wrench_rejected = Some((e, r.rejected_wrenches));
        }
    }
}

/// Accepted parameters → the running node: the settings apply at once, the controller's
/// parameters by the core's policy (`naic_core::pipeline::param_change`: the NAIC weights
/// restart when the force law or impedance changed; a force-limit retraction is kept: only
/// [`Inbox::reset_force_limit`] ends it).
/// `Err`: the core refused `cp`; the settings still apply, the controller is unchanged.
pub fn set_params<const N: usize>(
    p: &mut Params<N>,
    s: &mut State<N>,
    cp: ControllerParams<N>,
    settings: Settings,
    mut reference_params: ReferenceParams,
) -> Result<param_change::Outcome, ConfigError> {
    // One force set point: the `desired_force` setting is the stage's default force.
    reference_params.default_force = settings.desired_force;
    reference_params.validate()?;
    p.settings = settings;
    p.reference_params = reference_params;
    let (c, ctl, outcome) = param_change::apply(&p.controller, &s.ctl, cp)?;
    p.controller = c;
    s.ctl = ctl;
    Ok(outcome)
}

#[cfg(test)]
mod tests;
