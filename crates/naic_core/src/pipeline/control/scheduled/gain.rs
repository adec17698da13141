//! The model's acceleration gain along n, estimated online (its measurements:
//! docs/notes/2026-12-scheduled-tuning-rounds.md).
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
//! while acrylic's force settled, and the loop's gains were `F` of the designed.
//!
//! # The estimate
//!
//! On the measurement's time line (the velocity `v_k` is `n_v` cycles old), with
//! `S_k = T Σ_{i ≤ k} a_{i−D}` the integral of the commands sent `D = delay` cycles before,
//! the second difference over two windows of `N` cycles removes `w` (constant over `2N`
//! cycles), and the arm's response is a short FIR of `K` taps (the commands `D … D + K − 1`
//! cycles back: the loop's delay is not known to the law, and with the joints' friction the
//! response lags ≈ 2 cycles more than without):
//!
//! ```text
//! y_k   = v_k − 2 v_{k−N} + v_{k−2N}
//! φ_j,k = S_{k−j} − 2 S_{k−j−N} + S_{k−j−2N}          j = 0 … K − 1
//! y_k   = Σ_j h_j φ_j,k + noise,                      ĝ = clamp(Σ_j h_j, g_min, g_max)
//! ```
//!
//! (`ĝ`, the taps' sum, is the gain at low frequencies whatever the lag), estimated by RLS with
//! forgetting `λ`:
//!
//! ```text
//! K = P φ / (λ + φᵀ P φ),   h ← h + K (y − hᵀ φ),   P ← (P − K (P φ)ᵀ) / λ,   trace P ≤ K P₀
//! ```
//!
//! updated only where the commands excite it, `|φ_0| ≥ min_excitation` (a velocity change the
//! commands explain well above the encoders' noise), where the arm moves fast
//! (`|v| ≥ min_speed` at the three velocities: the approach's start, where joints break away
//! from static friction at different times, which reads as a gain error), and only
//! while the owner allows it (free space: no contact force in `w`); without excitation
//! neither `h` nor `P` moves (no wind-up). `ĝ` starts at 1 (the model is exact).
//!
//! # Its use
//!
//! With [`GainParams::scale_commands`] the control stage divides the law's commanded
//! acceleration along n by `ĝ` in contact (the arm realises what the law asks) and keeps the
//! predictor's history in realised units (`ĝ a` of the free-space commands; the approach
//! servo's integral primes `w̄ = −ĝ a_I`), so the observers integrate what the arm does.
//! By default `g_max = 1`: only a light model (`ĝ < 1`, a loop slower than designed) is
//! corrected: the loop's delay biases the estimate by several per cent, which would otherwise
//! correct an exact model, and a heavy model's extra loop gain the schedule covers
//! (`prediction` = 0.75).
//! `g = 1` exactly (as without the estimate) leaves the law bit for bit as before.

/// The longest window [cycles].
pub const MAX_WINDOW: usize = 32;
const RING: usize = 2 * MAX_WINDOW + MAX_TAPS;

/// Settings of the gain estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainParams {
    /// `N` [cycles], in `[1, MAX_WINDOW]`; 0 turns the estimate off (`ĝ = 1`).
    pub window: usize,
    /// Forgetting factor `λ` per update, in (0, 1].
    pub forgetting: f64,
    /// Taps `K` in [1, MAX_TAPS] of the response: the commands `delay … delay + K − 1` cycles
    /// before the measurement; `ĝ` is their sum (the gain at low frequencies, whatever the
    /// lag of the arm's response — with the joints' friction it lags by ≈ 2 cycles more than
    /// without, and a single tap at the wrong lag misread the gain by ≈ 3.5 % per cycle).
    pub taps: usize,
    /// The first tap's delay [cycles] (the measured velocity's age, less one).
    pub delay: usize,
    /// Smallest `|φ_0|` that updates the estimate [m/s].
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
    /// units (see the module's doc); `false`: estimated only (reported, not used). Keeping
    /// only the history in realised units (the loop's gain the model's) was measured worse
    /// (acrylic at F = 1.25 lost its goal) and is not offered.
    pub scale_commands: bool,
    /// The light model's gravity compensation corrected with the estimate once it is learnt
    /// ([`GravityCorrection`]); `None`: off.
    pub gravity: Option<GravityCorrection>,
}

