//! Stage 4 of the pipeline: joint friction feedforward (paper §5.1).
//!
//! The identified friction (eq 5, per direction as in Table 1, or any model
//! of [`crate::friction`]) is added to the controller's torque: `τ = τ_ctrl +
//! τ_f(q̇)`, the joint-space form of eq 6's `F_f` (`τ_f = Jᵀ F_f`). It is
//! evaluated at the median-filtered measured velocity. Near `q̇ = 0` the
//! printed law jumps by `f_b⁺ + f_b⁻` (35 N·m on joint 1); evaluating it with
//! the model's smoothing (`tanh(q̇/v_s)`) keeps encoder and velocity noise at
//! rest from turning into torque chatter.
//!
//! # On the reference velocity (the scheduled law)
//!
//! The smoothing is not enough: the encoders' velocity noise (2 mrad/s, 1 σ, per joint in
//! the simulator) is twice `v_s` = 1 mrad/s, so at rest the law still applies nearly
//! `±f_b` at random on every joint (joint 1: ±12 N·m of command SD). Widening `v_s` to the
//! noise loses the compensation of the joints that creep at a few mrad/s while the tool
//! slides. The standard remedy is to evaluate the friction
//! law at the *reference* velocity, which carries no noise: [`blend`] gives the velocity
//! the law is evaluated at,
//!
//! ```text
//! q̇_ff,i = w_i q̇_i + (1 − w_i) q̇_ref,i,   w_i = max(ρ(q̇_i), ρ(q̇_ref,i)),   ρ(v) = clamp((|v| − v_lo) / (v_hi − v_lo), 0, 1)
//! ```
//!
//! with `q̇_ref = J⁻¹ Ẋ_ref` the joint velocity of the twist the controller commands (the
//! controller computes it, [`super::controller::ControlOutputs::dq_ff`]): the measured
//! velocity as before wherever the joint or its reference moves above the noise
//! (`≥ v_hi`: a motion the reference does not know, an impact, a slip, or a joint that
//! follows the reference), the reference's only near rest (both below `v_lo`), so a joint
//! at rest with a reference at rest gets no feedforward whatever its velocity noise.
//! (Evaluated at the reference also where the reference moves, the joints the reference moves but that stick lose the measured
//! velocity's dither, and the slope at d = 2 settled later.)

use crate::friction::FrictionModel;
use crate::pipeline::ConfigError;
use crate::{JointVec, MAX_JOINTS};

/// The blend of measured and reference joint velocity for the friction feedforward
/// (module docs): the reference velocity where both the measured and the reference speed
/// are below `v_lo` [rad/s], the measured one where either is above `v_hi`, linear in between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceBlend {
    pub v_lo: f64,
    pub v_hi: f64,
}

impl ReferenceBlend {
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.v_lo >= 0.0 && self.v_lo < self.v_hi && self.v_hi.is_finite()) {
            return Err(ConfigError::invalid(
                "friction reference blend v_lo",
                self.v_lo,
                format!("rad/s must be >= 0 and below v_hi = {} rad/s (finite)", self.v_hi),
            ));
        }
        Ok(())
    }
}

/// The joint velocity the friction law is evaluated at (module docs): per joint the
/// measured `dq` where `|dq|` or `|dq_ref|` is at least `v_hi`, the reference `dq_ref`
/// where both are at most `v_lo`, linear in between. A non-finite `dq_ref` entry gives the
/// measured velocity.
pub fn blend<const N: usize>(b: &ReferenceBlend, dq: &JointVec<N>, dq_ref: &JointVec<N>) -> JointVec<N> {
    mix(b, dq, dq, dq_ref)
}

/// The blend's mix per joint: `w measured + (1 − w) dq_ref` with the weights `w` of the
/// median `dq` and of `dq_ref` ([`blend`]: `measured` = `dq`; [`blend_fast`]: `dq` moved
/// towards the unfiltered velocity). A non-finite `dq_ref` entry gives `measured`.
fn mix<const N: usize>(b: &ReferenceBlend, dq: &JointVec<N>, measured: &JointVec<N>, dq_ref: &JointVec<N>) -> JointVec<N> {
    std::array::from_fn(|i| {
        if !dq_ref[i].is_finite() {
            return measured[i];
        }
        let w = |v: f64| ((v.abs() - b.v_lo) / (b.v_hi - b.v_lo)).clamp(0.0, 1.0);
        let w = w(dq[i]).max(w(dq_ref[i]));
        w * measured[i] + (1.0 - w) * dq_ref[i]
    })
}

