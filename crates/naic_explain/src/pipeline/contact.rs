//! The contact stage (data with wrench columns): the sensor axes are analysed first, then
//! the measured contact wrench (sensor errors found removed) is taken out of the joint
//! residual.

use super::{analyse_all, time_fold};
use crate::analysis::{self, JointResult, JointSamples, NominalShape};
use crate::prepare::Prepared;
use crate::{contact, input, ExplainError, ExplainOptions, Run};
use naic_core::model::{FrameId, Model};

/// The sensor axes' samples and results, and the method note (none without wrench data).
#[derive(Default)]
pub(crate) struct ContactStage {
    pub axes: Vec<JointSamples>,
    pub results: Vec<JointResult>,
    pub note: Option<String>,
}

/// Analyses the wrench of `segs` (one recording) per sensor axis and subtracts the contact
/// torques from `prep.tau_rb`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn contact_stage(
    fit: &[Run],
    validate: &[Run],
    name: &str,
    segs: &[std::borrow::Cow<'_, input::TimeSeries>],
    prep: &mut Prepared,
    model: &Model,
    tip: FrameId,
    opts: &ExplainOptions,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Result<ContactStage, ExplainError> {
    let nj = model.nv();
    let tip_name = model.frame(tip).name.clone();
    let mut out = ContactStage::default();
    let has_wrench = fit.iter().chain(validate).any(|r| r.ts.wrench.is_some());
    if has_wrench && (fit.len() != 1 || !validate.is_empty() || segs.len() != 1) {
        return Err(ExplainError::input(format!(
            "{name}: contact data (wrench columns) is analysed from one continuous recording: give one --measured file \
             without gaps and no --validate"
        )));
    }
    if let Some(w) = segs.first().and_then(|s| s.wrench.as_ref()) {
        let sensor = model.frame_id(&opts.sensor_frame).ok_or_else(|| {
            ExplainError::model(format!(
                "{} has no frame `{}`; wrench data needs the F/T sensor frame (and the tool frame, --tip) in the URDF",
                opts.urdf.display(),
                opts.sensor_frame,
            ))
        })?;
        let (mass, com) = naic_sim::sensor::tool_from_urdf(&opts.urdf).map_err(|e| ExplainError::model(e.to_string()))?;
        let tool = contact::Tool { mass, com };
        progress(0.3, "contact: sensor and tip kinematics");
        let ck = contact::kinematics(prep, model, sensor, tip)?;
        let mut axes = contact::axis_samples(prep, w, &ck, &tool, &time_fold(prep, opts.block_s, opts.analysis.folds));
        // One surface: its height is calibrated on the axis that sees the contact force
        // most; the other axes get that height and their own scale of the spring column
        // (a weak axis alone would place the surface where its noise fits best).
        if let Some(dom) = contact::dominant_axis(&axes) {
            let r = analysis::analyse_joint(&axes[dom], &NominalShape::default(), &opts.analysis);
            let h = r.final_eval.full_structure.h;
            for (a, js) in axes.iter_mut().enumerate() {
                if a != dom && js.coupled {
                    js.h_grid = vec![h];
                }
            }
        }
        let axis_results = analyse_all(&axes, &[], &opts.analysis, opts.threads, &|f, w| progress(0.3 + 0.2 * f, w));
        let tau_ext = contact::external_torques(prep, model, sensor, &ck, &tool, &axis_results)?;
        for (rb, te) in prep.tau_rb.iter_mut().zip(tau_ext.iter()) {
            for j in 0..nj {
                rb[j] -= te[j];
            }
        }
        out.note = Some(format!(
            "Contact data: the wrench (`ft_sensor` frame) is analysed per axis against the simulator's contact model — a \
             horizontal surface (normal +z) acting as a linear spring k·δ on `{}`, δ = h − z_tip, seen by the F/T sensor \
             with the URDF's tool ({mass:.3} kg, centre of mass {:.4}, {:.4}, {:.4} m in the sensor frame); h is \
             calibrated on the axis that sees the contact force most, the spring's scale per axis, on the training folds. The joint residual has the measured contact wrench \
             (J_ftᵀ W; the URDF tool's weight and any ft_bias found removed) taken out.",
            tip_name, com.x, com.y, com.z
        ));
        out.axes = axes;
        out.results = axis_results;
    }
    Ok(out)
}
