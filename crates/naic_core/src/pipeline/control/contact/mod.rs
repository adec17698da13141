//! The contact estimator along the force axis `n` (issue 42, item 3): a Kalman filter on
//! the surface's stiffness `k_e`, its position and speed `x_e`, `ẋ_e`, the feed-through `μ`
//! and the damping `b_e`, as one pure step ([`step`]: `(params, state, inputs) →
//! (state, ContactEstimate)`, allocation-free).
//!
//! # The contact model
//!
//! Along `n` (into the surface positive), with `u` the push on the arm along `n` other than
//! the contact (what the law commanded for the period that ends at the sample):
//!
//! ```text
//! f = μ u + k_e (x − x_e) + b_e (ẋ − ẋ_e),        ẋ_e = d x_e / dt               (C1)
//! ```
//!
//! A spring–damper surface under a massive arm is `μ ≈ 0` (naic's own plant). MuJoCo's
//! soft constraint is exactly (C1): its constraint force is `f = (a_ref − a₀)/(A + R)` with
//! `A = 1/D` (D the apparent mass along n), `a₀ = −u/D`, `a_ref = b ẋ + k d (x − x_e)`
//! (MuJoCo's "Solver parameters", `solref` k, b and the impedance `d` of `solimp`), so
//! `μ = A/(A + R)`, `k_e = μ D k d`, `b_e = μ D b`; `R = (1 − d)/d · Â` with MuJoCo's own
//! estimate `Â` of A, so `μ = d` only where `Â = A` (docs/simulation.md gives the measured
//! values on the JK5). A rigid contact is `μ → 1`.
//!
//! The filter's state is `θ = [k_e, c, ẋ_e, μ, b_e]` with `c = k_e (x_e − x₀)` (x₀: the tip at
//! contact, so that the regressors are of similar size), measured through
//!
//! ```text
//! f = k_e (x − x₀) − c + μ u + b_e (ẋ − ẋ_e) + noise,   R = σ_f² + k̂² σ_x² + b̂² σ_v²     (C2)
//! ```
//!
//! (the damping acts on the speed relative to the surface) — linear in θ but for the
//! product `b_e ẋ_e`, which the filter linearises about its estimate (the measurement's
//! Jacobian `h = [x − x₀, −1, −b̂_e, u, ẋ − ẋ̂_e]`) — with `σ_x` the tip's position resolution
//! along n as a standard deviation (`resolution/√12`), `σ_v` the velocity regressor's
//! (`σ_x/(√2 T)` for the central difference below, `√2 σ_x / T` for a backward one): the
//! encoder's error in the regressors enters as force noise (errors in the
//! variables). The prediction moves the surface, `c ← c + T k_e ẋ_e`; `ẋ_e` is a random walk
//! of intensity `a_e` ([`ContactParams::surface_accel`]), `k_e`, `μ`, `b_e` random walks of
//! intensity `ρ` ([`ContactParams::drift`]).
//!
//! # The delay
//!
//! The measured force is `d` periods old ([`ContactInputs::delay_cycles`]); the step keeps
//! the last `x`, `ẋ`, `u` and pairs the force with the ones of its own time. Call the step
//! every cycle, in free space too, so that this history is there at contact.
//!
//! # Start: the force's rise rate
//!
//! At a new contact ([`ContactInputs::contact_start`]) the prior is wide: `k_e` uniform on
//! `[0, k_max]`, `μ` on `[0, μ_max]`, `b_e` on `[0, b_max]` (the uniform distribution's mean
//! and variance, `max/2` and `max²/12`; the bounds are capped at `k_max`, `μ_max`), `c`
//! pinned by the first sample, and the surface held still (`ẋ_e = 0`, no
//! random walk). With the surface still, the first samples' regression of `f` on `x` is the
//! rise rate `ḟ/v₀`. Once `k̂ − z σ_k > 0` (the stiffness known to be positive) the surface
//! speed is released: `ẋ_e` gets its prior `σ = v_e,max` ([`ContactParams::surface_speed`])
//! and the start's dependence on it, `∂k̂/∂ẋ_e = −k̂/v̄` (v̄ the tip's mean speed since
//! contact, at least `v_e,max`), is added to the covariance: `k̄` rises by what an unknown
//! surface speed could have done to the rise rate, and falls again as the tip's speed
//! changes (the only evidence that separates `k_e` from `ẋ_e`).
//!
//! # Updates only under excitation
//!
//! The information a sample adds along a parameter `i` is carried by its *effective
//! regressor* `h_i* = (P h)_i / P_ii`: the part of the regressor the other uncertain states
//! do not explain (after a long contact at rest it is `x` minus the mean `x` of the evidence;
//! right after a jump it is the penetration `x − x_e`). The update of `k_e` is made only
//! where `|h_k*| > z_x σ_x`. An errors-in-variables update biases the estimate by
//! `σ²/(h*²)` of its correction, so the gate bounds the bias by `1/z_x²` (1 % by default),
//! where the old estimator kept updating at rest on encoder counts and drifted 25 % low.
//! `u` is the commanded push, exact: `μ` is always updated; so is `b_e`, a nuisance the
//! estimate does not report, whose velocity noise is in `R` (`|h_b*| > z_x σ_v` is reported
//! in [`ContactState::excited`]). The velocity regressor is the central difference of the
//! positions around the force's time where the delay leaves one after it (`d ≥ 1`), else
//! the input `ẋ`.
//! Unexcited parameters are *considered*, not updated (Schmidt): their gain is zero, their
//! covariance and correlations are carried exactly (Joseph's form), so `c` and `ẋ_e` keep
//! following the surface. The contact is unilateral: (C1) holds only while it presses, and a
//! measured force within `z σ_f` of zero is no evidence (the contact may have opened).
//!
//! # Jumps
//!
//! A sample whose normalised innovation `|ν|/√S` exceeds `z_jump` is held back. After
//! `jump_cycles` such samples in a row the contact has changed, in one of two ways: the
//! material (the covariance reopened along `[1, x̂_e − x₀, 0, 0, 0] σ_k0`: the stiffness
//! changes, the surface stays where it was) or the surface's speed (`ẋ_e`'s variance back to
//! `v_e,max²`, and for the 0.1 s decision window a manoeuvre: `ẋ_e`'s random walk gets
//! `v_e,max² / 0.1 s` more, a speed change of up to `v_e,max` within the window, because a
//! surface that starts to move keeps accelerating after the jump is seen). From the state
//! before the first held sample, the held samples are filtered again with `k_e` reopened and
//! with `ẋ_e` reopened (one degree of freedom each); the one with the larger likelihood
//! `Σ −½ (ν²/S + ln S)` is reported first. The held samples do not decide: a reopened `k_e`
//! explains an offset at once, a speed only through its integral, so on a surface that starts
//! to move the held samples favour a softer material. Both hypotheses run on side by side,
//! their likelihoods counted from the first sample after the held ones, until one is 100 times
//! likelier or for 0.1 s; the likelier is reported at every sample, and the bounds cover both
//! while both are open. Decided for a new material, `μ` and `b_e` get their priors' variance
//! back too. A held sample followed by an ordinary one was an outlier and is dropped.
//!
//! # Constraints
//!
//! A passive surface has `μ ≥ 0` and `b_e ≥ 0`. Where an update leaves either below zero, the
//! estimate is projected onto the constraint weighted by `P⁻¹` (`θ ← θ − P e_i θ_i / P_ii`): the
//! states correlated with it move with it (the constrained Kalman filter's estimate
//! projection). Without it, on a surface that starts to move, `b̂_e` took up the difference
//! between the tip's speed and the lagging surface-speed estimate, ran to −400 N·s/m and,
//! through the term `b_e ẋ_e`, drove `ẋ̂_e` the wrong way.
//!
//! # Bounds
//!
//! `k̄ = k̂ + w`, `k_lower = max(k̂ − w, 0)` with `w = z σ_k + k̂ / z_x²`: the posterior's `z σ`
//! from the covariance plus the errors-in-variables bias the excitation gate admits (`1/z_x²`
//! of the estimate: the floor from the noise model). `μ̄ = μ̂ + z σ_μ` (its regressor, the
//! commanded push, is exact). The covariance shrinks only with data, so the bounds fall only
//! on evidence (they rise slowly by the random walks). Lacking a contact the estimate is the
//! prior's.

