//! The impedance on the force axis as a function of the environment stiffness:
//! `(k_e, delay) -> (m_d, b_d, σ)`, recomputed every cycle from the estimate.
//!
//! # The loop being scheduled
//!
//! In contact, with the computed-torque inner loop and the contact-wrench
//! feedforward `Jᵀ F_e` of eq 6 both working on a measurement that is `d`
//! cycles old (plus the half period of the zero-order hold), the force axis is
//!
//! ```text
//! D ẍ = D V + f(t − τ) − f(t),    V = (f_d − f(t − τ) − b_d ẋ(t − τ) + I) / m_d,    τ = (d + ½) T
//! ```
//!
//! with `D` the apparent mass of the arm along `n` (≈ 6.4 kg for the JK5 at the
//! §4.1 pose) and `f = k_e (x − x_e)`. Multiplying by `m_d / D`:
//! `m_d ẍ + b_d ẋ(t − τ) + (1 − m_d/D) k_e x(t − τ) + (m_d/D) k_e x = f_d + I`.
//!
//! Three bounds follow, each enforced here for the stiffness used:
//!
//! 1. **Delay floor on damping.** A delay `τ` on the spring term
//!    `(1 − m_d/D) k_e x(t − τ) ≈ (1 − m_d/D) k_e (x − τ ẋ)` is a *negative*
//!    damping `(1 − m_d/D) k_e τ`: the loop is stable only if
//!    `b_d > (1 − m_d/D) k_e (d + ½) T` ([`delay_floor`]). At 50 000 N/m
//!    and d = 2 that is 120 N·s/m — three times the paper's b_d = 40, which is
//!    why every paper law limit-cycles on acrylic. `b_d ≥ floor_margin · floor`.
//! 2. **Velocity-loop bandwidth.** The damping acts on a velocity that is `τ`
//!    old — `τ_v = τ + velocity_lag·T`, the median filter on q̇ adds 2 cycles —
//!    `ẍ = −(b_d/m_d) ẋ(t − τ_v)` is a delayed first-order loop, stable with
//!    a good margin only for `(b_d/m_d) τ_v ≤ α` (α < π/2 is the stability
//!    limit; α = 0.7 keeps the phase margin ≈ 50°). With near-critical damping
//!    `b_d = 2ζ√(k_e m_d)` this is `2ζ ω_n τ_v ≤ α`, a lower bound on the mass:
//!    `m_d ≥ k_e (2ζτ_v/α)²`. On soft surfaces `m_d_min` (0.1 kg) wins; on acrylic the
//!    mass grows to ≈ 0.9 kg with the predictor (residual τ_v = 1.5 ms, ω_n ≈ 230 rad/s)
//!    and to ≈ 8 kg without it (τ_v = 4.5 ms at d = 2, ω_n = 78 rad/s) — a light virtual
//!    mass on a hard surface with a delayed loop is what makes it chatter. The lightest
//!    mass matters beyond speed: a disturbance force Δ on the arm (friction, model
//!    error) reaches the contact force as `(m_d / D) Δ`.
//!
//!    All delays in these bounds are the residual delays the predictor leaves
//!    ([`ScheduleParams::delay`], [`ScheduleParams::velocity_delay`]); the predictor is
//!    designed for `delay_cycles`.
//!    With `m_d` from this bound, `b_d / m_d = 2ζ ω_n ≤ α/τ` holds, and the
//!    delay floor is below the critical damping whenever `4ζ²/α > 1`
//!    (checked by [`ScheduleParams::validate`]).
//! 3. **Integral gain.** The integral `I ← I + σ (f_d − f)` (N, per cycle) is
//!    stable in discrete time only for `σ < b_d T / (m_d + b_d T)` (Cao et
//!    al., IEEE Access 2019, for this family of laws; [`sigma_bound`]). We use
//!    `σ = min(sigma_fraction · bound, κ ω_n T)`: a fraction of the bound,
//!    and an integral bandwidth `σ/T ≤ κ ω_n` well below the force loop's
//!    natural frequency so that the third pole does not add overshoot.
//!
//! Near-critical: `b_d = max(2ζ√(k_e m_d), floor_margin · floor)` with ζ ≈ 1
//! (ζ = 0.59 is the 10 % overshoot line of a second-order loop; the delay
//! lowers the effective damping, so ζ = 1 is the target).
//!
//! The stiffness given to [`schedule`] is the estimator's *upper* confidence
//! value `k̂_e + 2 σ_k` (see [`super::estimator`]): with an uncertain estimate
//! the schedule errs on the stiff (over-damped, heavier) side, which is safe
//! for every stiffness below it.

