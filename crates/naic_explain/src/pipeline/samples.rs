//! Per-joint samples and their held-out folds, from prepared time series or friction points.

use crate::analysis::JointSamples;
use crate::prepare::Prepared;
use naic_ident::FrictionData;

/// The held-out fold of time `t` in prepared time-series data: blocks of `block_s`
/// seconds (longer for long files, ≤ 400 blocks), block b in fold b mod `folds`.
pub fn time_fold(p: &Prepared, block_s: f64, folds: usize) -> impl Fn(f64) -> u8 {
    let t0 = p.t.first().copied().unwrap_or(0.0);
    let t1 = p.t.last().copied().unwrap_or(1.0);
    let dur = (t1 - t0).max(1e-9);
    let block = block_s.max(dur / 400.0);
    move |t: f64| (((t - t0) / block).floor() as usize % folds) as u8
}

/// Per-joint samples from prepared time-series data.
pub fn joint_samples_from_series(p: &Prepared, block_s: f64, folds: usize) -> Vec<JointSamples> {
    let t0 = p.t.first().copied().unwrap_or(0.0);
    let t1 = p.t.last().copied().unwrap_or(1.0);
    let dur = (t1 - t0).max(1e-9);
    let fold_of = time_fold(p, block_s, folds);
    let corr = (p.window_samples as f64 / p.stride as f64).max(1.0);
    (0..p.nj())
        .map(|j| {
            let v_s = naic_core::friction::DEFAULT_V_S;
            let mut js = JointSamples {
                joint: j + 1,
                corr_len: corr,
                sample_period: p.dt_raw,
                time_series: true, coulomb_width: v_s,
                shift_step: p.shift_step,
                shift_half: p.shift_half,
                ..Default::default() };
            let ns = 2 * p.shift_half + 1;
            let lattice = p.shift_half > 0 && p.rb_shift.len() == p.len() * p.nj() * ns;
            for i in 0..p.len() {
                if !p.keep[i][j] {
                    continue;
                }
                js.y.push(p.tau[i][j] - p.tau_rb[i][j]);
                js.v.push(p.v[i][j]);
                // sgn(q̇) as the project's simulation friction evaluates it: tanh(q̇/v_s), 0 at rest
                js.s.push(if p.regime[i][j] == 0 { 0.0 } else { (p.v[i][j] / v_s).tanh() });
                js.q.push(p.q[i][j]);
                js.t.push(p.t[i]);
                js.tn.push((p.t[i] - t0) / dur - 0.5);
                js.a.push(p.a[i][j]);
                js.dtau.push(p.dtau[i][j]);
                js.payload.push(p.payload[i][j]);
                js.tau_rb.push(p.tau_rb[i][j]);
                js.fold.push(fold_of(p.t[i]));
                js.jerk.push(p.jerk[i][j]);
                js.dtau_rb.push(p.dtau_rb[i][j]);
                js.ddtau_rb.push(p.ddtau_rb[i][j]);
                if lattice {
                    let at = (i * p.nj() + j) * ns;
                    js.rb_shift.extend_from_slice(&p.rb_shift[at..at + ns]);
                }
            }
            if !lattice {
                js.shift_half = 0;
            }
            js
        })
        .collect()
}

/// Per-joint samples from friction points (interleaved velocity folds, see [`analysis`]).
/// Points slower than `v_min` (pre-sliding / stiction: the joint did not slide steadily,
/// so no friction law of eq. 4/5 applies) are left out.
pub fn joint_samples_from_points(d: &FrictionData, folds: usize, v_min: f64) -> Vec<JointSamples> {
    d.joints()
        .into_iter()
        .map(|joint| {
            let pts: Vec<_> = d.joint_samples(joint).filter(|s| s.qdot.abs() >= v_min).collect();
            let n = pts.len();
            let mut js = JointSamples { joint, corr_len: 1.0, time_series: false, ..Default::default() };
            for (r, s) in pts.iter().enumerate() {
                js.y.push(s.tau);
                js.v.push(s.qdot);
                js.s.push(if s.qdot > 0.0 { 1.0 } else if s.qdot < 0.0 { -1.0 } else { 0.0 });
                js.q.push(0.0);
                js.t.push(s.line as f64);
                js.tn.push(r as f64 / n.max(2) as f64 - 0.5);
                js.a.push(0.0);
                js.dtau.push(0.0);
                js.payload.push(0.0);
                js.fold.push(0);
            }
            js.assign_velocity_folds(folds);
            js
        })
        .collect()
}


/// The joints' samples of the fit runs (`prep`, each joint with ≥ 50) followed by those of
/// the validation runs (`val`, in [`crate::analysis::VALIDATION_FOLD`]).
pub(crate) fn series_joint_samples(
    prep: &Prepared,
    val: Option<&Prepared>,
    name: &str,
    block_s: f64,
    folds: usize,
    laps: &mut super::Laps,
) -> Result<Vec<JointSamples>, crate::ExplainError> {
    let mut joints = joint_samples_from_series(prep, block_s, folds);
    laps.lap("joint samples and folds");
    for js in &joints {
        if js.len() < 50 {
            return Err(crate::ExplainError::input(format!(
                "{name}: joint {} has only {} usable samples (moving or resting steadily); record longer or move the joint",
                js.joint,
                js.len()
            )));
        }
    }
    if let Some(vp) = val {
        let vj = joint_samples_from_series(vp, block_s, folds);
        for (js, mut v) in joints.iter_mut().zip(vj) {
            v.fold.iter_mut().for_each(|f| *f = crate::analysis::VALIDATION_FOLD);
            js.append(&v);
        }
    }
    Ok(joints)
}