pub mod kalman;
pub mod params;

pub use params::{ContactParams, MAX_JUMP_CYCLES};

use kalman::{Mat5, Vec5, B, C, K, MU, N, W};

/// The loop delays the history covers (the force's delay in periods, 0 – `MAX_DELAY`).
pub const MAX_DELAY: usize = 8;

/// What the estimator reports (agreed interface of issue 42's laws).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ContactEstimate {
    /// `k̂_e`, k_e estimate [N/m].
    pub k_hat: f64,
    /// `k̄`: upper bound, falls only on evidence [N/m].
    pub k_upper: f64,
    /// Lower bound [N/m] (≥ 0).
    pub k_lower: f64,
    /// Surface position along n [m].
    pub x_e: f64,
    /// Surface velocity along n [m/s].
    pub x_e_dot: f64,
    /// Feed-through `μ̂` in [0, 1].
    pub mu_hat: f64,
    /// `μ̄` in [0, 1].
    pub mu_upper: f64,
}

/// The inputs of one cycle (1 kHz), everything along `n`, into the surface positive.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ContactInputs {
    /// Tip position [m] and velocity [m/s], now.
    pub x: f64,
    pub x_dot: f64,
    /// Measured contact force [N], taken `delay_cycles` periods ago.
    pub f: f64,
    /// The push on the arm other than the contact [N] the law commanded for the period that
    /// ends now (`D̂ V + f_m` for eq 6's torque with the measured force fed forward).
    pub u: f64,
    /// A new contact starts this cycle (the law's contact detection): the prior restarts.
    pub contact_start: bool,
    /// In contact (the law's phase): without it the filter only predicts.
    pub in_contact: bool,
    /// Control period `T` [s].
    pub dt: f64,
    /// The force's delay `d` [periods], 0 – [`MAX_DELAY`].
    pub delay_cycles: u32,
    /// The encoders' position resolution mapped to the tip along n [m] (one count's size).
    pub x_resolution: f64,
    /// The force sensor's noise along n, 1 σ [N].
    pub sigma_f: f64,
}

