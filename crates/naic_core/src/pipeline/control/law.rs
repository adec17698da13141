//! One interface for the force laws along the force axis `n`, one dispatch point.
//!
//! A force law is its parameters ([`super::force_law::ForceLawParams`], with the scheduled
//! law's [`ScheduledParams`] inside), its state (the fields `law` and `sched` of
//! [`super::ControlState`], written only by [`step`], [`rearm`](step) at a new contact and
//! the constructors [`new_sched`] / [`after_hold`]) and one pure step on scalars along `n`
//! ([`step`]). What the generic stages need from a law is an output of that step, not a
//! branch on the mode in `controller.rs` or `super`:
//!
//! - the commanded acceleration along `n` ([`AxisOutputs::xdd`]; `None`: the generic
//!   stage's own, eq 6 in free space or the retraction),
//! - the reference velocity along `n` the friction feedforward is to be evaluated at, and
//!   how ([`AxisOutputs::v_ref`], [`AxisOutputs::friction`]),
//! - a factor on the model's gravity torque ([`AxisOutputs::gravity_factor`]),
//! - the gain the law divides its commands by ([`AxisOutputs::model_gain`]).
//!
//! Before the step, a law may shape the reference ([`shape`], pure: it returns the shaped
//! reference and the shaper state, which [`step`] stores) and bound the impedance of every
//! axis ([`impedance`], a function of the parameters); it names its contact threshold
//! ([`contact_threshold`]) and whether it needs the model's free fall along `n`
//! ([`needs_free_fall`]). Every `match` on [`Mode`] of the control stage is in this file.

use nalgebra::Vector3;

use super::force_law::{self, ForceLawInputs, ForceLawOutputs, ForceLawState, Mode};
use super::contact::ContactEstimate;
use super::derived::{self, DerivedInputs, DerivedState};
use super::stiction;
use super::scheduled::{self, ScheduledInputs, ScheduledParams, ScheduledState, Shaper};
use super::{ControlParams, ForceAxis, ImpedanceParams, Phase};
use crate::pipeline::feedforward::{FastVelocity, ReferenceBlend};

/// What the generic stage does along `n` this cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Regime {
    /// Free space (no force target).
    #[default]
    Free,
    /// In contact: the law commands the acceleration along `n`.
    Contact,
    /// A force-limit retraction, in progress or latched: the generic stage commands `n`.
    Retracting,
}

/// What the controller computes for the law before the control stage (see [`shape`],
/// [`needs_free_fall`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prepared {
    /// The shaper state [`shape`] returned (`None`: the law shapes nothing).
    pub shaper: Option<Shaper>,
    /// The model's free-fall acceleration along `n` at this pose [m/s²] (NaN: not computed).
    pub a_free: f64,
    /// The model's apparent mass along `n` at this pose, `D̂ = 1 / (nᵀ J M⁻¹ Jᵀ n)` [kg]
    /// (NaN: not computed; [`needs_apparent_mass`]).
    pub mass_n: f64,
    /// `m_t`: the mass of the tool beyond the F/T sensor [kg] (the robot file's tool, the
    /// URDF's `ft_sensor` link), whose inertial force `m_t ẍ` the sensor reads with the
    /// contact force (0: none known).
    pub tool_mass: f64,
    /// The contact force along `n` [N] free of the tool's inertial force, on a sensor that
    /// reads it (`estimate::ToolMotion`): what the contact decisions read instead of `f_ext`
    /// (`None`: `f_ext`).
    pub f_contact: Option<f64>,
}

impl Default for Prepared {
    fn default() -> Self {
        Self { shaper: None, a_free: f64::NAN, mass_n: f64::NAN, tool_mass: 0.0, f_contact: None }
    }
}

/// The inputs of one cycle along `n` (into the surface positive).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisInputs {
    pub regime: Regime,
    /// The phase of the previous cycle.
    pub prev_phase: Phase,
    /// Contact started this cycle.
    pub entered: bool,
    /// Tip position `x` [m], `ẋ` [m/s], error `e = x_d − x` [m], `ė` [m/s], reference
    /// velocity `ẋ_d` [m/s] and acceleration `ẍ_d` [m/s²], all along `n`.
    pub x: f64,
    pub x_dot: f64,
    pub e: f64,
    pub e_dot: f64,
    pub v_d: f64,
    pub a_d: f64,
    /// Measured force along `n` [N] (pushing positive) and its target.
    pub f_ext: f64,
    pub f_d: f64,
    /// The generic stage's commanded acceleration along `n` this cycle [m/s²] (eq 6, or the
    /// retraction's).
    pub v_n: f64,
    /// The free-space impedance along `n` (`m`, `b`, `k`) after [`impedance`].
    pub free_m: f64,
    pub free_b: f64,
    pub free_k: f64,
    /// The expected surface along `n` [m] (NaN: none).
    pub surface_n: f64,
    pub pre: Prepared,
}

/// How the friction feedforward's joint velocity is formed from the reference twist
/// ([`crate::pipeline::feedforward::blend`], [`crate::pipeline::feedforward::blend_fast`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionVelocity {
    pub blend: ReferenceBlend,
    /// The unfiltered velocity in a joint's Stribeck drop: the parameters, the contact gate
    /// and the stiffness it uses.
    pub fast: Option<(FastVelocity, f64, f64)>,
}

/// The outputs of one cycle along `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisOutputs {
    /// The acceleration to command along `n` [m/s²]; `None`: the generic stage's.
    pub xdd: Option<f64>,
    /// The velocity along `n` the friction feedforward is evaluated at [m/s]; `None`: the
    /// reference's.
    pub v_ref: Option<f64>,
    pub report: ForceLawOutputs,
    /// Factor `c` on the model's gravity torque added to τ (`τ += c G(q)`; 0: none).
    pub gravity_factor: f64,
    /// The model's gain along `n` the law's commands are divided by (1: none).
    pub model_gain: f64,
    /// The friction feedforward's velocity; `None`: the measured one.
    pub friction: Option<FrictionVelocity>,
}

