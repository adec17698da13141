//! The (damped) inverse of a 6×6 Jacobian near singularities: one rule, used
//! by [`super::cartesian_terms`] (explicit `J⁻¹`) and [`solve_damped`] (a solve).

use super::cartesian::Damping;
use nalgebra::{Matrix6, Vector6, SVD, U6};

/// `J = U Σ Vᵀ` with the per-singular-value gains of the [`Damping`] rule:
/// `J⁻¹ = V diag(gain) Uᵀ`.
pub(crate) struct DampedSvd {
    pub u: Matrix6<f64>,
    pub v_t: Matrix6<f64>,
    /// `1/σᵢ` (plain) or `σᵢ / (σᵢ² + λ²)` (damped).
    pub gain: Vector6<f64>,
    pub sigma_min: f64,
    pub lambda: f64,
    pub damped: bool,
}

impl DampedSvd {
    /// `None` for a non-finite `J` or an SVD that does not converge.
    pub(crate) fn new(j: &Matrix6<f64>, damping: &Damping) -> Option<Self> {
        if !j.iter().all(|x| x.is_finite()) {
            return None;
        }
        let svd = SVD::<f64, U6, U6>::try_new_unordered(*j, true, true, f64::EPSILON, 200)?;
        let (u, v_t) = (svd.u?, svd.v_t?);
        let sigma = svd.singular_values;
        let sigma_min = sigma.min();
        let (damped, lambda2) = damping.lambda2(sigma_min);
        let gain = sigma.map(|s| if damped { s / (s * s + lambda2) } else { 1.0 / s });
        Some(Self { u, v_t, gain, sigma_min, lambda: lambda2.sqrt(), damped })
    }

    /// The (damped) inverse `V diag(gain) Uᵀ`.
    pub(crate) fn inverse(&self) -> Matrix6<f64> {
        let mut v = self.v_t.transpose();
        for k in 0..6 {
            let mut col = v.column_mut(k);
            col *= self.gain[k];
        }
        v * self.u.transpose()
    }

    /// `J⁻¹ b` without forming the inverse.
    pub(crate) fn solve(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let ub = (self.u.transpose() * b).component_mul(&self.gain);
        self.v_t.transpose() * ub
    }
}

/// Solves `J x = b` for a 6×6 Jacobian with the damping rule of [`Damping`]:
/// the plain inverse while the smallest singular value `σ_min` is at least
/// `sigma_threshold`, damped least squares below it. Returns `x` and whether
/// the solve was damped. A non-finite `J` or `b`, or an SVD that does not
/// converge, gives `x = 0` and `true` (no motion is the safe answer).
///
/// Fast path: an LU inverse, whose Frobenius norm bounds the smallest singular
/// value from below (`σ_min = 1/‖J⁻¹‖₂ ≥ 1/‖J⁻¹‖_F`); when that bound already
/// clears `sigma_threshold` the SVD rule would use the plain inverse too, so the
/// SVD (≈ 20× the cost) runs only within a factor √6 of the threshold.
pub fn solve_damped(j: &Matrix6<f64>, b: &Vector6<f64>, damping: &Damping) -> (Vector6<f64>, bool) {
    if !b.iter().chain(j.iter()).all(|x| x.is_finite()) {
        return (Vector6::zeros(), true);
    }
    if let Some(inv) = j.lu().try_inverse() {
        let bound = 1.0 / inv.norm();
        if bound.is_finite() && bound >= damping.sigma_threshold {
            return (inv * b, false);
        }
    }
    match DampedSvd::new(j, damping) {
        Some(d) => (d.solve(b), d.damped),
        None => (Vector6::zeros(), true),
    }
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

    #[test]
    fn fast_path_agrees_with_the_svd_rule() {
        // Matrices from well conditioned to singular, around the threshold.
        let base = Matrix6::from_fn(|r, c| ((r * 5 + c * 7) % 11) as f64 * 0.1 + if r == c { 0.5 } else { 0.0 });
        let b = Vector6::new(0.3, -1.0, 2.0, 0.5, -0.2, 1.0);
        let damping = Damping::default();
        let svd = base.svd(true, true);
        let mut fast = 0;
        for k in 0..200 {
            // shrink the smallest singular value from 1 to 1e-6
            let mut s = svd.singular_values;
            let i = s.imin();
            s[i] = 10f64.powf(-6.0 * k as f64 / 199.0);
            let j = svd.u.unwrap() * Matrix6::from_diagonal(&s) * svd.v_t.unwrap();
            let (x, damped) = solve_damped(&j, &b, &damping);
            let d = DampedSvd::new(&j, &damping).unwrap();
            assert_eq!(damped, d.damped, "σ_min = {}", s[i]);
            let want = d.solve(&b);
            assert!((x - want).amax() <= 1e-9 * want.amax(), "σ_min = {}: {x} vs {want}", s[i]);
            fast += (!damped && 1.0 / j.try_inverse().unwrap().norm() >= damping.sigma_threshold) as usize;
        }
        assert!(fast > 50, "the LU fast path should serve the well-conditioned cases ({fast})");
    }

    #[test]
    fn solve_equals_inverse_times_b() {
        let j = Matrix6::from_fn(|r, c| ((r * 7 + c * 3) % 5) as f64 * 0.3 + if r == c { 1.0 } else { 0.0 });
        let b = Vector6::new(0.3, -1.0, 2.0, 0.5, -0.2, 1.0);
        for damping in [Damping::default(), Damping { sigma_threshold: 10.0, lambda_max: 0.5 }] {
            let d = DampedSvd::new(&j, &damping).unwrap();
            assert!((d.solve(&b) - d.inverse() * b).amax() < 1e-12);
            if !d.damped {
                assert!((d.inverse() - j.try_inverse().unwrap()).amax() < 1e-10);
            }
        }
    }
}