/// The filter's state. Plain data (`Copy`); written only by [`step`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactState {
    /// A contact has started (the filter runs).
    pub active: bool,
    /// The surface speed is released (module docs, "Start").
    pub released: bool,
    /// `θ = [k_e, c, ẋ_e, μ, b_e]` and its covariance.
    pub theta: Vec5,
    pub p: Mat5,
    /// Tip position at contact [m] (the regressor's origin).
    pub x0: f64,
    /// Time since contact [s].
    pub t: f64,
    /// Samples held by the jump test: `[x − x₀, ẋ, u, f]`.
    held: [[f64; 4]; MAX_JUMP_CYCLES],
    n_held: usize,
    /// The last `MAX_DELAY + 1` cycles' `[x, ẋ, u]`, newest at `head`.
    hist: [[f64; 3]; MAX_DELAY + 1],
    head: usize,
    n_hist: usize,
    /// Jumps detected since the contact started, and whether the last one was taken for the
    /// surface's speed (else the material).
    pub jumps: u32,
    pub surface_moved: bool,
    /// Time since the last jump [s] (module docs, "Jumps": the surface's manoeuvre).
    pub since_jump: f64,
    /// θ and P before the first held sample's update.
    pre_hold: (Vec5, Mat5),
    /// The other hypothesis of the last jump while it is still open (module docs, "Jumps").
    pub alt: Option<Alt>,
    /// Diagnostics of the last cycle: innovation [N], its σ [N], which parameters were
    /// excited (k_e, μ, b_e), whether the sample was used.
    pub nu: f64,
    pub nu_sigma: f64,
    pub excited: [bool; 3],
    pub used: bool,
}

impl Default for ContactState {
    fn default() -> Self {
        Self {
            active: false,
            released: false,
            theta: [0.0; N],
            p: [[0.0; N]; N],
            x0: 0.0,
            t: 0.0,
            held: [[0.0; 4]; MAX_JUMP_CYCLES],
            n_held: 0,
            hist: [[0.0; 3]; MAX_DELAY + 1],
            head: 0,
            n_hist: 0,
            jumps: 0,
            surface_moved: false,
            since_jump: f64::INFINITY,
            pre_hold: ([0.0; N], [[0.0; N]; N]),
            alt: None,
            nu: 0.0,
            nu_sigma: 0.0,
            excited: [false; 3],
            used: false,
        }
    }
}

