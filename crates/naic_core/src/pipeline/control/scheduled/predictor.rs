//! Delay compensation (a Smith predictor on the force axis): the state of *now* from
//! measurements that are `d` cycles old and the accelerations the controller itself
//! commanded since.
//!
//! # Why
//!
//! The force loop sees `f` and `x` from `d` periods ago and a velocity that is another
//! `velocity_lag` periods older (the median filter). That delay, not the law, is what
//! bounds the gains (see [`super::schedule`]): `m_d ≥ k_e (2ζτ_v/α)²`, and a heavier
//! virtual mass lets more of the arm's friction disturbance `Δ` through — the
//! disturbance reaches the contact force scaled by `m_d / D`.
//!
//! # The model
//!
//! The computed-torque loop realises the commanded acceleration along `n`
//! (`D ẍ = D a + Δ` with the contact force fed forward, see below), so the change of the state over
//! the last cycles is known from the commands `a_j` (`a_1` applied over the last period,
//! zero-order hold):
//!
//! ```text
//! v̂(t)  = v_m + T Σ_{j=1..n_v} a_j                                  n_v = d + velocity_lag
//! Δx    = x(t) − x(t − dT) = d T v̂ − T² Σ_{j=1..d} (d − j + ½) a_j
//! f̂(t)  = max(0, f_m + k̂_e Δx)
//! ```
//!
//! (`Δx`: the mean velocity over the period `j` back is `v̂ − T(Σ_{i<j} a_i + ½ a_j)`.)
//! The law then works on `f̂`, `v̂` instead of the delayed `f_m`, `v_m`, and the
//! contact-force feedforward of eq 6 (`Jᵀ F_e`, which uses the delayed `f_m`) is
//! corrected by `(f̂ − f_m) / D` on the commanded acceleration so that the realised
//! acceleration is the intended one ([`super::step`]).
//!
//! # What it cannot predict, and the design margin
//!
//! Only the response to the controller's own commands is predicted; disturbances
//! (friction, the impact at first contact) still arrive `d` cycles late, which is what
//! the remaining feedback is for. A wrong model scales the predicted increments: with
//! the controller's dynamic model off by a factor `F` the realised acceleration is
//! `F a`, and the prediction error is `(F − 1)` of the increment — to first order a
//! residual delay of `(F − 1)·(n_v T)` (a lead for `F < 1`). The schedule is therefore
//! designed for the residual delay `(1 − prediction)·d`, with `prediction = 0.75` covering
//! the issue's model mass errors 0.8 and 1.25 ([`super::schedule::ScheduleParams::prediction`]).
//! The predictor is designed for the delay of the schedule (`delay_cycles`, d = 2); on a
//! faster loop (d = 1) it predicts one period ahead of now, a phase lead.

/// Commands remembered [cycles]; the horizons are clamped to it.
pub const HISTORY: usize = 8;

/// The accelerations along `n` commanded in the last [`HISTORY`] cycles, newest first [m/s²].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct History {
    pub accel: [f64; HISTORY],
}

impl History {
    /// Remember the command of this cycle (a non-finite command counts as zero).
    pub fn push(&mut self, a: f64) {
        self.accel.rotate_right(1);
        self.accel[0] = if a.is_finite() { a } else { 0.0 };
    }
}

/// The predicted change of the state between the measurement and now.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Prediction {
    /// `v̂ − v_m` [m/s].
    pub dv: f64,
    /// `Δx = x(t) − x(t − dT)` [m] for the predicted velocity.
    pub dx: f64,
}

/// Prediction over `n_x` cycles for position/force and `n_v` for velocity (both clamped to
/// [`HISTORY`]) from the velocity `v_m` of `n_v` cycles ago, with the acceleration `w` not
/// commanded (the observer's disturbance estimate, 0 without it) added to every command.
pub fn predict(h: &History, period: f64, n_x: usize, n_v: usize, v_m: f64, w: f64) -> Prediction {
    let (n_x, n_v) = (n_x.min(HISTORY), n_v.min(HISTORY));
    let dv = period * (h.accel[..n_v].iter().sum::<f64>() + n_v as f64 * w);
    let v_hat = v_m + dv;
    let mut dx = n_x as f64 * period * v_hat;
    for (j, a) in h.accel[..n_x].iter().enumerate() {
        // j = 0 is a_1: weight n_x − 1 + ½.
        dx -= period * period * (n_x as f64 - j as f64 - 0.5) * (a + w);
    }
    Prediction { dv, dx }
}

