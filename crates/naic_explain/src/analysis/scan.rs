//! The scan over the shape-parameter grids of one structure: coarse grids one parameter at
//! a time with local refinement, or the nested exponent × surface-height search of a
//! non-linear contact spring. Every configuration tried keeps its per-fold Gram matrices,
//! so the fold fits ([`super::evaluate`]) choose among them without recomputing.

use super::gram::{depends_on, fold_grams, fold_grams_update, sum};
use super::solve::solve;
use super::{Col, JointSamples, NominalShape, ScanParam, Structure};
use crate::catalogue::{k_grid, k_pos_grid, n_exp_grid, q_s_grid};
use nalgebra::DMatrix;

/// Halvings of the grid step when refining the surface height: the contact force is
/// k·δ with k up to 10⁴–10⁵ N/m, so h must be resolved to well below 1 µm·(noise/k).
const H_HALVINGS: usize = 14;

/// Candidate value list of a scanned parameter.
fn grid_of(js: &JointSamples, sp: ScanParam) -> Vec<f64> {
    match sp {
        ScanParam::K => k_grid(),
        ScanParam::KPos => k_pos_grid(),
        ScanParam::H => js.h_grid.clone(),
        ScanParam::NExp => n_exp_grid(),
        ScanParam::Delay => crate::catalogue::delay_grid(),
        _ => q_s_grid(),
    }
}

/// Additive parameters (h, n, delay) are refined by repeated halving of the grid step;
/// log-spaced ones (q_s, k) by four multiplicative steps.
fn additive(sp: ScanParam) -> bool {
    matches!(sp, ScanParam::H | ScanParam::NExp | ScanParam::Delay)
}

/// A configuration tried: the scanned values and its per-fold Gram matrices.
type Tried = (Vec<f64>, Vec<DMatrix<f64>>);

/// The state of one scan: the structure, its columns, and every configuration tried.
struct Scan<'a> {
    js: &'a JointSamples,
    st: &'a Structure,
    scan: &'a [ScanParam],
    sh: &'a NominalShape,
    cols: &'a [Col],
    /// Columns (and the target, index p, for a delay) that change with the scanned values.
    scan_cols: Vec<usize>,
    k_folds: usize,
    p: usize,
    tried: Vec<Tried>,
}