/// The hypothesis of a jump not (yet) kept: its θ, P, its log-likelihood minus the kept one's
/// since the jump, the time since the jump [s], and whether it is the surface's speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alt {
    pub theta: Vec5,
    pub p: Mat5,
    pub ll: f64,
    pub t: f64,
    pub moved: bool,
}

/// A jump's two hypotheses run side by side until one is this much likelier (100 : 1) ...
const DECIDE_LL: f64 = 4.605_170_185_988_091;
/// ... or for at most this long [s] (the time issue 42 gives a jump's re-estimate).
const DECIDE_S: f64 = 0.1;

/// The prior's estimate (no contact yet), at tip position `x`.
pub fn prior(p: &ContactParams, x: f64) -> ContactEstimate {
    ContactEstimate { k_hat: 0.5 * p.k_max, k_upper: p.k_max, k_lower: 0.0, x_e: x, x_e_dot: 0.0, mu_hat: 0.5 * p.mu_max, mu_upper: p.mu_max }
}

/// The estimate read from a state (`x`: the tip now, for the prior).
pub fn estimate(p: &ContactParams, s: &ContactState, x: f64) -> ContactEstimate {
    if !s.active {
        return prior(p, x);
    }
    let e = estimate_one(p, s);
    match s.alt {
        // while a jump's hypotheses are both open, the bounds cover both
        Some(a) => {
            let o = estimate_one(p, &ContactState { theta: a.theta, p: a.p, alt: None, ..*s });
            ContactEstimate {
                k_upper: e.k_upper.max(o.k_upper),
                k_lower: e.k_lower.min(o.k_lower),
                mu_upper: e.mu_upper.max(o.mu_upper),
                ..e
            }
        }
        None => e,
    }
}

fn estimate_one(p: &ContactParams, s: &ContactState) -> ContactEstimate {
    let k = s.theta[K];
    let sk = s.p[K][K].max(0.0).sqrt();
    let k_hat = k.max(0.0);
    let w = half_width(p, k_hat, sk);
    let up = k_hat + w;
    let k_upper = if k_hat <= p.k_max { up.min(p.k_max) } else { up };
    let x_e = if k > 1e-9 { s.x0 + s.theta[C] / k } else { s.x0 };
    let mu = s.theta[MU];
    let smu = s.p[MU][MU].max(0.0).sqrt();
    let mu_hat = mu.clamp(0.0, 1.0);
    ContactEstimate {
        k_hat,
        k_upper: k_upper.max(k_hat),
        k_lower: (k - w).max(0.0),
        x_e,
        x_e_dot: s.theta[W],
        mu_hat,
        mu_upper: (mu + p.z * smu).clamp(mu_hat, 1.0),
    }
}

/// The half-width of the stiffness bounds: `z σ_k` from the covariance plus the
/// errors-in-variables bias the excitation gate admits, `k̂ / z_x²` (module docs, "Bounds").
fn half_width(p: &ContactParams, k_hat: f64, sk: f64) -> f64 {
    p.z * sk + k_hat / (p.z_x * p.z_x)
}

/// The inputs are usable (finite, positive period and noise, delay in range).
fn usable(i: &ContactInputs) -> bool {
    i.x.is_finite()
        && i.x_dot.is_finite()
        && i.f.is_finite()
        && i.u.is_finite()
        && i.dt.is_finite()
        && i.dt > 0.0
        && i.x_resolution.is_finite()
        && i.x_resolution >= 0.0
        && i.sigma_f.is_finite()
        && i.sigma_f >= 0.0
        && (i.delay_cycles as usize) <= MAX_DELAY
}

/// Prior standard deviations `[σ_k0, σ_μ0, σ_b0]`: the uniform distribution's on `[0, max]`
/// (`max/√12`; its mean `max/2`).
fn prior_sigmas(p: &ContactParams) -> [f64; 3] {
    let s = 1.0 / 12f64.sqrt();
    [s * p.k_max, s * p.mu_max, s * p.b_max]
}

