//! The significance test on friction points: the likelihood ratio of the candidate against
//! the current model, its law under the current model from a residual bootstrap within each
//! direction. Time series keep the block bootstrap of held-out gains ([`super::bootstrap`]);
//! nothing here runs on them.
//!
//! Friction points are independent segment means, two curves per joint (one per direction),
//! each with its own scatter (σ differs between the directions of a joint by up to 2.4× on the
//! JK5 file). On them the held-out block bootstrap is under-powered for reasons that are not
//! the data's evidence:
//! * a replicate draws the blocks with replacement, so it leaves out all of k blocks with
//!   probability ≈ e^{−k}; the interval's 1 − α/m low end can only be above zero when the gain
//!   is carried by more than ln(m/α) blocks (5.9 at m = 18), however large it is. A low-speed
//!   shape (`stribeck`) lives in the few slowest points of a direction: on the JK5's joint 3
//!   one pair of points carries more than half of its gain, the slowest point 9 σ of the
//!   negative direction's scatter off, and the interval's low end was −0.04;
//! * the difference of two models' held-out SSRs carries the noise cross term 2·ε·δ: its
//!   z-value grows as √λ/2 with the non-centrality λ = Σδ²/σ², the likelihood ratio of the
//!   nested fits as λ/√(2Δp).
//!
//! The test asks what the rule means — does the candidate's structure improve the fit of the
//! points at all, beyond the current model — with the likelihood ratio of the whole-data
//! least-squares fits, per direction: T = max over the two directions of
//! ln(SSR_current,d / SSR_candidate,d), the candidate at its configuration of least SSR over
//! all points among those its scan tries (its shape parameter, q_s, is not identified when its
//! amplitude is zero, so T has no χ² law: the sup-LR of Davies 1987 and Hansen 1996). The
//! larger of the two directions: a direction's curve is its own (Table 1 fits each
//! separately), and an effect of one direction is not diluted by the other's scatter and
//! parameters. T's law under the current model is simulated: y* = ŷ₀ + e*, e* drawn with
//! replacement from the current model's residuals of the point's own direction, scaled by
//! 1/√(1 − h) (h the leverage) and centred (the residual bootstrap, Freedman 1981, within
//! each direction, whose noise is one σ along speed as the lack-of-fit floor takes it,
//! [`crate::lack_of_fit`]); each replicate refits both models, the candidate at every
//! configuration, exactly as on the data. p = (1 + #{T* ≥ T})/(B + 1), a valid Monte Carlo
//! p-value for any B; the candidate passes when p ≤ α/m, the level of the block bootstrap's
//! one-sided bound (Bonferroni over candidates × joints). The held-out effect-size gate and the
//! BIC gate still come first.
//!
//! (A wild bootstrap, each point's own residual with a random sign, was tried first: it gives
//! every point its own variance, so the few points that carry a low-speed shape also carry
//! it in their bootstrap noise; on generated points with a sharp rise in one direction it
//! found 13 of 20, this test 19 of 20, the block bootstrap 6 of 20:
//! `tests/points_significance.rs`.)

use super::scan::scan_grid;
use super::{Eval, JointSamples, NominalShape, ScanParam, Structure};
use naic_core::rng::Rng;
use nalgebra::DMatrix;

/// Bootstrap replicates of the test: B + 1 = 5000, so at α/m = 0.05/18 a candidate passes with
/// at most 12 replicates at or above its statistic.
pub const REPLICATES: usize = 4999;

/// Replicates per batch (one matrix product each).
const BATCH: usize = 500;

/// The result of [`lr_test`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LrTest {
    /// T = the larger over the two directions of ln(SSR_current / SSR_candidate), on the data.
    pub statistic: f64,
    /// Monte Carlo p-value (1 + #{T* ≥ T})/(B + 1).
    pub p_value: f64,
}

/// An orthonormal basis (n × rank) of the column space of `x` (n × p): the left singular
/// vectors of the singular values above 10⁻¹⁰ of the largest, columns scaled to unit norm
/// first (as the least-squares solve does), so a nearly collinear column does not count.
fn basis(x: &DMatrix<f64>) -> DMatrix<f64> {
    let (n, p) = x.shape();
    if p == 0 || n == 0 {
        return DMatrix::zeros(n, 0);
    }
    let mut xs = x.clone();
    for mut c in xs.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    let svd = xs.svd(true, false);
    let Some(u) = svd.u else { return DMatrix::zeros(n, 0) };
    let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
    let keep: Vec<usize> = (0..svd.singular_values.len()).filter(|&k| svd.singular_values[k] > 1e-10 * smax && smax > 0.0).collect();
    DMatrix::from_fn(n, keep.len(), |i, k| u[(i, keep[k])])
}

/// The design matrix of `st` on the fitted samples `rows` (validation samples left out).
fn design(js: &JointSamples, st: &Structure, sh: &NominalShape, rows: &[usize]) -> DMatrix<f64> {
    let cols = st.columns();
    DMatrix::from_fn(rows.len(), cols.len(), |r, c| js.col(cols[c], st, sh, rows[r]))
}