/// Settings of the schedule (one set for every surface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduleParams {
    /// Lightest virtual mass [kg] (speed on soft surfaces; soft surfaces sit at it). The arm
    /// realises `m_d / F` under a model whose masses are `F` × the arm's, and the loop at the
    /// floor passes the F/T sensor's noise (1/16 N per sample) to the contact force: on the
    /// foam (1000 N/m, f_d = 3 N) 0.017 N SD at `m_d / F` = 0.1 kg, 0.019 N at 0.08 kg, so
    /// the ±2 % band (±0.06 N) was 3.1–3.5 SD away and single samples left it 1–2 s after
    /// the force was back (two-material's recovery at F = 1.25, seeds 1–10: 1.741 s, every
    /// seed back within ±2 % by 0.27 s). 0.125 kg keeps the realised floor at the former
    /// 0.1 kg for the heaviest model the schedule covers (F = 1.25, as `prediction` does for
    /// the delay): 1.741 → 0.208 s; at F = 1 the soft surfaces settle 4–9 ms later.
    pub m_d_min: f64,
    /// Target damping ratio ζ.
    pub zeta: f64,
    /// Loop delay the schedule is designed for, in control periods (sensor to torque, d).
    pub delay_cycles: f64,
    /// Velocity-loop gain–delay product limit α: `(b_d/m_d) τ_v ≤ α`.
    pub alpha: f64,
    /// Extra lag of the measured velocity [periods] on top of the loop delay: the
    /// median filter of the sense stage (window w) delays q̇ by (w − 1)/2 = 2 cycles.
    /// `τ_v = (d + velocity_lag + ½) T`.
    pub velocity_lag_cycles: f64,
    /// `b_d ≥ floor_margin ·` the delay floor.
    pub floor_margin: f64,
    /// Apparent mass `D` of the arm along the force axis [kg] (enters the delay floor).
    pub apparent_mass: f64,
    /// `σ ≤ sigma_fraction ·` the stability bound.
    pub sigma_fraction: f64,
    /// Integral bandwidth limit κ: `σ/T ≤ κ ω_n`.
    pub integral_bandwidth: f64,
    /// The stiffness the schedule accepts, [N/m]; NaN or outside → clamped (NaN → k_max).
    pub k_min: f64,
    pub k_max: f64,
    /// Fraction of the loop delay the predictor ([`super::predictor`]) is trusted to cancel,
    /// in [0, 1): the bounds below use the residual delays `(½ + (1 − prediction)·d) T` and
    /// `(½ + (1 − prediction)(d + velocity_lag)) T`. 0 turns the predictor off.
    pub prediction: f64,
}

impl Default for ScheduleParams {
    fn default() -> Self {
        Self {
            m_d_min: 0.125,
            zeta: 1.0,
            delay_cycles: 2.0,
            alpha: 0.7,
            velocity_lag_cycles: 2.0,
            floor_margin: 1.2,
            apparent_mass: 6.4,
            sigma_fraction: 0.25,
            integral_bandwidth: 0.3,
            k_min: 300.0,
            k_max: 1.0e5,
            prediction: 0.75,
        }
    }
}

