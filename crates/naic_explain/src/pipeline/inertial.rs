//! The inertial stage: the link inertials, one correction shared by every joint, scored on
//! all joints together after the per-joint catalogue; when significant, each joint gets its
//! cross-fitted column and the per-joint selection runs again with it as a candidate
//! ([`crate::inertial`]).

use super::analyse_all;
use crate::analysis::{self, AnalysisOptions, JointResult, JointSamples, NominalShape};
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
        // The correction is one δβ for the whole arm: its test pools every joint's time blocks
        // (each joint's nominal before and after the correction's column). A joint whose own
        // blocks are too few for the test at 1 − α/m (21 s of the Panda: ≈ 26 blocks, the
        // 0.06 % quantile) takes it when the pooled test passes and its own effect-size and
        // parsimony gates do; the selection runs again only when that changes something.
        if let Some(iv) = pooled_inertial(joints, results, shapes, &opts.analysis) {
            let held_back = results
                .iter()
                .flat_map(|r| r.rejected.iter())
                .any(|c| c.effect == catalogue::Effect::InertialParameters && c.gain_interval.is_some() && !c.significant);
            if held_back {
                let o = AnalysisOptions { inertial_pooled: Some(iv), ..opts.analysis.clone() };
                *results = analyse_all(joints, shapes, &o, opts.threads, &|f, w| progress(0.95 + 0.05 * f, w));
            }
        }
        // the estimate beside the effects that survived the second pass
        let mut fit = fit;
        fit.delta = inertial::fit(model, prep, val_prep, joints, results, shapes, &opts.analysis, false).delta;
        Some(fit)
    } else {
        Some(fit)
    }
}

/// The pooled test of `inertial_parameters` ([`analysis::bootstrap::pooled_blocks`]): each
/// time-series joint's nominal against the nominal with the correction's column, pooled over
/// the joints' time blocks, at the family's one-sided 1 − α/m. The interval when its low end is
/// above zero.
fn pooled_inertial(joints: &[JointSamples], results: &[JointResult], shapes: &[NominalShape], o: &AnalysisOptions) -> Option<(f64, f64)> {
    if analysis::bootstrap::pooled_targets(joints) < 2 {
        return None;
    }
    let parts: Vec<(&JointSamples, Vec<f64>, Vec<f64>)> = joints
        .iter()
        .zip(results)
        .filter(|(js, _)| js.time_series && !js.contact && !js.inertial.is_empty())
        .map(|(js, r)| {
            let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
            let c = analysis::score(js, &r.nominal, catalogue::Effect::InertialParameters, &sh, &AnalysisOptions { inertial_pooled: None, ..o.clone() });
            (js, analysis::residuals(js, &r.nominal, &sh).0, analysis::residuals(js, &c.eval, &sh).0)
        })
        .collect();
    if parts.len() < 2 {
        return None;
    }
    let blocks = analysis::bootstrap::pooled_blocks(&parts);
    let m = if o.comparisons > 0 { o.comparisons } else { analysis::bootstrap::comparisons(joints) };
    let alpha = analysis::bootstrap::test_alpha(o.family_alpha, m);
    let iv = analysis::bootstrap::gain_interval(&blocks, 2.0 * alpha, analysis::bootstrap::REPLICATES, analysis::bootstrap::seed(0, catalogue::Effect::InertialParameters));
    (iv.0 > 0.0).then_some(iv)
}
