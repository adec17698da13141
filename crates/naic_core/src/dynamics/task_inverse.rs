//! The dynamically consistent damped inverse of a 6×N Jacobian, for arms whose
//! joint count N is not 6 (a redundant 7-joint arm, or fewer joints than the
//! task has directions). A 6-joint arm keeps the square solve of
//! [`super::solve_damped`].
//!
//! With `M = M(q)` and the mean joint inertia `m̄ = tr(M)/N` (a scale that
//! gives the weighted Jacobian the units of `J`, so that the thresholds of
//! [`Damping`] mean what they mean for 6 joints):
//!
//! ```text
//! A   = m̄ J M⁻¹ Jᵀ = U diag(e) Uᵀ                   (6×6, eigenvalues e = σ̃², σ̃ those of J̃ = √m̄ J L⁻ᵀ, M = L Lᵀ)
//! J̄   = m̄ M⁻¹ Jᵀ U diag(1 / (eᵢ + λ²)) Uᵀ           (N×6)
//! ```
//!
//! `λ² = 0` while `σ̃_min ≥ sigma_threshold`, else the [`Damping`] rule's
//! `λ² = lambda_max² (1 − (σ̃_min / sigma_threshold)²)`; `σ̃_min` is the
//! smallest of the `min(N, 6)` largest σ̃ (the rank J can have). Undamped and
//! for N > 6 with J of full row rank, `J̄ = M⁻¹Jᵀ(J M⁻¹ Jᵀ)⁻¹`, the dynamically
//! consistent generalised inverse (Khatib 1987): `J J̄ = I`, and a joint torque
//! `(I − Jᵀ J̄ᵀ) τ₀` moves nothing of the task. For N < 6 it is the
//! `M`-weighted least-squares solution of `J x = b`. No allocation: every
//! matrix is on the stack.

use super::cartesian::Damping;
use nalgebra::{Cholesky, Const, Matrix6, SMatrix, SVector, Vector6};

/// `J̄` and what it was built from.
#[derive(Clone, Copy, Debug)]
pub struct TaskInverse<const N: usize> {
    /// The dynamically consistent (damped) inverse, N×6.
    pub j_bar: SMatrix<f64, N, 6>,
    /// `σ̃_min < sigma_threshold`: damped.
    pub damped: bool,
    /// `σ̃_min`; undamped at a regular pose (N ≥ 6), the lower bound `sigma_threshold`.
    pub sigma_min: f64,
    /// `λ` applied (0 when not damped).
    pub lambda: f64,
}

/// `J̄` of the module docs, or `None` for a non-finite input, an `M` that is not
/// positive definite, or an eigen-decomposition that fails.
pub fn consistent_inverse<const N: usize>(j: &SMatrix<f64, 6, N>, m: &SMatrix<f64, N, N>, damping: &Damping) -> Option<TaskInverse<N>> {
    consistent_inverse_factored(j, m, &factor(j, m)?, damping)
}

/// The Cholesky factor of `M` [`consistent_inverse`] works with, or `None` for a non-finite
/// `J` or `M`, or an `M` that is not positive definite. A caller that needs `M⁻¹` besides
/// `J̄` (the null-space posture task) factorises once and passes it to
/// [`consistent_inverse_factored`].
pub fn factor<const N: usize>(j: &SMatrix<f64, 6, N>, m: &SMatrix<f64, N, N>) -> Option<Cholesky<f64, Const<N>>> {
    if !(j.as_slice().iter().all(|x| x.is_finite()) && m.as_slice().iter().all(|x| x.is_finite())) {
        return None;
    }
    m.cholesky()
}

