//! The damped Jacobian inverse near singularities, as a solve.

use super::cartesian::Damping;
use nalgebra::{Matrix6, Vector6, SVD, U6};

/// Solves `J x = b` for a 6×6 Jacobian with the damping rule of [`Damping`]:
/// the plain inverse while the smallest singular value `σ_min` is at least
/// `sigma_threshold`, damped least squares below it. Returns `x` and whether
/// the solve was damped. A non-finite `J` or `b`, or an SVD that does not
/// converge, gives `x = 0` and `true` (no motion is the safe answer).
pub fn solve_damped(j: &Matrix6<f64>, b: &Vector6<f64>, damping: &Damping) -> (Vector6<f64>, bool) {
    if !j.iter().chain(b.iter()).all(|x| x.is_finite()) {
        return (Vector6::zeros(), true);
    }
    let Some(svd) = SVD::<f64, U6, U6>::try_new_unordered(*j, true, true, f64::EPSILON, 200) else {
        return (Vector6::zeros(), true);
    };
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else { return (Vector6::zeros(), true) };
    let sigma = svd.singular_values;
    let sigma_min = sigma.min();
    let damped = sigma_min < damping.sigma_threshold;
    let lambda2 = if damped {
        let r = sigma_min / damping.sigma_threshold;
        damping.lambda_max * damping.lambda_max * (1.0 - r * r)
    } else {
        0.0
    };
    // x = V diag(σ / (σ² + λ²)) Uᵀ b
    let mut ub = u.transpose() * b;
    for k in 0..6 {
        let s = sigma[k];
        ub[k] *= if damped { s / (s * s + lambda2) } else { 1.0 / s };
    }
    (v_t.transpose() * ub, damped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn well_conditioned_solve_is_exact_and_singular_solve_is_finite() {
        let j = Matrix6::from_fn(|r, c| if r == c { 1.0 + r as f64 } else { 0.1 * (r as f64 - c as f64) });
        let b = Vector6::new(1.0, -2.0, 0.5, 0.0, 3.0, -1.0);
        let (x, damped) = solve_damped(&j, &b, &Damping::default());
        assert!(!damped);
        assert!((j * x - b).norm() < 1e-12);
        let mut s = j;
        s.set_row(5, &s.row(4).clone_owned());
        let (x, damped) = solve_damped(&s, &b, &Damping::default());
        assert!(damped && x.iter().all(|v| v.is_finite()));
        let (x, damped) = solve_damped(&Matrix6::from_element(f64::NAN), &b, &Damping::default());
        assert!(damped && x == Vector6::zeros());
    }
}
