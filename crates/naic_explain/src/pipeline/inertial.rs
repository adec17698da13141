//! The inertial stage: the link inertials, one correction shared by every joint, scored on
//! all joints together after the per-joint catalogue; when significant, each joint gets its
//! cross-fitted column and the per-joint selection runs again with it as a candidate
//! ([`crate::inertial`]).

use super::analyse_all;
use crate::analysis::{JointResult, JointSamples, NominalShape};
use crate::prepare::Prepared;
use crate::{catalogue, inertial, ExplainOptions};
use naic_core::model::Model;

/// The `inertial_parameters` fit (`None` when not run: contact data, or the effect not
/// considered); `joints` and `results` are updated when it is significant.
#[allow(clippy::too_many_arguments)]
pub(crate) fn inertial_stage(
    model: &Model,
    prep: &Prepared,
    val_prep: Option<&Prepared>,
    joints: &mut [JointSamples],
    results: &mut Vec<JointResult>,
    shapes: &[NominalShape],
    opts: &ExplainOptions,
    contact: bool,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Option<inertial::InertialFit> {
    if contact || !opts.analysis.effects.contains(&catalogue::Effect::InertialParameters) {
        return None;
    }
    progress(0.95, "inertial_parameters: base parameters on all joints");
    let fit = inertial::fit(model, prep, val_prep, joints, results, shapes, &opts.analysis, true);
    if fit.significant {
        let share = fit.base_columns.len().div_ceil(joints.len().max(1));
        for (js, c) in joints.iter_mut().zip(&fit.corrections) {
            js.inertial = c.clone();
            js.inertial_params = share;
        }
        *results = analyse_all(joints, shapes, &opts.analysis, opts.threads, &|f, w| progress(0.95 + 0.05 * f, w));
        // the estimate beside the effects that survived the second pass
        let mut fit = fit;
        fit.delta = inertial::fit(model, prep, val_prep, joints, results, shapes, &opts.analysis, false).delta;
        Some(fit)
    } else {
        Some(fit)
    }
}
