//! Cartesian (operational-space) terms of the paper's equation 3.

use super::{bias_torques, crba, frame_jacobian, frame_jdot_qdot};
use crate::model::{Data, FrameId, Model};
use nalgebra::allocator::Allocator;
use nalgebra::storage::Storage;
use super::damped::DampedSvd;
use nalgebra::{DefaultAllocator, Dim, Matrix6, Vector, Vector6, U6};

/// Damping of the Jacobian inverse near singularities.
///
/// With `J = U Σ Vᵀ` and `σ_min` its smallest singular value:
/// * `σ_min ≥ sigma_threshold`: plain inverse `J⁻¹ = V Σ⁻¹ Uᵀ` (`damped = false`);
/// * `σ_min < sigma_threshold`: damped least squares
///   `J⁻¹ ≈ V diag(σᵢ / (σᵢ² + λ²)) Uᵀ` with the variable damping
///   `λ² = lambda_max² · (1 − (σ_min / sigma_threshold)²)` (Nakamura & Hanafusa 1986;
///   Maciejewski & Klein 1988), which is continuous at the threshold and gives
///   finite results at an exact singularity (`σ_min = 0`).
///
/// `J` mixes m/rad (linear rows) and rad/rad (angular rows), so σ has those
/// units; the defaults suit an arm of about 1 m reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Damping {
    /// Below this smallest singular value the inverse is damped (default 0.02).
    pub sigma_threshold: f64,
    /// Damping at an exact singularity (default 0.05).
    pub lambda_max: f64,
}

impl Default for Damping {
    fn default() -> Self {
        Self { sigma_threshold: 0.02, lambda_max: 0.05 }
    }
}

impl Damping {
    /// Whether an inverse with smallest singular value `sigma_min` is damped, and its `λ²`
    /// (the variable damping above; 0 when not damped).
    pub fn lambda2(&self, sigma_min: f64) -> (bool, f64) {
        let damped = sigma_min < self.sigma_threshold;
        let lambda2 = if damped {
            let r = sigma_min / self.sigma_threshold;
            self.lambda_max * self.lambda_max * (1.0 - r * r)
        } else {
            0.0
        };
        (damped, lambda2)
    }
}

/// `D` and `h` of eq. 3 (`D Ẍ + h + F_f = F − F_ext`) at a frame, with what they were built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CartesianTerms {
    /// `D = J⁻ᵀ M J⁻¹` (eq. 3), Cartesian inertia.
    pub d: Matrix6<f64>,
    /// `h = J⁻ᵀ (C q̇ + G) − D J̇ q̇` (eq. 3; the paper's `D J̇ J⁻¹ Ẋ` with `Ẋ = J q̇`).
    pub h: Vector6<f64>,
    /// Frame Jacobian (LOCAL_WORLD_ALIGNED, rows linear then angular).
    pub j: Matrix6<f64>,
    /// The (possibly damped) inverse of `j` used for `d` and `h`.
    pub j_inv: Matrix6<f64>,
    /// `J̇ q̇` (same convention as `j`).
    pub jdot_qdot: Vector6<f64>,
    /// Joint-space inertia `M(q)`.
    pub m: Matrix6<f64>,
    /// `C(q, q̇) q̇ + G(q)`.
    pub bias: Vector6<f64>,
    /// True when `sigma_min < sigma_threshold` and the inverse was damped.
    pub damped: bool,
    /// Smallest singular value of `j`.
    pub sigma_min: f64,
    /// Damping used (0 when not damped).
    pub lambda: f64,
}

/// Why [`cartesian_terms`] could not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CartesianError {
    #[error("eq. 3 needs a square 6×6 Jacobian, but the model has {nv} joints; use a 6-joint model")]
    NotSixDof { nv: usize },
    #[error("the Jacobian or inertia is not finite (NaN/inf in q or v?); check the joint state")]
    NonFinite,
    #[error("the SVD of the Jacobian did not converge")]
    SvdFailed,
}

/// `D` and `h` of eq. 3 for a 6-joint model at `frame` (e.g. the tool tip),
/// with a damped Jacobian inverse near singularities (see [`Damping`]).
/// Never panics on bad numbers: a non-finite state gives [`CartesianError::NonFinite`].
pub fn cartesian_terms<D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>>(
    model: &Model,
    data: &mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: &Vector<f64, D, S2>,
    frame: FrameId,
    damping: &Damping,
) -> Result<CartesianTerms, CartesianError>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    if model.nv() != 6 {
        return Err(CartesianError::NotSixDof { nv: model.nv() });
    }
    let mut m = Matrix6::zeros();
    crba(model, data, q);
    for c in 0..6 {
        for r in 0..6 {
            m[(r, c)] = data.m[(r, c)];
        }
    }
    let mut bias = Vector6::zeros();
    bias_torques(model, data, q, v);
    for r in 0..6 {
        bias[r] = data.tau[r];
    }
    let mut j = Matrix6::zeros();
    frame_jacobian(model, data, q, frame);
    for c in 0..6 {
        for r in 0..6 {
            j[(r, c)] = data.j[(r, c)];
        }
    }
    let jdot_qdot = frame_jdot_qdot(model, data, q, v, frame);
    let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
    if !finite(m.as_slice()) || !finite(bias.as_slice()) || !finite(j.as_slice()) || !finite(jdot_qdot.as_slice()) {
        return Err(CartesianError::NonFinite);
    }
    let inv = DampedSvd::new(&j, damping).ok_or(CartesianError::SvdFailed)?;
    let j_inv = inv.inverse();
    let j_inv_t = j_inv.transpose();
    let d = j_inv_t * m * j_inv;
    let h = j_inv_t * bias - d * jdot_qdot;
    Ok(CartesianTerms { d, h, j, j_inv, jdot_qdot, m, bias, damped: inv.damped, sigma_min: inv.sigma_min, lambda: inv.lambda })
}