/// The gravity compensation corrected by the learnt gain.
///
/// With every mass of the model scaled by `F` its gravity torque is `F G(q)`: a light model
/// (`F` < 1) leaves `(1 − F) G(q)` on every joint uncompensated. Along n the law's
/// disturbance estimate feeds it forward; on the other axes only the tangential stiffness and
/// the joints' static friction hold it, so a slide that starts breaks a different load on each
/// joint. The correction adds
///
/// ```text
/// τ_g = r(t) (1/ĝ_frozen − 1) G_model(q)      where ĝ_frozen < threshold (0 elsewhere)
/// ```
///
/// (`= (1 − F) G` for `ĝ_frozen = F`) with `ĝ_frozen` the estimate taken once it has not
/// updated for `quiet` (the correction never moves with an estimate that is learning), ramped
/// in by `r(t)` from 0 to 1 over `ramp`. `threshold` keeps the correction off where the
/// estimate cannot tell the model from an exact one (its spread at `F = 1`); where it applies
/// it is whole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GravityCorrection {
    /// Time without an update after which `ĝ` is frozen for the correction [s], > 0.
    pub quiet: f64,
    /// Ramp-in time of the correction [s], >= 0 (0: a step).
    pub ramp: f64,
    /// The correction applies where `ĝ_frozen < threshold`, in (0, 1].
    pub threshold: f64,
    /// The heavy side: the model's mass factor read from **statics** in the approach and the
    /// gravity corrected where it is above `heavy_threshold`, > 1 (`f64::INFINITY`: off). At a
    /// steady approach the servo's integral `a_I` along n holds the acceleration the model's
    /// gravity error leaves: with every mass of the model scaled by `F` the arm realises
    /// `ẍ = F a + (F − 1) J M⁻¹ G`, so at rest along n `a_I = (1 − 1/F) a_free` with
    /// `a_free = n·J q̈_free` the acceleration along n of the arm falling freely from the pose
    /// (`q̈_free = −M⁻¹ G`, the same for the model and the arm). Hence `F̂_s = 1 / (1 − a_I / a_free)`
    /// and the correction `(1/F̂_s − 1) G_model = −(a_I / a_free) G_model`. A static reading: the
    /// loop's delay does not bias it, as it does the dynamic `ĝ`.
    pub heavy_threshold: f64,
    /// When the static reading is taken [s], > 0: this long after `ĝ` is frozen (the
    /// approach's start is over and its servo's integral has had time to settle), in free
    /// space only (never in contact); ramped in over `ramp` as the light side.
    pub heavy_settle: f64,
    /// The light side's gate by statics: the light correction (`ĝ_frozen < threshold`) applies
    /// only where the static reading `F̂_s` ([`Self::heavy_threshold`]) is also below
    /// `light_static`, in (0, 1) (`f64::INFINITY`: no gate, the light side from the moment `ĝ`
    /// froze). Why: the loop's delay biases the dynamic `ĝ` by several per cent (an exact model
    /// reads low on the lockstep DDS chain); the static reading is not biased. With the gate the light correction waits for the reading (taken
    /// `heavy_settle` after `ĝ` froze) and ramps in over `ramp`; its size stays `1/ĝ_frozen − 1`.
    pub light_static: f64,
}

impl Default for GravityCorrection {
    fn default() -> Self {
        Self { quiet: 0.1, ramp: 0.2, threshold: 0.93, heavy_threshold: 1.1, heavy_settle: 0.5, light_static: 0.96 }
    }
}

impl GravityCorrection {
    /// Whether the light side waits for the static reading ([`Self::light_static`]).
    pub fn gated(&self) -> bool {
        self.light_static.is_finite()
    }

    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        if !(self.quiet > 0.0 && self.quiet.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.quiet", self.quiet, "s must be finite and > 0"));
        }
        if !(self.ramp >= 0.0 && self.ramp.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.ramp", self.ramp, "s must be finite and >= 0"));
        }
        if !(self.threshold > 0.0 && self.threshold <= 1.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.threshold", self.threshold, "must be in (0, 1]"));
        }
        if !(self.heavy_threshold > 1.0) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.heavy_threshold", self.heavy_threshold, "must be > 1 (inf: off)"));
        }
        if !(self.heavy_settle > 0.0 && self.heavy_settle.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.heavy_settle", self.heavy_settle, "s must be finite and > 0"));
        }
        if !((self.light_static > 0.0 && self.light_static < 1.0) || self.light_static == f64::INFINITY) {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.gravity.light_static", self.light_static, "must be in (0, 1) (inf: no gate)"));
        }
        Ok(())
    }
}

impl Default for GainParams {
    fn default() -> Self {
        Self {
            window: 16,
            taps: 6,
            delay: 3,
            forgetting: 0.998,
            min_excitation: 0.003,
            min_speed: 0.2,
            g_min: 0.5,
            g_max: 1.0,
            p0: 1e4,
            scale_commands: true,
            gravity: Some(GravityCorrection::default()),
        }
    }
}

impl GainParams {
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        if self.window > MAX_WINDOW {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.window", self.window, format!("cycles must be at most {MAX_WINDOW} (0: off)")));
        }
        if !(1..=MAX_TAPS).contains(&self.taps) || self.delay + 1 > super::predictor::HISTORY - 1 {
            return Err(crate::pipeline::ConfigError::invalid("scheduled model_gain.taps", self.taps, format!("must be in [1, {MAX_TAPS}], with delay = {} below {}", self.delay, super::predictor::HISTORY - 1)));
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
        if let Some(g) = &self.gravity {
            g.validate()?;
        }
        Ok(())
    }
}

