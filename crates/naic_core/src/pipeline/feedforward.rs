//! Stage 4 of the pipeline: joint friction feedforward (paper §5.1).
//!
//! The identified friction (eq 5, per direction as in Table 1, or any model
//! of [`crate::friction`]) is added to the controller's torque: `τ = τ_ctrl +
//! τ_f(q̇)`, the joint-space form of eq 6's `F_f` (`τ_f = Jᵀ F_f`). It is
//! evaluated at the median-filtered measured velocity. Near `q̇ = 0` the
//! printed law jumps by `f_b⁺ + f_b⁻` (35 N·m on joint 1); evaluating it with
//! the model's smoothing (`tanh(q̇/v_s)`) keeps encoder and velocity noise at
//! rest from turning into torque chatter.

use crate::friction::FrictionModel;
use crate::{JointVec, N_JOINTS};

/// One cycle: `τ_ctrl + τ_f(q̇)`. A model with a joint count other than [`N_JOINTS`]
/// adds nothing.
pub fn step(model: &FrictionModel, dq: &JointVec, tau_ctrl: &JointVec) -> JointVec {
    let mut tau_f = [0.0; N_JOINTS];
    if model.tau_f_into(dq, &mut tau_f).is_err() {
        return *tau_ctrl;
    }
    std::array::from_fn(|i| tau_ctrl[i] + tau_f[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::friction::{FrictionModel, JointFriction};

    #[test]
    fn adds_the_friction_torque_of_each_joint() {
        let joints = (0..6).map(|i| JointFriction::CoulombViscous { f_c: 1.0 + i as f64, f_v: 0.5 }).collect();
        let m = FrictionModel::new(joints).unwrap();
        let dq = [0.2, -0.2, 0.0, 1.0, -1.0, 0.1];
        let tau = step(&m, &dq, &[10.0; 6]);
        for i in 0..6 {
            assert!((tau[i] - (10.0 + m.tau_f(i, dq[i]))).abs() < 1e-15);
        }
        assert!((tau[0] - (10.0 + 1.0 + 0.1)).abs() < 1e-12);
        assert!((tau[1] - (10.0 - 2.0 - 0.1)).abs() < 1e-12);
    }
}