/// A velocity observer on the measurement's (delayed) time line: states `v̄` (the velocity
/// `n_v` cycles ago) and `w̄` (the acceleration the commands do not explain: friction, the
/// contact-force mismatch, a model error), driven by the command of that cycle,
///
/// ```text
/// v̄⁻ = v̄ + T (a_{n_v+1} + w̄),   ε = v_m − v̄⁻,   v̄ = v̄⁻ + L₁ ε,   w̄ ← w̄ + L₂ ε
/// L₁ = 1 − p²,   L₂ = (1 − p)² / T,   p = e^{−ω_o T}
/// ```
///
/// (both error poles at `p`: `(I − LC)A` has the characteristic polynomial `(z − p)²`).
/// Why: the measured velocity carries the encoders' noise (0.002 rad/s per joint in the
/// simulator, ≈ 0.6 mm/s at the tip after the median), and on a hard surface the damping
/// multiplies it by `b_d` ≈ 400 N·s/m — ±0.3 N of force noise at acrylic, more than the ±2 %
/// band. The observer takes the fast part of the velocity from the commands (noise-free)
/// and only the slow part (bandwidth `ω_o`) from the measurement.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Observer {
    pub v: f64,
    pub w: f64,
    /// Started (the first measurement initialises `v̄`).
    pub started: bool,
}

impl Observer {
    /// Not started, with a prior `w̄` (the disturbance the approach servo found) [m/s²].
    pub fn primed(w: f64) -> Self {
        Self { v: 0.0, w: if w.is_finite() { w } else { 0.0 }, started: false }
    }

    /// One cycle with the measured velocity `v_m` (of `n_v` cycles ago); `omega` ≤ 0 or
    /// non-finite passes the measurement through (`v̄ = v_m`, `w̄ = 0`).
    /// The first cycle after [`Self::primed`] starts `v̄` at `v_m` and keeps the prior `w̄`.
    pub fn step(&self, h: &History, period: f64, n_v: usize, v_m: f64, omega: f64) -> Self {
        self.step_fast(h, period, n_v, v_m, omega, omega)
    }

    /// [`Self::step`] with the velocity gain `L₁` from a higher bandwidth `omega_v ≥ omega`
    /// (after an impact: the velocity re-synchronises fast while `w̄` keeps its slow gain).
    pub fn step_fast(&self, h: &History, period: f64, n_v: usize, v_m: f64, omega: f64, omega_v: f64) -> Self {
        if !(omega > 0.0 && omega.is_finite() && v_m.is_finite()) {
            return Self { v: if v_m.is_finite() { v_m } else { self.v }, w: 0.0, started: true };
        }
        if !self.started {
            return Self { v: v_m, w: self.w, started: true };
        }
        let p = (-omega * period).exp();
        let pv = (-omega_v.max(omega) * period).exp();
        let (l1, l2) = (1.0 - pv * pv, (1.0 - p) * (1.0 - p) / period);
        let a = h.accel[n_v.min(HISTORY - 1)];
        let v_pred = self.v + period * (a + self.w);
        let eps = v_m - v_pred;
        let next = Self { v: v_pred + l1 * eps, w: self.w + l2 * eps, started: true };
        if next.v.is_finite() && next.w.is_finite() {
            next
        } else {
            Self { v: v_m, w: 0.0, started: true }
        }
    }
}