impl AxisOutputs {
    /// Nothing of the law's own: the generic stage's command, reference velocity and
    /// friction velocity, no gravity factor, model gain 1; the report carries the force
    /// error `e_f` [N].
    fn generic(e_f: f64) -> Self {
        AxisOutputs { xdd: None, v_ref: None, report: ForceLawOutputs { e_f, ..Default::default() }, gravity_factor: 0.0, model_gain: 1.0, friction: None }
    }
}

/// Checks the law's own parameters (the paper laws' are checked by the control stage).
pub fn validate(p: &ControlParams) -> Result<(), crate::pipeline::ConfigError> {
    match p.force_law.mode {
        Mode::Scheduled => p.force_law.scheduled.validate(),
        // The derived law shares the scheduled law's approach, shaping and axis bound.
        Mode::Derived => p.force_law.scheduled.validate().and_then(|_| p.force_law.derived.validate()),
        Mode::Naic | Mode::Aic | Mode::Fixed => Ok(()),
    }
}

/// The law's contact threshold [N].
pub fn contact_threshold(p: &ControlParams) -> f64 {
    match p.force_law.mode {
        Mode::Scheduled | Mode::Derived => p.contact.scheduled_enter_n,
        Mode::Naic | Mode::Aic | Mode::Fixed => p.contact.enter_n,
    }
}

/// The impedance every axis runs with (a law may bound it; the paper laws use it as set).
pub fn impedance(p: &ControlParams) -> ImpedanceParams {
    match p.force_law.mode {
        // The scheduled law bounds every axis' damping-to-mass ratio by the loop delay (the
        // derived law the tangential axes' the same way; along n its rule sets the gains).
        Mode::Scheduled | Mode::Derived => {
            let sp = &p.force_law.scheduled.schedule;
            ImpedanceParams { m_d: scheduled::schedule::axis_masses(sp, &p.impedance.m_d, &p.impedance.b_d, p.force_law.lambda), ..p.impedance }
        }
        Mode::Naic | Mode::Aic | Mode::Fixed => p.impedance,
    }
}

/// Whether the law needs [`Prepared::a_free`] (a forward dynamics per cycle).
pub fn needs_free_fall(p: &ControlParams) -> bool {
    match p.force_law.mode {
        Mode::Scheduled => true,
        Mode::Naic | Mode::Aic | Mode::Fixed | Mode::Derived => false,
    }
}

/// Whether the law needs [`Prepared::mass_n`] (two forward dynamics per cycle).
pub fn needs_apparent_mass(p: &ControlParams) -> bool {
    match p.force_law.mode {
        Mode::Derived => true,
        Mode::Naic | Mode::Aic | Mode::Fixed | Mode::Scheduled => false,
    }
}

/// The expected surface along `n` the law approaches (NaN: none).
pub fn surface_along(p: &ControlParams) -> f64 {
    match p.force_law.mode {
        Mode::Scheduled | Mode::Derived => p.force_law.scheduled.approach.expected_surface.map_or(f64::NAN, |z| p.force_axis.surface(z)),
        Mode::Naic | Mode::Aic | Mode::Fixed => f64::NAN,
    }
}

/// The tangential reference `(p_d, v_d, a_d)` as the law wants it this cycle, and the shaper
/// state for [`Prepared::shaper`]. Pure. The paper laws pass it unchanged.
pub fn shape(
    p: &ControlParams,
    sched: &ScheduledState,
    phase: Phase,
    p_d: &Vector3<f64>,
    v_d: &Vector3<f64>,
    a_d: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>, Option<Shaper>) {
    let fl = &p.force_law;
    let shapes = match fl.mode {
        Mode::Scheduled | Mode::Derived => fl.scheduled.reference_shaping > 0.0,
        Mode::Naic | Mode::Aic | Mode::Fixed => false,
    };
    if !shapes {
        return (*p_d, *v_d, *a_d, sched.shaper);
    }
    let on = Shaper::on(v_d);
    if phase != Phase::Contact {
        return (*p_d, *v_d, *a_d, Some(on));
    }
    let prev = sched.shaper.unwrap_or(on);
    let n = &p.force_axis;
    match n.aligned() {
        Some(ax) => {
            let (ps, vs, as_, sh) = scheduled::shape_reference(fl.scheduled.reference_shaping, fl.lambda, ax, &prev, p_d, v_d, a_d);
            (ps, vs, as_, Some(sh))
        }
        None => {
            // Shape every base axis, then put back the reference's component along n.
            let (ps, vs, as_, sh) = scheduled::shape_reference(fl.scheduled.reference_shaping, fl.lambda, usize::MAX, &prev, p_d, v_d, a_d);
            (n.with_along(&ps, n.dot(p_d)), n.with_along(&vs, n.dot(v_d)), n.with_along(&as_, n.dot(a_d)), Some(sh))
        }
    }
}

/// What the law's approach bounds, for the operator's log (not in the 1 kHz path): the
/// derived law's guarded approach at `approach_speed` and the force rise its first contact
/// may add on the stiffest surface expected, `k̄ v (d + ½) T`, or with an expected surface
/// the impact-bounded speed the braking approach reaches near it. `None`: the law states no bound.
pub fn approach_report(p: &ControlParams, f_d: f64) -> Option<String> {
    let fl = &p.force_law;
    match fl.mode {
        Mode::Derived => {
            let dp = &fl.derived;
            let (ap, k, t) = (&fl.scheduled.approach, dp.contact.k_max, fl.lambda);
            let guarded = derived::impact_bound(dp, ap.max_speed, k, t);
            let mut line = format!(
                "derived: approach along n at most approach_speed = {:.4} m/s; a first contact at that speed on the stiffest surface expected (stiffness_max = {k} N/m) adds up to k v (d + 1/2) T = {guarded:.2} N before the loop reacts (d = {} periods of {} s)",
                ap.max_speed, dp.delay_cycles, t
            );
            if ap.expected_surface.is_some() {
                let v = derived::impact_speed(dp, f_d, k, t).min(ap.max_speed);
                line += &format!(
                    "; toward expected_surface it brakes (a_b = w v / 2, w the servo's b/m) to eps f_d / (k (d + 1/2) T) = {:.4} m/s by surface_uncertainty = {} m before it, at f_d = {f_d} N (impact <= eps f_d = {:.2} N, eps = {})",
                    v,
                    dp.surface_uncertainty,
                    derived::impact_bound(dp, v, k, t),
                    dp.impact_fraction
                );
            }
            Some(line)
        }
        Mode::Naic | Mode::Aic | Mode::Fixed | Mode::Scheduled => None,
    }
}