/// The largest number of taps.
pub const MAX_TAPS: usize = 8;

/// The largest mass factor the heavy side's static reading gives ([`GainEstimator::with_heavy`]):
/// the correction then takes a third of the model's gravity away (`1/F̂_s − 1` = −1/3). The
/// table covers 1.25 (read as 1.20–1.27); a larger reading is more likely something pushing
/// the tool in the approach than a model 50 % too heavy, and a real arm should not lose more of
/// its gravity compensation to it (no reading reached 1.5 on the table's runs).
pub const HEAVY_MAX: f64 = 1.5;

/// The estimate and its data (fixed-size rings: no allocation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainEstimator {
    /// `ĝ = clamp(Σ h_j)`.
    pub g: f64,
    /// The taps `h_j` (the response to the command `delay + j` cycles back).
    pub h: [f64; MAX_TAPS],
    /// `P`.
    pub p: [[f64; MAX_TAPS]; MAX_TAPS],
    /// Updates applied.
    pub updates: u32,
    /// The commands along n as sent (newest first), for the measurement's time line.
    pub sent: super::predictor::History,
    /// Cycles since the last update (0 before the first).
    pub since_update: u32,
    /// `ĝ` frozen for the gravity correction ([`GravityCorrection`]), once it is learnt.
    pub frozen: Option<f64>,
    /// Cycles since `frozen` was set (the ramp).
    pub frozen_cycles: u32,
    /// The model's mass factor read from statics, `F̂_s` ([`GravityCorrection::heavy_threshold`]),
    /// once taken.
    pub heavy: Option<f64>,
    /// Cycles since `heavy` was set (its ramp).
    pub heavy_cycles: u32,
    s: f64,
    v: [f64; RING],
    s_ring: [f64; RING],
    head: usize,
    filled: usize,
}

impl GainEstimator {
    pub fn new(p: &GainParams) -> Self {
        let k = p.taps.clamp(1, MAX_TAPS);
        let mut h = [0.0; MAX_TAPS];
        let mut pp = [[0.0; MAX_TAPS]; MAX_TAPS];
        for j in 0..k {
            h[j] = 1.0 / k as f64;
            pp[j][j] = p.p0;
        }
        Self { g: 1.0, h, p: pp, updates: 0, sent: Default::default(), since_update: 0, frozen: None, frozen_cycles: 0, heavy: None, heavy_cycles: 0, s: 0.0, v: [0.0; RING], s_ring: [0.0; RING], head: 0, filled: 0 }
    }

    /// The taps' sum `Σ h_j` before the bounds (1 before any update).
    pub fn raw(&self, p: &GainParams) -> f64 {
        self.h[..p.taps.clamp(1, MAX_TAPS)].iter().sum()
    }

    /// The gain the law acts with: `ĝ` with [`GainParams::scale_commands`] (the divisor of its
    /// contact commands along n, and the acceleration the arm realises per unit sent, as the
    /// predictor's history counts it), 1 otherwise.
    pub fn used(&self, p: &GainParams) -> f64 {
        if p.window > 0 && p.scale_commands { self.g } else { 1.0 }
    }

    /// One cycle with the measured velocity `v_m` [m/s]: the command sent `delay + 1` cycles
    /// ago ([`Self::sent`]) is the first tap's; `learn`: the owner allows an update this
    /// cycle. Then remember this cycle's command `a_sent` [m/s²].
    pub fn cycle(&self, p: &GainParams, period: f64, v_m: f64, learn: bool, a_sent: f64) -> Self {
        let a = self.sent.accel[p.delay.min(super::predictor::HISTORY - 1)];
        let mut n = self.step(p, period, v_m, a, learn);
        n.sent.push(a_sent);
        if n.updates != self.updates {
            n.since_update = 0;
        } else if n.updates > 0 {
            n.since_update = self.since_update.saturating_add(1);
        }
        match (p.gravity, n.frozen) {
            (Some(gc), None) if n.updates > 0 && n.since_update as f64 * period >= gc.quiet => n.frozen = Some(n.g),
            (Some(_), Some(_)) => n.frozen_cycles = self.frozen_cycles.saturating_add(1),
            _ => {}
        }
        if n.heavy.is_some() {
            n.heavy_cycles = self.heavy_cycles.saturating_add(1);
        }
        n
    }

