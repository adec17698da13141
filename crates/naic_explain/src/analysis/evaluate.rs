//! The cross-validated fit of one structure ([`evaluate`]), in named steps: the per-fold
//! Gram matrices of every configuration ([`super::gram`], scanned by [`super::scan`]), the
//! whole-data fit, the fold split (train = all folds but one) with its per-fold solve, and
//! the held-out scoring.

use super::gram::{fold_grams, sum};
use super::scan::scan_grid;
use super::solve::{heldout, solve};
use super::{Eval, JointSamples, NominalShape, ScanParam, Structure, VALIDATION_FOLD};
use nalgebra::DMatrix;

/// The fit chosen among the configurations: (SSR, configuration index, θ).
type Choice = (f64, usize, Vec<f64>);

/// Fits `st` with the shape parameters in `scan` chosen per fold (grid + refinement).
pub fn evaluate(js: &JointSamples, st: &Structure, scan: &[ScanParam], sh: &NominalShape, k_folds: usize) -> Eval {
    let cols = st.columns();
    let p = cols.len();
    let (configs, grams) = if scan.is_empty() {
        (vec![st.clone()], vec![fold_grams(js, st, sh, &cols, k_folds)])
    } else {
        scan_grid(js, st, scan, sh, &cols, k_folds)
    };
    // Whole data and per fold: choose the configuration by training SSR.
    let totals: Vec<DMatrix<f64>> = grams.iter().map(|g| sum(&g[..k_folds])).collect();
    let full = fit_whole(&totals, p);
    let folds = fit_folds(&totals, &grams, k_folds, p);
    let fold_ssr = score_folds(&grams, &folds);
    let fold_structure = folds.iter().map(|f| configs[f.1].clone()).collect();
    let fold_theta = folds.into_iter().map(|f| f.2).collect();
    let n_shape = st.n_shape();
    let val_n = js.fold.iter().filter(|&&f| f == VALIDATION_FOLD).count();
    let val_ssr = if val_n > 0 { heldout(&grams[full.1][k_folds], &full.2) } else { 0.0 };
    Eval {
        structure: configs[full.1].clone(),
        columns: cols,
        full_structure: configs[full.1].clone(),
        full_theta: full.2,
        full_ssr: full.0,
        heldout_ssr: fold_ssr.iter().sum(),
        fold_structure,
        fold_theta,
        fold_ssr,
        n: js.len() - val_n,
        n_params: p + n_shape,
        val_ssr,
        val_n,
    }
}

/// The whole-data fit: the configuration with the lowest SSR on all folds (`totals`).
fn fit_whole(totals: &[DMatrix<f64>], p: usize) -> Choice {
    let mut full = (f64::INFINITY, 0usize, vec![]);
    for (c, tot) in totals.iter().enumerate() {
        let (th, ssr) = solve(tot, p);
        if ssr < full.0 {
            full = (ssr, c, th);
        }
    }
    full
}

/// Fold split and per-fold solve: for each fold f, the configuration with the lowest SSR on
/// its training part (all folds but f).
fn fit_folds(totals: &[DMatrix<f64>], grams: &[Vec<DMatrix<f64>>], k_folds: usize, p: usize) -> Vec<Choice> {
    (0..k_folds)
        .map(|f| {
            let mut best = (f64::INFINITY, 0usize, vec![]);
            for (c, tot) in totals.iter().enumerate() {
                let train = tot - &grams[c][f];
                let (th, ssr) = solve(&train, p);
                if ssr < best.0 {
                    best = (ssr, c, th);
                }
            }
            best
        })
        .collect()
}

/// Scoring: the held-out SSR of each fold's fit on that fold.
fn score_folds(grams: &[Vec<DMatrix<f64>>], folds: &[Choice]) -> Vec<f64> {
    folds.iter().enumerate().map(|(f, best)| heldout(&grams[best.1][f], &best.2)).collect()
}