/// One cycle: `(params, state, inputs) → (state, estimate)`. Unusable inputs (non-finite,
/// a non-positive period, a delay above [`MAX_DELAY`]) leave the state as it was and report
/// its estimate (the bounds hold).
pub fn step(p: &ContactParams, s: &ContactState, i: &ContactInputs) -> (ContactState, ContactEstimate) {
    if !usable(i) {
        let x = if i.x.is_finite() { i.x } else { s.x0 };
        return (*s, estimate(p, s, x));
    }
    let mut n = *s;
    // history: newest at head
    n.head = (s.head + 1) % (MAX_DELAY + 1);
    n.hist[n.head] = [i.x, i.x_dot, i.u];
    n.n_hist = (s.n_hist + 1).min(MAX_DELAY + 1);
    let d = (i.delay_cycles as usize).min(n.n_hist - 1);
    let at = |back: usize| n.hist[(n.head + MAX_DELAY + 1 - back) % (MAX_DELAY + 1)];
    let [xa, mut va, ua] = at(d);
    let sigma_x = i.x_resolution / 12f64.sqrt();
    let mut sigma_v = 2f64.sqrt() * sigma_x / i.dt;
    if d >= 1 && d + 1 < n.n_hist {
        // the force's own time has a sample on either side: the central difference is the
        // velocity at that time (a backward difference lags by T/2)
        va = (at(d - 1)[0] - at(d + 1)[0]) / (2.0 * i.dt);
        sigma_v = sigma_x / (2f64.sqrt() * i.dt);
    }
    n.used = false;
    n.excited = [false; 3];
    if i.contact_start {
        start(p, &mut n, xa, va, ua, i.f, i.sigma_f);
        let first = [xa - n.x0, va, ua, i.f];
        let _ = apply(p, &mut n, first, i.sigma_f, sigma_x, sigma_v);
        return (n, estimate(p, &n, i.x));
    }
    if !(n.active && i.in_contact) {
        return (n, estimate(p, &n, i.x));
    }
    n.t += i.dt;
    n.since_jump += i.dt;
    // prediction
    let q = process_noise(p, &n, i.dt);
    kalman::predict(&mut n.theta, &mut n.p, i.dt, &q);
    let xc = xa - n.x0;
    // release of the surface speed (module docs, "Start")
    if !n.released {
        let sk = n.p[K][K].max(0.0).sqrt();
        if n.theta[K] - p.z * sk > 0.0 {
            n.released = true;
            let v_mean = (xc / n.t.max(i.dt)).abs().max(p.surface_speed).max(1e-9);
            let g = [-n.theta[K] / v_mean, 0.0, 1.0, 0.0, 0.0];
            kalman::reopen(&mut n.p, &g, p.surface_speed * p.surface_speed);
        }
    }
    // the contact is unilateral: (C1) holds only while it presses, and a force within
    // z σ_f of zero cannot be told from a contact that has opened: no evidence
    if i.f < p.z * i.sigma_f {
        n.n_held = 0;
        return (n, estimate(p, &n, i.x));
    }
    let sample = [xc, va, ua, i.f];
    if let Some(mut a) = n.alt {
        // both hypotheses of the last jump on this sample; the likelier is kept
        let mut h = ContactState { theta: a.theta, p: a.p, alt: None, surface_moved: a.moved, ..n };
        let q = process_noise(p, &h, i.dt);
        kalman::predict(&mut h.theta, &mut h.p, i.dt, &q);
        let l_alt = apply(p, &mut h, sample, i.sigma_f, sigma_x, sigma_v);
        let l_main = apply(p, &mut n, sample, i.sigma_f, sigma_x, sigma_v);
        a.ll += l_alt - l_main;
        a.t += i.dt;
        a.theta = h.theta;
        a.p = h.p;
        if a.ll > 0.0 {
            // swap: the other is now the likelier
            let kept = Alt { theta: n.theta, p: n.p, ll: -a.ll, t: a.t, moved: n.surface_moved };
            n.theta = a.theta;
            n.p = a.p;
            n.surface_moved = a.moved;
            a = kept;
        }
        n.alt = if a.ll < -DECIDE_LL || a.t >= DECIDE_S { None } else { Some(a) };
        if n.alt.is_none() && !n.surface_moved {
            // decided for a new material: its feed-through and damping are new too
            let [_, s_mu0, s_b0] = prior_sigmas(p);
            n.p[MU][MU] += s_mu0 * s_mu0;
            n.p[B][B] += s_b0 * s_b0;
        }
        return (n, estimate(p, &n, i.x));
    }
    if n.released {
        let (h, f_hat) = measurement(&n.theta, xc, va, ua);
        let r = noise(&n, i.sigma_f, sigma_x, sigma_v);
        let (_, u) = kalman::innovation(&n.p, &h, i.f, f_hat, r);
        n.nu = u.nu;
        n.nu_sigma = u.s.max(0.0).sqrt();
        if u.nu.abs() > p.z_jump * n.nu_sigma {
            if n.n_held == 0 {
                n.pre_hold = (n.theta, n.p);
            }
            n.held[n.n_held] = sample;
            n.n_held += 1;
            if n.n_held >= p.jump_cycles as usize {
                let m = n.n_held;
                n.n_held = 0;
                n.jumps += 1;
                n.since_jump = 0.0;
                // one degree of freedom each: which changed, k_e or ẋ_e?
                let (stiffer, l_k) = refilter(p, &n, m, Reopen::Stiffness, i, sigma_x, sigma_v);
                let (moved, l_w) = refilter(p, &n, m, Reopen::SurfaceSpeed, i, sigma_x, sigma_v);
                let (keep, other) = if l_w > l_k { (moved, stiffer) } else { (stiffer, moved) };
                n = keep;
                n.surface_moved = l_w > l_k;
                // the held samples choose which is reported first, but the decision is left to
                // the samples after them (module docs, "Jumps")
                n.alt = Some(Alt { theta: other.theta, p: other.p, ll: 0.0, t: 0.0, moved: l_w <= l_k });
            }
            return (n, estimate(p, &n, i.x));
        }
        n.n_held = 0;
    }
    let _ = apply(p, &mut n, sample, i.sigma_f, sigma_x, sigma_v);
    (n, estimate(p, &n, i.x))
}

