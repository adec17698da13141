//! The model's acceleration gain along n, estimated online (round 13 of issue 12,
//! docs/controller.md).
//!
//! # Why
//!
//! The computed-torque loop realises the commanded acceleration through the controller's
//! dynamic model. With every inertia of the model off by a factor `F` (the simulator's model
//! mass error), the arm realises `F a` of a command `a`, plus an acceleration the commands do
//! not explain (the gravity compensation off by `(F − 1) g`, friction):
//!
//! ```text
//! ẍ = g a + w          g = F (unknown), w slowly varying
//! ```
//!
//! The scheduled law's observers and predictor integrate the commands at full size (`g = 1`);
//! under a light model (`F` = 0.8) the velocity observer's `v̄` was biased by 0.1–0.9 mm/s
//! while acrylic's force settled (round 12), and the loop's gains were `F` of the designed.
//!
//! # The estimate
//!
//! On the measurement's time line (the velocity `v_k` is `n_v` cycles old, the command `a_k`
//! the one that acted over the period before it), with `S_k = T Σ_{i ≤ k} a_i` the integral of
//! the commands, the second difference over two windows of `N` cycles removes `w` (constant
//! over `2N` cycles):
//!
//! ```text
//! y_k = v_k − 2 v_{k−N} + v_{k−2N},   φ_k = S_k − 2 S_{k−N} + S_{k−2N},   y_k = g φ_k + noise
//! ```
//!
//! and a scalar RLS with forgetting `λ` estimates `ĝ`:
//!
//! ```text
//! K = P φ / (λ + P φ²),   ĝ ← clamp(ĝ + K (y − ĝ φ), g_min, g_max),   P ← min((P − K φ P) / λ, P₀)
//! ```
//!
//! updated only where the commands excite it, `|φ| ≥ min_excitation` (a velocity change the
//! commands explain well above the encoders' noise), and only while the owner allows it
//! (free space: no contact force in `w`); without excitation neither `ĝ` nor `P` moves (no
//! wind-up). `ĝ` starts at 1 (the model is exact).
//!
//! # Its use
//!
//! With [`GainParams::scale_commands`] the control stage divides the law's commanded
//! acceleration along n by `ĝ` in contact (the arm realises what the law asks) and keeps the
//! predictor's history in realised units (`ĝ a` of the free-space commands; the approach
//! servo's integral primes `w̄ = −ĝ a_I`), so the observers integrate what the arm does.

/// The longest window [cycles].
pub const MAX_WINDOW: usize = 32;
const RING: usize = 2 * MAX_WINDOW + 1;

/// Settings of the gain estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainParams {
    /// `N` [cycles], in `[1, MAX_WINDOW]`; 0 turns the estimate off (`ĝ = 1`).
    pub window: usize,
    /// Forgetting factor `λ` per update, in (0, 1].
    pub forgetting: f64,
    /// Smallest `|φ|` that updates the estimate [m/s].
    pub min_excitation: f64,
    /// Smallest speed `|v|` at the three velocities of an update [m/s] (0: any): where the
    /// joints start from rest their friction falls with speed (Stribeck) while the commands
    /// accelerate them, an acceleration the commands do not explain that grows with them.
    pub min_speed: f64,
    /// Bounds of `ĝ`, `0 < g_min ≤ 1 ≤ g_max`.
    pub g_min: f64,
    pub g_max: f64,
    /// Initial (and largest) covariance `P₀` [(s/m)²].
    pub p0: f64,
    /// Divide the contact command along n by `ĝ` and keep the predictor's history in realised
    /// units (see the module's doc); `false`: estimated only (reported, not used).
    pub scale_commands: bool,
}

impl Default for GainParams {
    fn default() -> Self {
        Self { window: 16, forgetting: 0.998, min_excitation: 0.003, min_speed: 0.05, g_min: 0.5, g_max: 2.0, p0: 1e4, scale_commands: true }
    }
}

impl GainParams {
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        if self.window > MAX_WINDOW {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.window", self.window, format!("cycles must be at most {MAX_WINDOW} (0: off)")));
        }
        if !(self.forgetting > 0.0 && self.forgetting <= 1.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.forgetting", self.forgetting, "must be in (0, 1]"));
        }
        if !(self.min_excitation > 0.0 && self.min_excitation.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.min_excitation", self.min_excitation, "m/s must be finite and > 0"));
        }
        if !(self.min_speed >= 0.0 && self.min_speed.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.min_speed", self.min_speed, "m/s must be finite and >= 0"));
        }
        if !(self.g_min > 0.0 && self.g_min <= 1.0 && self.g_max >= 1.0 && self.g_max.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.g_min", self.g_min, format!("must be in (0, 1] and g_max = {} finite and >= 1", self.g_max)));
        }
        if !(self.p0 > 0.0 && self.p0.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.p0", self.p0, "must be finite and > 0"));
        }
        Ok(())
    }
}

/// The estimate and its data (fixed-size rings: no allocation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainEstimator {
    /// `ĝ`.
    pub g: f64,
    /// `P`.
    pub p: f64,
    /// Updates applied.
    pub updates: u32,
    /// The commands along n as sent (newest first), for the measurement's time line.
    pub sent: super::predictor::History,
    s: f64,
    v: [f64; RING],
    s_ring: [f64; RING],
    head: usize,
    filled: usize,
}

