//! The safe hold: gravity compensation plus joint damping, `τ = G(q) − b ⊙ q̇`, the
//! torque the controller applies on a sensor fault and a driver applies when no command
//! arrives. One law, used by both.
//!
//! The damping gain is applied for a whole control period `T` (zero-order hold), so per
//! joint it is a discrete loop `q̇⁺ ≈ (1 − b T / M_ii) q̇`: above `b = 2 M_ii / T` it
//! diverges into a limit cycle bounded only by the effort saturation. On the JK5 the
//! wrist roll has `M_66 ≈ 4·10⁻⁴ kg·m²`, so a damping of 5 N·m·s/rad is unstable at any
//! rate below 25 kHz (seen: joint 6 chattering at ±24 rad/s under the driver's hold after
//! a torque burst). Each gain is therefore capped at `KAPPA · M_ii(q) / T`.

use nalgebra::SVector;

use crate::{
    dynamics,
    JointVec,
    model::{DataN, Model},
};

/// Fraction of the per-joint deadbeat gain `M_ii / T` the damping may reach (at most
/// halves the joint velocity per period; 2 would be the stability limit).
pub const KAPPA: f64 = 0.5;

/// `min(damping_i, KAPPA · M_ii / period)` per joint; `m_diag` is the diagonal of `M(q)`.
pub fn stable_damping<const N: usize>(m_diag: &JointVec<N>, damping: &JointVec<N>, period: f64) -> JointVec<N> {
    std::array::from_fn(|i| damping[i].min(KAPPA * m_diag[i] / period).max(0.0))
}

/// `τ = G(q) − b ⊙ q̇` with `b` = [`stable_damping`] at `q`. No heap allocation.
/// Pass `dq = 0` for gravity compensation only (e.g. when q̇ itself is implausible).
pub fn torque<const N: usize>(model: &Model, data: &mut DataN<N>, q: &JointVec<N>, dq: &JointVec<N>, damping: &JointVec<N>, period: f64) -> JointVec<N> {
    let qv = SVector::<f64, N>::from(*q);
    let m = dynamics::crba(model, data, &qv);
    let m_diag: JointVec<N> = std::array::from_fn(|i| m[(i, i)]);
    let b = stable_damping(&m_diag, damping, period);
    let g = dynamics::gravity_torques(model, data, &qv);
    std::array::from_fn(|i| g[i] - b[i] * dq[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector6;
    use crate::model::Data6;
    use crate::N_JOINTS;

    fn jk5() -> Model {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../urdf/jk5.urdf");
        Model::from_urdf_file(root).unwrap()
    }

    /// Hold the arm with the torque of `law` recomputed every `period` (zero-order hold),
    /// integrating the rigid-body dynamics (ABA) with 20 semi-implicit Euler substeps, no
    /// friction, from a state where the wrist spins. Returns max |q̇| over the last 50 periods.
    fn run(period: f64, law: impl Fn(&Model, &mut Data6, &JointVec, &JointVec) -> JointVec) -> f64 {
        let model = jk5();
        let mut data = Data6::try_new(&model).unwrap();
        let mut q = [0.0, -0.524, 2.094, 0.0, -1.571, 0.0];
        let mut v = [0.0, 0.0, 0.0, 5.0, 5.0, 20.0];
        let mut tail: f64 = 0.0;
        let n = 400;
        for k in 0..n {
            let tau = law(&model, &mut data, &q, &v);
            let tau: JointVec = std::array::from_fn(|i| tau[i].clamp(-100.0, 100.0)); // URDF effort limits
            let h = period / 20.0;
            for _ in 0..20 {
                let a = *dynamics::aba(&model, &mut data, &Vector6::from(q), &Vector6::from(v), &Vector6::from(tau));
                for i in 0..N_JOINTS {
                    v[i] += h * a[i];
                    q[i] += h * v[i];
                }
            }
            if k >= n - 50 {
                tail = tail.max(v.iter().fold(0.0, |m, x| m.max(x.abs())));
            }
        }
        tail
    }

    #[test]
    fn the_capped_hold_stops_a_spinning_wrist_where_the_raw_damping_chatters() {
        for period in [1e-3, 4e-3] {
            let capped = run(period, |m, d, q, v| torque(m, d, q, v, &[5.0; 6], period));
            assert!(capped < 0.5, "T = {period}: capped hold leaves |q̇| = {capped} rad/s");
            // The uncapped law G − 5 q̇ (what the hold was): joint 6 never settles.
            let raw = run(period, |m, d, q, v| {
                let g = *dynamics::gravity_torques(m, d, &Vector6::from(*q));
                std::array::from_fn(|i| g[i] - 5.0 * v[i])
            });
            assert!(raw > 5.0, "T = {period}: the raw damping settled too (|q̇| = {raw}): the cap would be untested");
        }
    }

    #[test]
    fn big_joints_keep_the_requested_damping_and_the_wrist_roll_is_capped() {
        let model = jk5();
        let mut data = Data6::try_new(&model).unwrap();
        let q = [0.0, -0.524, 2.094, 0.0, -1.571, 0.0];
        let m = *dynamics::crba(&model, &mut data, &Vector6::from(q));
        let m_diag: JointVec = std::array::from_fn(|i| m[(i, i)]);
        let b = stable_damping(&m_diag, &[5.0; 6], 1e-3);
        assert_eq!(&b[..3], &[5.0; 3]);
        assert!((b[5] - KAPPA * m_diag[5] / 1e-3).abs() < 1e-12 && b[5] < 1.0, "{b:?}");
        // At rest the hold is pure gravity compensation.
        let t = torque(&model, &mut data, &q, &[0.0; 6], &[5.0; 6], 1e-3);
        let g = *dynamics::gravity_torques(&model, &mut data, &Vector6::from(q));
        assert!((0..N_JOINTS).all(|i| (t[i] - g[i]).abs() < 1e-12));
    }
}
