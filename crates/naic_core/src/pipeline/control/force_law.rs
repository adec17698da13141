//! The force-tracking laws on one Cartesian axis: fixed impedance (eq 8),
//! AIC (eq 9, the Jung et al. law) and NAIC (eq 10–15).
//!
//! Everything here is scalar and allocation-free. The caller projects the
//! Cartesian quantities onto the force axis `n` (a unit vector of the base
//! frame, e.g. `-z` to push down on a table) and maps the returned commanded
//! acceleration back (see [`super`]).
//!
//! # Signs (checked, not assumed)
//!
//! * `f_ext` is the force the robot applies to the environment along `n`,
//!   positive when pushing; `f_d` is its desired value (10 N in §4.1).
//! * `e = x_d − x` along `n` (position error, eq 7), `ė = ẋ_d − ẋ`, `ë = ẍ_d − ẍ`.
//! * `e_f = f_ext − f_d` (paper §3.2).
//!
//! Eq 8 in contact (k_d = 0) reads `e_f = m_d ë + b_d ė`. Solving for the
//! acceleration error the impedance law must impose gives
//! `ë = (e_f − b_d ė) / m_d`, so the commanded acceleration along `n` is
//! `ẍ = ẍ_d − ë = ẍ_d + (b_d ė + f_d − f_ext) / m_d`: when the robot pushes
//! less than desired (`f_ext < f_d`) it accelerates into the surface. With the
//! environment `f_ext = k_e (x − x_e)` this closes to
//! `m_d ẍ + b_d ẋ + k_e x = f_d + k_e x_e`, a stable second-order system whose
//! rest point is `f_ext = f_d`.
//!
//! AIC (eq 9) adds `b_d Φ(t)` with `Φ(t) = Φ(t−λ) + σ (f_d − f_ext)(t−λ) / b_d`:
//! `e_f = m_d ë + b_d ė + b_d Φ(t)`, i.e. `ẍ = ẍ_d + (b_d ė + b_d Φ(t) − e_f) / m_d`.
//! `b_d Φ` is `σ` times the running sum of `f_d − f_ext`: a discrete integral
//! of the force error with gain `σ/λ` per second. The sign is the one that
//! removes a steady error — a persistent shortfall (`f_ext < f_d`) makes `Φ`
//! grow and the robot push harder. The pitfall reported for this family of laws
//! is the opposite sign on the `Φ` update (or on `Δb_d = b_d Φ / ė` when `ė`
//! is read with the other convention `e = x − x_d`), which turns the integral
//! into positive feedback. The tests check both: the law as written settles on
//! a mass–spring plant with zero steady error, the flipped sign diverges.
//!
//! NAIC (eq 11–12) reads eq 10 as a linear neuron
//! `e_f(t) = w₁ f₁ + w₂ f₂ + w₃ f₃` with weights `w = (m_d, b_d, σ)` and
//! hidden values `f₁ = ë`, `f₂ = ė + Φ(t−λ)`, `f₃ = f_d(t−λ) − f_ext(t−λ)`.
//! The paper's eq 11 lists the fourth input as `e_f(t−λ) = f_ext − f_d`, but
//! eq 10 — which NAIC must reduce to when γ = 0 (stated below eq 15) — has
//! `+σ (f_d − f_ext)(t−λ)`; with `f₃ = +e_f(t−λ)` the NAIC law would differ
//! from AIC by the sign of its integral term. We therefore take
//! `f₃ = −e_f(t−λ)` so that `w₃ = σ` and γ = 0 gives AIC exactly (tested).
//!
//! Each cycle NAIC (1) forms `f_i(t)`, (2) updates the weights by eq 14–15,
//! `w_i ← w_i − γ e_f(t) f_i(t)`, with `γ` clipped to
//! `2 Σ f_i² / Σ f_i⁴` (eq 15; reported in the outputs), then (3) solves its
//! neuron for the acceleration error, `ë = (e_f − b_d f₂ − σ f₃) / m_d`, with
//! the updated weights, and (4) advances `Φ(t) = Φ(t−λ) + σ f₃ / b_d`.
//! `ë(t)` is not known before the law has run, so `f₁` is the acceleration
//! error the law imposed on the previous cycle; the computed-torque inner loop
//! realises it up to model error, and unlike a twice-differentiated encoder
//! signal it is free of noise. The paper bounds γ but not the weights; so that
//! a large update can never make `m_d ≤ 0` (a division by zero in step 3) the
//! weights are projected onto [`WeightBounds`] after each update, and the
//! outputs say when that happened.
//!
//! # What the law as written does to σ
//!
//! `∂L/∂σ = e_f(t) f₃ = −e_f(t) e_f(t−λ)`, which at 1 kHz is `≈ −e_f² ≤ 0`:
//! gradient descent raises σ on every cycle with a force error and never
//! lowers it. σ is the integral gain of the force loop (`σ/λ` per second),
//! and the loop is stable only for `σ < λ b_d / m_d`
//! ([`sigma_stability_limit`]). With any γ large enough to matter (1e-5 and
//! up on the paper's §4.1 numbers) σ climbs past that limit within a fraction
//! of a second and the contact force oscillates with growing amplitude (test
//! `naic_as_written_drives_sigma_past_the_stability_limit`). NAIC therefore
//! also projects σ below `sigma_margin` times that limit; `sigma_margin = ∞`
//! restores the law as written.

