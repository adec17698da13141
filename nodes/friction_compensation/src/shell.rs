//! What every shell of friction_compensation needs besides the core: the start-up checks
//! (robot model, effort limits, the velocity filter), the parameter check, the reload of
//! accepted parameters and the event log. Used by the DDS shell (`main.rs`) and by
//! `naic launch --composed`.

use naic_core::{model::Model, pipeline::sense::SenseParams};
use naic_ros::{
    params::{effort_limit_within, SetCheck, EFFORT_CAP},
    ParamSpec, ParamView, RosArgs, RosError, RosNode,
};

use crate::{config, core};

pub const NODE: &str = "friction_compensation";

/// What the node is built from, read before any DDS participant exists.
pub struct Setup {
    /// The URDF's `<limit effort>` (capped): the highest saturation a parameter may set.
    pub effort_limit: [f64; 6],
    /// The velocity filter: the controller's sense stage (joint limits of the model).
    pub sense: SenseParams,
}

impl Setup {
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
        let robot = Model::from_urdf_file(&urdf)
            .map_err(|e| RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
        let l = robot.effort_limits();
        if l.len() != 6 {
            return Err(RosError::Param(format!("'{urdf}' has {} joints; the JK5 needs 6", l.len())));
        }
        let effort_limit: [f64; 6] = std::array::from_fn(|i| if l[i].is_finite() && l[i] > 0.0 { l[i].min(EFFORT_CAP) } else { EFFORT_CAP });
        let sense = SenseParams { wrench_max: [f64::INFINITY; 6], joint_timeout: 1.0, wrench_timeout: 1.0, ..SenseParams::for_model(&robot) };
        Ok(Setup { effort_limit, sense })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        config::specs(&self.effort_limit)
    }

    /// A friction file that does not load, or a saturation above the URDF's, is rejected
    /// like any bad value.
    pub fn check(&self) -> SetCheck {
        let effort_limit = self.effort_limit;
        Box::new(move |p: &ParamView| {
            effort_limit_within(p, &effort_limit)?;
            config::load_model(p).map(|_| ())
        })
    }
}

/// Take the node's parameters when a set was accepted since generation `gen`.
pub fn reload(node: &RosNode, gen: &mut u64, sense: &SenseParams, p: &mut core::Params) {
    if node.params.generation() != *gen {
        *gen = node.params.generation();
        match node.params.with(|v| config::core_params(v, sense)) {
            Ok(np) => *p = np,
            Err(e) => log::error!("{e}"),
        }
    }
}

pub fn log_event(e: &Option<core::Event>) {
    match e {
        Some(core::Event::BadCommand(e)) => log::warn!("ignoring /naic/effort: {e}"),
        Some(core::Event::MissingJoint(j)) => log::error!("/joint_states has no '{j}': no friction feedforward"),
        None => {}
    }
}