impl Scan<'_> {
    /// `st` with the scanned parameters at `vals`.
    fn build(&self, vals: &[f64]) -> Structure {
        let pairs: Vec<(ScanParam, f64)> = self.scan.iter().copied().zip(vals.iter().copied()).collect();
        let mut s = self.st.clone();
        for &(sp, v) in &pairs {
            s.set(sp, v);
        }
        s
    }

    /// Training SSR over all folds of the configuration `vals` (its Grams kept in `tried`).
    fn ssr(&mut self, vals: &[f64]) -> f64 {
        let (k_folds, p) = (self.k_folds, self.p);
        if let Some((_, g)) = self.tried.iter().find(|(v, _)| v.as_slice() == vals) {
            let tot = sum(&g[..k_folds]);
            return solve(&tot, p).1;
        }
        let s = self.build(vals);
        let g = match self.tried.first() {
            // only the scanned columns change between configurations
            Some((_, base)) => fold_grams_update(self.js, &s, self.sh, self.cols, &self.scan_cols, base),
            None => fold_grams(self.js, &s, self.sh, self.cols, k_folds),
        };
        let ssr = solve(&sum(&g[..k_folds]), p).1;
        self.tried.push((vals.to_vec(), g));
        ssr
    }

    /// The configuration `best_vals` with parameter `a` at `v`: kept in `best` (SSR, value)
    /// when its SSR is lower.
    fn try_value(&mut self, best_vals: &[f64], a: usize, v: f64, best: &mut (f64, f64)) {
        let mut vals = best_vals.to_vec();
        vals[a] = v;
        let ssr = self.ssr(&vals);
        if ssr < best.0 {
            *best = (ssr, v);
        }
    }

    /// Line search of h around `h0` at exponent `n`: 17 points over ±`half_width`, then
    /// [`H_HALVINGS`] halvings. Returns (SSR, h).
    fn line_h(&mut self, h0: f64, n: f64, half_width: f64) -> (f64, f64) {
        let mut best = (f64::INFINITY, h0);
        let pts = 17;
        for k in 0..pts {
            let h = h0 - half_width + 2.0 * half_width * k as f64 / (pts - 1) as f64;
            let ssr = self.ssr(&[n, h]);
            if ssr < best.0 {
                best = (ssr, h);
            }
        }
        let mut step = 2.0 * half_width / (pts - 1) as f64;
        for _ in 0..H_HALVINGS {
            step *= 0.5;
            let c = best.1;
            for h in [c - step, c + step] {
                let ssr = self.ssr(&[n, h]);
                if ssr < best.0 {
                    best = (ssr, h);
                }
            }
        }
        best
    }

    /// Exponent and surface height are strongly coupled (a power law seen from a shifted
    /// surface looks like another exponent): nested search, for each n on its grid (then
    /// refined by halving) a local line search of h around the current one.
    fn nested(&mut self, best_vals: &[f64]) -> Vec<f64> {
        let h0 = best_vals[1];
        let ng = n_exp_grid();
        let mut best = (f64::INFINITY, best_vals[0], h0);
        for &n in &ng {
            let (ssr, h) = self.line_h(h0, n, 0.008);
            if ssr < best.0 {
                best = (ssr, n, h);
            }
        }
        let mut step = ng[1] - ng[0];
        for _ in 0..6 {
            step *= 0.5;
            let c = best.1;
            for n in [c - step, c + step] {
                let (ssr, h) = self.line_h(h0, n, 0.002);
                if ssr < best.0 {
                    best = (ssr, n, h);
                }
            }
        }
        vec![best.1, best.2]
    }

    /// Coarse grids, one parameter at a time (the others at their current values in
    /// `best_vals`), each refined around its best (`passes` passes).
    fn coordinates(&mut self, best_vals: &mut [f64], passes: usize) {
        for pass in 0..passes {
            for (a, &sp) in self.scan.iter().enumerate() {
                let grid = grid_of(self.js, sp);
                if grid.len() < 2 {
                    continue;
                }
                let mut best = (f64::INFINITY, best_vals[a]);
                if pass == 0 {
                    for &v in &grid {
                        self.try_value(best_vals, a, v, &mut best);
                    }
                } else {
                    best = (self.ssr(best_vals), best_vals[a]);
                }
                best_vals[a] = best.1;
                // stage 2: refinement around the best
                if additive(sp) {
                    let mut step = (grid[1] - grid[0]).abs();
                    if pass > 0 {
                        step *= 0.25;
                    }
                    let halvings = if sp == ScanParam::H { H_HALVINGS } else { 6 };
                    for _ in 0..halvings {
                        step *= 0.5;
                        let centre = best.1;
                        for v in [centre - step, centre + step] {
                            self.try_value(best_vals, a, v, &mut best);
                        }
                    }
                } else {
                    let step = (grid[1] / grid[0]).sqrt();
                    for f in [1.0 / step, 1.0 / step.sqrt(), step.sqrt(), step] {
                        self.try_value(best_vals, a, best.1 * f, &mut best);
                    }
                }
                best_vals[a] = best.1;
            }
        }
    }
}

/// Scans the shape parameters `scan` (not empty) of `st`: every configuration tried, in the
/// order tried, with its per-fold Gram matrices (columns `cols`).
pub(super) fn scan_grid(
    js: &JointSamples,
    st: &Structure,
    scan: &[ScanParam],
    sh: &NominalShape,
    cols: &[Col],
    k_folds: usize,
) -> (Vec<Structure>, Vec<Vec<DMatrix<f64>>>) {
    let p = cols.len();
    // Enumerate configurations: for one parameter, its grid; for two (q_s±, disjoint
    // supports) scan each with the other fixed at its current value, then combine the
    // per-direction bests — the Gram blocks of the two directions do not interact except
    // through shared columns, which this coordinate step accounts for by re-fitting.
    let mut scan_cols: Vec<usize> =
        cols.iter().enumerate().filter(|(_, c)| scan.iter().any(|&sp| depends_on(**c, sp))).map(|(i, _)| i).collect();
    if scan.contains(&ScanParam::Delay) {
        scan_cols.push(p); // the delay shifts the target, the last column of [X y]
    }
    let mut s = Scan { js, st, scan, sh, cols, scan_cols, k_folds, p, tried: Vec::new() };
    // stage 1: coarse grids, one parameter at a time (others at current values)
    let mut best_vals: Vec<f64> = scan.iter().map(|&sp| st.get(sp)).collect();
    let nested = scan == [ScanParam::NExp, ScanParam::H] && js.h_grid.len() > 1;
    if nested {
        best_vals = s.nested(&best_vals);
    }
    let passes = if nested { 0 } else { 1 };
    s.coordinates(&mut best_vals, passes);
    let _ = s.ssr(&best_vals);
    let tried = std::mem::take(&mut s.tried);
    let mut configs = Vec::with_capacity(tried.len());
    let mut grams = Vec::with_capacity(tried.len());
    for (vals, g) in tried {
        configs.push(s.build(&vals));
        grams.push(g);
    }
    (configs, grams)
}