impl GainEstimator {
    pub fn new(p: &GainParams) -> Self {
        Self { g: 1.0, p: p.p0, updates: 0, sent: Default::default(), s: 0.0, v: [0.0; RING], s_ring: [0.0; RING], head: 0, filled: 0 }
    }

    /// `ĝ` where it is used ([`GainParams::scale_commands`]), 1 otherwise.
    pub fn used(&self, p: &GainParams) -> f64 {
        if p.window > 0 && p.scale_commands { self.g } else { 1.0 }
    }

    /// One cycle with the measured velocity `v_m` [m/s], `n_v` cycles old: the command sent
    /// `n_v + 1` cycles ago ([`Self::sent`]) acted over the period before it; `learn`: the
    /// owner allows an update this cycle. Then remember this cycle's command `a_sent` [m/s²].
    pub fn cycle(&self, p: &GainParams, period: f64, n_v: usize, v_m: f64, learn: bool, a_sent: f64) -> Self {
        let a = self.sent.accel[n_v.min(super::predictor::HISTORY - 1)];
        let mut n = self.step(p, period, v_m, a, learn);
        n.sent.push(a_sent);
        n
    }

    /// The update with the command `a` [m/s²] that acted over the period before `v_m` (on the
    /// measurement's time line). A non-finite `v_m` or `a` restarts the data (the estimate is kept).
    pub fn step(&self, p: &GainParams, period: f64, v_m: f64, a: f64, learn: bool) -> Self {
        let mut n = *self;
        if p.window == 0 {
            return n;
        }
        if !(v_m.is_finite() && a.is_finite()) {
            n.filled = 0;
            n.s = 0.0;
            return n;
        }
        n.s += period * a;
        n.head = (self.head + 1) % RING;
        n.v[n.head] = v_m;
        n.s_ring[n.head] = n.s;
        n.filled = (self.filled + 1).min(RING);
        let w = p.window;
        if n.filled < 2 * w + 1 || !learn {
            return n;
        }
        let at = |k: usize| (n.head + RING - k) % RING;
        let y = n.v[n.head] - 2.0 * n.v[at(w)] + n.v[at(2 * w)];
        let phi = n.s_ring[n.head] - 2.0 * n.s_ring[at(w)] + n.s_ring[at(2 * w)];
        let slow = [n.v[n.head], n.v[at(w)], n.v[at(2 * w)]].iter().any(|v| v.abs() < p.min_speed);
        if phi.abs() < p.min_excitation || slow {
            return n;
        }
        let k = self.p * phi / (p.forgetting + self.p * phi * phi);
        let g = (self.g + k * (y - self.g * phi)).clamp(p.g_min, p.g_max);
        let pp = ((self.p - k * phi * self.p) / p.forgetting).min(p.p0);
        if g.is_finite() && pp.is_finite() && pp > 0.0 {
            n.g = g;
            n.p = pp;
            n.updates = self.updates.saturating_add(1);
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A double integrator `ẍ = F a + w` (w a slow drift), velocity measured with noise: the
    /// estimate reaches F within 2 % in 2000 cycles of a varying command, and then, with a
    /// constant command (no excitation), neither `ĝ` nor `P` moves for 20 000 cycles.
    #[test]
    fn converges_to_the_gain_and_does_not_wind_up_without_excitation() {
        let p = GainParams::default();
        let t = 1e-3;
        for f in [0.8, 1.0, 1.25] {
            let mut e = GainEstimator::new(&p);
            let mut v = 0.0;
            let mut a_prev = 0.0;
            for k in 0..2000 {
                let noise = 6e-4 * ((((k as f64) * 12.9898).sin() * 43758.5453).rem_euclid(1.0) - 0.5) * 3f64.sqrt() * 2.0;
                let w = -2.0 * (1.0 - f) + 0.3 * (k as f64 * t * 0.5).sin();
                v += t * (f * a_prev + w);
                e = e.step(&p, t, v + noise, a_prev, true);
                a_prev = 4.0 * (k as f64 * t * 30.0).sin() + 1.0;
            }
            assert!((e.g - f).abs() < 0.02 * f, "F = {f}: ĝ = {} after {} updates", e.g, e.updates);
            // A constant command: once the windows have passed the last change (2N cycles)
            // nothing excites the estimate.
            let mut hold = |e: GainEstimator, n: usize| {
                let mut e = e;
                for _ in 0..n {
                    v += t * (f * 0.5 - 0.1);
                    e = e.step(&p, t, v, 0.5, true);
                }
                e
            };
            e = hold(e, 2 * p.window + 1);
            let (g, pp) = (e.g, e.p);
            e = hold(e, 20_000);
            assert_eq!((e.g, e.p), (g, pp), "F = {f}: moved without excitation");
        }
        // Not allowed to learn: nothing moves; off: ĝ = 1 used.
        let mut e = GainEstimator::new(&p);
        for k in 0..200 {
            e = e.step(&p, t, 0.01 * k as f64, if k % 20 < 10 { 5.0 } else { -5.0 }, false);
        }
        assert_eq!((e.g, e.updates), (1.0, 0));
        let off = GainParams { window: 0, ..p };
        assert_eq!(GainEstimator { g: 0.7, ..e }.used(&off), 1.0);
        assert!(off.validate().is_ok() && p.validate().is_ok());
        assert!(GainParams { g_min: 1.1, ..p }.validate().unwrap_err().to_string().contains("model_gain.g_min"));
        assert!(GainParams { window: 33, ..p }.validate().unwrap_err().to_string().contains("model_gain.window"));
    }
}
