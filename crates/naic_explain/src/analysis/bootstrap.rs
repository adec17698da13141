//! The significance test of a candidate: a block bootstrap of its held-out gain over time
//! blocks, at a level corrected for every candidate tried on every joint (Bonferroni). A
//! candidate is significant only when this interval lies above zero (with the effect-size and
//! parsimony gates of [`super::significance`]); the same interval is the one reported.
//!
//! For one finding on one joint the out-of-fold residuals of the model before and after the
//! effect was added are summed per time block: consecutive analysis samples of one fold's
//! held-out time block, at most [`BLOCK_WINDOWS`] filter windows long (the autocorrelation of
//! the filtered torque, one window, stays inside a block). A bootstrap replicate draws as many blocks with replacement and computes
//! the gain 1 − Σ SSR_after / Σ SSR_before over them; the interval is the replicates'
//! a and 1 − a quantiles with a = 0.05 / m, m = the candidates tried × the joints: its low end
//! is a one-sided 1 − 0.05/m lower bound, and a candidate passes the test when it is above zero
//! (Bonferroni: the chance that any of the m tests passes on data where no candidate helps is
//! ≤ 5 %).

use super::{residuals, Eval, JointSamples, NominalShape};
use crate::catalogue::{Effect, ALL_EFFECTS};
use naic_core::rng::Rng;

/// Family-wise error rate the test is built for (over all candidates × joints), the default of
/// `AnalysisOptions::family_alpha` (`naic explain --alpha`).
pub const FAMILY_ALPHA: f64 = 0.05;
/// Length of a bootstrap block in filter windows. The filtered torque noise is correlated over
/// one filter window only (the smoother's kernel is one window long), so sums over blocks of
/// four windows are nearly independent; the fold's 2 s time blocks (10 on 21 s of the Panda
/// data) are too few for a percentile interval at a Bonferroni level of 1 − 0.05/84.
pub const BLOCK_WINDOWS: f64 = 4.0;
/// At most about this many blocks (longer blocks on long recordings: the cost of a replicate is
/// one draw per block, and one hour of data at 4 windows per block gave thousands, which made
/// the one-hour benchmark's catalogue stage ≈ 4× slower). Binds above ≈ 200 s at a 51 ms window.
pub const MAX_BLOCKS: usize = 1000;
/// Bootstrap replicates per interval.
pub const REPLICATES: usize = 20_000;

/// The family of the test: every candidate the catalogue could try on every target (joint or
/// sensor axis). `inertial_parameters` counts on every time-series joint: the all-joint stage
/// tries it there whether or not it then becomes a per-joint candidate.
pub fn comparisons(joints: &[JointSamples]) -> usize {
    joints
        .iter()
        .map(|js| {
            ALL_EFFECTS
                .iter()
                .filter(|e| js.applicable(**e) || (**e == Effect::InertialParameters && js.time_series && !js.contact))
                .count()
        })
        .sum::<usize>()
        .max(1)
}

/// The per-test level α/m of a family of `m` comparisons (one-sided: the gain is > 0).
pub fn test_alpha(alpha: f64, m: usize) -> f64 {
    alpha / m.max(1) as f64
}

/// The two-sided level of the interval whose low end is the one-sided bound of [`test_alpha`]:
/// 1 − 2α/m.
pub fn interval_level(alpha: f64, m: usize) -> f64 {
    1.0 - 2.0 * test_alpha(alpha, m)
}

/// The seed of one joint's and one effect's bootstrap (the same for the test and the report).
pub fn seed(joint: usize, e: Effect) -> u64 {
    (joint as u64) << 8 | e as u64
}

/// Per held-out time block: (SSR before, SSR after) of the out-of-fold residuals (validation
/// samples left out).
pub fn block_ssr(js: &JointSamples, before: &Eval, after: &Eval, sh: &NominalShape) -> Vec<(f64, f64)> {
    let (rb, _) = residuals(js, before, sh);
    let (ra, _) = residuals(js, after, sh);
    blocks_of(js, &rb, &ra)
}

/// [`block_ssr`] of two residual vectors already computed.
pub fn blocks_of(js: &JointSamples, rb: &[f64], ra: &[f64]) -> Vec<(f64, f64)> {
    // a block never crosses a fold's time block and holds at most BLOCK_WINDOWS filter windows
    // of consecutive analysis samples (more on long recordings: MAX_BLOCKS)
    let n_fit = (0..js.len()).filter(|&i| !js.is_validation(i)).count();
    let len = ((BLOCK_WINDOWS * js.corr_len).ceil() as usize).max(n_fit.div_ceil(MAX_BLOCKS)).max(1);
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut last: Option<u8> = None;
    let mut count = 0usize;
    for i in 0..js.len() {
        if js.is_validation(i) {
            continue;
        }
        if last != Some(js.fold[i]) || count >= len {
            out.push((0.0, 0.0));
            last = Some(js.fold[i]);
            count = 0;
        }
        count += 1;
        if let Some(b) = out.last_mut() {
            b.0 += rb[i] * rb[i];
            b.1 += ra[i] * ra[i];
        }
    }
    out
}

/// The (low, high) bootstrap interval of the gain at two-sided level 1 − `alpha`.
pub fn gain_interval(blocks: &[(f64, f64)], alpha: f64, reps: usize, seed: u64) -> (f64, f64) {
    let n = blocks.len();
    if n < 2 || reps == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mut rng = Rng::seed(seed);
    let mut g: Vec<f64> = (0..reps)
        .map(|_| {
            let (mut b, mut a) = (0.0, 0.0);
            for _ in 0..n {
                let k = ((rng.uniform() * n as f64) as usize).min(n - 1);
                b += blocks[k].0;
                a += blocks[k].1;
            }
            if b > 0.0 {
                1.0 - a / b
            } else {
                0.0
            }
        })
        .collect();
    g.sort_by(f64::total_cmp);
    let q = |p: f64| g[((p * reps as f64).floor() as usize).min(reps - 1)];
    (q(0.5 * alpha), q(1.0 - 0.5 * alpha))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_covers_the_gain_and_excludes_zero_only_when_blocks_agree() {
        // every block 10 % better: the interval is tight around 0.1
        let same: Vec<(f64, f64)> = (0..50).map(|i| (1.0 + 0.01 * i as f64, 0.9 * (1.0 + 0.01 * i as f64))).collect();
        let (lo, hi) = gain_interval(&same, 0.001, REPLICATES, 1);
        assert!((lo - 0.1).abs() < 1e-9 && (hi - 0.1).abs() < 1e-9, "{lo} {hi}");
        // half the blocks 30 % better, half 30 % worse: the interval spans zero
        let mixed: Vec<(f64, f64)> = (0..50).map(|i| (1.0, if i % 2 == 0 { 0.7 } else { 1.3 })).collect();
        let (lo, hi) = gain_interval(&mixed, 0.001, REPLICATES, 1);
        assert!(lo < 0.0 && hi > 0.0, "{lo} {hi}");
        // too few blocks: no interval
        assert!(gain_interval(&same[..1], 0.05, 100, 1).0.is_nan());
    }
}
