//! The significance test of a candidate: a block bootstrap of its held-out gain over time
//! blocks, at a level corrected for every candidate tried on every joint. A candidate is
//! significant only when this interval lies above zero (with the effect-size and parsimony
//! gates of [`super::significance`]); the same interval is the one reported.
//!
//! For one finding on one joint the out-of-fold residuals of the model before and after the
//! effect was added are summed per time block: consecutive analysis samples of one fold's
//! held-out time block, at most [`BLOCK_WINDOWS`] filter windows long (the autocorrelation of
//! the filtered torque, one window, stays inside a block). A bootstrap replicate draws as many blocks with replacement and computes
//! the gain 1 − Σ SSR_after / Σ SSR_before over them; the interval is the replicates'
//! a and 1 − a quantiles: its low end is a one-sided 1 − a lower bound, and a candidate passes
//! the test when it is above zero. The level a keeps the chance that any of the m = candidates ×
//! joints tests passes on data where no candidate helps ≤ α (5 %): a = α/m (Bonferroni,
//! [`test_alpha`]), or, over one joint's candidates drawn together, the balanced level of
//! [`balanced_intervals`] at that joint's share of α, which is never below α/m.

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
/// sensor axis), and the pooled test of the one base-parameter correction the joints share
/// ([`pooled_blocks`]) when two or more joints carry it. `inertial_parameters` counts on every
/// time-series joint: the all-joint stage tries it there whether or not it then becomes a
/// per-joint candidate.
pub fn comparisons(joints: &[JointSamples]) -> usize {
    usize::from(pooled_targets(joints) >= 2)
        + joints
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

/// The joints of the pooled test of `inertial_parameters` (time series, not a sensor axis).
pub fn pooled_targets(joints: &[JointSamples]) -> usize {
    joints.iter().filter(|js| js.time_series && !js.contact).count()
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

/// The time blocks of one effect shared by several joints of the same recording (the base
/// parameters' correction `inertial_parameters`, one δβ for every joint), for the pooled test:
/// per time block (the same time span on every joint: [`BLOCK_WINDOWS`] filter windows, never
/// across a fold's time block), the sum over the joints of (SSR before, SSR after) of the
/// out-of-fold residuals, each joint's divided by its own held-out SSR before, so the pooled
/// gain is the mean of the joints' gains and a joint carrying large torques does not outweigh
/// the others. Resampling the joints' time blocks together keeps what the joints share at one
/// instant (the same motion, the same δβ) in one block.
///
/// `parts`: per joint, its samples and the residuals before and after the effect.
pub fn pooled_blocks(parts: &[(&JointSamples, Vec<f64>, Vec<f64>)]) -> Vec<(f64, f64)> {
    let Some(first) = parts.first() else { return Vec::new() };
    let js0 = first.0;
    // the analysis step from the first joint's time stamps (median of consecutive steps)
    let mut steps: Vec<f64> = js0.t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    if steps.is_empty() {
        return Vec::new();
    }
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    let t0 = parts.iter().filter_map(|(js, _, _)| js.t.first().copied()).fold(f64::INFINITY, f64::min);
    let t1 = parts.iter().filter_map(|(js, _, _)| js.t.last().copied()).fold(f64::NEG_INFINITY, f64::max);
    let len = (BLOCK_WINDOWS * js0.corr_len * dt).max((t1 - t0) / MAX_BLOCKS as f64).max(dt);
    // key: (time block, fold), so a block never spans two folds' time blocks
    let mut acc: std::collections::BTreeMap<(u64, u8), (f64, f64)> = std::collections::BTreeMap::new();
    for (js, rb, ra) in parts {
        let kept = (0..js.len()).filter(|&i| !js.is_validation(i));
        let total: f64 = kept.clone().map(|i| rb[i] * rb[i]).sum();
        if total <= 0.0 {
            continue;
        }
        for i in kept {
            let k = (((js.t[i] - t0) / len).floor().max(0.0) as u64, js.fold[i]);
            let e = acc.entry(k).or_insert((0.0, 0.0));
            e.0 += rb[i] * rb[i] / total;
            e.1 += ra[i] * ra[i] / total;
        }
    }
    acc.into_values().collect()
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

/// Balanced simultaneous intervals of the gains of a family of candidates on one joint (Beran
/// 1988, "Balanced simultaneous confidence sets"): the same replicates (the same blocks drawn)
/// for every candidate, and one per-test level a* for all of them, the largest at which the
/// chance over the replicates that any candidate falls below its own a*-quantile is ≤ `share`.
/// The percentile interval of candidate i is then (its a*-quantile, its (1 − a*)-quantile), and
/// every low end holds jointly at 1 − `share`: a test of "gain ≤ 0" that passes when its low
/// end is above zero keeps the family's error rate at `share` (Westfall & Young 1993, the max
/// statistic over the family, here the min of the candidates' replicate ranks).
///
/// Independent candidates give a* ≈ `share`/m (Šidák, a little above Bonferroni's); candidates
/// that move together (on one joint, a constant, a slow position torque and the gravity
/// columns explain much of the same residual, so their replicates rise and fall with the same
/// blocks) give a larger a*, up to `share` for identical ones. a* is never below
/// ⌊`share`·reps/m⌋/reps, Bonferroni's order statistic (the union bound over the replicates).
///
/// `before`: the blocks' SSR of the model before (shared by the candidates); `after[i]`: the
/// blocks' SSR with candidate i (the same blocks). Returns (a*, each candidate's interval); a
/// candidate whose replicates are all equal (it changes nothing) never falls below its bound.
pub fn balanced_intervals(before: &[f64], after: &[Vec<f64>], share: f64, reps: usize, seed: u64) -> (f64, Vec<(f64, f64)>) {
    let n = before.len();
    let m = after.len();
    if n < 2 || reps == 0 || m == 0 || after.iter().any(|a| a.len() != n) {
        return (share / m.max(1) as f64, vec![(f64::NAN, f64::NAN); m]);
    }
    let mut rng = Rng::seed(seed);
    // g[i][r]: candidate i's gain in replicate r
    let mut g = vec![vec![0.0; reps]; m];
    let mut acc = vec![0.0; m];
    for r in 0..reps {
        let mut b = 0.0;
        acc.iter_mut().for_each(|a| *a = 0.0);
        for _ in 0..n {
            let k = ((rng.uniform() * n as f64) as usize).min(n - 1);
            b += before[k];
            for (a, ai) in acc.iter_mut().zip(after) {
                *a += ai[k];
            }
        }
        for (gi, a) in g.iter_mut().zip(&acc) {
            gi[r] = if b > 0.0 { 1.0 - a / b } else { 0.0 };
        }
    }
    // c[r]: the smallest over the candidates of "how many of its replicates are ≤ this one's":
    // replicate r falls below candidate i's j-th order statistic exactly when j ≥ that count
    let mut c = vec![reps; reps];
    let mut order: Vec<usize> = (0..reps).collect();
    for gi in g.iter_mut() {
        order.sort_by(|&x, &y| gi[x].total_cmp(&gi[y]));
        let mut p = reps;
        while p > 0 {
            // the tie group ending at p − 1: every member counts p replicates ≤ it
            let v = gi[order[p - 1]];
            let mut q = p;
            while q > 0 && gi[order[q - 1]] == v {
                c[order[q - 1]] = c[order[q - 1]].min(p);
                q -= 1;
            }
            p = q;
        }
        // the replicates in order, in place: the quantiles below
        gi.sort_by(f64::total_cmp);
    }
    // j*: the largest order statistic with #{r : c[r] ≤ j*} ≤ share·reps
    c.sort_unstable();
    let allowed = (share * reps as f64).floor() as usize;
    let mut j = 0usize;
    while j + 1 < reps && c.partition_point(|&x| x <= j + 1) <= allowed {
        j += 1;
    }
    let level = j as f64 / reps as f64;
    let iv = g.iter().map(|s| (s[j], s[(reps - j).min(reps - 1)])).collect();
    (level, iv)
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

    /// `m` candidates over 200 blocks: before 1 + noise; each candidate removes 10 % of each
    /// block ± its own noise (`common`: the same noise for every candidate).
    fn family(m: usize, common: bool) -> (Vec<f64>, Vec<Vec<f64>>) {
        let mut rng = Rng::seed(11);
        let before: Vec<f64> = (0..200).map(|_| 1.0 + 0.3 * rng.uniform()).collect();
        let shared: Vec<f64> = (0..200).map(|_| rng.gaussian()).collect();
        let after = (0..m)
            .map(|_| before.iter().zip(&shared).map(|(b, s)| b * (0.9 + 0.2 * if common { *s } else { rng.gaussian() })).collect())
            .collect();
        (before, after)
    }

    #[test]
    fn balanced_level_is_bonferroni_for_one_candidate_and_the_share_for_identical_ones() {
        let share = 0.01;
        // one candidate: the same replicates and the same order statistic as its own interval
        let (before, after) = family(1, false);
        let (level, iv) = balanced_intervals(&before, &after, share, REPLICATES, 5);
        assert_eq!(level, (share * REPLICATES as f64).floor() / REPLICATES as f64);
        let blocks: Vec<(f64, f64)> = before.iter().copied().zip(after[0].iter().copied()).collect();
        assert_eq!(iv[0], gain_interval(&blocks, 2.0 * share, REPLICATES, 5));
        assert!(iv[0].0 > 0.0, "{iv:?}");
        // six identical candidates: one test, so the share is the per-test level
        let (before, after) = family(6, true);
        let (level6, iv6) = balanced_intervals(&before, &after, share, REPLICATES, 5);
        assert_eq!(level6, level);
        assert!(iv6.iter().all(|v| *v == iv6[0]));
    }

    #[test]
    fn balanced_level_of_independent_candidates_is_near_bonferroni_and_never_below_it() {
        let share = 0.05;
        let m = 8;
        let (before, after) = family(m, false);
        let (level, iv) = balanced_intervals(&before, &after, share, REPLICATES, 9);
        let bonferroni = (share / m as f64 * REPLICATES as f64).floor() / REPLICATES as f64;
        // Šidák: 1 − (1 − share)^(1/m) = 0.00639 against 0.00625; the replicates' own
        // dependence (the shared draw of `before`) may raise it a little
        assert!(level >= bonferroni && level < 1.4 * bonferroni, "{level} vs {bonferroni}");
        // each interval is its own candidate's at that level
        for (a, v) in after.iter().zip(&iv) {
            assert!(v.0 < 0.1 && v.1 > 0.1 && v.0 > 0.0, "{v:?}");
            let blocks: Vec<(f64, f64)> = before.iter().copied().zip(a.iter().copied()).collect();
            let own = gain_interval(&blocks, 2.0 * level, REPLICATES, 9);
            assert!((own.0 - v.0).abs() < 0.01, "{own:?} {v:?}");
        }
        // a candidate that changes nothing (all its replicates 0) never falls below its bound:
        // it leaves the level of the others unchanged
        let mut with_null = after.clone();
        with_null.push(before.clone());
        let (level_null, iv_null) = balanced_intervals(&before, &with_null, share, REPLICATES, 9);
        assert_eq!(level_null, level);
        assert_eq!(iv_null[m], (0.0, 0.0));
    }

    /// `n` joints of 40 s at 100 Hz (10 folds of 2 s time blocks, one filter window = 9 samples:
    /// blocks of 0.36 s): noise of the same size before and after everywhere, and on joint j
    /// `strong` time blocks, at instants of its own, where the effect removes 15/16 of the residual
    /// (the fast moves of that joint).
    fn joints_with_sparse_gain(n: usize, strong: usize, effect: bool) -> Vec<(JointSamples, Vec<f64>, Vec<f64>)> {
        let mut rng = Rng::seed(7);
        (0..n)
            .map(|j| {
                let t: Vec<f64> = (0..4000).map(|i| i as f64 * 0.01).collect();
                let fold: Vec<u8> = t.iter().map(|&x| ((x / 2.0).floor() as usize % 10) as u8).collect();
                let js = JointSamples { joint: j + 1, y: vec![0.0; t.len()], t: t.clone(), fold, corr_len: 9.0, time_series: true, ..Default::default() };
                let mut rb: Vec<f64> = (0..t.len()).map(|_| 0.03 * rng.gaussian()).collect();
                let mut ra: Vec<f64> = rb.iter().map(|&r| r + 0.01 * rng.gaussian()).collect();
                for k in 0..strong {
                    // 20 samples inside one of a joint's own 0.36 s blocks (fold time blocks of
                    // 200 samples, blocks from each fold block's start), a different instant per
                    // joint and event
                    let e = j * strong + k;
                    let start = 200 * (e % 20) + 36 * (1 + e / 20) + 5;
                    for i in start..start + 20 {
                        rb[i] = 0.6 * (i as f64).sin();
                        ra[i] = if effect { rb[i] / 4.0 } else { rb[i] };
                    }
                }
                (js, rb, ra)
            })
            .collect()
    }

    #[test]
    fn pooled_blocks_join_the_joints_evidence_at_the_same_instants() {
        let alpha = 2.0 * test_alpha(FAMILY_ALPHA, 85);
        let joints = joints_with_sparse_gain(7, 4, true);
        // one joint alone: 4 strong blocks of ≈ 111; a replicate draws none of them with
        // probability ≈ e^−4 = 1.8 % > 0.06 %, so its bound is not above zero
        for (js, rb, ra) in &joints {
            let (lo, hi) = gain_interval(&blocks_of(js, rb, ra), alpha, REPLICATES, 3);
            assert!(lo <= 0.0 && hi > 0.5, "joint {}: {lo} {hi}", js.joint);
        }
        // pooled: 28 strong events at different instants (some split over two blocks of the
        // pooled grid): the bound is above zero
        let parts: Vec<(&JointSamples, Vec<f64>, Vec<f64>)> = joints.iter().map(|(js, rb, ra)| (js, rb.clone(), ra.clone())).collect();
        let pooled = pooled_blocks(&parts);
        // the same time blocks on every joint: 112 of 0.36 s in 40 s, those the 19 fold-block
        // boundaries cross cut in two (never across a fold's time block)
        assert!((125..=131).contains(&pooled.len()), "{}", pooled.len());
        let (lo, _) = gain_interval(&pooled, alpha, REPLICATES, 3);
        assert!(lo > 0.0, "pooled {lo}");
        // no effect (the strong blocks unchanged): the pooled bound is not above zero
        let null = joints_with_sparse_gain(7, 4, false);
        let parts: Vec<(&JointSamples, Vec<f64>, Vec<f64>)> = null.iter().map(|(js, rb, ra)| (js, rb.clone(), ra.clone())).collect();
        let (lo, _) = gain_interval(&pooled_blocks(&parts), alpha, REPLICATES, 3);
        assert!(lo <= 0.0, "null pooled {lo}");
    }
}
