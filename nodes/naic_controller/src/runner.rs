//! The controller node's loop body, whatever carries the messages: the DDS shell
//! (`main.rs`) and `naic launch --composed` hand it the messages they received and publish
//! what it leaves in its buffers.
//!
//! [`Runner`] owns the core's parameters, state and workspace and the outgoing messages
//! (filled in place). Per wake-up the shell calls [`Runner::reload`] (accepted parameter
//! values apply to the data that woke it), [`Runner::wrench`] for each wrench,
//! [`Runner::reference`] for the newest reference samples and [`Runner::joint_states`]
//! for the newest joint state. The core's events are logged here, rate-limited by the core.

use std::fmt::Write;

use naic_core::pipeline::controller::{ControllerParams, Workspace};
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState, NaicParams, PoseStamped, WrenchStamped},
    node::QOS_SUB,
    time::{time_from_ns, wall_ns},
    source::SourceGate,
    wait::take_newest_admitted,
    ParamTable, RosError, RosNode,
};

use crate::{
    config, core,
    setup::{Setup, NODE},
};

/// The node between two wake-ups (an arm of `N` joints).
pub struct Runner<const N: usize = { naic_core::N_JOINTS }> {
    pub p: core::Params<N>,
    pub s: core::State<N>,
    ws: Workspace<N>,
    base: ControllerParams<N>,
    /// Generation of the parameter table last applied.
    gen: u64,
    effort: msgs::EffortBuffer,
    report: NaicParams,
    warned: bool,
}

/// What a joint-state cycle leaves to publish (the runner's buffers).
pub struct Published<'a> {
    pub effort: Option<&'a Float64MultiArray>,
    pub report: Option<&'a NaicParams>,
}

impl<const N: usize> Runner<N> {
    /// From the node's setup; `params` is the node's parameter table as it starts.
    pub fn new(setup: Setup<N>, params: &ParamTable) -> Runner<N> {
        let s = core::State::new(&setup.params);
        let ws = setup.params.controller.workspace();
        Runner {
            p: setup.params,
            s,
            ws,
            base: setup.base,
            gen: params.generation(),
            effort: msgs::EffortBuffer::new(N),
            report: NaicParams::default(),
            warned: false,
        }
    }

    /// Take the node's parameters when a set was accepted since the last call (the core's
    /// parameter-change policy, `core::set_params`).
    pub fn reload(&mut self, params: &ParamTable) {
        if params.generation() == self.gen {
            return;
        }
        self.gen = params.generation();
        let base = &self.base;
        let (cp, settings, rp) = params.with(|v| (config::controller_params(v, base), config::settings(v), config::reference_params(v)));
        if let Ok(cp) = &cp {
            if let Some(line) = naic_core::pipeline::control::law::approach_report(&cp.control, settings.desired_force) {
                log::info!("{line}");
            }
        }
        match cp.and_then(|cp| Ok(core::set_params(&mut self.p, &mut self.s, cp, settings, rp)?)) {
            Ok(_) if self.s.ctl.control.retracting() => log::warn!(
                "parameters changed; the force-limit retraction stays until ~/reset_force_limit is called (std_srvs/srv/Trigger)"
            ),
            Ok(_) => {}
            Err(e) => log::error!("parameters not applied: {e}"),
        }
    }

    fn step(&mut self, inbox: core::Inbox, now_ns: i64) -> core::Outbox<N> {
        let (p, s, ws) = (&self.p, &self.s, &mut self.ws);
        let (next, out) = alloc_check::check(NODE, &mut self.warned, || core::step(p, s, &inbox, now_ns, ws));
        self.s = next;
        out
    }

    /// A call of `~/reset_force_limit`: the core's answer (logged here).
    pub fn reset_force_limit(&mut self) -> core::TriggerAnswer {
        let out = self.step(core::Inbox { reset_force_limit: true, ..Default::default() }, wall_ns());
        logged("~/reset_force_limit", out.reset_force_limit)
    }

