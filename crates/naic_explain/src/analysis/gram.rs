//! The design matrix, kept as per-fold Gram matrices of `[X y]` (one per held-out fold and
//! one for the validation samples), and their update when only scanned columns change.

use super::{Col, Dir, JointSamples, NominalShape, ScanParam, Structure, VALIDATION_FOLD};
use nalgebra::DMatrix;

/// Per-fold Gram matrices of `[X y]` for one structure (columns in `cols` order).
pub(super) fn fold_grams(js: &JointSamples, st: &Structure, sh: &NominalShape, cols: &[Col], k_folds: usize) -> Vec<DMatrix<f64>> {
    let p = cols.len();
    // one Gram per fold, and the last one for the validation samples
    let mut g = vec![DMatrix::<f64>::zeros(p + 1, p + 1); k_folds + 1];
    let mut x = vec![0.0; p + 1];
    for i in 0..js.len() {
        for (c, xc) in cols.iter().zip(x.iter_mut()) {
            *xc = js.col(*c, st, sh, i);
        }
        x[p] = js.target(st, i);
        let gm = &mut g[gram_index(js.fold[i], k_folds)];
        for a in 0..=p {
            let xa = x[a];
            if xa == 0.0 {
                continue;
            }
            for b in a..=p {
                gm[(a, b)] += xa * x[b];
            }
        }
    }
    for gm in &mut g {
        for a in 0..=p {
            for b in 0..a {
                gm[(a, b)] = gm[(b, a)];
            }
        }
    }
    g
}

#[inline]
pub(super) fn gram_index(fold: u8, k_folds: usize) -> usize {
    if fold == VALIDATION_FOLD {
        k_folds
    } else {
        fold as usize
    }
}

/// Like [`fold_grams`] for a structure that differs from the one behind `base` only in
/// the columns flagged in `scan_cols`: only their rows/columns are recomputed.
pub(super) fn fold_grams_update(
    js: &JointSamples,
    st: &Structure,
    sh: &NominalShape,
    cols: &[Col],
    scan_cols: &[usize],
    base: &[DMatrix<f64>],
) -> Vec<DMatrix<f64>> {
    let p = cols.len();
    let mut g: Vec<DMatrix<f64>> = base.to_vec();
    for gm in &mut g {
        for &a in scan_cols {
            for b in 0..=p {
                gm[(a, b)] = 0.0;
                gm[(b, a)] = 0.0;
            }
        }
    }
    let mut x = vec![0.0; p + 1];
    for i in 0..js.len() {
        for (c, xc) in cols.iter().zip(x.iter_mut()) {
            *xc = js.col(*c, st, sh, i);
        }
        x[p] = js.target(st, i);
        let gm = &mut g[gram_index(js.fold[i], base.len() - 1)];
        for &a in scan_cols {
            let xa = x[a];
            if xa == 0.0 {
                continue;
            }
            for b in 0..=p {
                gm[(a, b)] += xa * x[b];
            }
        }
    }
    for gm in &mut g {
        for &a in scan_cols {
            for b in 0..=p {
                if !scan_cols.contains(&b) {
                    gm[(b, a)] = gm[(a, b)];
                }
            }
        }
    }
    g
}

/// Whether column `c` changes with the shape parameter `sp`.
pub(super) fn depends_on(c: Col, sp: ScanParam) -> bool {
    matches!(
        (c, sp),
        (Col::Strib(Dir::Both), ScanParam::Qs)
            | (Col::Strib(Dir::Pos), ScanParam::QsPos)
            | (Col::Strib(Dir::Neg), ScanParam::QsNeg)
            | (Col::RipSin | Col::RipCos, ScanParam::K)
            | (Col::PosSin | Col::PosCos, ScanParam::KPos)
            | (Col::Spring | Col::CDamp, ScanParam::H)
            | (Col::Spring, ScanParam::NExp)
            // a delay shifts the motion every column is evaluated at
            | (_, ScanParam::Delay)
    )
}

/// The sum of the Gram matrices `g` (the training Gram of the folds they belong to).
pub(super) fn sum(g: &[DMatrix<f64>]) -> DMatrix<f64> {
    let mut t = g[0].clone();
    for m in &g[1..] {
        t += m;
    }
    t
}