/// Where the friction feedforward takes the unfiltered joint velocity instead of the median:
/// the median is `d + 2` periods old, and on a
/// Stribeck drop (a negative slope of `τ_f`) that lag leaves part of the drop's negative
/// damping uncancelled (joint 4 oscillated at 46 Hz while the tool slid on a stiff surface);
/// the unfiltered velocity is `d` periods old. Only where that is the cause: in contact, in
/// a joint's drop, sliding steadily in one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastVelocity {
    /// Per joint, the unfiltered velocity's weight ([`fast_weight`]) rises from 0 where the
    /// slower of the median and the unfiltered speed is `v_on` [rad/s] to 1 at `2 v_on`, and
    /// is 0 where they differ in sign: a joint that slides steadily in one direction, not
    /// one that breaks away from rest or reverses.
    pub v_on: f64,
    /// In contact only, from this contact age on [s]; `None`: in and out of contact.
    pub contact_age: Option<f64>,
    /// Per joint the velocity intervals where the friction law falls with speed (its
    /// Stribeck drop, [`drop_bands`]): `[lo⁻, hi⁻, lo⁺, hi⁺]` [rad/s], the unfiltered velocity
    /// only where the median lies in one of them; `None`: at every speed.
    pub drop: Option<[[f64; 4]; MAX_JOINTS]>,
    /// Periods by which the unfiltered velocity is extrapolated: `q̇_f = q̇_raw +
    /// (lead / base) (q̇_raw − q̇_raw,−base)`, `q̇_raw,−base` the unfiltered velocity `base`
    /// cycles before. The unfiltered velocity is still `d` periods old (and the torque held
    /// for one more), which at d = 2 left joint 4 oscillating at 44 Hz in its drop. 0: none.
    pub lead: f64,
    /// The extrapolation's baseline in cycles, 1 or 2: over 2 cycles the lead multiplies
    /// the encoders' white velocity noise by `√((1 + l/2)² + (l/2)²)` (√5 at `lead` = 2)
    /// instead of `√((1 + l)² + l²)` (√13) over 1.
    pub lead_base: usize,
    /// The lead only on a surface at least this stiff [N/m] (the schedule's stiffness, known
    /// or estimated): the drop's oscillation moves the force by `k_e` times the tip's swing,
    /// so on soft surfaces there is nothing for the lead to gain and only its noise to add.
    pub lead_k_min: f64,
}

impl FastVelocity {
    /// The setting of the table: `v_on` = 16 mrad/s (8 σ of the encoders' velocity
    /// noise, so the sign test does not flip on noise; 8 mrad/s measured the same, 32 mrad/s
    /// lost the 46 Hz band's lower half), in contact from its start, in `model`'s drops; and
    /// led by 2 periods (the loop delay the scheduled law's predictor is designed
    /// for, `ScheduleParams::delay_cycles`; 1.5 measured the same) over a 2-cycle baseline
    /// (`q̇_f = 2 q̇_raw − q̇_raw,−2`: noise × √5; over 1 cycle, × √13, acrylic's settling under a
    /// model error got tails of 0.18–0.26 s) on surfaces of at least 10 000 N/m (the force
    /// observer's `force_observer_k_min`: the stiff surfaces, where joint 4's drop reached the
    /// ±2 % band).
    pub fn for_model(model: &FrictionModel) -> Self {
        Self { v_on: 0.016, contact_age: Some(0.0), drop: Some(drop_bands(model)), lead: 2.0, lead_base: 2, lead_k_min: 10_000.0 }
    }

    /// The gate [`blend_fast`] takes: 1 in contact from `contact_age` [s] on (out
    /// of contact the fast velocity changed the approach's stick-slip and two-material's
    /// contact), everywhere without `contact_age`, else 0.
    pub fn contact_gate(&self, in_contact: bool, contact_age_s: f64) -> f64 {
        match self.contact_age {
            None => 1.0,
            Some(a) if in_contact && contact_age_s >= a => 1.0,
            Some(_) => 0.0,
        }
    }

