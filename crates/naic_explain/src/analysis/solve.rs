//! Least squares on Gram matrices: the fit on the training folds and the SSR on a held-out one.

use nalgebra::{DMatrix, DVector};

/// Least squares from the Gram matrix `g` of `[X y]` (p columns): (θ, SSR).
pub(crate) fn solve(g: &DMatrix<f64>, p: usize) -> (Vec<f64>, f64) {
    // g is (p+1)x(p+1) Gram of [X y]
    // Columns are scaled to unit norm first, so the tiny ridge that keeps the solve
    // defined for collinear or empty columns is the same relative size for every column
    // (the contact spring column u·δ is ~10⁻⁵ of a constant column: an absolute ridge
    // would shrink its coefficient by several per cent).
    let scale: Vec<f64> = (0..p).map(|k| if g[(k, k)] > 0.0 { 1.0 / g[(k, k)].sqrt() } else { 1.0 }).collect();
    let mut a = DMatrix::from_fn(p, p, |r, c| g[(r, c)] * scale[r] * scale[c]);
    let b = DVector::from_fn(p, |r, _| g[(r, p)] * scale[r]);
    let yy = g[(p, p)];
    for k in 0..p {
        a[(k, k)] += 1e-9 * a[(k, k)] + 1e-12;
    }
    let z = match a.clone().cholesky() {
        Some(ch) => ch.solve(&b),
        None => a.pseudo_inverse(1e-12).map(|pi| pi * &b).unwrap_or_else(|_| DVector::zeros(p)),
    };
    let theta = DVector::from_fn(p, |r, _| z[r] * scale[r]);
    let b = g.view((0, p), (p, 1)).column(0).clone_owned();
    let ssr = (yy - 2.0 * theta.dot(&b) + (g.view((0, 0), (p, p)) * &theta).dot(&theta)).max(0.0);
    (theta.iter().copied().collect(), ssr)
}

/// SSR of the parameters `theta` on the samples of the Gram matrix `g` of `[X y]`.
pub(crate) fn heldout(g: &DMatrix<f64>, theta: &[f64]) -> f64 {
    let p = theta.len();
    let th = DVector::from_column_slice(theta);
    let b = g.view((0, p), (p, 1)).column(0).clone_owned();
    (g[(p, p)] - 2.0 * th.dot(&b) + (g.view((0, 0), (p, p)) * &th).dot(&th)).max(0.0)
}
