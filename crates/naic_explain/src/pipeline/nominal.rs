//! The nominal model: the friction parameter file (`--nominal`), its Stribeck shape per
//! joint, and the Coulomb law's smoothing per joint.

use crate::analysis::{self, JointSamples, NominalShape};
use crate::{ExplainError, ExplainOptions};
use naic_core::friction::{FrictionParams, JointFriction};

/// Nominal Stribeck shape per joint from a params file (symmetrised by averaging the directions).
pub fn nominal_shapes(params: Option<&FrictionParams>, n: usize) -> Vec<NominalShape> {
    let mut out = vec![NominalShape::default(); n];
    if let Some(p) = params {
        for jp in &p.joints {
            if jp.joint == 0 || jp.joint > n {
                continue;
            }
            let (fa, fb, qs) = match jp.friction {
                JointFriction::CoulombViscous { .. } => continue,
                JointFriction::Stribeck(s) => (s.f_a, s.f_b, s.q_s),
                JointFriction::StribeckPerDirection { positive, negative } => (
                    0.5 * (positive.f_a + negative.f_a),
                    0.5 * (positive.f_b + negative.f_b),
                    0.5 * (positive.q_s + negative.q_s),
                ),
            };
            if fa > 0.0 && qs > 0.0 {
                out[jp.joint - 1] = NominalShape { r0: fb / fa - 1.0, q_s0: qs };
            }
        }
    }
    out
}

pub(crate) fn load_nominal(opts: &ExplainOptions) -> Result<(Option<FrictionParams>, String), ExplainError> {
    match &opts.nominal {
        Some(p) => {
            let params = FrictionParams::from_yaml_file(p).map_err(|e| ExplainError::input(format!("--nominal: {e}")))?;
            Ok((Some(params), format!("Stribeck shape (f_b/f_a, q_s; directions averaged) from {}; levels f_a, f_v calibrated on the training folds", p.display())))
        }
        None => Ok((None, "eq. 5 symmetric with a flat shape (f_b = f_a, no --nominal given); levels f_a, f_v calibrated on the training folds".into())),
    }
}


/// The nominal's Coulomb law at the lowest speeds (sign or tanh of some width), per joint
/// ([`analysis::calibrate_coulomb_width`]).
pub(crate) fn calibrate_coulomb_widths(joints: &mut [JointSamples], shapes: &[NominalShape], folds: usize) {
    for js in joints.iter_mut() {
        let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
        analysis::calibrate_coulomb_width(js, &sh, folds);
    }
}