    pub fn validate(&self) -> Result<(), ConfigError> {
        let age_ok = self.contact_age.is_none_or(|a| a >= 0.0 && a.is_finite());
        let drop_ok = self.drop.is_none_or(|d| d.iter().flatten().all(|v| v.is_finite()));
        let lead_ok = (0.0..=20.0).contains(&self.lead) && (1..=2).contains(&self.lead_base) && self.lead_k_min >= 0.0 && self.lead_k_min.is_finite();
        if !(self.v_on > 0.0 && self.v_on.is_finite() && age_ok && drop_ok && lead_ok) {
            return Err(ConfigError::invalid(
                "friction fast velocity v_on",
                self.v_on,
                format!(
                    "rad/s must be finite and > 0, with contact_age = {:?} s finite and >= 0 (or none), finite drop bands, lead = {} periods in [0, 20], lead_base = {} cycles in [1, 2] and lead_k_min = {} N/m finite and >= 0",
                    self.contact_age, self.lead, self.lead_base, self.lead_k_min
                ),
            ));
        }
        Ok(())
    }
}

/// Per joint the velocity intervals where `model`'s friction torque falls with speed
/// (`∂τ_f/∂q̇ < 0`, the Stribeck drop's negative damping): `[lo⁻, hi⁻, lo⁺, hi⁺]` [rad/s],
/// the negative-direction interval (`lo⁻ ≤ hi⁻ < 0`) and the positive one (`0 < lo⁺ ≤ hi⁺`),
/// each the outermost points of negative slope found on a grid of 1 mrad/s-ish steps from
/// 0.1 mrad/s to 1 rad/s; `[0; 4]` where there is none (or the model has no such joint).
/// Not for the 1 kHz path (a few thousand evaluations).
pub fn drop_bands(model: &FrictionModel) -> [[f64; 4]; MAX_JOINTS] {
    std::array::from_fn(|i| {
        let mut band = [0.0; 4];
        if i >= model.n_joints() {
            return band;
        }
        for (dir, k) in [(-1.0, 0), (1.0, 2)] {
            let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
            for n in 0..=4000 {
                // Logarithmic from 1e-4 to 1 rad/s.
                let v = 1e-4 * 10f64.powf(4.0 * n as f64 / 4000.0);
                if model.tau_f_and_slope(i, dir * v).1 < 0.0 {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            if lo.is_finite() {
                band[k] = if dir < 0.0 { -hi } else { lo };
                band[k + 1] = if dir < 0.0 { -lo } else { hi };
            }
        }
        band
    })
}

/// Whether `v` lies in one of the intervals of a [`drop_bands`] entry.
pub fn in_drop(band: &[f64; 4], v: f64) -> bool {
    (v < 0.0 && band[0] < band[1] && v >= band[0] && v <= band[1]) || (v > 0.0 && band[2] < band[3] && v >= band[2] && v <= band[3])
}

/// The unfiltered velocity's weight in [0, 1] for one joint ([`FastVelocity::v_on`]):
/// `clamp((min(|dq|, |dq_raw|) − v_on) / v_on, 0, 1)` where `dq` (the median) and `dq_raw`
/// have the same sign, 0 otherwise (and for non-finite inputs).
pub fn fast_weight(v_on: f64, dq: f64, dq_raw: f64) -> f64 {
    if !(dq * dq_raw > 0.0) {
        return 0.0;
    }
    ((dq.abs().min(dq_raw.abs()) - v_on) / v_on).clamp(0.0, 1.0)
}

/// [`blend`] with the measured part moved towards the unfiltered velocity by
/// `gate × fast_weight` per joint: `q̇_m = q̇ + u (q̇_f − q̇)`, `u = gate · fast_weight(v_on,
/// q̇, q̇_raw)` where the median `q̇` lies in the joint's drop band (with `f.drop`), `q̇_f =
/// q̇_raw + (lead / base) (q̇_raw − dq_prev[base − 1])` ([`FastVelocity::lead`]; `dq_prev[k −
/// 1]` the unfiltered velocity k cycles before); the blend's weights stay on the median `dq`,
/// so a joint at rest with its reference at rest still gets no feedforward. `gate` in
/// [0, 1] (the contact gate of [`FastVelocity`]); `gate = 0` is [`blend`] exactly. `k_e`: the
/// surface's stiffness [N/m] (known or estimated), the lead only where it is at least
/// `f.lead_k_min`.
#[allow(clippy::too_many_arguments)]
pub fn blend_fast<const N: usize>(b: &ReferenceBlend, f: &FastVelocity, gate: f64, k_e: f64, dq: &JointVec<N>, dq_raw: &JointVec<N>, dq_prev: &[JointVec<N>; 2], dq_ref: &JointVec<N>) -> JointVec<N> {
    let base = f.lead_base.clamp(1, 2);
    let lead = if k_e >= f.lead_k_min { f.lead } else { 0.0 };
    let measured: JointVec<N> = std::array::from_fn(|i| {
        if f.drop.is_some_and(|d| !in_drop(&d[i], dq[i])) {
            return dq[i];
        }
        let u = gate * fast_weight(f.v_on, dq[i], dq_raw[i]);
        if u > 0.0 {
            let fast = dq_raw[i] + lead / base as f64 * (dq_raw[i] - dq_prev[base - 1][i]);
            dq[i] + u * (fast - dq[i])
        } else {
            dq[i]
        }
    });
    mix(b, dq, &measured, dq_ref)
}

/// One cycle: `τ_ctrl + τ_f(q̇)`. A model with a joint count other than `N` adds
/// nothing.
pub fn step<const N: usize>(model: &FrictionModel, dq: &JointVec<N>, tau_ctrl: &JointVec<N>) -> JointVec<N> {
    let mut tau_f = [0.0; N];
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

    #[test]
    fn the_blend_takes_the_reference_only_near_rest() {
        let b = ReferenceBlend { v_lo: 0.004, v_hi: 0.008 };
        let dq = [0.003, -0.003, 0.006, 0.02, 0.002, 0.001];
        let dq_ref = [0.0, 0.01, 0.001, -0.05, 0.006, f64::NAN];
        let v = blend(&b, &dq, &dq_ref);
        // Both at rest (the measurement within the noise): the reference.
        assert_eq!(v[0], 0.0);
        // The reference moves: the measured velocity, as without the blend.
        assert_eq!(v[1], -0.003);
        assert_eq!(v[3], 0.02);
        // Half-way through the band (measured, reference at rest): the mean.
        assert!((v[2] - 0.5 * (0.006 + 0.001)).abs() < 1e-15, "{}", v[2]);
        assert!((v[4] - 0.5 * (0.002 + 0.006)).abs() < 1e-15, "{}", v[4]);
        // No reference: the measured velocity.
        assert_eq!(v[5], 0.001);
        // At rest with a reference at rest, noise does not reach the friction torque.
        let joints = (0..6).map(|_| JointFriction::CoulombViscous { f_c: 10.0, f_v: 0.5 }).collect();
        let m = FrictionModel::new(joints).unwrap();
        let noise = [0.0035, -0.0039, 0.002, -0.001, 0.0, 0.003];
        assert_eq!(step(&m, &blend(&b, &noise, &[0.0; 6]), &[1.0; 6]), [1.0; 6]);
    }

    #[test]
    fn the_fast_weight_needs_a_steady_slide_in_one_direction() {
        let v = 0.016;
        // Both clearly above the band, same direction: full weight, either sign.
        assert_eq!(fast_weight(v, 0.05, 0.04), 1.0);
        assert_eq!(fast_weight(v, -0.05, -0.04), 1.0);
        // The slower of the two decides: half-way through [v_on, 2 v_on].
        assert!((fast_weight(v, 0.05, 0.024) - 0.5).abs() < 1e-12);
        assert!((fast_weight(v, 0.024, 0.05) - 0.5).abs() < 1e-12);
        // A breakaway from rest (the median still below the band) or a reversal: none.
        assert_eq!(fast_weight(v, 0.01, 0.06), 0.0);
        assert_eq!(fast_weight(v, 0.05, -0.04), 0.0);
        assert_eq!(fast_weight(v, 0.0, 0.05), 0.0);
        assert_eq!(fast_weight(v, f64::NAN, 0.05), 0.0);
    }

    #[test]
    fn the_fast_blend_moves_only_sliding_joints_to_the_unfiltered_velocity() {
        let b = ReferenceBlend { v_lo: 0.004, v_hi: 0.008 };
        let dq = [0.05, 0.05, 0.001, -0.05, 0.05, 0.05];
        let raw = [0.04, -0.02, 0.003, -0.06, 0.024, 0.04];
        let dq_ref = [0.05, 0.05, 0.0, -0.05, 0.05, f64::NAN];
        let f = FastVelocity { v_on: 0.016, contact_age: None, drop: None, lead: 0.0, lead_base: 1, lead_k_min: 0.0 };
        // No gate: exactly the median's blend.
        assert_eq!(blend_fast(&b, &f, 0.0, 0.0, &dq, &raw, &[raw; 2], &dq_ref), blend(&b, &dq, &dq_ref));
        let v = blend_fast(&b, &f, 1.0, 0.0, &dq, &raw, &[raw; 2], &dq_ref);
        assert_eq!(v[0], 0.04);
        assert_eq!(v[1], 0.05, "a reversal stays on the median");
        assert_eq!(v[2], 0.0, "at rest with the reference at rest: no feedforward");
        assert_eq!(v[3], -0.06);
        assert!((v[4] - (0.05 + 0.5 * (0.024 - 0.05))).abs() < 1e-15, "{}", v[4]);
        assert_eq!(v[5], 0.04, "no reference: the measured part");
        // Half the gate, half the step.
        let h = blend_fast(&b, &f, 0.5, 0.0, &dq, &raw, &[raw; 2], &dq_ref);
        assert!((h[0] - 0.045).abs() < 1e-15, "{}", h[0]);
        // Led by 2 periods over a 2-cycle baseline on a stiff surface: q̇_f = 2 q̇_raw − q̇_raw,−2
        // = 2 (0.04) − 0.036 = 0.044 where it slides; nothing where the blend had the median
        // or the reference; on a surface below `lead_k_min` the unled velocity.
        let prev = [[0.039, 0.0, 0.0, -0.06, 0.024, 0.04], [0.036, 0.0, 0.0, -0.06, 0.024, 0.04]];
        let led = FastVelocity { lead: 2.0, lead_base: 2, lead_k_min: 10_000.0, ..f };
        let l = blend_fast(&b, &led, 1.0, 50_000.0, &dq, &raw, &prev, &dq_ref);
        assert!((l[0] - 0.044).abs() < 1e-15, "{}", l[0]);
        assert_eq!(l[1], 0.05);
        assert_eq!(l[2], 0.0);
        assert_eq!(l[3], -0.06);
        // Over a 1-cycle baseline: 0.04 + 2 (0.04 − 0.039) = 0.042.
        let l1 = blend_fast(&b, &FastVelocity { lead_base: 1, ..led }, 1.0, 50_000.0, &dq, &raw, &prev, &dq_ref);
        assert!((l1[0] - 0.042).abs() < 1e-15, "{}", l1[0]);
        // Soft surface (or no estimate yet): no lead.
        assert_eq!(blend_fast(&b, &led, 1.0, 2000.0, &dq, &raw, &prev, &dq_ref), v);
        assert_eq!(blend_fast(&b, &led, 1.0, f64::NAN, &dq, &raw, &prev, &dq_ref), v);
    }

    #[test]
    fn the_contact_gate_opens_in_contact_from_contact_age_on() {
        let f = FastVelocity { v_on: 0.016, contact_age: Some(0.1), drop: None, lead: 0.0, lead_base: 1, lead_k_min: 0.0 };
        assert_eq!(f.contact_gate(true, 0.1), 1.0);
        assert_eq!(f.contact_gate(true, 0.099), 0.0);
        assert_eq!(f.contact_gate(false, 5.0), 0.0, "out of contact: closed");
        assert_eq!(FastVelocity { contact_age: None, ..f }.contact_gate(false, 0.0), 1.0, "no contact_age: everywhere");
    }

    #[test]
    fn a_fast_velocity_band_that_is_not_positive_is_refused() {
        let ok = FastVelocity { v_on: 0.016, contact_age: Some(0.1), drop: Some([[0.0; 4]; crate::MAX_JOINTS]), lead: 0.0, lead_base: 1, lead_k_min: 0.0 };
        assert!(ok.validate().is_ok());
        assert!(FastVelocity { contact_age: None, drop: None, ..ok }.validate().is_ok());
        let mut nan = [[0.0; 4]; crate::MAX_JOINTS];
        nan[3][2] = f64::NAN;
        for bad in [
            FastVelocity { v_on: 0.0, ..ok },
            FastVelocity { v_on: f64::NAN, ..ok },
            FastVelocity { contact_age: Some(-1.0), ..ok },
            FastVelocity { contact_age: Some(f64::INFINITY), ..ok },
            FastVelocity { drop: Some(nan), ..ok },
            FastVelocity { lead: -1.0, ..ok },
            FastVelocity { lead: f64::NAN, ..ok },
            FastVelocity { lead_base: 0, ..ok },
            FastVelocity { lead_base: 3, ..ok },
            FastVelocity { lead_k_min: -1.0, ..ok },
            FastVelocity { lead_k_min: f64::INFINITY, ..ok },
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains("v_on") && e.contains("contact_age"), "{e}");
        }
    }

    #[test]
    fn the_drop_bands_are_where_the_law_falls_with_speed() {
        use crate::friction::{Smoothing, StribeckParams};
        // Table 1's joint 4: a drop from 2.923 to 2.254 N·m over q_s = 0.066 rad/s against
        // f_v = 3.208 (positive); 3.916 → 3.111 over 0.036 against 2.984 (negative).
        let j4 = JointFriction::StribeckPerDirection {
            positive: StribeckParams { f_a: 2.254, f_b: 2.923, q_s: 0.066, f_v: 3.208 },
            negative: StribeckParams { f_a: 3.111, f_b: 3.916, q_s: 0.036, f_v: 2.984 },
        };
        // No drop: the Stribeck level rises (f_b < f_a), or the viscous slope outweighs it.
        let flat = JointFriction::CoulombViscous { f_c: 2.0, f_v: 1.0 };
        let rising = JointFriction::Stribeck(StribeckParams { f_a: 5.7, f_b: 5.5, q_s: 0.036, f_v: 22.0 });
        let m = FrictionModel::new(vec![flat, rising, flat, j4, flat, flat]).unwrap().with_smoothing(Smoothing::Tanh { v_s: 1e-3 }).unwrap();
        let d = drop_bands(&m);
        assert_eq!(d[0], [0.0; 4]);
        assert_eq!(d[1], [0.0; 4]);
        let [lo_n, hi_n, lo_p, hi_p] = d[3];
        // The positive drop: slope −2.4 at 0.02, −5.5 at 0.047, +1.9 at 0.12 rad/s (docs/controller.md).
        assert!(lo_p > 0.005 && lo_p < 0.02 && hi_p > 0.09 && hi_p < 0.12, "{:?}", d[3]);
        assert!(lo_n < -0.05 && hi_n > -0.01 && hi_n < 0.0, "{:?}", d[3]);
        for (v, inside) in [(0.047, true), (0.15, false), (0.003, false), (-0.02, true), (-0.2, false), (0.0, false)] {
            assert_eq!(in_drop(&d[3], v), inside, "{v}");
            let (_, slope) = m.tau_f_and_slope(3, v);
            if v != 0.0 && v.abs() > 0.005 {
                assert_eq!(slope < 0.0, inside, "{v}: slope {slope}");
            }
        }
        assert!(!in_drop(&d[0], 0.047));
        // The table's setting takes them from the model.
        let f = FastVelocity::for_model(&m);
        assert_eq!(f.drop, Some(d));
        assert!(f.validate().is_ok());
    }

    #[test]
    fn outside_its_drop_a_joint_keeps_the_median() {
        let b = ReferenceBlend { v_lo: 0.004, v_hi: 0.008 };
        let mut drop = [[0.0; 4]; crate::MAX_JOINTS];
        drop[0] = [-0.06, -0.005, 0.01, 0.1];
        let f = FastVelocity { v_on: 0.016, contact_age: Some(0.0), drop: Some(drop), lead: 0.0, lead_base: 1, lead_k_min: 0.0 };
        let dq = [0.05, 0.05, 0.2, 0.0, 0.0, 0.0];
        let raw = [0.04, 0.04, 0.19, 0.0, 0.0, 0.0];
        let dq_ref = [0.05; 6];
        let v = blend_fast(&b, &f, 1.0, 0.0, &dq, &raw, &[raw; 2], &dq_ref);
        assert_eq!(v[0], 0.04, "in its drop: the unfiltered velocity");
        assert_eq!(v[1], 0.05, "a joint without a drop: the median");
        assert_eq!(v[2], 0.2);
    }

    #[test]
    fn a_blend_band_that_is_empty_or_not_finite_is_refused() {
        assert!(ReferenceBlend { v_lo: 0.004, v_hi: 0.008 }.validate().is_ok());
        for (lo, hi) in [(0.008, 0.004), (0.004, 0.004), (-1.0, 0.004), (0.0, f64::INFINITY), (f64::NAN, 0.1)] {
            let e = ReferenceBlend { v_lo: lo, v_hi: hi }.validate().unwrap_err().to_string();
            assert!(e.contains("v_lo") && e.contains("v_hi"), "{e}");
        }
    }
}