/// What a jump reopens (module docs, "Jumps").
#[derive(Clone, Copy, PartialEq)]
enum Reopen {
    /// `k_e`, the surface where it was.
    Stiffness,
    /// `ẋ_e`.
    SurfaceSpeed,
}

/// The held samples filtered again from the state before the first of them, the
/// covariance reopened for `what`; returns the state and the samples' log-likelihood.
fn refilter(p: &ContactParams, n: &ContactState, m: usize, what: Reopen, i: &ContactInputs, sigma_x: f64, sigma_v: f64) -> (ContactState, f64) {
    let [s_k0, _, _] = prior_sigmas(p);
    let mut h = *n;
    (h.theta, h.p) = n.pre_hold;
    h.surface_moved = what == Reopen::SurfaceSpeed;
    h.since_jump = 0.0;
    if what == Reopen::SurfaceSpeed {
        h.p[W][W] += p.surface_speed * p.surface_speed;
    } else {
        let k = h.theta[K];
        let xe_c = if k > 1e-9 { h.theta[C] / k } else { 0.0 };
        kalman::reopen(&mut h.p, &[1.0, xe_c, 0.0, 0.0, 0.0], s_k0 * s_k0);
    }
    let mut ll = 0.0;
    for (j, smp) in n.held.iter().take(m).enumerate() {
        if j > 0 {
            let q = process_noise(p, &h, i.dt);
            kalman::predict(&mut h.theta, &mut h.p, i.dt, &q);
        }
        ll += apply(p, &mut h, *smp, i.sigma_f, sigma_x, sigma_v);
    }
    (h, ll)
}

/// The random walks' variances over one period `dt` (module docs).
fn process_noise(p: &ContactParams, n: &ContactState, dt: f64) -> Vec5 {
    let k_pos = n.theta[K].max(0.0);
    let rho2 = p.drift * p.drift * dt;
    let mut q = [0.0; N];
    q[K] = k_pos * k_pos * rho2;
    q[MU] = rho2;
    q[B] = p.b_max * p.b_max * rho2;
    if n.released {
        q[W] = p.surface_accel * p.surface_accel * dt;
        if n.surface_moved && n.since_jump < DECIDE_S {
            // the surface's manoeuvre: a speed change of up to v_e,max within the decision
            // window after a jump taken for the surface's speed
            q[W] += p.surface_speed * p.surface_speed / DECIDE_S * dt;
        }
    }
    q
}