    /// Whether the static reading of the heavy side is due this cycle: the correction's heavy
    /// side on, `ĝ` frozen for `heavy_settle`, not yet taken. The owner then takes it with
    /// [`Self::with_heavy`] if the arm is in free space (it costs a forward dynamics).
    pub fn wants_heavy(&self, p: &GainParams, period: f64) -> bool {
        match (p.gravity, self.frozen, self.heavy) {
            (Some(gc), Some(g), None) => (gc.heavy_threshold.is_finite() || (gc.gated() && g < gc.threshold && g < 1.0)) && self.frozen_cycles as f64 * period >= gc.heavy_settle,
            _ => false,
        }
    }

    /// The static reading `F̂_s = 1 / (1 − a_I / a_free)` from the approach servo's integral
    /// `a_i` and the free fall's acceleration `a_free` along n [m/s²], in [0.5, [`HEAVY_MAX`]] (1 where
    /// `a_free` is not a clear fall, below 1 m/s², or the data are not finite).
    pub fn with_heavy(&self, a_i: f64, a_free: f64) -> Self {
        let r = a_i / a_free;
        let f = if a_free >= 1.0 && r.is_finite() && r < 0.5 { (1.0 / (1.0 - r)).clamp(0.5, HEAVY_MAX) } else { 1.0 };
        Self { heavy: Some(f), heavy_cycles: 0, ..*self }
    }

    /// The factor `c` of the gravity correction `τ_g = c G_model(q)` ([`GravityCorrection`]):
    /// `r(t) (1/ĝ_frozen − 1)` where `ĝ_frozen < threshold` and (gated) the static
    /// reading `F̂_s < light_static`, ramped from the reading; `r(t) (1/F̂_s − 1)` where `F̂_s >
    /// heavy_threshold`; 0 until `ĝ` is frozen (gated: until the reading), elsewhere and
    /// without the correction.
    pub fn gravity_factor(&self, p: &GainParams, period: f64) -> f64 {
        let (Some(gc), Some(g)) = (p.gravity, self.frozen) else {
            return 0.0;
        };
        let ramp = |cycles: u32| if gc.ramp > 0.0 { (cycles as f64 * period / gc.ramp).min(1.0) } else { 1.0 };
        let light = g < gc.threshold && g < 1.0;
        if light && !gc.gated() {
            return ramp(self.frozen_cycles) * (1.0 / g - 1.0);
        }
        match self.heavy {
            Some(f) if light && f < gc.light_static => ramp(self.heavy_cycles) * (1.0 / g - 1.0),
            Some(f) if f > gc.heavy_threshold => ramp(self.heavy_cycles) * (1.0 / f - 1.0),
            _ => 0.0,
        }
    }