/// The scheduled law's state at start.
pub fn new_sched(p: &ControlParams) -> ScheduledState {
    ScheduledState::new(&p.force_law.scheduled, p.force_law.lambda)
}

/// The scheduled law's state after a safe hold: fresh, but the oracle's known stiffness and
/// the shaper are kept.
pub fn after_hold(p: &ControlParams, s: &ScheduledState) -> ScheduledState {
    ScheduledState { k_known: s.k_known, shaper: s.shaper, ..new_sched(p) }
}

/// The gain along `n` the law divides its commands by, in state `s` (the paper laws never
/// learn it: its initial value, 1).
pub fn model_gain(p: &ControlParams, s: &ScheduledState) -> f64 {
    s.gain.used(&p.force_law.scheduled.model_gain)
}

/// `(k̂_e, confidence)` of the scheduled law's estimator (the oracle's known k_e if set).
fn estimator_report(p: &ScheduledParams, s: &ScheduledState) -> (f64, f64) {
    if let Some(k) = s.k_known {
        return (k, 1.0);
    }
    let e = scheduled::estimator::estimate(&p.estimator, &s.est);
    (e.k_e, e.confidence)
}

/// One cycle of the force law along `n`. Pure: the law's states `(law, sched, derived)`
/// in, the next ones and the outputs out (the copying form of [`update`]).
pub fn step(p: &ControlParams, law: &ForceLawState, sched: &ScheduledState, der: &DerivedState, u: &AxisInputs) -> (ForceLawState, ScheduledState, DerivedState, AxisOutputs) {
    let (mut l, mut s, mut d) = (*law, *sched, *der);
    let out = update(p, &mut l, &mut s, &mut d, u);
    (l, s, d, out)
}

/// One cycle of the force law along `n`: the one dispatch point. The law's states
/// `(law, sched, derived)` are updated in place: the same numbers as [`step`].
pub fn update(p: &ControlParams, law: &mut ForceLawState, sched: &mut ScheduledState, der: &mut DerivedState, u: &AxisInputs) -> AxisOutputs {
    let fl = &p.force_law;
    if fl.mode == Mode::Derived {
        let (l, s, d, out) = step_derived(p, law, sched, der, u);
        (*law, *sched, *der) = (l, s, d);
        return out;
    }
    update_scheduled_or_paper(p, law, sched, u)
}

/// The derived law's approach along n: the scheduled law's PI approach servo at most
/// `approach_speed`; toward an expected surface on the braking profile that reaches the
/// impact-bounded speed `ε f_d / (k̄ (d + ½) T)` `δ` before it (derived::braking_speed): the
/// profile is the servo's speed limit at every distance (`band` unbounded), not
/// `approach_band_speed` within `approach_band`. Returns `(ẍ_n, a_i, v_t)`: the command, the
/// servo's integral and its target speed.
fn derived_approach(p: &ControlParams, est: &ContactEstimate, u: &AxisInputs, integral: f64) -> (f64, f64, f64) {
    let fl = &p.force_law;
    let dp = &fl.derived;
    let k_up = if est.k_upper.is_finite() && est.k_upper > 0.0 { est.k_upper } else { dp.contact.k_max };
    let v_b = derived::braking_speed(dp, u.f_d, k_up, fl.lambda, u.surface_n - u.x, u.x_dot, u.free_b / u.free_m);
    let ap = &scheduled::ApproachParams { speed: v_b.min(fl.scheduled.approach.max_speed), band: f64::INFINITY, ..fl.scheduled.approach };
    let free = scheduled::ApproachAxis { m: u.free_m, b: u.free_b, k: u.free_k, e: u.e, v_d: u.v_d, a_d: u.a_d };
    let (a_n, e) = scheduled::approach_accel(ap, u.surface_n, u.x, u.x_dot, free, u.v_n, integral, fl.lambda);
    (a_n, e, scheduled::approach_target(ap, u.surface_n, u.x, &free))
}