impl ScheduleParams {
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        let pos = |name: &str, v: f64| {
            if v > 0.0 && v.is_finite() { Ok(()) } else { Err(crate::pipeline::ConfigError::invalid(format!("scheduled.{name}"), v, "must be a positive finite number")) }
        };
        pos("m_d_min", self.m_d_min)?;
        pos("zeta", self.zeta)?;
        pos("alpha", self.alpha)?;
        pos("apparent_mass", self.apparent_mass)?;
        pos("k_min", self.k_min)?;
        pos("k_max", self.k_max)?;
        if !(self.velocity_lag_cycles >= 0.0 && self.velocity_lag_cycles <= 20.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.velocity_lag_cycles", self.velocity_lag_cycles, "must be in [0, 20]"));
        }
        if !(self.delay_cycles >= 0.0 && self.delay_cycles <= 20.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.delay_cycles", self.delay_cycles, "must be in [0, 20] control periods"));
        }
        if !(self.alpha < std::f64::consts::FRAC_PI_2) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.alpha", self.alpha, "must be below π/2 (the delayed velocity loop's stability limit)"));
        }
        if !(self.floor_margin >= 1.0 && self.floor_margin * self.alpha <= 4.0 * self.zeta * self.zeta) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.floor_margin", self.floor_margin, format!("must be >= 1 and floor_margin·alpha <= 4ζ² (= {}) so that damping at the floor keeps (b_d/m_d)τ <= alpha", 4.0 * self.zeta * self.zeta)));
        }
        if !(self.sigma_fraction >= 0.0 && self.sigma_fraction < 1.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.sigma_fraction", self.sigma_fraction, "must be in [0, 1) (fraction of the σ stability bound)"));
        }
        if !(self.integral_bandwidth >= 0.0 && self.integral_bandwidth.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.integral_bandwidth", self.integral_bandwidth, "must be finite and >= 0"));
        }
        if !(self.prediction >= 0.0 && self.prediction < 1.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.prediction", self.prediction, "must be in [0, 1) (fraction of the delay the predictor cancels)"));
        }
        if self.prediction > 0.0 && self.horizons().1 > super::predictor::HISTORY {
            return Err(crate::pipeline::ConfigError::invalid("scheduled: delay_cycles + velocity_lag_cycles", self.delay_cycles + self.velocity_lag_cycles, format!("exceeds the predictor's history of {} cycles", super::predictor::HISTORY)));
        }
        if !(self.k_min < self.k_max) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled.k_min", self.k_min, format!("must be below k_max = {}", self.k_max)));
        }
        Ok(())
    }

    /// `τ = ((1 − prediction) d + ½) T` [s]: the delay of the force feedback the
    /// predictor leaves (the whole loop delay without it).
    pub fn delay(&self, period: f64) -> f64 {
        ((1.0 - self.prediction) * self.delay_cycles + 0.5) * period
    }

    /// `τ_v = ((1 − prediction)(d + velocity_lag) + ½) T` [s]: the delay of the velocity
    /// feedback the predictor leaves.
    pub fn velocity_delay(&self, period: f64) -> f64 {
        ((1.0 - self.prediction) * (self.delay_cycles + self.velocity_lag_cycles) + 0.5) * period
    }

    /// `(d + velocity_lag + ½) T` [s]: the whole velocity delay, for the axes without a
    /// predictor ([`axis_masses`]).
    pub fn loop_velocity_delay(&self, period: f64) -> f64 {
        (self.delay_cycles + self.velocity_lag_cycles + 0.5) * period
    }

    /// The predictor's horizons `(n_x, n_v) = (d, d + velocity_lag)` [cycles], `(0, 0)`
    /// with the predictor off.
    pub fn horizons(&self) -> (usize, usize) {
        if self.prediction > 0.0 {
            (self.delay_cycles.round() as usize, (self.delay_cycles + self.velocity_lag_cycles).round() as usize)
        } else {
            (0, 0)
        }
    }
}

/// The impedance of one cycle and the bounds it respects.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Gains {
    /// The stiffness scheduled for (after clamping) [N/m].
    pub k_e: f64,
    pub m_d: f64,
    pub b_d: f64,
    /// Integral gain per cycle [-].
    pub sigma: f64,
    /// Delay floor on b_d [N·s/m] (bound 1).
    pub b_floor: f64,
    /// Largest b_d with `(b_d/m_d) τ ≤ α` [N·s/m] (bound 2).
    pub b_max: f64,
    /// `b_d T / (m_d + b_d T)` (bound 3).
    pub sigma_bound: f64,
}