    /// The update with the command `a` [m/s²] of the first tap (the one that acted over the
    /// period before `v_m` if the arm responded at once). A non-finite `v_m` or `a` restarts
    /// the data (the estimate is kept).
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
        let (w, k) = (p.window, p.taps.clamp(1, MAX_TAPS));
        if n.filled < 2 * w + k || !learn {
            return n;
        }
        let at = |i: usize| (n.head + RING - i) % RING;
        let y = n.v[n.head] - 2.0 * n.v[at(w)] + n.v[at(2 * w)];
        let mut phi = [0.0; MAX_TAPS];
        for (j, f) in phi.iter_mut().enumerate().take(k) {
            *f = n.s_ring[at(j)] - 2.0 * n.s_ring[at(j + w)] + n.s_ring[at(j + 2 * w)];
        }
        let slow = [n.v[n.head], n.v[at(w)], n.v[at(2 * w)]].iter().any(|v| v.abs() < p.min_speed);
        if phi[0].abs() < p.min_excitation || slow {
            return n;
        }
        // RLS: K = Pφ / (λ + φᵀPφ), h ← h + K (y − hᵀφ), P ← (P − K (Pφ)ᵀ) / λ.
        let mut pphi = [0.0; MAX_TAPS];
        for (x, row) in pphi.iter_mut().zip(&self.p).take(k) {
            *x = (0..k).map(|j| row[j] * phi[j]).sum();
        }
        let denom = p.forgetting + (0..k).map(|i| phi[i] * pphi[i]).sum::<f64>();
        let err = y - (0..k).map(|i| self.h[i] * phi[i]).sum::<f64>();
        let mut next_p = self.p;
        let mut next_h = self.h;
        for i in 0..k {
            next_h[i] = self.h[i] + pphi[i] / denom * err;
            for j in 0..k {
                next_p[i][j] = (self.p[i][j] - pphi[i] * pphi[j] / denom) / p.forgetting;
            }
        }
        // Bounded covariance: the trace at most k P₀ (scaled down as a whole).
        let tr: f64 = (0..k).map(|i| next_p[i][i]).sum();
        if tr > k as f64 * p.p0 {
            let c = k as f64 * p.p0 / tr;
            next_p.iter_mut().flatten().for_each(|x| *x *= c);
        }
        let g: f64 = next_h[..k].iter().sum();
        if g.is_finite() && next_p.iter().flatten().all(|x| x.is_finite()) && denom > 0.0 {
            n.h = next_h;
            n.p = next_p;
            n.g = g.clamp(p.g_min, p.g_max);
            n.updates = self.updates.saturating_add(1);
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random number in [−0.5, 0.5) for sample `k`.
    fn noise(k: usize) -> f64 {
        (((k as f64) * 12.9898).sin() * 43758.5453).rem_euclid(1.0) - 0.5
    }

    /// `ẍ = F a_{k−lag} + w` (w a slow drift), the velocity measured with noise (0.6 mm/s,
    /// 1 σ) around 0.3 m/s: the estimate reaches F within 3 % in 2000 cycles of a varying
    /// command whatever the response's lag within the taps, and then, with a constant command
    /// (no excitation), neither the taps nor `P` move for 20 000 cycles.
    #[test]
    fn converges_to_the_gain_and_does_not_wind_up_without_excitation() {
        let p = GainParams { g_max: 2.0, ..GainParams::default() };
        let t = 1e-3;
        for (f, lag) in [(0.8, 0), (1.0, 2), (1.25, 4)] {
            let mut e = GainEstimator::new(&p);
            let mut v = 0.3;
            let mut sent = [0.0; 8];
            for k in 0..2000 {
                let w = -2.0 * (1.0 - f) + 0.3 * (k as f64 * t * 0.5).sin();
                v += t * (f * sent[lag] + w);
                e = e.step(&p, t, v + 6e-4 * 12f64.sqrt() * noise(k), sent[0], true);
                sent.rotate_right(1);
                sent[0] = 4.0 * (k as f64 * t * 30.0).sin();
            }
            assert!((e.g - f).abs() < 0.03 * f, "F = {f}, lag {lag}: ĝ = {} after {} updates", e.g, e.updates);
            // A constant command: once the windows have passed the last change nothing
            // excites the estimate.
            let mut hold = |e: GainEstimator, n: usize| {
                let mut e = e;
                for _ in 0..n {
                    v += t * (f * 0.5 - 0.1);
                    e = e.step(&p, t, v, 0.5, true);
                }
                e
            };
            e = hold(e, 2 * p.window + p.taps + 1);
            let (h, pp, n) = (e.h, e.p, e.updates);
            e = hold(e, 20_000);
            assert_eq!((e.h, e.p, e.updates), (h, pp, n), "F = {f}: moved without excitation");
        }
    }

    /// Not allowed to learn, or too slow (`min_speed`): nothing moves. The default bounds `ĝ`
    /// to at most 1; off (`window = 0`) and `scale_commands = false` use 1.
    #[test]
    fn gates_bounds_and_switches() {
        let p = GainParams::default();
        let t = 1e-3;
        let run = |p: &GainParams, v0: f64, learn: bool, f: f64| {
            let mut e = GainEstimator::new(p);
            let mut v = v0;
            for k in 0..2000 {
                let a = 4.0 * (k as f64 * t * 30.0).sin();
                v += t * f * a;
                e = e.step(p, t, v, a, learn);
            }
            e
        };
        assert_eq!(run(&p, 0.3, false, 0.8).updates, 0);
        assert_eq!(run(&p, -0.1, true, 0.8).updates, 0, "below min_speed (|v| ≤ 0.12 m/s)");
        let light = run(&p, 0.3, true, 0.8);
        assert!(light.updates > 0 && (light.g - 0.8).abs() < 0.01 && light.used(&p) == light.g);
        let heavy = run(&p, 0.3, true, 1.25);
        assert_eq!((heavy.g, heavy.used(&p)), (1.0, 1.0));
        let off = GainParams { window: 0, ..p };
        assert_eq!(GainEstimator { g: 0.7, ..light }.used(&off), 1.0);
        let estimated_only = GainParams { scale_commands: false, ..p };
        assert_eq!(light.used(&estimated_only), 1.0);
        assert!(off.validate().is_ok() && p.validate().is_ok());
        for (bad, name) in [
            (GainParams { g_min: 1.1, ..p }, "model_gain.g_min"),
            (GainParams { window: 33, ..p }, "model_gain.window"),
            (GainParams { taps: 0, ..p }, "model_gain.taps"),
            (GainParams { forgetting: 0.0, ..p }, "model_gain.forgetting"),
            (GainParams { min_speed: -1.0, ..p }, "model_gain.min_speed"),
            (GainParams { min_excitation: 0.0, ..p }, "model_gain.min_excitation"),
            (GainParams { p0: f64::NAN, ..p }, "model_gain.p0"),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains(name), "{name}: {e}");
        }
    }