/// The disturbance along n observed through the contact force (on stiff surfaces): with
/// `f = k (x − x_e)` the force measures the tip position to `q / k` per F/T count `q`
/// (1.25 µm at 50 000 N/m for 1/16 N), far finer than the encoders' velocity measures its
/// integral, and `d` cycles old instead of `d + 2` (no median). States `f̄`, `ḟ̄` [N, N/s]
/// and `w̄` [m/s²] (the acceleration the commands do not explain, as [`Observer::w`]) on the
/// force's time line, driven by the command of that cycle:
///
/// ```text
/// f̈ = k (a + w̄):  f̄⁻ = f̄ + T ḟ̄ + ½T² k (a + w̄),  ḟ̄⁻ = ḟ̄ + T k (a + w̄),  ε = f_m − f̄⁻
/// f̄ = f̄⁻ + α ε,   ḟ̄ = ḟ̄⁻ + (β/T) ε,   w̄ ← w̄ + (2γ/T²) ε / k
/// α = 1 − p³,  γ = (3p² − 3p + α)/2,  β = 3 − 3p − α − γ,  p = e^{−ωT}
/// ```
///
/// (an α-β-γ filter with all three error poles at `p`, checked in the tests). A wrong `k`
/// scales the commanded part: the estimate is `(k/k̂ − 1) a + (k/k̂) w`, so it is used only
/// with a confident estimate ([`super::ScheduledParams::force_observer`]).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ForceObserver {
    pub f: f64,
    pub f_dot: f64,
    pub w: f64,
    /// Started (the first measurement initialises `f̄`, `ḟ̄`).
    pub started: bool,
}

impl ForceObserver {
    /// Not started, with a prior `w̄` [m/s²].
    pub fn primed(w: f64) -> Self {
        Self { f: 0.0, f_dot: 0.0, w: if w.is_finite() { w } else { 0.0 }, started: false }
    }

