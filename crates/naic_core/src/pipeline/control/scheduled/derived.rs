//! The scheduled law along the force axis `n`, derived from the loop model
//! (docs/controller.md, "The scheduled law"): eq 6 with `k_d = 0` on `n` and the measured
//! force fed forward, in I-P form: `ë = (f − b_d ė − I) / m_d` with the integral
//! `I_{k+1} = I_k + k_i T (f_d − f_m)` (the force it asks for; the target enters through it
//! alone, so a step of `f_d` meets no zero of the controller: the step response is the loop's
//! poles'), whose gains `m_d`, `b_d`, `k_i` are the
//! rule of [`crate::force_design::rule`] evaluated every cycle from the contact's bounds
//! (`k̄`, `k_low`, `μ̄`), the model's apparent mass `D̂` along `n` at this pose, the loop
//! delay `d` and the period `T`. `I` starts at the force measured at contact (bumpless).
//!
//! The contact's bounds come from a [`ContactEstimate`]. STAND-IN (until the contact
//! estimator of issue 42 item 3 is merged): [`StandIn`], a secant stiffness from the contact
//! point whose upper bound starts at `k_max` and only falls; the simulator's `oracle` gives
//! the true `k_e` instead.
//!
//! Pure: `(params, state, inputs) → (state, outputs)`, no allocation.

use crate::force_design::rule::{self, RuleInputs};

/// The contact estimate the law uses (the interface agreed with the contact estimator).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEstimate {
    /// `k̂_e` [N/m].
    pub k_hat: f64,
    /// `k̄`: upper bound, falls only on evidence [N/m].
    pub k_upper: f64,
    /// Lower bound [N/m].
    pub k_lower: f64,
    /// Surface position along n [m].
    pub x_e: f64,
    /// Surface velocity along n [m/s].
    pub x_e_dot: f64,
    /// Feed-through `μ̂` in [0, 1].
    pub mu_hat: f64,
    pub mu_upper: f64,
}

/// The law's parameters (docs/controller.md's table; ROS parameters `scheduled.*`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedParams {
    /// `d` [periods]: the loop delay the gains are designed for (measure it on the chain).
    pub delay_cycles: f64,
    /// `k_max` [N/m]: the stiffest surface expected; `k̄` before any evidence.
    pub k_max: f64,
    /// `k_min` [N/m]: the softest surface expected; the integral is set for it until the
    /// estimate's lower bound is higher.
    pub k_min: f64,
    /// `μ_max`: the contact's feed-through bound (1: any contact, rigid or soft constraint;
    /// 0: a pure spring).
    pub mu_max: f64,
    /// `b̄_e` [N·s/m]: the surface damping the gains are designed for.
    pub b_e_max: f64,
    /// The tip's position resolution along n [m]: the stand-in estimate takes a penetration
    /// as evidence above 10 of them.
    pub x_resolution: f64,
}

impl Default for DerivedParams {
    fn default() -> Self {
        Self { delay_cycles: 1.0, k_max: 200_000.0, k_min: 100.0, mu_max: 1.0, b_e_max: 50.0, x_resolution: 2e-6 }
    }
}

impl DerivedParams {
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        use crate::pipeline::ConfigError;
        let pos = |name: &str, v: f64, what: &str| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(ConfigError::invalid(name, v, what)) }
        };
        if !(self.delay_cycles.is_finite() && (0.0..=50.0).contains(&self.delay_cycles)) {
            return Err(ConfigError::invalid("scheduled.delay_cycles", self.delay_cycles, "must be in [0, 50] periods (the measured loop delay)"));
        }
        pos("scheduled.k_min", self.k_min, "must be > 0 N/m (the softest surface expected, e.g. 100)")?;
        pos("scheduled.k_max", self.k_max, "must be > 0 N/m (the stiffest surface expected, e.g. 200000)")?;
        if self.k_max < self.k_min {
            return Err(ConfigError::invalid("scheduled.k_max", self.k_max, format!("must be at least scheduled.k_min = {}", self.k_min)));
        }
        if !(self.mu_max.is_finite() && (0.0..=1.0).contains(&self.mu_max)) {
            return Err(ConfigError::invalid("scheduled.mu_max", self.mu_max, "must be in [0, 1] (1: any contact)"));
        }
        if !(self.b_e_max.is_finite() && self.b_e_max >= 0.0) {
            return Err(ConfigError::invalid("scheduled.b_e_max", self.b_e_max, "must be >= 0 N·s/m"));
        }
        pos("scheduled.x_resolution", self.x_resolution, "must be > 0 m (the encoders' resolution at the tip, e.g. 2e-6)")
    }
}

/// STAND-IN contact estimate (see the module's doc): the contact point `x_c`, `f_c` at entry;
/// the secant `k_s = (f − f_c) / (x − x_c)` once the penetration exceeds 10 resolutions;
/// `k̄ = min(k̄, 2 k_s)` (falls only), `k_low = max(k_min, k_s / 2)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StandIn {
    pub x_c: f64,
    pub f_c: f64,
    pub k_upper: f64,
    pub k_lower: f64,
    pub k_hat: f64,
}

impl StandIn {
    pub fn start(p: &DerivedParams, x: f64, f: f64) -> Self {
        Self { x_c: x, f_c: f, k_upper: p.k_max, k_lower: p.k_min, k_hat: p.k_max }
    }

