//! The scheduled law's gain rule: `m_d`, `b_d`, `k_i` along the force axis as closed forms
//! of the stiffness bounds `k̄` / `k_low`, the model's apparent mass `D̂`, the loop delay `d`
//! and the period `T` (docs/notes/2026-12-06-issue42-derived-law.md). No stiffness
//! threshold, no regime switch: each bound below is one inequality of the loop model
//! ([`super::model`]), and the rule takes the largest of them.
//!
//! With eq 6's measured force fed forward the loop along n is the target impedance
//! `m_d ẍ + b_d ẋ + k_e x = f_d + I` behind the delays `τ_f = (d + ½) T` (force) and
//! `τ_v = (d + d_v + ½) T` (velocity):
//!
//! - (R1) quasi-static: a contact that passes a fraction `μ` of a push to the force within
//!   the loop's reaction time `(d + 1) T` gives `e_k = (1 − μ) e_{k−1} + μ (1 − F D̂/m_d) e_{k−1−d}`
//!   (design note, eq 2), stable for `μ F D̂/m_d` below 0.7–2 (d = 3 … 0, small μ) and below
//!   2 at `μ = 1`. The rule takes `m_d ≥ 2 μ_eff D̂`, so `μ_eff F D̂/m_d ≤ F/2 ≤ 0.7` for
//!   every mass error `F ≤ 1.4`. `μ_eff` is the largest of: the contact's feed-through bound
//!   `μ̄` (a soft constraint or rigid contact), a spring's `1 − cos(√(k̄/D̂) (d + 1) T)` (the
//!   fraction of a force step a spring passes within `(d + 1) T`) and a surface damper's
//!   `b̄_e (d + 1) T / D̂`, at most 1;
//! - (R2) damping at the stiffest surface: `b_d = 2 ζ_b √(k̄ m_d)`, so the impedance's
//!   damping `b_d / (2 √(k_e m_d))` is at least `ζ_b` for every `k_e ≤ k̄`;
//! - (R3) the velocity loop `m_d s + b_d e^{−s τ_v}` crosses over at `b_d/m_d` and loses
//!   `(b_d/m_d) τ_v` of phase: `(b_d/m_d) τ_v ≤ α_v`, which with (R2) is
//!   `m_d ≥ (2 ζ_b τ_v / α_v)² k̄`;
//! - (R4) the integral `İ = k_i (f_d − f_m)` on the overdamped force loop
//!   `(b_d/k_e) ė = −e − k_i ∫e` has damping `½ √(k_e / (b_d k_i))`: `k_i = k_low / (4 ζ_i² b_d)`
//!   keeps it at least `ζ_i` for every `k_e ≥ k_low`.
//!
//! So `m_d = max(2 μ_eff D̂, (2 ζ_b τ_v / α_v)² k̄)`, `b_d = 2 ζ_b √(k̄ m_d)`,
//! `k_i = k_low / (4 ζ_i² b_d)`. The constants are the design's targets, not fits: `ζ_b` = 0.75 (the 0.7 goal with a margin), `ζ_i` = 0.9 (with the force target entering
//! through the integral alone, the law's I-P form, the integral pair at 0.9 answers a step
//! of `f_d` without overshoot on the loop model; at 0.75 it overshoots 3–5 %), `α_v` = 0.35 rad (20°: the velocity loop's
//! share of the phase, leaving the 45° goal to the force path); the grid test in
//! `force_design::tests` checks the whole rule on the loop model.

use super::model::Gains;

/// `ζ_b`: the impedance's damping at the stiffest surface `k̄` (R2).
pub const ZETA_B: f64 = 0.75;
/// `ζ_i`: the integral mode's damping at the softest surface `k_low` (R4).
pub const ZETA_I: f64 = 0.9;
/// `α_v` [rad]: the phase the velocity loop may lose to its delay at its crossover (R3).
pub const ALPHA_V: f64 = 0.35;
/// `c_μ`: `m_d ≥ c_μ μ_eff D̂` (R1).
pub const C_MU: f64 = 2.0;
/// `d_v` [periods]: the velocity's lag beyond the loop delay (the 5-sample median: 2; the derived
/// law's velocity observer is placed to lag as much, `derived::OBSERVER_POLE_T`).
pub const VELOCITY_LAG: u32 = 2;

/// What the rule is given (every cycle in the law).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RuleInputs {
    /// `k̄` [N/m]: the contact's stiffness upper bound (falls only on evidence).
    pub k_upper: f64,
    /// `k_low` [N/m]: its lower bound (> 0).
    pub k_lower: f64,
    /// `μ̄`: the contact's feed-through upper bound in [0, 1].
    pub mu_upper: f64,
    /// `b̄_e` [N·s/m]: the surface damping the law is designed for.
    pub b_e_max: f64,
    /// `D̂` [kg]: the model's apparent mass along n at this pose.
    pub mass: f64,
    /// `d` [periods]: the loop delay.
    pub delay: f64,
    /// `T` [s]: the control period.
    pub period: f64,
}

/// `τ_v = (d + d_v + ½) T` [s].
pub fn velocity_delay(delay: f64, period: f64) -> f64 {
    (delay + VELOCITY_LAG as f64 + 0.5) * period
}

/// The gains (R1–R4). Finite and positive for finite positive inputs; a non-finite or
/// non-positive input is clamped to the safe side (a heavier, more damped impedance, no
/// integral), so the 1 kHz path never divides by zero.
pub fn gains(u: &RuleInputs) -> Gains {
    let mass = if u.mass.is_finite() && u.mass > 0.0 { u.mass } else { 1.0 };
    let k_up = if u.k_upper.is_finite() && u.k_upper > 0.0 { u.k_upper } else { 1.0 };
    let k_lo = if u.k_lower.is_finite() && u.k_lower > 0.0 { u.k_lower.min(k_up) } else { 0.0 };
    let (d, t) = (u.delay.max(0.0), u.period.max(0.0));
    let m_d = (C_MU * feedthrough_bound(u.mu_upper, k_up, u.b_e_max, mass, d, t) * mass).max((2.0 * ZETA_B * velocity_delay(d, t) / ALPHA_V).powi(2) * k_up);
    let b_d = 2.0 * ZETA_B * (k_up * m_d).sqrt();
    let k_i = k_lo / (4.0 * ZETA_I * ZETA_I * b_d);
    Gains { m_d, b_d, k_i }
}

/// `μ_eff` of (R1): `max(μ̄, 1 − cos(√(k̄/D̂) (d + 1) T), b̄_e (d + 1) T / D̂)`, at most 1
/// (a non-finite `μ̄` or `b̄_e` counts as 1: the safe side).
pub fn feedthrough_bound(mu_upper: f64, k_upper: f64, b_e_max: f64, mass: f64, delay: f64, period: f64) -> f64 {
    let window = (delay + 1.0) * period;
    let mu = if mu_upper.is_finite() { mu_upper.max(0.0) } else { 1.0 };
    let spring = 1.0 - ((k_upper / mass).sqrt() * window).min(std::f64::consts::PI).cos();
    let damper = if b_e_max.is_finite() { b_e_max.max(0.0) * window / mass } else { 1.0 };
    mu.max(spring).max(damper).min(1.0)
}