/// The derived law ([`super::derived`]): its step in contact, the scheduled law's approach
/// servo in free space; the contact estimator every cycle (its history pairs the delayed
/// force); no gravity factor or model gain; in contact the friction feedforward at the
/// reference blend (the stiction-aware hold, [`super::stiction`]).
fn step_derived(p: &ControlParams, law: &ForceLawState, sched: &ScheduledState, der: &DerivedState, u: &AxisInputs) -> (ForceLawState, ScheduledState, DerivedState, AxisOutputs) {
    let fl = &p.force_law;
    let dp = &fl.derived;
    let mut next_law = if u.entered { law.rearm(u.f_ext - u.f_d) } else { *law };
    let mut next_sched = *sched;
    let mut out = AxisOutputs::generic(u.f_ext - u.f_d);
    let (d, est) = derived::estimate(dp, der, u.x, u.x_dot, u.f_ext, u.entered, u.regime == Regime::Contact, fl.lambda);
    let mut next_der = if u.entered { d.rearm(u.f_ext) } else { d };
    // The velocity along n from the encoders' position (derived::observe), every cycle.
    next_der.observer = derived::observe(der, dp.delay_cycles, u.x, u.x_dot, fl.lambda);
    let e_dot = match next_der.observer {
        Some(o) if dp.parts.velocity_observer => u.e_dot + (u.x_dot - o.v),
        _ => u.e_dot,
    };
    match u.regime {
        Regime::Contact => {
            let inputs = DerivedInputs { e_dot, f_ext: u.f_ext, f_d: u.f_d, mass: u.pre.mass_n, estimate: est, k_known: sched.k_known };
            let (s, r) = derived::step(dp, fl.lambda, fl.integral_limit_n, &next_der, &inputs);
            // No contact in evidence (the force less the tool's inertial force below the
            // contact exit level, until it exceeds the entry level again:
            // [`derived::contact_force`], [`derived::contact_lost`]): the tip may be in the air
            // (a contact entered on the tool's inertial wrench, or left), and its next touch is
            // an impact. The law then runs its free-space approach ([`derived_approach`]), so
            // that touch is no harder than a first contact; the integral is held and the
            // reference responses restart from the measured force (no wind-up against a force
            // the approach withholds). With force in evidence the law is as designed. A tip at
            // or beyond the position where contact was last in evidence (a force above the
            // entry level, and a surface the estimator has located: `k_lower > 0`) has not left
            // the surface: a force that falls there says the surface is softer (a switch of
            // material), which is the force loop's to follow, not an impact to come.
            let f_c = if dp.parts.tool_inertia { u.pre.f_contact.unwrap_or_else(|| derived::contact_force(der, u.f_ext, u.pre.tool_mass)) } else { u.f_ext };
            let in_evidence = f_c > contact_threshold(p) && est.k_lower > 0.0;
            let x_touch = if in_evidence && u.x.is_finite() { Some(u.x) } else if u.entered { None } else { der.x_touch };
            // (within one count of the tip's position resolution)
            let beyond_touch = x_touch.is_some_and(|x_t| u.x >= x_t - dp.x_resolution);
            let lost = dp.parts.contact_loss && !beyond_touch && derived::contact_lost(der.approaching && !u.entered, f_c, u.f_d, contact_threshold(p), p.contact.exit_n);
            let approach = lost.then(|| derived_approach(p, &est, u, sched.approach_integral));
            next_der = if lost {
                DerivedState { integral: next_der.integral, approaching: true, x_touch, ..s.rearm(u.f_ext) }
            } else {
                DerivedState { approaching: false, x_touch, ..s }
            };
            // The shared law state reports the gains (Status, /naic/params).
            next_law = ForceLawState { m_d: s.m_d, b_d: s.b_d, sigma: s.k_i * fl.lambda, phi: s.integral / s.b_d, e_f_prev: r.e_f, edd_prev: r.e_ddot };
            // The approach servo's integral `a_i` is the free-space estimate of the constant
            // acceleration disturbance along n (the model's gravity error, b⁻¹ΔF at rest):
            // it persists in contact, so it stays as a feedforward there (held, not updated)
            // instead of stepping the contact loop by ΔF at the first contact.
            out.report = ForceLawOutputs { e_ddot: r.e_ddot, e_f: r.e_f, k_e_hat: r.estimate.k_hat, k_e_confidence: derived::confidence(&r.estimate), ..Default::default() };
            if let Some((a_n, e, v_t)) = approach {
                next_sched.approach_integral = e;
                out.xdd = Some(a_n);
                out.v_ref = Some(v_t);
            } else {
                let a_i = if dp.parts.disturbance_feedforward { sched.approach_integral } else { 0.0 };
                out.xdd = Some(u.a_d - r.e_ddot + a_i);
                // The stiction-aware hold (super::stiction): a joint held by its static
                // friction gets no friction feedforward from its velocity noise.
                if dp.parts.stiction_hold {
                    out.friction = stiction::friction_velocity(fl.scheduled.friction_reference, u.regime);
                }
            }
        }
        Regime::Free => {
            let (a_n, e, v_t) = derived_approach(p, &est, u, sched.approach_integral);
            next_sched.approach_integral = e;
            out.xdd = Some(a_n);
            out.v_ref = Some(v_t);
            out.report.k_e_hat = est.k_hat;
            out.report.k_e_confidence = derived::confidence(&est);
        }
        Regime::Retracting => {}
    }
    next_der = derived::commanded(&next_der, u.pre.mass_n, out.xdd.unwrap_or(u.v_n), u.f_ext);
    if let Some(shaper) = u.pre.shaper {
        next_sched.shaper = Some(shaper);
    }
    (next_law, next_sched, next_der, out)
}

