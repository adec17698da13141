//! What every shell of the controller needs besides the core: building the node from its
//! arguments (files checked before any DDS participant exists), reacting to accepted
//! parameters, logging the core's events and writing `/naic/params`. Used by the DDS shell
//! (`main.rs`) and by `naic launch --composed`.

use std::fmt::Write;

use naic_core::{
    model::Model,
    pipeline::{control::force_law::{self, Mode}, controller::{Controller, ControllerParams}},
};
use naic_ros::{
    msgs::{NaicParams, PoseStamped, WrenchStamped},
    time::time_from_ns,
    ParamSpec, ParamTable, RosArgs, RosError, RosNode,
};

use crate::{config, core, reference::ScenarioReference};

pub const NODE: &str = "naic_controller";

/// The node's core parameters and what its ROS parameters are declared from.
pub struct Setup {
    pub params: core::Params,
    /// The core's paper settings on the loaded model: the parameters' defaults.
    pub base: ControllerParams,
}

impl Setup {
    /// Read and check everything that reads a file or can reject the model: the start-up
    /// parameters, the model (6 joints, 'tip' and 'ft_sensor' frames) and the scenario.
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
        let model = Model::from_urdf_file(&urdf)
            .map_err(|e| RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
        // Defaults: the core's paper settings on this model (learning rate: not in the paper).
        let base = ControllerParams::paper_defaults(&model, Mode::Naic, force_law::DEFAULT_GAMMA);
        let table = ParamTable::new(config::specs(&base), Some(config::check(base)), &args.overrides(NODE)?).map_err(RosError::Param)?;
        let bad_model = |e: String| RosError::Param(format!("robot model '{urdf}': {e} (set -p urdf:=PATH)"));
        let cp = table.with(|p| config::controller_params(p, &base)).map_err(RosError::Param)?;
        // The model first (its message names the URDF file), then the scenario.
        let ctl = Controller::new(model.clone(), cp).map_err(bad_model)?;
        let reference = ScenarioReference::new(&table.with(|p| p.str("scenario").to_string()), &model).map_err(RosError::Param)?;
        let rp = table.with(config::reference_params);
        let params = core::Params::new(ctl, table.with(config::settings), reference, rp).map_err(bad_model)?;
        Ok(Setup { params, base })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        config::specs(&self.base)
    }

    pub fn check(&self) -> naic_ros::params::SetCheck {
        config::check(self.base)
    }
}

/// Take the node's parameters when a set was accepted since generation `gen`.
pub fn reload(node: &RosNode, gen: &mut u64, base: &ControllerParams, p: &mut core::Params, s: &mut core::State) {
    if node.params.generation() == *gen {
        return;
    }
    *gen = node.params.generation();
    let (cp, settings, rp) =
        node.params.with(|v| (config::controller_params(v, base), config::settings(v), config::reference_params(v)));
    match cp.and_then(|cp| core::set_params(p, s, cp, settings, rp)) {
        Ok(o) if o.resumed => log::info!("parameters changed: resuming force control"),
        Ok(_) => {}
        Err(e) => log::error!("parameters not applied: {e}"),
    }
}

pub fn log_events(e: &core::Events, force_limit: f64) {
    if let Some(j) = e.missing_joint {
        log::error!("/joint_states has no '{j}'; holding");
    }
    if let Some(p) = e.start_tip {
        log::info!("start tip position {p:?}");
    }
    if let Some(f) = e.force_limited {
        log::warn!("measured force {f:.1} N above force_limit {force_limit} N: retracting (set any parameter to resume)");
    }
    if let Some((f, n)) = e.fault {
        log::warn!("holding: {f} (faults so far: {n})");
    }
    if e.non_finite_torque {
        log::error!("controller produced a non-finite torque; not published");
    }
}

pub fn log_reference_events(e: &core::Events, tp: Option<&PoseStamped>, dw: Option<&WrenchStamped>, base: &str) {
    if e.reference_too_early {
        log::warn!("reference sample before the first /joint_states (no start pose yet): ignored");
    }
    if let (Some((r, n)), Some(m)) = (e.target_rejected, tp) {
        log::warn!("/naic/target_pose (frame '{}'; base frame '{base}') refused: {r} ({n} refused so far)", m.header.frame_id);
    }
    if let (Some((r, n)), Some(m)) = (e.wrench_rejected, dw) {
        log::warn!("/naic/desired_wrench (frame '{}'; base frame '{base}') refused: {r} ({n} refused so far)", m.header.frame_id);
    }
}

/// `/naic/params` from the core's report, in place (the strings keep their capacity).
pub fn fill_report(m: &mut NaicParams, r: &core::Report) {
    let st = &r.status;
    m.header.stamp = time_from_ns(r.stamp_ns);
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
    (m.k_e_hat, m.k_e_confidence) = (st.k_e_hat, st.k_e_confidence);
}