    /// A call of `~/zero_wrench`: the core's answer (logged here).
    pub fn zero_wrench(&mut self) -> core::TriggerAnswer {
        let out = self.step(core::Inbox { zero_wrench: true, ..Default::default() }, wall_ns());
        logged("~/zero_wrench", out.zero_wrench)
    }

    /// A `/joint_effort_cmd` sample: which joint state the torque reaching the arm answers.
    pub fn actuated(&mut self, m: &Float64MultiArray) {
        self.step(core::Inbox { actuated: Some(m), ..Default::default() }, wall_ns());
    }

    /// A `/wrench` sample (the newest one is used by the next cycle).
    pub fn wrench(&mut self, w: &WrenchStamped) {
        self.step(core::Inbox { wrench: Some(w), ..Default::default() }, wall_ns());
    }

    /// The newest `/naic/target_pose` and `/naic/desired_wrench` samples (scenario `none`).
    pub fn reference(&mut self, tp: Option<&PoseStamped>, dw: Option<&WrenchStamped>) {
        if tp.is_some() || dw.is_some() {
            let out = self.step(core::Inbox { target_pose: tp, desired_wrench: dw, ..Default::default() }, wall_ns());
            log_reference_events(&out.events, tp, dw, &self.p.reference_params.base_frame, self.p.controller.model());
        }
    }

    /// One cycle on a `/joint_states` sample. In lockstep its wrench may still be on the
    /// way: `paired_wrench(until_ns)` is then asked for it (wait for it until that wall
    /// time; `None`: it did not come, and the core gives the pairing up).
    pub fn joint_states(&mut self, js: &JointState, mut paired_wrench: impl FnMut(i64) -> Option<WrenchStamped>) -> Published<'_> {
        let mut out = self.step(core::Inbox { joint_states: Some(js), ..Default::default() }, wall_ns());
        while let Some(until) = out.wait_until_ns {
            let w = paired_wrench(until);
            let now = if w.is_some() { wall_ns() } else { wall_ns().max(until) };
            out = self.step(core::Inbox { wrench: w.as_ref(), ..Default::default() }, now);
        }
        log_events(&out.events, self.p.settings.force_limit, &self.p.joints);
        if let Some((tau, stamp)) = out.effort {
            self.effort.set(&tau, Some(stamp), out.friction_velocity.as_ref().map(|v| &v[..]));
        }
        if let Some(r) = &out.report {
            fill_report(&mut self.report, r, &self.p.reference_params.base_frame);
        }
        Published { effort: out.effort.map(|_| &self.effort.msg), report: out.report.map(|_| &self.report) }
    }
}

/// The reference topics' subscriptions (`/naic/target_pose`, `/naic/desired_wrench`):
/// the real-robot setting (`scenario: none`) only. The node process and `naic launch
/// --composed` both feed the controller through this.
pub struct ReferenceSubs {
    target_pose: ros2_client::Subscription<PoseStamped>,
    desired_wrench: ros2_client::Subscription<WrenchStamped>,
    /// `reference_source`: who may publish each (default: any writer, warned about when two
    /// write).
    gates: std::cell::RefCell<(SourceGate, SourceGate)>,
}

impl ReferenceSubs {
    /// Subscribe on `node` when `r` follows the reference topics (`scenario: none`);
    /// `None` (and a log line saying so) when it follows a scenario.
    pub fn new<const N: usize>(node: &mut RosNode, r: &Runner<N>) -> Result<Option<ReferenceSubs>, RosError> {
        if r.p.reference.is_some() {
            log::info!("following the scenario's reference: /naic/target_pose and /naic/desired_wrench are not subscribed (scenario:=none follows them)");
            return Ok(None);
        }
        let source = node.params.with(|p| p.str("reference_source").to_string());
        // A new writer of the source node is taken at once (gap 0): a reference is kept
        // until the next one, so there is no stream to interleave with.
        let gate = |topic| SourceGate::in_context(&node.context, topic, "reference_source", &source, 0);
        let gates = std::cell::RefCell::new((gate("/naic/target_pose")?, gate("/naic/desired_wrench")?));
        Ok(Some(ReferenceSubs {
            target_pose: node.subscription::<PoseStamped>("naic/target_pose", msgs::POSE_STAMPED, QOS_SUB)?,
            desired_wrench: node.subscription::<WrenchStamped>("naic/desired_wrench", msgs::WRENCH_STAMPED, QOS_SUB)?,
            gates,
        }))
    }