/// The scheduled law and the paper laws (the latter: eq 8–15 in contact, nothing else).
/// In place: `law` and `sched` hold the previous cycle's states on entry.
fn update_scheduled_or_paper(p: &ControlParams, law: &mut ForceLawState, sched: &mut ScheduledState, u: &AxisInputs) -> AxisOutputs {
    let fl = &p.force_law;
    let sp = &fl.scheduled;
    // The ĝ this cycle's commands are made with (in realised units for the predictor):
    // the previous cycle's, read before a re-arm.
    let g_used = sched.gain.used(&sp.model_gain);
    if u.entered {
        *law = law.rearm(u.f_ext - u.f_d);
        *sched = sched.rearm(&fl.scheduled, u.x, u.f_ext);
    }
    let (next_law, next_sched) = (law, sched);
    let mut out = AxisOutputs::generic(u.f_ext - u.f_d);
    if fl.mode != Mode::Scheduled {
        if u.regime == Regime::Contact {
            let (l, report) = force_law::step(fl, &next_law, &ForceLawInputs { e_dot: u.e_dot, f_ext: u.f_ext, f_d: u.f_d });
            *next_law = l;
            out.xdd = Some(u.a_d - report.e_ddot);
            out.report = report;
        }
        return out;
    }

    // The scheduled law.
    match u.regime {
        Regime::Contact => {
            let inputs = ScheduledInputs { x: u.x, x_dot: u.x_dot, e_dot: u.e_dot, f_ext: u.f_ext, f_d: u.f_d, xdd_d: u.a_d };
            let (s, r) = scheduled::step(sp, fl.lambda, fl.integral_limit_n, &next_sched, &inputs);
            *next_sched = s;
            let g = &s.gains;
            // The shared law state reports the scheduled weights (Status, /naic/params).
            *next_law = ForceLawState { m_d: g.m_d, b_d: g.b_d, sigma: g.sigma, phi: s.integral / g.b_d, e_f_prev: r.e_f, edd_prev: r.e_ddot };
            // Divided by the model's gain along n: the arm realises what the law asks.
            out.xdd = Some((u.a_d - r.e_ddot) / g_used);
            // The friction feedforward's velocity along n: the observer's v̄ where it runs,
            // the reference's where v̄ would be the raw encoder velocity.
            out.v_ref = r.v_bar;
            out.report = ForceLawOutputs {
                e_ddot: r.e_ddot,
                e_f: r.e_f,
                gamma: r.gamma,
                gamma_bound: r.gamma_bound,
                gamma_clipped: r.gamma_clipped,
                weights_projected: r.weights_projected,
                k_e_hat: r.estimate.k_e,
                k_e_confidence: r.estimate.confidence,
            };
        }
        Regime::Free => {
            // A PI velocity servo along n toward the reference (robust to a model error),
            // slower near an expected surface (`scheduled::approach_accel`).
            let free = scheduled::ApproachAxis { m: u.free_m, b: u.free_b, k: u.free_k, e: u.e, v_d: u.v_d, a_d: u.a_d };
            let (a_n, e) = scheduled::approach_accel(&sp.approach, u.surface_n, u.x, u.x_dot, free, u.v_n, next_sched.approach_integral, fl.lambda);
            next_sched.approach_integral = e;
            out.xdd = Some(a_n);
            out.v_ref = Some(scheduled::approach_target(&sp.approach, u.surface_n, u.x, &free));
        }
        Regime::Retracting => {}
    }
    if u.regime != Regime::Retracting {
        let e = estimator_report(sp, next_sched);
        out.report.k_e_hat = e.0;
        out.report.k_e_confidence = e.1;
    }
    let v_n = out.xdd.unwrap_or(u.v_n);
    if u.regime != Regime::Contact {
        // The predictor remembers every command along n; in contact the law pushes its own.
        *next_sched = next_sched.commanded(g_used * v_n);
    }
    // The model's gain along n: learnt in free space only (no contact force).
    let phase_free = u.regime == Regime::Free;
    let learn = u.prev_phase == Phase::Free && phase_free && u.f_ext < p.contact.scheduled_enter_n;
    next_sched.gain = next_sched.gain.cycle(&sp.model_gain, fl.lambda, u.x_dot, learn, v_n);
    // The gravity correction by the learnt model gain (scheduled::gain::GravityCorrection),
    // its static reading once, in free space, from the model's free fall along n.
    if u.regime != Regime::Contact && next_sched.gain.wants_heavy(&sp.model_gain, fl.lambda) {
        next_sched.gain = next_sched.gain.with_heavy(next_sched.approach_integral, u.pre.a_free);
    }
    out.gravity_factor = next_sched.gain.gravity_factor(&sp.model_gain, fl.lambda);
    out.model_gain = next_sched.gain.used(&sp.model_gain);
    if let Some(shaper) = u.pre.shaper {
        next_sched.shaper = Some(shaper);
    }
    if let Some(b) = sp.friction_reference {
        let fast = sp.friction_fast.map(|f| {
            let age = next_sched.contact_cycles as f64 * fl.lambda;
            let gate = f.contact_gate(u.regime == Regime::Contact, age);
            (f, gate, next_sched.k_known.unwrap_or(out.report.k_e_hat))
        });
        out.friction = Some(FrictionVelocity { blend: b, fast });
    }
    out
}