/// [`consistent_inverse`] with `M`'s Cholesky factor `ch` from [`factor`] (the same numbers).
pub fn consistent_inverse_factored<const N: usize>(
    j: &SMatrix<f64, 6, N>,
    m: &SMatrix<f64, N, N>,
    ch: &Cholesky<f64, Const<N>>,
    damping: &Damping,
) -> Option<TaskInverse<N>> {
    let m_bar = m.trace() / N as f64;
    // M⁻¹ Jᵀ (N×6).
    let minv_jt = ch.solve(&j.transpose());
    let a = (j * minv_jt) * m_bar;
    let a = (a + a.transpose()) * 0.5;
    if N >= 6 {
        // The common case, a regular pose: `A − σ_t² I` positive definite means every
        // eigenvalue of A, so σ̃_min², is above σ_t² = sigma_threshold²: undamped, and
        // `J̄ = m̄ M⁻¹Jᵀ A⁻¹` by a Cholesky solve, without the eigen-decomposition (which took
        // a fifth of the 7-joint controller cycle). `sigma_min` is then that lower bound.
        let t = damping.sigma_threshold * damping.sigma_threshold;
        if (a - Matrix6::identity() * t).cholesky().is_some() {
            if let Some(ca) = a.cholesky() {
                let j_bar = ca.solve(&minv_jt.transpose()).transpose() * m_bar;
                if j_bar.iter().all(|x| x.is_finite()) {
                    return Some(TaskInverse { j_bar, damped: false, sigma_min: damping.sigma_threshold, lambda: 0.0 });
                }
            }
        }
    }
    eigen_inverse(&minv_jt, a, m_bar, damping)
}

/// [`consistent_inverse`] through the eigen-decomposition of `A` (module docs): near a
/// singularity (damped), and for N < 6.
fn eigen_inverse<const N: usize>(minv_jt: &SMatrix<f64, N, 6>, a: Matrix6<f64>, m_bar: f64, damping: &Damping) -> Option<TaskInverse<N>> {
    let eig = nalgebra::SymmetricEigen::try_new(a, f64::EPSILON, 200)?;
    let mut e: [f64; 6] = std::array::from_fn(|i| eig.eigenvalues[i].max(0.0));
    let mut sorted = e;
    sorted.sort_by(|x, y| y.total_cmp(x));
    let rank = N.min(6);
    let sigma_min = sorted[rank - 1].sqrt();
    let (damped, lambda2) = damping.lambda2(sigma_min);
    // Directions beyond the rank (eigenvalue 0 for N < 6) carry nothing: Jᵀ u = 0 there.
    let cut = if rank < 6 { sorted[rank - 1] * 1e-12 } else { -1.0 };
    for x in e.iter_mut() {
        *x = if *x > cut && *x + lambda2 > 0.0 { 1.0 / (*x + lambda2) } else { 0.0 };
    }
    let u = eig.eigenvectors;
    let inner: Matrix6<f64> = u * Matrix6::from_diagonal(&Vector6::from(e)) * u.transpose();
    let j_bar = minv_jt * inner * m_bar;
    if !j_bar.iter().all(|x| x.is_finite()) {
        return None;
    }
    Some(TaskInverse { j_bar, damped, sigma_min, lambda: lambda2.sqrt() })
}