    /// The newest sample of each topic into [`Runner::reference`] (the stage keeps only the
    /// last target).
    pub fn feed<const N: usize>(&self, r: &mut Runner<N>) {
        let mut g = self.gates.borrow_mut();
        let now = naic_ros::time::wall_ns();
        let tp = take_newest_admitted(&self.target_pose, |i| g.0.admit(i.publisher_gid(), now));
        let dw = take_newest_admitted(&self.desired_wrench, |i| g.1.admit(i.publisher_gid(), now));
        r.reference(tp.as_ref(), dw.as_ref());
    }
}

/// The controller's `std_srvs/srv/Trigger` services (`~/reset_force_limit`), served from
/// the loop of the node process and of `naic launch --composed` alike.
pub struct Services {
    reset_force_limit: naic_ros::service::TriggerServer,
    zero_wrench: naic_ros::service::TriggerServer,
}

impl Services {
    pub fn new(node: &mut RosNode) -> Result<Services, RosError> {
        Ok(Services {
            reset_force_limit: naic_ros::service::TriggerServer::new(node, "reset_force_limit")?,
            zero_wrench: naic_ros::service::TriggerServer::new(node, "zero_wrench")?,
        })
    }

    /// Answer the waiting calls through the core ([`Runner::reset_force_limit`]) and send
    /// the answers their clients can receive.
    pub fn serve<const N: usize>(&mut self, r: &mut Runner<N>, node: &RosNode) {
        while let Some(id) = self.reset_force_limit.take() {
            let a = r.reset_force_limit();
            self.reset_force_limit.answer(id, a.success, a.message);
        }
        self.reset_force_limit.flush(node);
        while let Some(id) = self.zero_wrench.take() {
            let a = r.zero_wrench();
            self.zero_wrench.answer(id, a.success, a.message);
        }
        self.zero_wrench.flush(node);
    }
}

pub fn log_events(e: &core::Events, force_limit: f64, joints: &[String]) {
    if let Some(j) = e.missing_joint {
        log::error!("/joint_states has no '{}' (joint {} of the arm's joints {joints:?}); holding", joints[j], j + 1);
    }
    if let Some(p) = e.start_tip {
        log::info!("start tip position {p:?}");
    }
    if let Some((why, n)) = e.tare_waiting {
        log::warn!("F/T tare waits for the arm to rest (held meanwhile): {why} (window restarted {n} times)");
    }
    if let Some(b) = e.tared {
        log::info!(
            "F/T tare done at rest: bias force [{:.3}, {:.3}, {:.3}] N, torque [{:.4}, {:.4}, {:.4}] N m (sensor frame)",
            b[0], b[1], b[2], b[3], b[4], b[5]
        );
    }
    if let Some(f) = e.force_limited {
        log::warn!(
            "measured force {f:.1} N above force_limit {force_limit} N: retracting, then holding off the surface (call ~/reset_force_limit, std_srvs/srv/Trigger, to resume)"
        );
    }
    if let Some((f, n)) = e.fault {
        log::warn!("holding: {f} (faults so far: {n})");
    }
    if e.non_finite_torque {
        log::error!("controller produced a non-finite torque; not published");
    }
    match e.actuation {
        Some(core::Actuation::Lost(ms)) => log::warn!(
            "no /joint_effort_cmd answering the joint states for {ms:.0} ms (friction_compensation down?): the driver holds the arm; force control restarts in free space when commands reach it again"
        ),
        Some(core::Actuation::Restored) => log::info!("/joint_effort_cmd answers the joint states again: force control restarts in free space (contact re-detected)"),
        None => {}
    }
}