/// The expected surface's coordinate `z` on `n`'s dominant base axis, as a position along
/// `n` (exact for an axis-aligned `n`: `sign · z`).
impl ForceAxis {
    pub fn surface(&self, z: f64) -> f64 {
        let ax = self.dominant();
        self.n[ax].signum() * z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::control::{ContactDetect, ForceLimit};
    use crate::pipeline::control::force_law::{ForceLawParams, WeightBounds};

    fn params(mode: Mode, surface: Option<f64>) -> ControlParams {
        let mut fl = ForceLawParams { mode, sigma: 0.01, gamma: 0.0, bounds: WeightBounds::default(), lambda: 1e-3, sigma_margin: 0.5, integral_limit_n: 50.0, scheduled: Default::default(), derived: Default::default() };
        fl.scheduled.approach.expected_surface = surface;
        ControlParams {
            impedance: ImpedanceParams { m_d: [1.0; 6], b_d: [40.0; 6], k_free: [50.0; 6], k_contact: [100.0; 6] },
            force_axis: ForceAxis::base(2, -1.0),
            force_law: fl,
            contact: ContactDetect { enter_n: 1.0, scheduled_enter_n: 0.5, exit_n: 0.2, exit_cycles: 0 },
            force_limit: ForceLimit { limit_n: 50.0, retract_speed: 0.02, retract_cycles: 500, latch: false },
        }
    }

    /// The law's inputs in free space with the tip at `x` along n moving at `v`, the
    /// reference 3 cm beyond the surface at 0.
    fn free_inputs(p: &ControlParams, x: f64, v: f64, f_d: f64) -> AxisInputs {
        AxisInputs {
            regime: Regime::Free,
            prev_phase: Phase::Free,
            entered: false,
            x,
            x_dot: v,
            e: 0.03 - x,
            e_dot: -v,
            v_d: 0.0,
            a_d: 0.0,
            f_ext: 0.0,
            f_d,
            v_n: 0.0,
            free_m: 1.0,
            free_b: 40.0,
            free_k: 50.0,
            surface_n: surface_along(p),
            pre: Prepared::default(),
        }
    }

    /// The derived law's free-space target speed along n (`x` the tip along n, at rest) and
    /// the approach's reported bound.
    fn target_speed(p: &ControlParams, x: f64, f_d: f64) -> f64 {
        let s = super::super::ControlState::new(p);
        let (_, _, _, out) = step(p, &s.law, &s.sched, &s.derived, &free_inputs(p, x, 0.0, f_d));
        out.v_ref.expect("the derived law names its approach speed")
    }

    /// Item 5 of issue 42 with the braking profile (group F): within `δ` of an expected
    /// surface the derived law approaches at `v_c = ε f_d / (k̄ (d + ½) T)`, so a first
    /// contact on the stiffest surface the estimate allows adds at most `ε f_d` before the
    /// loop reacts; farther out at `√(2 a_b (s − δ))` (at rest, `a_b = w v_c / 2`, `w = b/m`
    /// = 40/s here); far from it, and with no expected surface, at the free-space servo's
    /// speed (at most `approach_speed`).
    #[test]
    fn the_derived_approach_bounds_the_impact_near_an_expected_surface() {
        for (d, f_d) in [(1.0, 10.0), (2.0, 10.0), (2.0, 3.0), (0.0, 20.0)] {
            let mut p = params(Mode::Derived, Some(0.0));
            p.force_law.derived.delay_cycles = d;
            let dp = &p.force_law.derived;
            let k = dp.contact.k_max;
            let v_c = dp.impact_fraction * f_d / (k * (d + 0.5) * 1e-3);
            let v_near = target_speed(&p, -0.0008, f_d);
            let rise = derived::impact_bound(dp, v_near, k, 1e-3);
            assert!(rise <= dp.impact_fraction * f_d + 1e-9, "d {d}, f_d {f_d}: impact {rise} N at {v_near} m/s");
            assert!((v_near - v_c.min(1.25 * 0.0308)).abs() < 1e-12, "d {d}, f_d {f_d}: {v_near} m/s");
            // Farther out: the braking profile or the impedance's own approach (50/40 × the
            // distance to the reference 3 cm beyond the surface), the slower; above v_c.
            let profile = |s: f64| (2.0 * 0.5 * 40.0 * v_c * (s - dp.surface_uncertainty)).sqrt();
            for s in [0.005, 0.1] {
                let v = target_speed(&p, -s, f_d);
                let want = profile(s).min(1.25 * (0.03 + s));
                assert!((v - want).abs() < 1e-12 && v > v_c, "d {d}, f_d {f_d}, {s} m out: {v} m/s, want {want}");
            }
        }
        // No expected surface (scenario none): the guarded approach at the servo's speed,
        // its impact bound reported; the other laws report none.
        let p = params(Mode::Derived, None);
        assert!((target_speed(&p, -0.005, 10.0) - 1.25 * 0.035).abs() < 1e-9);
        let line = approach_report(&p, 10.0).expect("derived reports its approach");
        let bound = derived::impact_bound(&p.force_law.derived, p.force_law.scheduled.approach.max_speed, p.force_law.derived.contact.k_max, 1e-3);
        assert!(line.contains("approach_speed") && line.contains(&format!("{bound:.2} N")), "{line}");
        assert!(approach_report(&params(Mode::Derived, Some(0.0)), 10.0).unwrap().contains("surface_uncertainty = 0.001 m"));
        for m in [Mode::Naic, Mode::Aic, Mode::Fixed, Mode::Scheduled] {
            assert_eq!(approach_report(&params(m, None), 10.0), None, "{m:?}");
        }
    }

    /// The braking approach in closed loop (group F of issue 42): the law's free-space
    /// command drives a double integrator through a loop delay of `d` periods (the arm
    /// realises the commanded acceleration), from 37 mm/s (the scenarios' approach) toward a
    /// surface of stiffness `k̄` at the expected position and at the earliest the
    /// uncertainty allows (`δ` before it). The force that surface would reach in the loop's
    /// reaction time `(d + ½) T` after contact, at the measured contact speed, is at most
    /// `ε f_d` (item 5), over the whole `(d + 1)` periods at most `ε f_d (d + 1)/(d + ½)`;
    /// and the time from 10 mm out to the surface is below the constant-speed band's
    /// `10 mm / v_c` by the profile's saving. Without the profile the crossing took the band
    /// at `v_c`: 5.0 s at 3 N, d = 1.
    #[test]
    fn the_braking_approach_arrives_at_the_impact_speed_and_saves_the_band() {
        let t = 1e-3;
        for (d, f_d) in [(0usize, 20.0), (1, 10.0), (1, 3.0), (2, 3.0), (3, 3.0)] {
            let mut p = params(Mode::Derived, Some(0.0));
            p.force_law.derived.delay_cycles = d as f64;
            let dp = p.force_law.derived;
            let k = dp.contact.k_max;
            let v_c = dp.impact_fraction * f_d / (k * (d as f64 + 0.5) * t);
            for wall in [0.0, -dp.surface_uncertainty] {
                let mut s = super::super::ControlState::new(&p);
                let (mut x, mut v) = (-0.03f64, 0.037f64);
                let mut cmds = std::collections::VecDeque::from(vec![0.0; d]);
                let (mut t_band, mut n) = (None, 0usize);
                while x < wall && n < 60_000 {
                    let u = free_inputs(&p, x, v, f_d);
                    let (l, sc, de, out) = step(&p, &s.law, &s.sched, &s.derived, &u);
                    (s.law, s.sched, s.derived) = (l, sc, de);
                    cmds.push_back(out.xdd.unwrap());
                    let a = cmds.pop_front().unwrap();
                    v += a * t;
                    x += v * t;
                    n += 1;
                    if t_band.is_none() && x >= -0.01 {
                        t_band = Some(n);
                    }
                }
                assert!(x >= wall, "d {d}, f_d {f_d}: never reached the surface at {wall} m (x = {x})");
                let rise = k * v * (d as f64 + 0.5) * t;
                assert!(rise <= dp.impact_fraction * f_d * 1.02, "d {d}, f_d {f_d}, wall {wall}: contact at {v} m/s (v_c {v_c}) adds {rise} N > eps f_d");
                let worst = k * v * (d as f64 + 1.0) * t;
                assert!(worst <= dp.impact_fraction * f_d * (d as f64 + 1.0) / (d as f64 + 0.5) * 1.02, "d {d}: {worst} N");
                let band_time = (n - t_band.unwrap()) as f64 * t;
                let flat = (0.01 + wall) / v_c;
                // Where v_c is well below the approach's speed (every case but d 0 at 20 N,
                // where v_c = 40 mm/s and nothing brakes).
                if v_c < 0.25 * 0.037 {
                    assert!(band_time < 0.5 * flat, "d {d}, f_d {f_d}, wall {wall}: {band_time} s in the last 10 mm (at v_c: {flat} s)");
                }
                eprintln!("d {d}, f_d {f_d}, wall {wall}: contact at {v:.5} m/s (v_c {v_c:.5}), rise {rise:.3} N, last 10 mm in {band_time:.3} s (at v_c {flat:.2} s)");
            }
        }
    }

    /// Issue 42, contact lost (MuJoCo two-material and acrylic runs): the derived law in its
    /// contact regime with the tip in the air. A point mass realises the command `d` periods
    /// late; the sensor reads the spring's force plus the tool's inertial force `m_t ẍ`
    /// (0.424 kg, the JK5's tool) as MuJoCo's and a real one do. The tip starts 20 mm above
    /// a stiff surface (50 000 N/m) in the contact regime, as after a contact entered on the
    /// inertial wrench or a bounce. While no force is in evidence the law commands what its
    /// free approach does (checked cycle by cycle), so it comes back at the approach's speed
    /// (the impedance's `k/b e`, at most 1.25 × 0.05 m/s here, the servo's 25 % overshoot)
    /// and the force rises by at most `k v (d + 2) T` (+ 3 σ_f) before the loop answers (the
    /// touch falls within a period, the answer lands `d` periods later and moves the tip one
    /// period after): the impact bound of a first contact, in this discrete model. Where the expected surface is known, the braking
    /// profile brings that touch to `v_c`.
    #[test]
    fn a_contact_lost_comes_back_at_the_approach_speed() {
        let (t, m_t, k_e, f_d) = (1e-3, 0.424, 50_000.0, 3.0);
        for (d, surface) in [(1usize, None), (2, None), (2, Some(0.0))] {
            let mut p = params(Mode::Derived, surface);
            p.force_law.derived.delay_cycles = d as f64;
            let mut s = super::super::ControlState::new(&p);
            let (mut x, mut v, mut a) = (-0.02f64, 0.0f64, 0.0f64);
            let mut cmds = std::collections::VecDeque::from(vec![0.0; d]);
            let (mut v_touch, mut f_peak, mut n_touch) = (None, 0.0f64, 0usize);
            for n in 0..20_000 {
                let f = k_e * x.max(0.0) + m_t * a;
                let mut u = free_inputs(&p, x, v, f_d);
                u.regime = Regime::Contact;
                u.prev_phase = Phase::Contact;
                u.f_ext = f;
                u.pre = Prepared { mass_n: 3.19, tool_mass: m_t, ..Prepared::default() };
                let (l, sc, de, out) = step(&p, &s.law, &s.sched, &s.derived, &u);
                let xdd = out.xdd.unwrap();
                if derived::contact_force(&s.derived, f, m_t) < contact_threshold(&p) {
                    let est = derived::estimate(&p.force_law.derived, &s.derived, x, v, f, false, true, t).1;
                    let (free, _, _) = derived_approach(&p, &est, &u, s.sched.approach_integral);
                    assert!((xdd - free).abs() < 1e-9, "d {d}: in the air the law commands {xdd}, its approach {free}");
                }
                (s.law, s.sched, s.derived) = (l, sc, de);
                cmds.push_back(xdd);
                a = cmds.pop_front().unwrap();
                v += a * t;
                x += v * t;
                if x >= 0.0 && v_touch.is_none() {
                    v_touch = Some(v);
                    n_touch = n;
                }
                if v_touch.is_some() && n <= n_touch + d + 1 {
                    f_peak = f_peak.max(k_e * x.max(0.0));
                }
                if v_touch.is_some() && n > n_touch + 50 {
                    break;
                }
            }
            let v_touch = v_touch.unwrap_or_else(|| panic!("d {d}: never came back (x = {x})"));
            let bound = k_e * v_touch * (d as f64 + 2.0) * t + 3.0 * 0.0625;
            eprintln!("d {d}, surface {surface:?}: touch at {v_touch:.4} m/s, force {f_peak:.2} N in (d + 2) T (bound {bound:.2} N)");
            assert!(v_touch <= 1.25 * 0.05, "d {d}: came back at {v_touch} m/s");
            assert!(f_peak <= bound, "d {d}: {f_peak} N > {bound} N");
            if surface.is_some() {
                let dp = &p.force_law.derived;
                let rise = derived::impact_bound(dp, v_touch, dp.contact.k_max, t);
                assert!(rise <= dp.impact_fraction * f_d * 1.02, "d {d}: with the surface expected the touch adds {rise} N");
            }
        }
    }

    /// A surface that turns soft under the tool (acrylic → foam: the force falls to almost 0
    /// at the same depth) has not been left: the tip is beyond the position where contact
    /// was in evidence (a force, and a surface the estimator has located), so the force loop
    /// follows it down and no approach runs.
    #[test]
    fn a_surface_that_softens_under_the_tool_is_not_a_lost_contact() {
        let (t, m_t, d, f_d) = (1e-3, 0.424, 1usize, 3.0);
        let mut p = params(Mode::Derived, None);
        p.force_law.derived.delay_cycles = d as f64;
        let mut s = super::super::ControlState::new(&p);
        // The tool comes down onto the stiff surface from 0.5 mm above, holds f_d, and at
        // `n_soft` the surface under it turns soft at the depth it is pressed to.
        let (k_stiff, k_soft, n_soft) = (50_000.0f64, 1_000.0f64, 3_000usize);
        let (mut x, mut v, mut a) = (-0.5e-3f64, 0.0f64, 0.0f64);
        let mut cmds = std::collections::VecDeque::from(vec![0.0; d]);
        let (mut approached, mut f_last, mut x_e) = (0usize, 0.0, 0.0);
        for n in 0..n_soft + 5_000 {
            if n == n_soft {
                // the soft surface's own rest position: 0.06 N at the depth the tool is at
                x_e = x - 0.06 / k_soft;
            }
            let k_e = if n < n_soft { k_stiff } else { k_soft };
            let f = k_e * (x - x_e).max(0.0) + m_t * a;
            let mut u = free_inputs(&p, x, v, f_d);
            u.regime = Regime::Contact;
            u.prev_phase = Phase::Contact;
            u.entered = n == 0;
            u.f_ext = f;
            u.pre = Prepared { mass_n: 3.19, tool_mass: m_t, ..Prepared::default() };
            let (l, sc, de, out) = step(&p, &s.law, &s.sched, &s.derived, &u);
            (s.law, s.sched, s.derived) = (l, sc, de);
            if n == n_soft - 1 {
                assert!(s.derived.x_touch.is_some(), "no contact in evidence after {n} cycles on the stiff surface: the test's precondition");
                assert!((f - f_d).abs() < 0.1 * f_d, "not holding f_d on the stiff surface before the switch: {f} N");
            }
            if n >= n_soft && s.derived.approaching {
                approached += 1;
            }
            cmds.push_back(out.xdd.unwrap());
            a = cmds.pop_front().unwrap();
            v += a * t;
            x += v * t;
            f_last = k_e * (x - x_e).max(0.0);
        }
        assert_eq!(approached, 0, "the law ran its approach for {approached} cycles on a surface it never left");
        assert!((f_last - f_d).abs() < 0.1 * f_d, "the force loop did not follow the soft surface: {f_last} N against {f_d} N");
    }

    /// Every part of the derived law an ablation can turn off (`DerivedParts`, `naic sim
    /// --ablate`) changes what the law does in a cycle where that part acts, and nothing
    /// where it is on: the switch reaches the part it names.
    #[test]
    fn each_part_of_the_derived_law_can_be_ablated() {
        use derived::DerivedParts;
        let (m_t, f_d) = (0.424, 10.0);
        // One contact cycle from the state `s0` with the measured force `f`; `parts` as given.
        let cycle = |parts: DerivedParts, f: f64, a_i: f64, a_cmd: f64| {
            let mut p = params(Mode::Derived, None);
            p.force_law.derived.parts = parts;
            let mut s = super::super::ControlState::new(&p);
            s.sched.approach_integral = a_i;
            s.derived.a_cmd = a_cmd;
            let mut u = free_inputs(&p, 0.0, 0.0, f_d);
            u.regime = Regime::Contact;
            u.prev_phase = Phase::Contact;
            u.f_ext = f;
            u.pre = Prepared { mass_n: 3.19, tool_mass: m_t, ..Prepared::default() };
            let (_, _, de, out) = step(&p, &s.law, &s.sched, &s.derived, &u);
            (de, out)
        };
        let all = DerivedParts::ALL;
        let off = |name: &str| all.without(name).expect("a part's name");
        // The disturbance feedforward: the approach integral `a_i` in the contact command.
        let (_, with) = cycle(all, f_d, 0.7, 0.0);
        let (_, without) = cycle(off("disturbance-feedforward"), f_d, 0.7, 0.0);
        assert!((with.xdd.unwrap() - without.xdd.unwrap() - 0.7).abs() < 1e-12, "{with:?} / {without:?}");
        // The stiction-aware hold: the friction feedforward at the reference blend.
        assert!(with.friction.is_some() && cycle(off("stiction-hold"), f_d, 0.0, 0.0).1.friction.is_none());
        // The contact-loss rule: no force in evidence runs the approach.
        assert!(cycle(all, 0.0, 0.0, 0.0).0.approaching);
        assert!(!cycle(off("contact-loss"), 0.0, 0.0, 0.0).0.approaching);
        // The tool's inertia: 4.34 N read while the tool accelerates at 10 m/s² is 0.1 N of
        // contact (lost), or 4.34 N without the part (kept).
        assert!(cycle(all, m_t * 10.0 + 0.1, 0.0, 10.0).0.approaching);
        assert!(!cycle(off("tool-inertia"), m_t * 10.0 + 0.1, 0.0, 10.0).0.approaching);
        // The reference band: a force inside the band of reference responses winds up no
        // integral; the classical integral winds up on the force error.
        let dp = derived::DerivedParams::default();
        let band = |parts: DerivedParts| {
            let p = derived::DerivedParams { parts, ..dp };
            let s = derived::DerivedState { f_ref: 5.0, f_ref_low: 4.0, f_ref_high: 6.0, ..derived::DerivedState::new(&p) };
            let est = crate::pipeline::control::contact::ContactEstimate { k_hat: 2000.0, k_upper: 4000.0, k_lower: 1000.0, ..Default::default() };
            let u = derived::DerivedInputs { e_dot: 0.0, f_ext: 5.0, f_d, mass: 3.19, estimate: est, k_known: None };
            derived::step(&p, 1e-3, 50.0, &s, &u).0.integral
        };
        assert_eq!(band(all), 0.0);
        assert!(band(off("reference-band")) > 0.0);
        // The velocity observer: with the observer's velocity (0) away from the measured one
        // (0.01 m/s) the damping acts on the observer's; off, on the measurement.
        let observed = |parts: DerivedParts| {
            let mut p = params(Mode::Derived, None);
            p.force_law.derived.parts = parts;
            let mut s = super::super::ControlState::new(&p);
            s.derived.observer = Some(derived::Observer { x: 0.0, v: 0.0, w: 0.0 });
            let mut u = free_inputs(&p, 0.0, 0.01, f_d);
            u.regime = Regime::Contact;
            u.prev_phase = Phase::Contact;
            u.f_ext = f_d;
            u.pre = Prepared { mass_n: 3.19, tool_mass: m_t, ..Prepared::default() };
            step(&p, &s.law, &s.sched, &s.derived, &u).3.xdd.unwrap()
        };
        assert!((observed(all) - observed(off("velocity-observer"))).abs() > 1e-3);
        // Unknown names are refused; the names listed are the parts.
        assert_eq!(all.without("gravity-correction"), None);
        for n in DerivedParts::NAMES {
            assert_eq!(off(n).off(), vec![n]);
        }
    }

    /// With no force target (`f_d ≤ 0`) nothing bounds the speed but `approach_speed`.
    #[test]
    fn the_impact_speed_needs_a_force_target() {
        let dp = derived::DerivedParams::default();
        assert_eq!(derived::impact_speed(&dp, 0.0, 1e5, 1e-3), f64::INFINITY);
        assert_eq!(derived::impact_speed(&dp, 10.0, 0.0, 1e-3), f64::INFINITY);
        assert!(derived::impact_speed(&dp, 10.0, 1e5, 1e-3).is_finite());
    }
}
