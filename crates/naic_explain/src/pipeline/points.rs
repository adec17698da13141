//! Friction points: the points too slow to be sliding, and the outlier segments left out
//! between the two passes of the analysis.

use crate::analysis::{self, JointResult, JointSamples, NominalShape};
use naic_ident::FrictionData;

/// Friction points slower than this [rad/s] are not sliding (0.1 mrad/s ≈ one encoder
/// count per second on a 2²⁰-count encoder): left out.
pub const POINTS_V_MIN: f64 = 1e-4;

/// Robust-σ multiple beyond which a friction point is an outlier segment.
pub const OUTLIER_K: f64 = 6.0;

/// A friction point left out as an outlier segment.
#[derive(Clone, Debug)]
pub struct Outlier {
    pub joint: usize,
    /// 1-based line in the CSV file.
    pub line: usize,
    pub velocity: f64,
    pub torque: f64,
    /// Out-of-fold residual under the first-pass model [N·m].
    pub residual: f64,
    /// Robust residual σ of the joint [N·m].
    pub sigma: f64,
}


/// The notes on points left out before the analysis (slower than `v_min`) and on the
/// effects steady-state points cannot show.
pub(crate) fn points_notes(d: &FrictionData, v_min: f64) -> Vec<String> {
    let mut notes: Vec<String> = Vec::new();
    let slow: Vec<String> = d
        .samples
        .iter()
        .filter(|s| s.qdot.abs() < v_min)
        .map(|s| format!("joint {} at {:.2e} rad/s, {:.3} N·m (line {})", s.joint, s.qdot, s.tau, s.line))
        .collect();
    if !slow.is_empty() {
        notes.push(format!(
            "{} point(s) slower than {v_min} rad/s left out (pre-sliding/stiction, not steady sliding friction): {}",
            slow.len(),
            slow.join("; ")
        ));
    }
    notes.push(
        "torque_offset, delay, drift, position_ripple, payload and rotor_inertia cannot be told apart in steady-state \
         segment means (no time, position or acceleration; an offset is indistinguishable from a friction asymmetry \
         without rest segments), so only friction_asymmetry, stribeck and viscous_nonlinearity are scored."
            .into(),
    );
    notes
}

/// Outlier segments: points whose out-of-fold residual under the joint's final model
/// (`results`, first pass) exceeds [`OUTLIER_K`] robust standard deviations (1.4826·MAD).
/// They are left out of `joints` and returned; whether any was.
pub(crate) fn leave_out_outliers(
    joints: &mut [JointSamples],
    results: &[JointResult],
    shapes: &[NominalShape],
    folds: usize,
) -> (Vec<Outlier>, bool) {
    let mut outliers = Vec::new();
    let mut cleaned = false;
    for (k, js) in joints.iter_mut().enumerate() {
        let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
        let (oof, _) = analysis::residuals(js, &results[k].final_eval, &sh);
        let mut abs: Vec<f64> = oof.iter().map(|r| r.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let sigma = 1.4826 * abs[abs.len() / 2];
        let bad: Vec<usize> = (0..js.len()).filter(|&i| oof[i].abs() > OUTLIER_K * sigma && sigma > 0.0).collect();
        if bad.is_empty() {
            continue;
        }
        for &i in &bad {
            outliers.push(Outlier { joint: js.joint, line: js.t[i] as usize, velocity: js.v[i], torque: js.y[i], residual: oof[i], sigma });
        }
        let keep: Vec<bool> = (0..js.len()).map(|i| !bad.contains(&i)).collect();
        *js = js.filtered(&keep, folds);
        cleaned = true;
    }
    (outliers, cleaned)
}

/// The method table of a friction-points run.
pub(crate) fn points_method(folds: usize, v_min: f64) -> Vec<(String, String)> {
    vec![
        ("outliers".into(), format!("points with out-of-fold residual > {OUTLIER_K} robust σ (1.4826·MAD) are listed in the notes, left out, and the analysis repeated once")),
        ("held-out".into(), format!(
            "{} folds of interleaved velocity blocks: per joint and direction, points sorted by speed, point r in fold r mod {}",
            folds, folds
        )),
        ("samples used".into(), format!("points with |velocity| ≥ {v_min} rad/s (slower ones are stiction, see notes)")),
    ]
}