/// A new contact: the prior (module docs, "Start") at the aligned sample `x`, `ẋ`, `u`, `f`.
fn start(p: &ContactParams, n: &mut ContactState, x: f64, v: f64, u: f64, f: f64, sigma_f: f64) {
    let [s_k0, s_mu0, s_b0] = prior_sigmas(p);
    let mu0 = 0.5 * p.mu_max;
    let b0 = 0.5 * p.b_max;
    n.active = true;
    n.released = false;
    n.x0 = x;
    n.t = 0.0;
    n.n_held = 0;
    n.jumps = 0;
    n.since_jump = f64::INFINITY;
    n.alt = None;
    // at x = x₀: f = −c + μ u + b ẋ
    n.theta = [0.5 * p.k_max, -(f - mu0 * u - b0 * v), 0.0, mu0, b0];
    let s_c0 = f.abs() + p.mu_max * u.abs() + p.b_max * v.abs() + p.z * sigma_f + 1e-3;
    n.p = [[0.0; N]; N];
    n.p[K][K] = s_k0 * s_k0;
    n.p[C][C] = s_c0 * s_c0;
    n.p[MU][MU] = s_mu0 * s_mu0;
    n.p[B][B] = s_b0 * s_b0;
}

/// The measurement's Jacobian and prediction (C2) at the sample `x − x₀`, `ẋ`, `u`.
fn measurement(th: &Vec5, xc: f64, v: f64, u: f64) -> (Vec5, f64) {
    let h = [xc, -1.0, -th[B], u, v - th[W]];
    (h, th[K] * xc - th[C] + th[MU] * u + th[B] * (v - th[W]))
}

/// Measurement noise (C2): the sensor's and the regressors' errors.
fn noise(n: &ContactState, sigma_f: f64, sigma_x: f64, sigma_v: f64) -> f64 {
    let k = n.theta[K].max(0.0);
    let b = n.theta[B].max(0.0);
    (sigma_f * sigma_f + k * k * sigma_x * sigma_x + b * b * sigma_v * sigma_v).max(1e-12)
}

/// One measurement update with the excitation gate (module docs); returns the sample's
/// log-likelihood under the prediction, `−½ (ν²/S + ln S)`.
fn apply(p: &ContactParams, n: &mut ContactState, smp: [f64; 4], sigma_f: f64, sigma_x: f64, sigma_v: f64) -> f64 {
    let [xc, v, u, f] = smp;
    let (h, f_hat) = measurement(&n.theta, xc, v, u);
    let r = noise(n, sigma_f, sigma_x, sigma_v);
    let (ph, upd) = kalman::innovation(&n.p, &h, f, f_hat, r);
    let eff = |i: usize| if n.p[i][i] > 0.0 { (ph[i] / n.p[i][i]).abs() } else { 0.0 };
    let ex_k = eff(K) > p.z_x * sigma_x;
    let ex_mu = n.p[MU][MU] > 0.0 && eff(MU) > 0.0;
    let ex_b = eff(B) > p.z_x * sigma_v;
    let mask = [ex_k, true, n.released, ex_mu, true];
    kalman::update(&mut n.theta, &mut n.p, &ph, upd, &mask);
    // a passive surface: μ ≥ 0, b_e ≥ 0 (module docs, "Constraints")
    for i in [MU, B] {
        if n.theta[i] < 0.0 && n.p[i][i] > 0.0 {
            kalman::project(&mut n.theta, &n.p, i, 0.0);
        }
    }
    if !n.theta.iter().all(|v| v.is_finite()) {
        // numerical failure: back to the prior at this sample (fails safe: k̄ = k_max)
        let x0 = n.x0;
        start(p, n, x0 + xc, v, u, f, sigma_f);
        return f64::NEG_INFINITY;
    }
    n.nu = upd.nu;
    n.nu_sigma = upd.s.max(0.0).sqrt();
    n.excited = [ex_k, ex_mu, ex_b];
    n.used = true;
    -0.5 * (upd.nu * upd.nu / upd.s + upd.s.ln())
}

#[cfg(test)]
mod tests;