/// Bound 1: `(1 − m_d/D)₊ k_e (d + ½) T` [N·s/m].
pub fn delay_floor(k_e: f64, m_d: f64, apparent_mass: f64, tau: f64) -> f64 {
    (1.0 - m_d / apparent_mass).max(0.0) * k_e * tau
}

/// Bound 3: `σ < b_d T / (m_d + b_d T)`.
pub fn sigma_bound(m_d: f64, b_d: f64, period: f64) -> f64 {
    b_d * period / (m_d + b_d * period)
}

/// Bound 2 on every axis of the Cartesian impedance (the scheduled law's free space and
/// the axes other than the force axis, which have no predictor): `m_i ≥ b_i τ_v / α` with
/// the whole velocity delay `τ_v = (d + velocity_lag + ½) T`.
///
/// The paper's `B_d = 500` (N·s/m, N·m·s/rad) on x, y and the rotations with `M_d = 1`
/// gives `(b/m) τ_v = 1.75` at d = 1 and 2.25 at d = 2, past the stability limit π/2 of
/// the delayed velocity loop: those axes chatter, held back only by joint friction, and
/// the chatter reaches the contact force (±0.3–0.8 N while sliding on `flat`, the
/// "stick-slip" of docs/controller.md). Raising the mass to the bound (3.2 at d = 2) keeps
/// the damping and stiffness (the steady behaviour) and only slows those axes' fastest
/// mode. Masses already above the bound are kept.
pub fn axis_masses(p: &ScheduleParams, m_d: &[f64; 6], b_d: &[f64; 6], period: f64) -> [f64; 6] {
    let tau_v = p.loop_velocity_delay(period);
    std::array::from_fn(|i| m_d[i].max(b_d[i] * tau_v / p.alpha))
}