    fn step(&self, p: &DerivedParams, x: f64, f: f64) -> Self {
        let pen = x - self.x_c;
        let mut s = *self;
        if pen > 10.0 * p.x_resolution && f > self.f_c {
            let k_s = (f - self.f_c) / pen;
            s.k_hat = k_s.clamp(p.k_min, p.k_max);
            s.k_upper = self.k_upper.min((2.0 * k_s).max(p.k_min));
            s.k_lower = (0.5 * k_s).clamp(p.k_min, s.k_upper);
        }
        s
    }

    fn estimate(&self, p: &DerivedParams) -> ContactEstimate {
        ContactEstimate { k_hat: self.k_hat, k_upper: self.k_upper, k_lower: self.k_lower, x_e: self.x_c, x_e_dot: 0.0, mu_hat: p.mu_max, mu_upper: p.mu_max }
    }
}

/// What the law remembers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedState {
    /// `I` [N].
    pub integral: f64,
    pub stand_in: StandIn,
    /// The gains of the last cycle.
    pub m_d: f64,
    pub b_d: f64,
    pub k_i: f64,
}

impl DerivedState {
    pub fn new(p: &DerivedParams) -> Self {
        Self { integral: 0.0, stand_in: StandIn::start(p, 0.0, 0.0), m_d: 1.0, b_d: 1.0, k_i: 0.0 }
    }

    /// A new contact at `x` with force `f`: `I = f` (bumpless).
    pub fn rearm(&self, p: &DerivedParams, x: f64, f: f64) -> Self {
        Self { integral: f, stand_in: StandIn::start(p, x, f), ..*self }
    }
}

/// One contact cycle's inputs along n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedInputs {
    pub x: f64,
    /// `ė = ẋ_d − ẋ` [m/s].
    pub e_dot: f64,
    pub f_ext: f64,
    pub f_d: f64,
    /// `D̂` [kg] (NaN: unknown, the rule takes 1 kg... see [`rule::gains`]).
    pub mass: f64,
    /// A stiffness known to the owner (the simulator's `oracle`): `k̂ = k̄ = k_low` = it.
    pub k_known: Option<f64>,
}

/// The outputs: `ë` along n [m/s²] and the estimate used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedOutputs {
    pub e_ddot: f64,
    pub e_f: f64,
    pub estimate: ContactEstimate,
}

/// One contact cycle. `period` is `T` [s], `integral_limit` bounds `|I|` [N].
pub fn step(p: &DerivedParams, period: f64, integral_limit: f64, s: &DerivedState, u: &DerivedInputs) -> (DerivedState, DerivedOutputs) {
    let mut next = *s;
    next.stand_in = s.stand_in.step(p, u.x, u.f_ext);
    let est = match u.k_known {
        Some(k) => ContactEstimate { k_hat: k, k_upper: k, k_lower: k, ..next.stand_in.estimate(p) },
        None => next.stand_in.estimate(p),
    };
    let g = rule::gains(&RuleInputs {
        k_upper: est.k_upper,
        k_lower: est.k_lower,
        mu_upper: est.mu_upper,
        b_e_max: p.b_e_max,
        mass: u.mass,
        delay: p.delay_cycles,
        period,
    });
    let e_f = u.f_ext - u.f_d;
    // ë = (f − b_d ė − I) / m_d: I is the force the law asks for (I-P form).
    let e_ddot = (u.f_ext - g.b_d * u.e_dot - s.integral) / g.m_d;
    let lim = if integral_limit.is_finite() && integral_limit > 0.0 { integral_limit } else { f64::INFINITY };
    next.integral = (s.integral + g.k_i * period * (u.f_d - u.f_ext)).clamp(-lim, lim);
    next.m_d = g.m_d;
    next.b_d = g.b_d;
    next.k_i = g.k_i;
    (next, DerivedOutputs { e_ddot, e_f, estimate: est })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a mass–spring with the measured force fed forward (the arm realises `ẍ = V`),
    /// the law settles on the target force within 10 s with no steady error (μ̄ = 1: the
    /// soft surface is slow, docs/controller.md), on a soft and a stiff
    /// surface, and the stand-in's `k̄` never rises.
    #[test]
    fn the_law_settles_on_a_spring_and_k_upper_only_falls() {
        for k_e in [300.0, 2000.0, 50_000.0] {
            let p = DerivedParams::default();
            let mut s = DerivedState::new(&p).rearm(&p, 0.0, 0.0);
            let (mut x, mut v) = (0.0f64, 0.0f64);
            let t = 1e-3;
            let f_d = 10.0;
            let mut k_prev = f64::INFINITY;
            let mut f = 0.0;
            for _ in 0..10_000 {
                f = k_e * x.max(0.0) + 0.5; // a 0.5 N bias the integral must remove
                let (n, o) = step(&p, t, 100.0, &s, &DerivedInputs { x, e_dot: -v, f_ext: f, f_d, mass: 3.19, k_known: None });
                assert!(o.estimate.k_upper <= k_prev, "k̄ rose");
                k_prev = o.estimate.k_upper;
                s = n;
                let a = -o.e_ddot; // ẍ = ẍ_d − ë, ẍ_d = 0
                v += a * t;
                x += v * t;
            }
            assert!((f - f_d).abs() < 0.05, "k_e {k_e}: f {f}");
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let p = DerivedParams { k_max: 10.0, ..Default::default() };
        assert!(p.validate().unwrap_err().to_string().contains("scheduled.k_max"));
        let p = DerivedParams { mu_max: 2.0, ..Default::default() };
        assert!(p.validate().unwrap_err().to_string().contains("scheduled.mu_max"));
        assert!(DerivedParams::default().validate().is_ok());
    }
}