    /// One cycle with the measured force `f_m` (of `n_x` cycles ago) on stiffness `k`, the
    /// measured velocity `v_m` (only to start `ḟ̄ = k v_m`) and bandwidth `omega`; `omega`
    /// or `k` ≤ 0 or non-finite, or a non-finite `f_m`, leave the state as it is.
    #[allow(clippy::too_many_arguments)]
    pub fn step(&self, h: &History, period: f64, n_x: usize, f_m: f64, k: f64, v_m: f64, omega: f64) -> Self {
        if !(omega > 0.0 && omega.is_finite() && f_m.is_finite() && k > 0.0 && k.is_finite()) {
            return *self;
        }
        if !self.started {
            return Self { f: f_m, f_dot: k * if v_m.is_finite() { v_m } else { 0.0 }, w: self.w, started: true };
        }
        let p = (-omega * period).exp();
        let alpha = 1.0 - p * p * p;
        let gamma = 0.5 * (3.0 * p * p - 3.0 * p + alpha);
        let beta = 3.0 - 3.0 * p - alpha - gamma;
        let acc = k * (h.accel[n_x.min(HISTORY - 1)] + self.w);
        let f_pred = self.f + period * self.f_dot + 0.5 * period * period * acc;
        let eps = f_m - f_pred;
        let next = Self {
            f: f_pred + alpha * eps,
            f_dot: self.f_dot + period * acc + beta / period * eps,
            w: self.w + 2.0 * gamma / (period * period) * eps / k,
            started: true,
        };
        if next.f.is_finite() && next.f_dot.is_finite() && next.w.is_finite() {
            next
        } else {
            Self { f: f_m, f_dot: 0.0, w: 0.0, started: true }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A double integrator under a zero-order-hold command, observed `d` cycles late (and its
    /// velocity `d + lag` cycles late): the prediction recovers the present state exactly.
    #[test]
    fn recovers_the_present_state_of_a_double_integrator() {
        let (t, d, lag) = (1e-3, 2usize, 2usize);
        let (mut x, mut v) = (0.01, -0.02);
        let mut past = vec![(x, v)];
        let mut h = History::default();
        for k in 0..40 {
            let a = 3.0 * (0.3 * k as f64).sin() - 1.0;
            // the cycle: predict with the history, then command a over one period
            if k >= d + lag {
                let (x_m, _) = past[past.len() - 1 - d];
                let (_, v_m) = past[past.len() - 1 - d - lag];
                let p = predict(&h, t, d, d + lag, v_m, 0.0);
                assert!((v_m + p.dv - v).abs() < 1e-12, "v at {k}");
                assert!((x_m + p.dx - x).abs() < 1e-12, "x at {k}: {} vs {x}", x_m + p.dx);
            }
            h.push(a);
            x += v * t + 0.5 * a * t * t;
            v += a * t;
            past.push((x, v));
        }
    }

    /// The observer follows a double integrator with an unknown constant acceleration
    /// (`w̄` → the disturbance, `v̄` → the delayed velocity) and passes less of the
    /// measurement noise than the raw measurement.
    #[test]
    fn observer_finds_the_disturbance_and_filters_the_noise() {
        let (t, n_v, w_true) = (1e-3, 4usize, -0.7);
        let mut v = 0.0;
        let mut past = vec![v; n_v + 1];
        let mut h = History::default();
        let mut ob = Observer::default();
        let (mut err_raw, mut err_obs, mut n) = (0.0, 0.0, 0.0);
        for k in 0..3000 {
            let noise = 1e-3 * (((k as f64) * 12.9898).sin() * 43758.5453).rem_euclid(1.0) - 0.5e-3;
            let v_m = past[past.len() - 1 - n_v] + noise;
            ob = ob.step(&h, t, n_v, v_m, 50.0);
            if k > 1000 {
                let truth = past[past.len() - 1 - n_v];
                err_raw += (v_m - truth).powi(2);
                err_obs += (ob.v - truth).powi(2);
                n += 1.0;
            }
            let a = 2.0 * (0.01 * k as f64).sin();
            h.push(a);
            v += t * (a + w_true);
            past.push(v);
        }
        assert!((ob.w - w_true).abs() < 0.05, "w̄ = {}", ob.w);
        assert!(err_obs < 0.25 * err_raw, "noise power: observer {} vs raw {}", err_obs / n, err_raw / n);
        // off: the measurement passes
        assert_eq!(Observer::default().step(&h, t, n_v, 0.3, 0.0).v, 0.3);
    }

    #[test]
    fn no_history_no_change_and_nan_is_dropped() {
        let mut h = History::default();
        assert_eq!(predict(&h, 1e-3, 2, 4, 0.0, 0.0), Prediction { dv: 0.0, dx: 0.0 });
        h.push(f64::NAN);
        assert_eq!(h.accel[0], 0.0);
        let p = predict(&h, 1e-3, 2, 4, 0.01, 0.0);
        assert!((p.dx - 2e-5).abs() < 1e-15);
        // horizons beyond the history are clamped, not a panic
        let _ = predict(&h, 1e-3, 100, 100, 0.0, 0.0);
    }

    /// The force observer on a spring `f = k x` driven by the commands plus an unknown
    /// constant acceleration, the force measured `n_x` cycles late and quantised to 1/16 N:
    /// `w̄` finds the disturbance (its three error poles are at `p`).
    #[test]
    fn force_observer_finds_the_disturbance_through_the_force() {
        let (t, n_x, k, w_true): (f64, usize, f64, f64) = (1e-3, 2, 50_000.0, 1.8);
        let (mut x, mut v): (f64, f64) = (6e-5, 0.0);
        let mut past = vec![x; n_x + 1];
        let mut h = History::default();
        let mut ob = ForceObserver::primed(0.0);
        for i in 0..400 {
            let f_m = (k * past[past.len() - 1 - n_x] * 16.0).round() / 16.0;
            ob = ob.step(&h, t, n_x, f_m, k, 0.0, 200.0);
            // a command that holds the force near 3 N without knowing w
            let a = -(k * x - 3.0) / 0.9 - 400.0 / 0.9 * v - if i > 100 { ob.w } else { 0.0 };
            h.push(a);
            x += v * t + 0.5 * (a + w_true) * t * t;
            v += (a + w_true) * t;
            past.push(x);
        }
        assert!((ob.w - w_true).abs() < 0.05 * w_true, "w̄ = {} vs {w_true}", ob.w);
        // the poles: (I − LC)A of the α-β-γ gains has the characteristic polynomial (z − p)³
        let p = (-200.0f64 * t).exp();
        let alpha = 1.0 - p * p * p;
        let gamma = 0.5 * (3.0 * p * p - 3.0 * p + alpha);
        let beta = 3.0 - 3.0 * p - alpha - gamma;
        assert!((alpha + beta + gamma - 3.0 + 3.0 * p).abs() < 1e-12);
        assert!((3.0 - 2.0 * alpha - beta + gamma - 3.0 * p * p).abs() < 1e-12);
        // off: the state is kept
        let s = ForceObserver::primed(0.5);
        assert_eq!(s.step(&h, t, n_x, 3.0, 50_000.0, 0.0, 0.0), s);
        assert_eq!(s.step(&h, t, n_x, f64::NAN, 50_000.0, 0.0, 200.0), s);
    }
}