/// The likelihood-ratio test (module docs) of the structure `alt` with the shape parameters
/// `scan` against the current model `cur` of friction points `js`; `seed` seeds the draws.
pub fn lr_test(
    js: &JointSamples,
    cur: &Eval,
    alt: &Structure,
    scan: &[ScanParam],
    sh: &NominalShape,
    k_folds: usize,
    seed: u64,
) -> LrTest {
    let rows: Vec<usize> = (0..js.len()).filter(|&i| !js.is_validation(i)).collect();
    let n = rows.len();
    let st0 = &cur.full_structure;
    let y = nalgebra::DVector::from_iterator(n, rows.iter().map(|&i| js.target(st0, i)));
    // the current model: fit, residuals scaled by 1/√(1 − leverage)
    let q0 = basis(&design(js, st0, sh, &rows));
    let fit0 = &q0 * (q0.transpose() * &y);
    let r0 = &y - &fit0;
    let u: Vec<f64> = (0..n)
        .map(|i| {
            let h: f64 = q0.row(i).iter().map(|x| x * x).sum();
            if h < 1.0 - 1e-9 {
                r0[i] / (1.0 - h).sqrt()
            } else {
                0.0
            }
        })
        .collect();
    // the candidate at every configuration its scan tries (the same set on data and replicates)
    let configs: Vec<Structure> = if scan.is_empty() {
        vec![alt.clone()]
    } else {
        scan_grid(js, alt, scan, sh, &alt.columns(), k_folds).0
    };
    let bases: Vec<DMatrix<f64>> = configs.iter().map(|c| basis(&design(js, c, sh, &rows))).collect();
    // all bases side by side, the current model's first: one product per batch of replicates
    let widths: Vec<usize> = std::iter::once(q0.ncols()).chain(bases.iter().map(|b| b.ncols())).collect();
    let total: usize = widths.iter().sum();
    let mut all = DMatrix::<f64>::zeros(n, total);
    let mut at = 0;
    for b in std::iter::once(&q0).chain(bases.iter()) {
        all.view_mut((0, at), (n, b.ncols())).copy_from(b);
        at += b.ncols();
    }
    let allt = all.transpose();
    // the directions of the points (+1, −1; 0 at rest, in neither)
    let dir: Vec<f64> = rows.iter().map(|&i| js.s[i].signum()).collect();
    // per direction, ln(SSR_current / SSR_candidate) of the fits to the column `y`; `proj` the
    // projections of `y` on every basis (`allt · y`)
    let by_direction = |y: &[f64], proj: &[f64], best: usize| -> f64 {
        let mut res = [vec![0.0; n], vec![0.0; n]];
        for (slot, w) in [(0usize, widths[0]), (1, widths[best + 1])] {
            let start: usize = if slot == 0 { 0 } else { widths[..=best].iter().sum() };
            let q = all.view((0, start), (n, w));
            let coef = nalgebra::DVector::from_column_slice(&proj[start..start + w]);
            let fit = q * coef;
            for i in 0..n {
                res[slot][i] = y[i] - fit[i];
            }
        }
        let mut t = f64::NEG_INFINITY;
        for d in [1.0, -1.0] {
            let ssr = |r: &[f64]| (0..n).filter(|&i| dir[i] == d).map(|i| r[i] * r[i]).sum::<f64>();
            let (s0, s1) = (ssr(&res[0]), ssr(&res[1]));
            if s0 > 0.0 && s1 > 0.0 {
                t = t.max((s0 / s1).ln());
            }
        }
        t
    };
    // T of each column of `ys` (n × b): the candidate at its configuration of least SSR (all
    // points), and of its two directions' log-ratios the larger
    let stats = |ys: &DMatrix<f64>| -> Vec<f64> {
        let proj = &allt * ys;
        (0..ys.ncols())
            .map(|c| {
                let yy: f64 = ys.column(c).norm_squared();
                let mut off = widths[0];
                let mut best = (f64::INFINITY, 0usize);
                for (k, &w) in widths[1..].iter().enumerate() {
                    let pp: f64 = (off..off + w).map(|r| proj[(r, c)] * proj[(r, c)]).sum();
                    if yy - pp < best.0 {
                        best = (yy - pp, k);
                    }
                    off += w;
                }
                let pc: Vec<f64> = proj.column(c).iter().copied().collect();
                let yc: Vec<f64> = ys.column(c).iter().copied().collect();
                by_direction(&yc, &pc, best.1)
            })
            .collect()
    };
    let t_obs = stats(&DMatrix::from_column_slice(n, 1, y.as_slice()))[0];
    // the residual pool of each direction, centred (the bootstrap noise of its points)
    let pools: Vec<(f64, Vec<f64>)> = [1.0, -1.0, 0.0]
        .iter()
        .map(|&d| {
            let r: Vec<f64> = (0..n).filter(|&i| dir[i] == d).map(|i| u[i]).collect();
            let m = r.iter().sum::<f64>() / r.len().max(1) as f64;
            (d, r.into_iter().map(|x| x - m).collect())
        })
        .collect();
    let pool_of: Vec<&[f64]> = dir.iter().map(|&d| pools.iter().find(|p| p.0 == d).map(|p| p.1.as_slice()).unwrap_or(&[])).collect();
    let mut rng = Rng::seed(seed);
    let mut exceed = 0usize;
    let mut done = 0usize;
    while done < REPLICATES {
        let b = BATCH.min(REPLICATES - done);
        let ys = DMatrix::from_fn(n, b, |i, _| {
            let pool = pool_of[i];
            let k = ((rng.uniform() * pool.len() as f64) as usize).min(pool.len().saturating_sub(1));
            fit0[i] + pool.get(k).copied().unwrap_or(0.0)
        });
        exceed += stats(&ys).into_iter().filter(|&t| t >= t_obs).count();
        done += b;
    }
    LrTest { statistic: t_obs, p_value: (1 + exceed) as f64 / (REPLICATES + 1) as f64 }
}