use super::derived::DerivedParams;
use super::scheduled::ScheduledParams;

/// Which law runs on the force axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Fixed impedance, eq 6–8: the parameters never change.
    Fixed,
    /// Adaptive impedance control, eq 9 (Jung et al.).
    Aic,
    /// Neural adaptive impedance control, eq 10–15.
    Naic,
    /// The stiffness-scheduled law of [`super::scheduled`] (not a paper law).
    Scheduled,
    /// The law derived from the loop model, [`super::derived`] (not a paper law): gains from
    /// the contact estimator's bounds by [`crate::force_design::rule`].
    Derived,
}

impl Mode {
    /// The name used on the command line, in ROS parameters and in `/naic/params`.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Fixed => "fixed",
            Mode::Aic => "aic",
            Mode::Naic => "naic",
            Mode::Scheduled => "scheduled",
            Mode::Derived => "derived",
        }
    }

    /// Every mode, paper laws first.
    pub const ALL: [Mode; 5] = [Mode::Naic, Mode::Aic, Mode::Fixed, Mode::Scheduled, Mode::Derived];

    /// Parses `fixed`, `aic`, `naic`, `scheduled` or `derived`.
    pub fn parse(s: &str) -> Result<Mode, crate::pipeline::ConfigError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "fixed" => Ok(Mode::Fixed),
            "aic" => Ok(Mode::Aic),
            "naic" => Ok(Mode::Naic),
            "scheduled" => Ok(Mode::Scheduled),
            "derived" => Ok(Mode::Derived),
            other => Err(crate::pipeline::ConfigError::invalid("controller mode", format!("'{other}'"), "is unknown: use naic, aic, fixed, scheduled or derived")),
        }
    }
}

/// Box constraints applied to the NAIC weights after every update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightBounds {
    /// Bounds of `m_d` [kg]; the lower bound must be > 0.
    pub m_d: (f64, f64),
    /// Bounds of `b_d` [N·s/m]; the lower bound must be > 0 (Φ divides by it).
    pub b_d: (f64, f64),
    /// Bounds of `σ` [-].
    pub sigma: (f64, f64),
}

impl Default for WeightBounds {
    fn default() -> Self {
        Self { m_d: (0.05, 100.0), b_d: (1.0, 1.0e4), sigma: (0.0, 1.0) }
    }
}