/// Gains for stiffness `k_e` at control period `period`. Total: any `k_e`
/// (NaN, ±∞, negative) gives finite gains within every bound.
pub fn schedule(p: &ScheduleParams, k_e: f64, period: f64) -> Gains {
    let k = if k_e.is_nan() { p.k_max } else { k_e.clamp(p.k_min, p.k_max) };
    let (tau, tau_v) = (p.delay(period), p.velocity_delay(period));
    let m_d = p.m_d_min.max(k * (2.0 * p.zeta * tau_v / p.alpha).powi(2));
    let b_floor = delay_floor(k, m_d, p.apparent_mass, tau);
    let b_max = p.alpha * m_d / tau_v;
    let b_d = (2.0 * p.zeta * (k * m_d).sqrt()).max(p.floor_margin * b_floor);
    let bound = sigma_bound(m_d, b_d, period);
    let omega = (k / m_d).sqrt();
    let sigma = (p.sigma_fraction * bound).min(p.integral_bandwidth * omega * period);
    Gains { k_e: k, m_d, b_d, sigma, b_floor, b_max, sigma_bound: bound }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn acrylic_and_flat_numbers() {
        let p = ScheduleParams::default();
        // The delay floor for the paper's m_d = 1: 63 N·s/m at d = 1, 105 at d = 2.
        let f1 = delay_floor(50_000.0, 1.0, 6.4, 1.5e-3);
        let f2 = delay_floor(50_000.0, 1.0, 6.4, 2.5e-3);
        assert!((f1 - 63.3).abs() < 0.1 && (f2 - 105.5).abs() < 0.1, "{f1} {f2}");
        // With the predictor cancelling 3/4 of the d = 2 delay the velocity loop sees
        // τ_v = (¼ (2 + 2) + ½) T = 1.5 ms; without it 4.5 ms.
        assert!((p.velocity_delay(1e-3) - 1.5e-3).abs() < 1e-15);
        assert!((ScheduleParams { prediction: 0.0, ..p }.velocity_delay(1e-3) - 4.5e-3).abs() < 1e-15);
        let g = schedule(&p, 20_000.0, 1e-3);
        assert!((g.m_d - p.m_d_min.max(20_000.0 * (2.0 * 1.5e-3 / 0.7f64).powi(2))).abs() < 1e-12, "{g:?}");
        // Soft surfaces sit at the floor: 0.125 kg (0.1 kg realised under a
        // model 1.25 × too heavy).
        assert_eq!(p.m_d_min, 0.125);
        let g = schedule(&p, 1000.0, 1e-3);
        assert_eq!(g.m_d, 0.125);
        assert!((g.b_d - 2.0 * (1000.0f64 * 0.125).sqrt()).abs() < 1e-9);
        let g = schedule(&p, 50_000.0, 1e-3);
        assert!(g.m_d > 0.9 && g.b_d > g.b_floor && g.b_d <= g.b_max * (1.0 + 1e-12), "{g:?}");
        // the paper's b_d = 40 is below the floor of its own m_d = 1 on acrylic
        assert!(40.0 < f1);
    }

    proptest! {
        /// Every bound, every cycle, for any input: b_d ≥ floor, (b_d/m_d)τ ≤ α,
        /// 0 ≤ σ < its bound, m_d ≥ m_d_min, nothing NaN.
        #[test]
        fn bounds_hold_for_any_stiffness_and_design(
            k in prop_oneof![any::<f64>(), 0.0..2.0e5f64],
            d in 0.0..3.0f64,
            zeta in 0.6..1.5f64,
            alpha in 0.2..1.5f64,
            m_min in 0.05..2.0f64,
            period in 2.5e-4..4e-3f64,
        ) {
            let p = ScheduleParams { delay_cycles: d, zeta, alpha, m_d_min: m_min, floor_margin: 1.0, ..Default::default() };
            prop_assume!(p.validate().is_ok());
            let g = schedule(&p, k, period);
            for v in [g.k_e, g.m_d, g.b_d, g.sigma, g.b_floor, g.sigma_bound] {
                prop_assert!(v.is_finite(), "{:?}", g);
            }
            prop_assert!(g.m_d >= m_min);
            let floor = delay_floor(g.k_e, g.m_d, p.apparent_mass, p.delay(period));
            prop_assert!(g.b_d >= p.floor_margin * floor * (1.0 - 1e-12), "{:?}", g);
            prop_assert!(g.b_d * p.velocity_delay(period) / g.m_d <= p.alpha * (1.0 + 1e-9), "{:?}", g);
            prop_assert!(g.sigma >= 0.0 && g.sigma < sigma_bound(g.m_d, g.b_d, period), "{:?}", g);
        }
    }

    proptest! {
        /// Every Cartesian axis: `(b_i / m_i) τ_v ≤ α` with the whole loop delay, masses
        /// never lowered, damping and stiffness untouched.
        #[test]
        fn axis_masses_bound_every_axis(
            m in proptest::array::uniform6(0.01..10.0f64),
            b in proptest::array::uniform6(0.0..2000.0f64),
            d in 0.0..4.0f64,
        ) {
            let p = ScheduleParams { delay_cycles: d, ..Default::default() };
            let out = axis_masses(&p, &m, &b, 1e-3);
            for i in 0..6 {
                prop_assert!(out[i] >= m[i] && out[i].is_finite());
                prop_assert!(b[i] * p.loop_velocity_delay(1e-3) / out[i] <= p.alpha * (1.0 + 1e-12));
            }
        }
    }

    #[test]
    fn paper_tangential_impedance_is_past_the_delay_limit() {
        // B_d = 500, M_d = 1 (x, y, rotations): (b/m) τ_v = 2.25 at d = 2 > π/2; raised to 3.2.
        let p = ScheduleParams::default();
        assert!(500.0 * p.loop_velocity_delay(1e-3) > std::f64::consts::FRAC_PI_2);
        let m = axis_masses(&p, &[1.0; 6], &[500.0, 500.0, 40.0, 500.0, 500.0, 500.0], 1e-3);
        assert!((m[0] - 500.0 * 4.5e-3 / 0.7).abs() < 1e-12 && m[2] == 1.0, "{m:?}");
    }

    #[test]
    fn bad_settings_are_named() {
        let p = ScheduleParams { alpha: 2.0, ..Default::default() };
        assert!(p.validate().unwrap_err().to_string().contains("alpha"));
        let p = ScheduleParams { k_min: 1e6, ..Default::default() };
        assert!(p.validate().unwrap_err().to_string().contains("k_min"));
        assert!(ScheduleParams::default().validate().is_ok());
    }
}