/// The null-space projection of a joint acceleration: `(I − J̄ J) x`.
pub fn null_space_project<const N: usize>(inv: &TaskInverse<N>, j: &SMatrix<f64, 6, N>, x: &SVector<f64, N>) -> SVector<f64, N> {
    x - inv.j_bar * (j * x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm<const N: usize>() -> (SMatrix<f64, 6, N>, SMatrix<f64, N, N>) {
        let j = SMatrix::<f64, 6, N>::from_fn(|r, c| ((r * 5 + c * 7) % 11) as f64 * 0.1 - 0.4 + if r == c { 0.5 } else { 0.0 });
        let b = SMatrix::<f64, N, N>::from_fn(|r, c| ((r * 3 + c * 2) % 7) as f64 * 0.05);
        (j, b * b.transpose() + SMatrix::<f64, N, N>::identity() * 0.3)
    }

    #[test]
    fn seven_joints_give_the_dynamically_consistent_inverse() {
        let (j, m) = arm::<7>();
        let inv = consistent_inverse(&j, &m, &Damping::default()).unwrap();
        assert!(!inv.damped, "σ̃_min = {}", inv.sigma_min);
        // J J̄ = I and J̄ = M⁻¹Jᵀ(J M⁻¹ Jᵀ)⁻¹ (Khatib).
        assert!((j * inv.j_bar - Matrix6::identity()).amax() < 1e-10);
        let minv = m.try_inverse().unwrap();
        let want = minv * j.transpose() * (j * minv * j.transpose()).try_inverse().unwrap();
        assert!((inv.j_bar - want).amax() < 1e-9 * want.amax());
        // A null-space torque moves nothing of the task: J M⁻¹ (I − Jᵀ J̄ᵀ) τ₀ = 0.
        let tau0 = SVector::<f64, 7>::from_fn(|i, _| 1.0 - 0.3 * i as f64);
        let x = null_space_project(&inv, &j, &(minv * tau0));
        assert!((j * x).amax() < 1e-10);
        assert!(x.amax() > 1e-3, "the projection is not trivially zero");
    }

    /// The Cholesky path of a regular pose is the eigen-decomposition's inverse, to rounding;
    /// with a threshold above σ̃_min the eigen path damps instead.
    #[test]
    fn the_cholesky_path_of_a_regular_pose_equals_the_eigen_path() {
        let (j, m) = arm::<7>();
        let d = Damping::default();
        let fast = consistent_inverse(&j, &m, &d).unwrap();
        let m_bar = m.trace() / 7.0;
        let minv_jt = m.cholesky().unwrap().solve(&j.transpose());
        let a = (j * minv_jt) * m_bar;
        let slow = eigen_inverse(&minv_jt, (a + a.transpose()) * 0.5, m_bar, &d).unwrap();
        assert!(!fast.damped && !slow.damped && slow.sigma_min > d.sigma_threshold, "{}", slow.sigma_min);
        assert!((fast.j_bar - slow.j_bar).amax() < 1e-12 * slow.j_bar.amax(), "{}", (fast.j_bar - slow.j_bar).amax());
        let high = Damping { sigma_threshold: 2.0 * slow.sigma_min, lambda_max: 0.05 };
        let damped = consistent_inverse(&j, &m, &high).unwrap();
        assert!(damped.damped && (damped.sigma_min - slow.sigma_min).abs() < 1e-12, "{}", damped.sigma_min);
    }

    #[test]
    fn six_joints_give_the_plain_inverse_and_three_the_weighted_least_squares() {
        let (j, m) = arm::<6>();
        let inv = consistent_inverse(&j, &m, &Damping::default()).unwrap();
        let j6 = Matrix6::from_fn(|r, c| j[(r, c)]);
        assert!((Matrix6::from_fn(|r, c| inv.j_bar[(r, c)]) - j6.try_inverse().unwrap()).amax() < 1e-9);
        let (j, m) = arm::<3>();
        let inv = consistent_inverse(&j, &m, &Damping { sigma_threshold: 1e-6, lambda_max: 0.05 }).unwrap();
        // Normal equations of min ‖J x − b‖: Jᵀ (J x − b) = 0 (M only weighs the null space, empty here).
        let b = Vector6::new(0.3, -1.0, 2.0, 0.5, -0.2, 1.0);
        let x = inv.j_bar * b;
        assert!((j.transpose() * (j * x - b)).amax() < 1e-9, "{}", j.transpose() * (j * x - b));
    }

    #[test]
    fn a_singular_or_bad_jacobian_is_damped_or_refused() {
        let (mut j, m) = arm::<7>();
        let r = j.row(4).clone_owned();
        j.set_row(5, &r);
        let inv = consistent_inverse(&j, &m, &Damping::default()).unwrap();
        assert!(inv.damped && inv.j_bar.iter().all(|x| x.is_finite()));
        j[(0, 0)] = f64::NAN;
        assert!(consistent_inverse(&j, &m, &Damping::default()).is_none());
    }
}