/// The requested NAIC learning rate `γ` used by default everywhere (simulator, CLI, the
/// `naic_controller` node). The paper gives no value; eq 15 only bounds it. 1e-4 is the
/// setting of the simulation studies in the README (γ sweep): 1e-3 drives m_d to its floor
/// and 1e-2 never settles after a stiffness step, and on the ROS chain γ = 1e-2 spun the
/// wrist beyond 2π rad/s at first contact.
pub const DEFAULT_GAMMA: f64 = 1e-4;

/// Parameters of the force law on the force axis in contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLawParams {
    pub mode: Mode,
    /// Initial update rate `σ` of eq 9 (NAIC weight w₃). The initial `m_d`
    /// and `b_d` are the force axis's entries of the impedance parameters.
    pub sigma: f64,
    /// Requested learning rate `γ` of eq 15 (NAIC only; clipped to the bound every step).
    pub gamma: f64,
    pub bounds: WeightBounds,
    /// Controller sampling period `λ` [s] (enters only the σ stability bound).
    pub lambda: f64,
    /// NAIC keeps `σ ≤ sigma_margin · λ · b_d / m_d`, a fraction of the
    /// stability limit of the force loop (see [`sigma_stability_limit`]).
    /// `f64::INFINITY` disables it and leaves the paper's law as written
    /// (plus the [`WeightBounds`] box).
    pub sigma_margin: f64,
    /// Anti-windup of eq 9's integral: `|b_d Φ| ≤ integral_limit_n` [N]. `b_d Φ` is σ times
    /// the running sum of `f_d − f_ext`; with the arm blocked (held, or pushing on something
    /// that does not give) it would grow without bound and so would the torque. The
    /// controller sets it to its contact-force limit: a correction larger than the force
    /// the robot may apply is never needed. `f64::INFINITY` leaves eq 9 as written.
    /// The scheduled law clamps its integral with the same limit.
    pub integral_limit_n: f64,
    /// Settings of [`Mode::Scheduled`] (unused by the paper laws; [`Mode::Derived`] shares
    /// its reference shaping, axis impedance bound and approach).
    pub scheduled: ScheduledParams,
    /// Settings of [`Mode::Derived`] (unused by the other laws).
    pub derived: DerivedParams,
}

/// The largest `σ` for which the AIC/NAIC force loop is stable.
///
/// In contact with `x_d` constant, eq 9 with `b_d Φ ≈ −(σ/λ) ∫ e_f dt` and an
/// environment `f_ext = k_e (x − x_e)` gives
/// `m_d x⃛ + b_d ẍ + k_e ẋ + (σ/λ) k_e x = const`. Routh–Hurwitz on
/// `m_d s³ + b_d s² + k_e s + (σ/λ) k_e` requires `b_d k_e > m_d (σ/λ) k_e`:
/// `σ < λ b_d / m_d`, whatever the (unknown) stiffness `k_e`. With the
/// paper's `λ = 1 ms`, `b_d = 40`, `m_d = 1` the limit is 0.04 (paper: 0.01).
pub fn sigma_stability_limit(lambda: f64, m_d: f64, b_d: f64) -> f64 {
    lambda * b_d / m_d
}

/// What the force law remembers between cycles (one place for all of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLawState {
    /// Current weights (`m_d`, `b_d`, `σ`): constant for fixed/AIC, learned by NAIC.
    pub m_d: f64,
    pub b_d: f64,
    pub sigma: f64,
    /// `Φ(t−λ)` of eq 9 [m/s].
    pub phi: f64,
    /// `e_f(t−λ)` [N].
    pub e_f_prev: f64,
    /// The acceleration error `ë` imposed on the previous cycle [m/s²] (NAIC input f₁).
    pub edd_prev: f64,
}

impl ForceLawState {
    /// State before the first contact: weights at their initial values
    /// (`m_d`, `b_d` of the force axis, `σ` of the law), `Φ = 0`.
    pub fn new(p: &ForceLawParams, m_d: f64, b_d: f64) -> Self {
        Self { m_d, b_d, sigma: p.sigma, phi: 0.0, e_f_prev: 0.0, edd_prev: 0.0 }
    }