    /// The gravity correction: nothing until the estimate has updated and then stayed quiet
    /// for `quiet`; then `ĝ` is frozen (later updates do not move the correction) and the
    /// factor ramps from 0 to `1/ĝ − 1` over `ramp`; none where the frozen `ĝ` is at or above
    /// `threshold`, nor without the correction. Its parameters are validated.
    #[test]
    fn the_gravity_correction_freezes_ramps_and_stays_off_near_an_exact_model() {
        // The light side without the gate by statics (the gate is tested below).
        let gc = GravityCorrection { light_static: f64::INFINITY, ..GainParams::default().gravity.expect("on by default") };
        let p = GainParams { gravity: Some(gc), ..GainParams::default() };
        assert!(p.validate().is_ok());
        let t = 1e-3;
        // Learn F = 0.8 from a varying command (cycle(): the commands sent `delay + 1` back).
        let learn = |p: &GainParams, f: f64, n: usize| {
            let mut e = GainEstimator::new(p);
            let mut v = 0.3;
            for k in 0..n {
                let a = 4.0 * (k as f64 * t * 30.0).sin();
                v += t * f * e.sent.accel[p.delay];
                e = e.cycle(p, t, v, true, a);
            }
            e
        };
        let e = learn(&p, 0.8, 2000);
        assert!(e.updates > 0 && e.frozen.is_none(), "still learning: {:?}", (e.updates, e.since_update, e.frozen));
        assert_eq!(e.gravity_factor(&p, t), 0.0, "not frozen: no correction");
        // Quiet (not allowed to learn): frozen once `quiet` has passed since the last update.
        let hold_with = |p: &GainParams, e: GainEstimator, n: usize| (0..n).fold(e, |e, _| e.cycle(p, t, 0.3, false, 0.0));
        let hold = |e: GainEstimator, n: usize| hold_with(&p, e, n);
        let quiet = (gc.quiet / t).round() as usize - e.since_update as usize;
        let before = hold(e, quiet - 1);
        assert!(before.frozen.is_none() && before.gravity_factor(&p, t) == 0.0);
        let frozen = hold(e, quiet);
        let g = frozen.frozen.expect("frozen after quiet");
        assert_eq!(g, e.g);
        assert!((g - 0.8).abs() < 0.02, "ĝ = {g}");
        // The ramp: half way half the factor, then all of it.
        let full = 1.0 / g - 1.0;
        let half = hold(frozen, (0.5 * gc.ramp / t).round() as usize);
        assert!((half.gravity_factor(&p, t) - 0.5 * full).abs() < 1e-9, "{} vs {}", half.gravity_factor(&p, t), 0.5 * full);
        let done = hold(frozen, (gc.ramp / t).round() as usize + 10);
        assert!((done.gravity_factor(&p, t) - full).abs() < 1e-12);
        // A later update moves ĝ (the commands' divisor) but not the frozen value.
        let mut later = done;
        let mut v = 0.3;
        for k in 0..500 {
            let a = 4.0 * (k as f64 * t * 30.0).sin();
            v += t * 0.9 * later.sent.accel[p.delay];
            later = later.cycle(&p, t, v, true, a);
        }
        assert!(later.updates > done.updates && later.g != g && later.frozen == Some(g));
        assert!((later.gravity_factor(&p, t) - full).abs() < 1e-12);
        // At or above the threshold (an estimate that cannot tell the model from exact): none.
        assert_eq!(GainEstimator { frozen: Some(gc.threshold), ..done }.gravity_factor(&p, t), 0.0);
        assert_eq!(GainEstimator { frozen: Some(1.0), ..done }.gravity_factor(&p, t), 0.0);
        let everywhere = GainParams { gravity: Some(GravityCorrection { threshold: 1.0, ..gc }), ..p };
        assert!((GainEstimator { frozen: Some(0.95), ..done }.gravity_factor(&everywhere, t) - (1.0 / 0.95 - 1.0)).abs() < 1e-12);
        // Off: never frozen, no correction; a step without a ramp.
        let off = GainParams { gravity: None, ..p };
        let e_off = learn(&off, 0.8, 2000);
        assert!(hold_with(&off, e_off, 1000).frozen.is_none() && done.gravity_factor(&off, t) == 0.0);
        let step = GainParams { gravity: Some(GravityCorrection { ramp: 0.0, ..gc }), ..p };
        assert!((GainEstimator { frozen_cycles: 0, ..done }.gravity_factor(&step, t) - full).abs() < 1e-12);
        for (bad, name) in [
            (GravityCorrection { quiet: 0.0, ..gc }, "gravity.quiet"),
            (GravityCorrection { ramp: -1.0, ..gc }, "gravity.ramp"),
            (GravityCorrection { ramp: f64::INFINITY, ..gc }, "gravity.ramp"),
            (GravityCorrection { threshold: 0.0, ..gc }, "gravity.threshold"),
            (GravityCorrection { threshold: 1.1, ..gc }, "gravity.threshold"),
            (GravityCorrection { heavy_threshold: 1.0, ..gc }, "gravity.heavy_threshold"),
            (GravityCorrection { heavy_threshold: f64::NAN, ..gc }, "gravity.heavy_threshold"),
            (GravityCorrection { heavy_settle: 0.0, ..gc }, "gravity.heavy_settle"),
            (GravityCorrection { heavy_settle: f64::INFINITY, ..gc }, "gravity.heavy_settle"),
            (GravityCorrection { light_static: 0.0, ..gc }, "gravity.light_static"),
            (GravityCorrection { light_static: 1.0, ..gc }, "gravity.light_static"),
            (GravityCorrection { light_static: f64::NAN, ..gc }, "gravity.light_static"),
            (GravityCorrection { light_static: f64::NEG_INFINITY, ..gc }, "gravity.light_static"),
        ] {
            let e = GainParams { gravity: Some(bad), ..p }.validate().unwrap_err().to_string();
            assert!(e.contains(name), "{name}: {e}");
        }
    }