pub fn log_reference_events(e: &core::Events, tp: Option<&PoseStamped>, dw: Option<&WrenchStamped>, base: &str, model: &naic_core::model::Model) {
    if e.reference_too_early {
        log::warn!("reference sample before the first /joint_states (no start pose yet): ignored");
    }
    // An unknown frame: name the frames that exist (rate-limited with the refusal).
    let frames = |r: &naic_core::pipeline::reference::Rejection| {
        if *r == naic_core::pipeline::reference::Rejection::Frame {
            let names: Vec<&str> = model.frames().iter().map(|f| f.name.as_str()).collect();
            format!("; the frames of the model: {}", names.join(", "))
        } else {
            String::new()
        }
    };
    if let (Some((r, n)), Some(m)) = (e.target_rejected, tp) {
        log::warn!("/naic/target_pose (frame '{}'; base frame '{base}') refused: {r} ({n} refused so far){}", m.header.frame_id, frames(&r));
    }
    if let (Some((r, n)), Some(m)) = (e.wrench_rejected, dw) {
        log::warn!("/naic/desired_wrench (frame '{}'; base frame '{base}') refused: {r} ({n} refused so far){}", m.header.frame_id, frames(&r));
    }
}

/// `/naic/params` from the core's report, in place (the strings keep their capacity).
/// `header.frame_id` is the base frame (`base_frame`): the frame of `reference_position`
/// and of the force axis.
pub fn fill_report(m: &mut NaicParams, r: &core::Report, base_frame: &str) {
    let st = &r.status;
    m.header.stamp = time_from_ns(r.stamp_ns);
    if m.header.frame_id != base_frame {
        m.header.frame_id.clear();
        m.header.frame_id.push_str(base_frame);
    }
    m.mode.clear();
    m.mode.push_str(st.mode.as_str());
    m.phase = st.phase as u8;
    m.force_axis = st.force_axis as u8;
    (m.desired_force, m.measured_force, m.e_f) = (st.f_d, st.f_ext, st.e_f);
    (m.m_d, m.b_d, m.k_d, m.sigma, m.phi) = (st.m_d, st.b_d, st.k_d, st.sigma, st.phi);
    (m.gamma, m.gamma_bound, m.gamma_clipped) = (st.gamma, st.gamma_bound, st.gamma_clipped);
    m.fault.clear();
    if let Some(f) = &r.fault {
        let _ = write!(m.fault, "{f}");
    }
    m.fault_count = st.fault_count;
    let a = &r.reference;
    m.reference_source.clear();
    m.reference_source.push_str(a.source);
    m.reference_position.clear();
    m.reference_position.extend_from_slice(&a.position);
    (m.reference_stale, m.reference_rejected) = (a.stale, a.rejected);
    (m.k_e_hat, m.k_e_confidence, m.model_gain, m.gravity_scale) = (st.k_e_hat, st.k_e_confidence, st.model_gain, st.gravity_scale);
    m.wrench_bias.clear();
    if let Some(b) = &r.wrench_bias {
        m.wrench_bias.extend_from_slice(b);
    }
}

#[cfg(test)]
mod tests {
    use naic_ros::{
        msgs::{effort_source_stamp, Header, JOINT_NAMES},
        ParameterValue, RosArgs,
    };

    use super::*;

    /// The runner on the repository's JK5 model, with `-p` overrides `extra`, and the node's
    /// parameter table as `RosNode` would build it.
    fn runner(extra: &[&str]) -> (Runner, ParamTable) {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let files = [format!("urdf:={root}/urdf/jk5.urdf"), format!("friction_file:={root}/params/friction_jk5.yaml")];
        let args = RosArgs::with_params(files.into_iter().chain(extra.iter().map(|e| e.to_string()))).unwrap();
        let setup = Setup::from_args(&args).unwrap();
        let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
        (Runner::new(setup, &table), table)
    }