    /// Re-arm for a new contact phase keeping the learned weights: `Φ = 0` and
    /// the one-step memories set from the current error, so the first update
    /// does not see stale values.
    pub fn rearm(&self, e_f_now: f64) -> Self {
        Self { phi: 0.0, e_f_prev: e_f_now, edd_prev: 0.0, ..*self }
    }
}

/// Inputs of the force law for one cycle, all along the force axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLawInputs {
    /// `ė = ẋ_d − ẋ` [m/s].
    pub e_dot: f64,
    /// Measured `f_ext` [N].
    pub f_ext: f64,
    /// Desired `f_d` [N].
    pub f_d: f64,
}

/// What the force law reports for one cycle.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ForceLawOutputs {
    /// Acceleration error to impose, `ë` [m/s²]; the commanded acceleration
    /// along the axis is `ẍ_d − ë`.
    pub e_ddot: f64,
    /// `e_f = f_ext − f_d` [N].
    pub e_f: f64,
    /// Learning rate applied this cycle (0 unless NAIC).
    pub gamma: f64,
    /// Eq 15 bound `2 Σ f_i² / Σ f_i⁴` this cycle (`+∞` when every `f_i` is 0).
    pub gamma_bound: f64,
    /// The requested γ exceeded the bound and was clipped to it.
    pub gamma_clipped: bool,
    /// A weight hit its [`WeightBounds`] and was projected back.
    pub weights_projected: bool,
    /// [`Mode::Scheduled`]: the stiffness estimate `k̂_e` [N/m] and its confidence in
    /// [0, 1] (0 for the paper laws, which estimate nothing).
    pub k_e_hat: f64,
    pub k_e_confidence: f64,
}

/// Eq 15: the largest learning rate for which ΔV ≤ 0 (eq 21).
/// Returns `+∞` when all hidden values are zero (any γ leaves the weights unchanged).
pub fn gamma_bound(f: &[f64; 3]) -> f64 {
    let s2: f64 = f.iter().map(|x| x * x).sum();
    let s4: f64 = f.iter().map(|x| x * x * x * x).sum();
    if s4 > 0.0 && s4.is_finite() {
        2.0 * s2 / s4
    } else if s2 == 0.0 {
        f64::INFINITY
    } else {
        // Σf⁴ overflowed: the bound is effectively zero.
        0.0
    }
}