    /// The heavy side: the static reading is due `heavy_settle` after `ĝ` froze,
    /// once; `F̂_s = 1 / (1 − a_I / a_free)` (F = 1.25: `a_I = 0.2 a_free`); the factor
    /// `1/F̂_s − 1` ramps in over `ramp` from the reading, only above `heavy_threshold`, and
    /// the light side (`ĝ_frozen < threshold`) takes precedence. Off with an infinite threshold.
    #[test]
    fn the_heavy_side_reads_the_mass_factor_from_statics_once() {
        let p = GainParams::default();
        let gc = p.gravity.expect("on by default");
        let t = 1e-3;
        let hold = |p: &GainParams, e: GainEstimator, n: usize| (0..n).fold(e, |e, _| e.cycle(p, t, 0.3, false, 0.0));
        let frozen = GainEstimator { frozen: Some(1.0), updates: 10, ..GainEstimator::new(&p) };
        assert!(!frozen.wants_heavy(&p, t), "just frozen");
        let settle = (gc.heavy_settle / t).round() as usize;
        assert!(!hold(&p, frozen, settle - 1).wants_heavy(&p, t));
        let due = hold(&p, frozen, settle);
        assert!(due.wants_heavy(&p, t));
        let a_free = 9.0;
        let heavy = due.with_heavy(0.2 * a_free, a_free);
        assert!((heavy.heavy.unwrap() - 1.25).abs() < 1e-12 && !heavy.wants_heavy(&p, t), "taken once");
        assert_eq!(heavy.gravity_factor(&p, t), 0.0, "the ramp starts at 0");
        let half = hold(&p, heavy, (0.5 * gc.ramp / t).round() as usize);
        assert!((half.gravity_factor(&p, t) - 0.5 * (1.0 / 1.25 - 1.0)).abs() < 1e-9);
        let done = hold(&p, heavy, (gc.ramp / t).round() as usize + 10);
        assert!((done.gravity_factor(&p, t) - (1.0 / 1.25 - 1.0)).abs() < 1e-12, "−0.2: (1 − F) G of the arm");
        // An exact model (a_I ≈ 0, or a little friction either way), F = 1.05, a reading
        // that is no fall: no correction.
        for (a_i, a_f) in [(0.0, a_free), (-0.2, a_free), (0.2, a_free), (0.05 / 1.05 * a_free, a_free), (1.8, 0.5), (f64::NAN, a_free)] {
            let e = hold(&p, due.with_heavy(a_i, a_f), 1000);
            assert_eq!(e.gravity_factor(&p, t), 0.0, "a_I {a_i}, a_free {a_f}: F̂_s {:?}", e.heavy);
        }
        assert_eq!(due.with_heavy(1.8, 0.5).heavy, Some(1.0));
        assert_eq!(due.with_heavy(0.9 * a_free, a_free).heavy, Some(1.0), "beyond the bound: none");
        // A reading above HEAVY_MAX (a_I = 0.45 a_free would be F = 1.82) is bounded to it.
        assert_eq!(due.with_heavy(0.45 * a_free, a_free).heavy, Some(HEAVY_MAX));
        // A frozen ĝ below `threshold` with a heavy static reading: the gate keeps
        // the light side off and the heavy side applies; ungated the light side came first.
        let light = GainEstimator { frozen: Some(0.8), ..done };
        assert!((light.gravity_factor(&p, t) - (1.0 / 1.25 - 1.0)).abs() < 1e-12);
        let ungated = GainParams { gravity: Some(GravityCorrection { light_static: f64::INFINITY, ..gc }), ..p };
        assert!((light.gravity_factor(&ungated, t) - (1.0 / 0.8 - 1.0)).abs() < 1e-12);
        // Off: never due.
        let off = GainParams { gravity: Some(GravityCorrection { heavy_threshold: f64::INFINITY, ..gc }), ..p };
        assert!(off.validate().is_ok() && !hold(&off, frozen, settle + 10).wants_heavy(&off, t));
        assert_eq!(done.gravity_factor(&off, t), 0.0);
    }
    /// The light side's gate by statics (`light_static`): with `ĝ` frozen below
    /// `threshold` nothing applies until the static reading is taken (`heavy_settle` after the
    /// freeze, due even with the heavy side off); then `1/ĝ − 1` ramps in over `ramp` from the
    /// reading where `F̂_s < light_static`, and nothing where the reading says the model is exact
    /// (the lockstep DDS chain: `ĝ` 0.9125, `F̂_s` ≈ 0.985).
    #[test]
    fn the_light_side_waits_for_the_static_reading_and_needs_it_low() {
        let p = GainParams::default();
        let gc = p.gravity.expect("on by default");
        assert!(gc.gated() && gc.light_static == 0.96);
        let t = 1e-3;
        let hold = |p: &GainParams, e: GainEstimator, n: usize| (0..n).fold(e, |e, _| e.cycle(p, t, 0.3, false, 0.0));
        let a_free = 9.0;
        // a_I for a reading F̂_s = f: a_I = (1 − 1/f) a_free.
        let a_i = |f: f64| (1.0 - 1.0 / f) * a_free;
        let settle = (gc.heavy_settle / t).round() as usize;
        let ramp = (gc.ramp / t).round() as usize;
        for heavy_threshold in [gc.heavy_threshold, f64::INFINITY] {
            let q = GainParams { gravity: Some(GravityCorrection { heavy_threshold, ..gc }), ..p };
            let frozen = GainEstimator { frozen: Some(0.8), updates: 10, ..GainEstimator::new(&q) };
            // Waiting: no correction until the reading, however long after the freeze.
            let waiting = hold(&q, frozen, settle - 1);
            assert!(!waiting.wants_heavy(&q, t) && waiting.gravity_factor(&q, t) == 0.0);
            let due = hold(&q, frozen, settle);
            assert!(due.wants_heavy(&q, t), "heavy_threshold {heavy_threshold}: the reading is due for the light side");
            assert_eq!(due.gravity_factor(&q, t), 0.0);
            // A light reading: 1/ĝ − 1 ramps in from the reading.
            let light = due.with_heavy(a_i(0.8), a_free);
            assert!((light.heavy.unwrap() - 0.8).abs() < 1e-12);
            assert_eq!(light.gravity_factor(&q, t), 0.0, "the ramp starts at the reading");
            let half = hold(&q, light, ramp / 2);
            assert!((half.gravity_factor(&q, t) - 0.5 * (1.0 / 0.8 - 1.0)).abs() < 1e-9);
            let done = hold(&q, light, ramp + 10);
            assert!((done.gravity_factor(&q, t) - (1.0 / 0.8 - 1.0)).abs() < 1e-12);
            // F = 0.95 read 0.935: the light side with its ĝ.
            let g95 = GainEstimator { frozen: Some(0.92), ..hold(&q, due.with_heavy(a_i(0.935), a_free), ramp + 10) };
            assert!((g95.gravity_factor(&q, t) - (1.0 / 0.92 - 1.0)).abs() < 1e-12);
            // The exact model on the lockstep DDS chain: ĝ 0.9125, F̂_s 0.985: none (was +9.6 %).
            let exact = GainEstimator { frozen: Some(0.9125), ..hold(&q, due.with_heavy(a_i(0.985), a_free), ramp + 10) };
            assert_eq!(exact.gravity_factor(&q, t), 0.0);
            // Just above the gate (0.97): none.
            assert_eq!(GainEstimator { frozen: Some(0.85), ..hold(&q, due.with_heavy(a_i(0.97), a_free), ramp + 10) }.gravity_factor(&q, t), 0.0);
            // ĝ at or above `threshold`: no reading is due with the heavy side off, none applies.
            let high = GainEstimator { frozen: Some(gc.threshold), updates: 10, ..GainEstimator::new(&q) };
            assert_eq!(hold(&q, high, settle).wants_heavy(&q, t), heavy_threshold.is_finite());
            assert_eq!(hold(&q, high.with_heavy(a_i(0.8), a_free), ramp + 10).gravity_factor(&q, t), 0.0);
        }
        // Ungated (inf): the light side from the freeze, no reading needed for it.
        let ungated = GainParams { gravity: Some(GravityCorrection { light_static: f64::INFINITY, heavy_threshold: f64::INFINITY, ..gc }), ..p };
        assert!(ungated.validate().is_ok() && !ungated.gravity.unwrap().gated());
        let frozen = GainEstimator { frozen: Some(0.8), updates: 10, ..GainEstimator::new(&ungated) };
        let later = hold(&ungated, frozen, ramp + 10);
        assert!(!later.wants_heavy(&ungated, t) && (later.gravity_factor(&ungated, t) - (1.0 / 0.8 - 1.0)).abs() < 1e-12);
    }
}
