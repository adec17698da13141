//! Levenberg–Marquardt for box-constrained nonlinear least squares, on nalgebra.
//!
//! Minimises ‖r(θ)‖² subject to `lower ≤ θ ≤ upper` by an active-set projected LM:
//! at each iteration the parameters sitting on a bound whose gradient pushes them
//! outward are held fixed, the damped normal equations
//! `(J_Fᵀ J_F + λ·diag(J_Fᵀ J_F)) δ = −J_Fᵀ r` (Marquardt's scaling) are solved for the
//! free ones, and the step is projected onto the box. A step is accepted only if it
//! lowers the cost (λ ÷ 3), otherwise λ × 4 and retry.
//! Stops when the scaled gradient (cosine between r and each free column of J), the
//! relative cost decrease or the relative step falls below its tolerance.

use nalgebra::{DMatrix, DVector};

/// A least-squares problem: residuals r(θ) ∈ ℝᵐ and their Jacobian ∂r/∂θ ∈ ℝ^{m×n}.
pub trait LeastSquares {
    fn n_params(&self) -> usize;
    fn n_residuals(&self) -> usize;
    /// Writes r(θ) into `r` and, if asked, ∂r/∂θ into `jac`.
    fn eval(&self, theta: &[f64], r: &mut DVector<f64>, jac: Option<&mut DMatrix<f64>>);
}

/// Tolerances and iteration limit.
#[derive(Clone, Copy, Debug)]
pub struct LmOptions {
    pub max_iter: usize,
    /// Relative cost decrease below which an accepted step ends the search.
    pub ftol: f64,
    /// Relative step size below which the search ends.
    pub xtol: f64,
    /// Largest |cos(r, J_i)| over free parameters at which θ counts as stationary.
    pub gtol: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self { max_iter: 500, ftol: 1e-14, xtol: 1e-12, gtol: 1e-10 }
    }
}

/// The outcome of [`lm_box`].
#[derive(Clone, Debug)]
pub struct LmResult {
    pub theta: Vec<f64>,
    /// Sum of squared residuals at `theta`.
    pub ssr: f64,
    pub iterations: usize,
    /// true if a tolerance was met (false: iteration limit reached).
    pub converged: bool,
    /// Which test ended the search.
    pub stop: &'static str,
    /// Parameters that end exactly on a bound.
    pub at_bound: Vec<bool>,
}

fn clamp(v: f64, lo: f64, hi: f64) -> f64 {
    v.max(lo).min(hi)
}

/// Minimises ‖r(θ)‖² on the box [lower, upper], starting from `theta0` (projected onto the box).
pub fn lm_box<P: LeastSquares>(problem: &P, theta0: &[f64], lower: &[f64], upper: &[f64], opts: &LmOptions) -> LmResult {
    let n = problem.n_params();
    let m = problem.n_residuals();
    assert!(theta0.len() == n && lower.len() == n && upper.len() == n, "lm_box: θ and bounds need n_params entries");
    let mut theta: Vec<f64> = (0..n).map(|i| clamp(theta0[i], lower[i], upper[i])).collect();
    let mut r = DVector::zeros(m);
    let mut jac = DMatrix::zeros(m, n);
    problem.eval(&theta, &mut r, Some(&mut jac));
    let mut ssr = r.norm_squared();
    let mut r_try = DVector::zeros(m);
    let mut theta_try = theta.clone();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut converged = false;
    let mut stop = "iteration limit";

    'outer: while iterations < opts.max_iter {
        iterations += 1;
        if ssr == 0.0 {
            converged = true;
            stop = "zero residual";
            break;
        }
        let g = jac.tr_mul(&r);
        let free: Vec<usize> = (0..n)
            .filter(|&i| !((theta[i] <= lower[i] && g[i] > 0.0) || (theta[i] >= upper[i] && g[i] < 0.0)))
            .collect();
        if free.is_empty() {
            converged = true;
            stop = "all parameters held at bounds";
            break;
        }
        let rnorm = ssr.sqrt();
        let gmax = free
            .iter()
            .map(|&i| {
                let cn = jac.column(i).norm();
                if cn > 0.0 {
                    g[i].abs() / (cn * rnorm)
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        if gmax <= opts.gtol {
            converged = true;
            stop = "gradient";
            break;
        }
        let jf = jac.select_columns(&free);
        let a = jf.tr_mul(&jf);
        let gf = DVector::from_iterator(free.len(), free.iter().map(|&i| g[i]));
        let dmax = (0..free.len()).map(|k| a[(k, k)]).fold(0.0, f64::max);
        let floor = (dmax * 1e-12).max(1e-300);
        loop {
            let mut aa = a.clone();
            for k in 0..free.len() {
                aa[(k, k)] += lambda * a[(k, k)].max(floor);
            }
            let Some(ch) = aa.cholesky() else {
                lambda *= 10.0;
                if lambda > 1e16 {
                    converged = true;
                    stop = "no descent step (normal equations singular)";
                    break 'outer;
                }
                continue;
            };
            let delta = ch.solve(&(-&gf));
            theta_try.copy_from_slice(&theta);
            for (k, &i) in free.iter().enumerate() {
                theta_try[i] = clamp(theta[i] + delta[k], lower[i], upper[i]);
            }
            problem.eval(&theta_try, &mut r_try, None);
            let ssr_try = r_try.norm_squared();
            if ssr_try.is_finite() && ssr_try < ssr {
                let step: f64 = (0..n).map(|i| (theta_try[i] - theta[i]).powi(2)).sum::<f64>().sqrt();
                let size: f64 = theta.iter().map(|t| t * t).sum::<f64>().sqrt();
                let rel_decrease = (ssr - ssr_try) / ssr;
                std::mem::swap(&mut theta, &mut theta_try);
                ssr = ssr_try;
                lambda = (lambda / 3.0).max(1e-15);
                problem.eval(&theta, &mut r, Some(&mut jac));
                if rel_decrease <= opts.ftol {
                    converged = true;
                    stop = "cost decrease";
                    break 'outer;
                }
                if step <= opts.xtol * (size + opts.xtol) {
                    converged = true;
                    stop = "step size";
                    break 'outer;
                }
                break;
            }
            lambda *= 4.0;
            if lambda > 1e16 {
                converged = true;
                stop = "no descent step (local minimum)";
                break 'outer;
            }
        }
    }
    let at_bound = (0..n).map(|i| theta[i] <= lower[i] || theta[i] >= upper[i]).collect();
    LmResult { theta, ssr, iterations, converged, stop, at_bound }
}