/// One cycle of the force law in contact (k_d = 0 on the force axis). The
/// law is discrete: one call per sampling period `λ`; `λ` itself only enters
/// through the caller's rate.
///
/// Pure: `(params, state, inputs) -> (state, outputs)`.
pub fn step(p: &ForceLawParams, s: &ForceLawState, u: &ForceLawInputs) -> (ForceLawState, ForceLawOutputs) {
    let e_f = u.f_ext - u.f_d;
    let mut out = ForceLawOutputs { e_f, gamma_bound: f64::INFINITY, ..Default::default() };
    let mut next = *s;
    match p.mode {
        // The scheduled and derived laws run in `super::law` (the control stage dispatches);
        // called here it is fixed impedance with the current weights.
        Mode::Fixed | Mode::Scheduled | Mode::Derived => {
            // Eq 8 with k_d = 0: e_f = m_d ë + b_d ė.
            out.e_ddot = (e_f - s.b_d * u.e_dot) / s.m_d;
        }
        Mode::Aic | Mode::Naic => {
            // Hidden layer, eq 11 (with f₃ = f_d − f_ext at t−λ, see module docs).
            let f = [s.edd_prev, u.e_dot + s.phi, -s.e_f_prev];
            if p.mode == Mode::Naic {
                let bound = gamma_bound(&f);
                out.gamma_bound = bound;
                out.gamma_clipped = p.gamma > bound;
                out.gamma = p.gamma.min(bound).max(0.0);
                // Eq 14–15: w_i ← w_i − γ e_f f_i.
                let w = [
                    s.m_d - out.gamma * e_f * f[0],
                    s.b_d - out.gamma * e_f * f[1],
                    s.sigma - out.gamma * e_f * f[2],
                ];
                let b = &p.bounds;
                next.m_d = w[0].clamp(b.m_d.0, b.m_d.1);
                next.b_d = w[1].clamp(b.b_d.0, b.b_d.1);
                let sigma_max = (p.sigma_margin * sigma_stability_limit(p.lambda, next.m_d, next.b_d)).min(b.sigma.1);
                next.sigma = w[2].min(sigma_max).max(b.sigma.0);
                out.weights_projected = next.m_d != w[0] || next.b_d != w[1] || next.sigma != w[2];
            }
            // Eq 10 solved for ë with the current weights.
            out.e_ddot = (e_f - next.b_d * f[1] - next.sigma * f[2]) / next.m_d;
            // Eq 9: Φ(t) = Φ(t−λ) + σ (f_d − f_ext)(t−λ) / b_d, with |b_d Φ| ≤ the anti-windup limit.
            let phi_max = p.integral_limit_n / next.b_d;
            next.phi = (s.phi + next.sigma * f[2] / next.b_d).clamp(-phi_max, phi_max);
        }
    }
    next.e_f_prev = e_f;
    next.edd_prev = out.e_ddot;
    (next, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(mode: Mode, gamma: f64) -> ForceLawParams {
        ForceLawParams { mode, sigma: 0.01, gamma, bounds: WeightBounds::default(), lambda: 1e-3, sigma_margin: 0.5, integral_limit_n: f64::INFINITY, scheduled: ScheduledParams::default(), derived: DerivedParams::default() }
    }

    /// A 1-D plant: the impedance law's commanded acceleration is realised
    /// exactly (perfect inner loop), the environment is a spring at x_e.
    /// Returns the force history.
    fn simulate(p: &ForceLawParams, k_e: f64, f_d: f64, steps: usize, flip_phi: bool) -> Vec<f64> {
        let (x_e, dt) = (0.0, 1e-3);
        let mut s = ForceLawState::new(p, 1.0, 40.0);
        let (mut x, mut v, mut out) = (0.001, 0.0, Vec::with_capacity(steps));
        for _ in 0..steps {
            let f_ext = (k_e * (x - x_e)).max(0.0);
            let (mut n, o) = step(p, &s, &ForceLawInputs { e_dot: -v, f_ext, f_d });
            if flip_phi {
                // The sign pitfall: integrate f_ext − f_d instead of f_d − f_ext.
                n.phi = s.phi - (n.phi - s.phi);
            }
            s = n;
            let a = -o.e_ddot; // ẍ = ẍ_d − ë with ẍ_d = 0
            v += a * dt;
            x += v * dt;
            out.push(f_ext);
        }
        out
    }

    #[test]
    fn fixed_law_closes_to_the_target_impedance_relation() {
        // m_d ẍ + b_d ẋ + k_e x = f_d: rest at f_ext = f_d, overshoot of a
        // second-order system with ζ = b / (2 sqrt(m k)).
        let p = params(Mode::Fixed, 0.0);
        let f = simulate(&p, 2000.0, 10.0, 3000, false);
        assert!((f.last().unwrap() - 10.0).abs() < 1e-3, "settles at f_d: {}", f.last().unwrap());
        let zeta = 40.0 / (2.0 * (2000.0f64).sqrt());
        let expected_overshoot = (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
        let peak = f.iter().cloned().fold(f64::MIN, f64::max);
        let start = 2000.0 * 0.001;
        let overshoot = (peak - 10.0) / (10.0 - start);
        assert!((overshoot - expected_overshoot).abs() < 0.02, "overshoot {overshoot} vs {expected_overshoot}");
    }

    #[test]
    fn aic_as_written_settles_and_the_flipped_sign_diverges() {
        let p = params(Mode::Aic, 0.0);
        let good = simulate(&p, 2000.0, 10.0, 5000, false);
        assert!((good.last().unwrap() - 10.0).abs() < 1e-2, "AIC settles: {}", good.last().unwrap());
        let bad = simulate(&p, 2000.0, 10.0, 5000, true);
        let tail_err = bad[4000..].iter().map(|f| (f - 10.0).abs()).fold(0.0, f64::max);
        assert!(tail_err > 5.0, "flipped Φ sign must not track: worst tail error {tail_err}");
    }

    #[test]
    fn naic_with_zero_learning_rate_is_exactly_aic() {
        let aic = simulate(&params(Mode::Aic, 0.0), 2000.0, 10.0, 4000, false);
        let naic = simulate(&params(Mode::Naic, 0.0), 2000.0, 10.0, 4000, false);
        assert_eq!(aic, naic);
    }

    #[test]
    fn learning_rate_never_exceeds_the_eq15_bound() {
        let p = params(Mode::Naic, 1.0e3);
        let mut s = ForceLawState::new(&p, 1.0, 40.0);
        let mut clipped = 0;
        for k in 0..2000 {
            let t = k as f64 * 1e-3;
            let u = ForceLawInputs { e_dot: 0.01 * (7.0 * t).sin(), f_ext: 10.0 + 3.0 * (3.0 * t).cos(), f_d: 10.0 };
            let (n, o) = step(&p, &s, &u);
            assert!(o.gamma <= o.gamma_bound, "γ {} > bound {}", o.gamma, o.gamma_bound);
            assert!(o.gamma >= 0.0);
            clipped += o.gamma_clipped as usize;
            assert!(n.m_d >= p.bounds.m_d.0 && n.b_d >= p.bounds.b_d.0 && n.sigma >= p.bounds.sigma.0);
            assert!(o.e_ddot.is_finite());
            s = n;
        }
        assert!(clipped > 0, "a huge requested γ must be clipped");
    }

    #[test]
    fn gamma_bound_matches_eq15_and_makes_the_lyapunov_step_non_positive() {
        let f = [0.3, -1.2, 2.0];
        let b = gamma_bound(&f);
        let s2: f64 = f.iter().map(|x| x * x).sum();
        let s4: f64 = f.iter().map(|x| x.powi(4)).sum();
        assert_eq!(b, 2.0 * s2 / s4);
        // Eq 21: ΔV = γ e_f² Σ(½ γ f⁴ − f²) ≤ 0 for γ in [0, bound].
        for g in [0.0, 0.25 * b, 0.5 * b, b] {
            let dv = g * (0.5 * g * s4 - s2);
            assert!(dv <= 1e-12, "ΔV {dv} at γ {g}");
        }
        let g = 1.01 * b;
        assert!(g * (0.5 * g * s4 - s2) > 0.0, "just above the bound ΔV turns positive");
        assert_eq!(gamma_bound(&[0.0; 3]), f64::INFINITY);
    }

    #[test]
    fn naic_learns_in_the_direction_of_the_gradient() {
        // With γ small and below the bound, one step changes each weight by −γ e_f f_i.
        let p = params(Mode::Naic, 1e-6);
        let s = ForceLawState { m_d: 1.0, b_d: 40.0, sigma: 0.01, phi: 0.02, e_f_prev: -2.0, edd_prev: 0.5 };
        let u = ForceLawInputs { e_dot: 0.1, f_ext: 7.0, f_d: 10.0 };
        let (n, o) = step(&p, &s, &u);
        assert!(!o.gamma_clipped);
        let e_f = -3.0;
        let f = [0.5, 0.1 + 0.02, 2.0];
        assert!((n.m_d - (1.0 - 1e-6 * e_f * f[0])).abs() < 1e-15);
        assert!((n.b_d - (40.0 - 1e-6 * e_f * f[1])).abs() < 1e-12);
        assert!((n.sigma - (0.01 - 1e-6 * e_f * f[2])).abs() < 1e-15);
    }

    #[test]
    fn naic_as_written_drives_sigma_past_the_stability_limit() {
        // The paper's law (no σ projection) with a learning rate that matters:
        // σ only ever grows, leaves the stable range and the force diverges.
        let mut p = params(Mode::Naic, 1e-3);
        p.sigma_margin = f64::INFINITY;
        let f = simulate(&p, 2000.0, 10.0, 3000, false);
        let worst = f[2000..].iter().map(|x| (x - 10.0).abs()).fold(0.0, f64::max);
        assert!(worst > 20.0, "law as written should not settle: worst late error {worst}");
        // With σ kept below half the Routh limit the same γ settles.
        p.sigma_margin = 0.5;
        let f = simulate(&p, 2000.0, 10.0, 3000, false);
        let worst = f[2000..].iter().map(|x| (x - 10.0).abs()).fold(0.0, f64::max);
        assert!(worst < 0.05, "projected NAIC settles: worst late error {worst}");
    }

    #[test]
    fn sigma_stability_limit_is_the_routh_bound() {
        // AIC (σ fixed) on the 1-D plant: stable below λ b_d / m_d, unstable above.
        let lim = sigma_stability_limit(1e-3, 1.0, 40.0);
        assert!((lim - 0.04).abs() < 1e-15);
        for (sigma, stable) in [(0.8 * lim, true), (1.25 * lim, false)] {
            let mut p = params(Mode::Aic, 0.0);
            p.sigma = sigma;
            p.bounds.sigma = (0.0, 1.0);
            let f = simulate(&p, 5000.0, 10.0, 20000, false);
            let late = f[18000..].iter().map(|x| (x - 10.0).abs()).fold(0.0, f64::max);
            assert_eq!(late < 0.5, stable, "σ = {sigma}: late error {late}");
        }
    }

    #[test]
    fn mode_names_round_trip_and_bad_names_are_explained() {
        for m in Mode::ALL {
            assert_eq!(Mode::parse(m.as_str()), Ok(m));
        }
        let e = Mode::parse("pid").unwrap_err();
        assert!(matches!(&e, crate::pipeline::ConfigError::Invalid { field, value, .. } if field == "controller mode" && value == "'pid'"), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("pid") && e.contains("naic"), "{e}");
    }

    /// Anti-windup: with the arm blocked (no motion, the force stuck 10 N short of f_d),
    /// eq 9's integral b_d Φ stops at the limit and the commanded acceleration stays
    /// bounded; without the limit both grow without bound.
    #[test]
    fn a_blocked_arm_does_not_wind_up_the_integral() {
        for mode in [Mode::Aic, Mode::Naic] {
            let run = |limit: f64| {
                let p = ForceLawParams { integral_limit_n: limit, ..params(mode, 1e-4) };
                let mut s = ForceLawState::new(&p, 1.0, 40.0);
                let u = ForceLawInputs { f_ext: 0.0, f_d: 10.0, e_dot: 0.0 };
                let mut worst = (0.0f64, 0.0f64);
                for _ in 0..200_000 {
                    let (n, o) = step(&p, &s, &u);
                    s = n;
                    worst = (worst.0.max((s.b_d * s.phi).abs()), worst.1.max(o.e_ddot.abs()));
                }
                worst
            };
            let (integral, edd) = run(50.0);
            assert!(integral <= 50.0 * (1.0 + 1e-12), "{mode:?}: |b_d Φ| = {integral}");
            let (integral_free, edd_free) = run(f64::INFINITY);
            assert!(integral_free > 1000.0 && edd_free > 10.0 * edd, "{mode:?}: {integral_free} {edd_free} vs {edd}");
        }
    }
}