    /// The flat scenario's start pose, at rest, at `stamp` [ns].
    fn js(stamp: i64) -> JointState {
        JointState {
            header: Header { stamp: time_from_ns(stamp), frame_id: String::new() },
            name: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
            position: vec![0.0, 0.3, 1.8, 0.0, 1.0, 0.0],
            velocity: vec![0.0; 6],
            effort: vec![0.0; 6],
        }
    }

    fn wrench(stamp: i64) -> WrenchStamped {
        WrenchStamped { header: Header { stamp: time_from_ns(stamp), frame_id: "ft_sensor".into() }, ..Default::default() }
    }

    #[test]
    fn in_simulated_time_a_joint_state_waits_for_the_wrench_of_its_stamp() {
        let (mut r, _) = runner(&["use_sim_time:=true"]);
        r.wrench(&wrench(0));
        let out = r.joint_states(&js(0), |_| panic!("the wrench of stamp 0 is in: nothing to wait for"));
        assert_eq!(out.effort.map(effort_source_stamp), Some(Some(0)), "the command carries its state's stamp");
        let report = out.report.expect("a report every cycle");
        assert_eq!((report.header.stamp.to_nanos(), report.mode.as_str(), report.fault.as_str()), (0, "scheduled", ""));
        assert_eq!(report.header.frame_id, "base_link", "the frame of reference_position and the force axis");
        // The next state's wrench is not in yet: the runner asks for it, once.
        let mut asked = Vec::new();
        let out = r.joint_states(&js(1_000_000), |until| {
            asked.push(until);
            Some(wrench(1_000_000))
        });
        assert_eq!(asked.len(), 1, "{asked:?}");
        assert!(asked[0] > wall_ns() - 1_000_000_000, "a wall-clock deadline, soon: {asked:?}");
        assert_eq!(out.effort.map(effort_source_stamp), Some(Some(1_000_000)));
        assert_eq!(r.s.cycles, 2);
        // It never comes: the pairing is given up (the wrench is then stale: a hold).
        let out = r.joint_states(&js(2_000_000), |_| None);
        assert_eq!(out.report.map(|m| m.header.stamp.to_nanos()), Some(2_000_000));
    }

    #[test]
    fn an_accepted_parameter_applies_at_the_next_reload() {
        let (mut r, table) = runner(&["use_sim_time:=true"]);
        r.wrench(&wrench(0));
        assert_eq!(r.joint_states(&js(0), |_| None).report.unwrap().mode, "scheduled", "the default law");
        table.set_atomically(&[("mode".into(), ParameterValue::String("aic".into()))]).unwrap();
        r.wrench(&wrench(1_000_000));
        assert_eq!(r.joint_states(&js(1_000_000), |_| None).report.unwrap().mode, "scheduled", "not before the reload");
        r.reload(&table);
        r.wrench(&wrench(2_000_000));
        assert_eq!(r.joint_states(&js(2_000_000), |_| None).report.unwrap().mode, "aic");
        // A refused value never reaches the runner (the table refuses it).
        assert!(table.set_atomically(&[("learning_rate".into(), ParameterValue::Double(-1.0))]).is_err());
    }
}

/// A Trigger call's answer from the core (a refusal if it gave none), logged as the ROS CLI
/// user sees it: info when accepted, a warning with the reason when refused.
fn logged(service: &str, answer: Option<core::TriggerAnswer>) -> core::TriggerAnswer {
    let a = answer.unwrap_or(core::TriggerAnswer { success: false, message: "the core did not answer" });
    if a.success {
        log::info!("{service}: {}", a.message);
    } else {
        log::warn!("{service}: {}", a.message);
    }
    a
}
