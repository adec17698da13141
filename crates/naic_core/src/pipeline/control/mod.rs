//! Stage 3 of the pipeline: the torque-based Cartesian impedance controller
//! (eq 6–8) with fixed, AIC (eq 9) or NAIC (eq 10–15) force tracking on one
//! axis.
//!
//! This module turns task-space errors into the commanded task acceleration
//! `V` of eq 6; [`super::inverse_dynamics`] turns `V` into joint torques. The
//! per-axis force laws and their sign conventions are in [`force_law`].
//!
//! # Eq 6 → code
//!
//! Per Cartesian axis `i` (x, y, z, then rotation about x, y, z; all in the
//! base frame, world-aligned at the tip):
//!
//! ```text
//! V_i = ẍ_d,i + ( b_d,i ė_i + k_d,i e_i + f_d,i − F_e,i ) / m_d,i          (eq 6 with eq 8's F_d)
//! ```
//!
//! with `e = X_d − X` (translation: `p_d − p`; rotation: the rotation vector of
//! `R_d Rᵀ`), `ė = Ẋ_d − J q̇`, `F_e` the wrench the robot applies to the
//! environment (from [`super::estimate`]) and `f_d,i` non-zero only on the
//! force axis in contact. Substituting `Ẍ = V` (what the inverse-dynamics
//! stage realises) gives eq 7/8: `F_e − F_d = M_d Ë + B_d Ė + K_d E`.
//!
//! Two phases (paper §3.1): in free space every axis uses the free-space
//! stiffness and the force axis has no force target; once contact is
//! detected the contact stiffness applies, `k_d = 0` on the force axis, and
//! the force axis follows the selected force law instead of the line above:
//! `V_n = ẍ_d,n − ë` with `ë` from [`force_law::step`], mapped to the base
//! frame by the axis sign.
//!
//! Contact detection is a parameter ([`ContactDetect`]): enter contact when
//! `f_ext` exceeds `enter_n` (the paper's laws) or `scheduled_enter_n` (the scheduled
//! law); leave it after `exit_cycles` consecutive cycles below `exit_n`
//! (`exit_cycles = 0` latches contact, as in the paper).
//!
//! The contact-force limit ([`ForceLimit`]) is the one retraction mechanism of
//! naic (the simulator and the ROS node use this, nothing else): above
//! `limit_n` the tool stops pushing and backs off along −n for
//! `retract_cycles`; then either free space resumes and contact is
//! re-detected, or (`latch`) the tool stays where the retraction ended, at a
//! fixed offset from the reference and with no force target, until the owner
//! calls [`ControlState::resume`] (the ROS node does on any parameter change).

pub mod force_law;
pub mod scheduled;

use force_law::{ForceLawInputs, ForceLawOutputs, ForceLawParams, ForceLawState, Mode};
use nalgebra::{Vector3, Vector6};
use scheduled::{ScheduledInputs, ScheduledState};

/// Diagonal impedance parameters, one entry per Cartesian axis (x, y, z, rx, ry, rz).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceParams {
    /// `M_d` [kg, kg·m²].
    pub m_d: [f64; 6],
    /// `B_d` [N·s/m, N·m·s/rad].
    pub b_d: [f64; 6],
    /// `K_d` in free space [N/m, N·m/rad].
    pub k_free: [f64; 6],
    /// `K_d` in contact; its force-axis entry is ignored (k_d = 0 there, §3.1).
    pub k_contact: [f64; 6],
}

/// The force axis: `n = sign · e_axis` in the base frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceAxis {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    /// +1 or −1: the direction in which the tool pushes (−1 on z to push down).
    pub sign: f64,
}

/// The scheduled law's contact threshold [N] ([`ContactDetect::scheduled_enter_n`]): 8 σ of
/// the F/T noise (1 σ = one count, 1/16 N, of the simulated ATI mini45), the level from which
/// its stiffness estimator takes a force as evidence of contact
/// (`scheduled::estimator::EstimatorParams::f_min_n`).
pub const SCHEDULED_CONTACT_ENTER_N: f64 = 0.5;

/// How contact is detected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactDetect {
    /// Enter contact when `f_ext` exceeds this [N] (the paper's laws: `naic`, `aic`, `fixed`).
    pub enter_n: f64,
    /// Enter contact when `f_ext` exceeds this [N] in `Mode::Scheduled`
    /// ([`SCHEDULED_CONTACT_ENTER_N`] by default). The paper's 1 N is 16 σ of the F/T noise;
    /// on `flat` the force rises at 74 N/s (37 mm/s onto 2000 N/m), so the law took over
    /// 15–20 ms after the force started to rise, and that wait was most of its RMS error
    /// over the contact (68 % of the squared error is in the first 0.1 s, seed 1, d = 1).
    /// Entering at 0.5 N: RMS 0.965 → 0.893 N (medians of 5 seeds, d = 1, docs/controller.md).
    /// The largest free-space reading in flat's approach was 0.25 N (seeds 1–5).
    pub scheduled_enter_n: f64,
    /// Leave contact when `f_ext` stays below this [N] ...
    pub exit_n: f64,
    /// ... for this many consecutive cycles; 0 latches contact once detected.
    pub exit_cycles: u32,
}

/// What happens when the contact force gets too large.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLimit {
    /// Above this `f_ext` [N] the controller stops pushing and retracts (`inf` disables).
    pub limit_n: f64,
    /// Speed of the retraction along −n [m/s].
    pub retract_speed: f64,
    /// How long the retraction lasts [cycles]; then free space resumes and contact is re-detected ...
    pub retract_cycles: u32,
    /// ... unless `latch`: then the tool stays off the surface until [`ControlState::resume`].
    pub latch: bool,
}

/// All parameters of the control stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlParams {
    pub impedance: ImpedanceParams,
    pub force_axis: ForceAxis,
    pub force_law: ForceLawParams,
    pub contact: ContactDetect,
    pub force_limit: ForceLimit,
}

impl ControlParams {
    /// Checks every value; the message names the parameter and the fix.
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        let imp = &self.impedance;
        for i in 0..6 {
            if !(imp.m_d[i] > 0.0 && imp.m_d[i].is_finite()) {
                return Err(crate::pipeline::ConfigError::invalid(format!("m_d[{i}]"), imp.m_d[i], "must be a positive finite mass"));
            }
            for (name, v) in [("b_d", imp.b_d[i]), ("k_d (free)", imp.k_free[i]), ("k_d (contact)", imp.k_contact[i])] {
                if !(v >= 0.0 && v.is_finite()) {
                    return Err(crate::pipeline::ConfigError::invalid(format!("{name}[{i}]"), v, "must be a finite value >= 0"));
                }
            }
        }
        if self.force_axis.axis > 2 {
            return Err(crate::pipeline::ConfigError::invalid("force_axis", self.force_axis.axis, "must be 0, 1 or 2 (x, y, z)"));
        }
        if self.force_axis.sign != 1.0 && self.force_axis.sign != -1.0 {
            return Err(crate::pipeline::ConfigError::invalid("force axis sign", self.force_axis.sign, "must be +1 or -1"));
        }
        let fl = &self.force_law;
        if !(fl.gamma >= 0.0 && fl.gamma.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("learning_rate (gamma)", fl.gamma, "must be a finite value >= 0 (eq 15)"));
        }
        if !(fl.lambda > 0.0 && fl.lambda.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("control period (lambda)", fl.lambda, "s must be positive"));
        }
        if !(fl.sigma_margin > 0.0) {
            return Err(crate::pipeline::ConfigError::invalid("sigma_margin", fl.sigma_margin, "must be > 0 (inf disables the σ stability bound)"));
        }
        if !(fl.integral_limit_n > 0.0) {
            return Err(crate::pipeline::ConfigError::invalid("integral_limit_n", fl.integral_limit_n, "must be > 0 N (inf: eq 9 without anti-windup)"));
        }
        if !(fl.sigma >= 0.0 && fl.sigma.is_finite()) {
            return Err(crate::pipeline::ConfigError::invalid("sigma", fl.sigma, "must be a finite value >= 0"));
        }
        let b = &fl.bounds;
        let n = self.force_axis.axis;
        if !(b.m_d.0 > 0.0 && b.m_d.0 <= imp.m_d[n] && imp.m_d[n] <= b.m_d.1) {
            return Err(crate::pipeline::ConfigError::invalid("m_d on the force axis", imp.m_d[n], format!("must lie in the NAIC weight bounds {:?}, lower bound > 0", b.m_d)));
        }
        if !(b.b_d.0 > 0.0 && b.b_d.0 <= imp.b_d[n] && imp.b_d[n] <= b.b_d.1) {
            return Err(crate::pipeline::ConfigError::invalid("b_d on the force axis", imp.b_d[n], format!("must lie in the NAIC weight bounds {:?}, lower bound > 0", b.b_d)));
        }
        if !(b.sigma.0 <= fl.sigma && fl.sigma <= b.sigma.1) {
            return Err(crate::pipeline::ConfigError::invalid("sigma", fl.sigma, format!("must lie in the NAIC weight bounds {:?}", b.sigma)));
        }
        if fl.mode == Mode::Scheduled {
            fl.scheduled.validate()?;
        }
        let fl = &self.force_limit;
        if !(fl.limit_n > self.contact.enter_n) {
            return Err(crate::pipeline::ConfigError::invalid("force_limit", fl.limit_n, format!("N must be above the contact threshold {} N", self.contact.enter_n)));
        }
        if !(fl.limit_n > self.contact.scheduled_enter_n) {
            return Err(crate::pipeline::ConfigError::invalid("force_limit", fl.limit_n, format!("N must be above the scheduled law's contact threshold {} N", self.contact.scheduled_enter_n)));
        }
        if !(fl.retract_speed > 0.0 && fl.retract_speed <= 0.5) {
            return Err(crate::pipeline::ConfigError::invalid("retract speed", fl.retract_speed, "m/s must be in (0, 0.5]"));
        }
        let c = &self.contact;
        if !(c.enter_n > 0.0 && c.enter_n.is_finite() && c.exit_n >= 0.0 && c.exit_n <= c.enter_n) {
            return Err(crate::pipeline::ConfigError::invalid("contact_threshold: enter", c.enter_n, format!("N must be > 0 and exit = {} N in [0, enter]", c.exit_n)));
        }
        if !(c.scheduled_enter_n > 0.0 && c.scheduled_enter_n.is_finite() && c.exit_n <= c.scheduled_enter_n) {
            return Err(crate::pipeline::ConfigError::invalid(
                "scheduled_contact_threshold",
                c.scheduled_enter_n,
                format!("N must be finite, > 0 and at least the exit force {} N", c.exit_n),
            ));
        }
        Ok(())
    }
}

/// The phase of the two-phase controller (§3.1), plus the safe hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Phase {
    #[default]
    Free = 0,
    Contact = 1,
    /// Measurements unusable: gravity compensation and joint damping only.
    Hold = 2,
}

/// What the control stage remembers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlState {
    pub phase: Phase,
    /// Consecutive cycles with `f_ext` below the exit threshold.
    pub below_exit: u32,
    pub law: ForceLawState,
    /// Cycles of retraction left after the force limit was exceeded (0: not retracting).
    pub retract_left: u32,
    /// Latched after a retraction ([`ForceLimit::latch`]): the error `e` along the force
    /// axis (base frame) to keep, i.e. the tool stays at `X_d − e_hold` on that axis.
    pub retract_hold: Option<f64>,
    /// The scheduled law's memory (estimator, gains, integral); idle for the paper laws.
    pub sched: ScheduledState,
}

impl ControlState {
    pub fn new(p: &ControlParams) -> Self {
        let n = p.force_axis.axis;
        Self {
            phase: Phase::Free,
            below_exit: 0,
            law: ForceLawState::new(&p.force_law, p.impedance.m_d[n], p.impedance.b_d[n]),
            retract_left: 0,
            retract_hold: None,
            sched: ScheduledState::new(&p.force_law.scheduled, p.force_law.lambda),
        }
    }

    /// Leave a force-limit retraction (in progress or latched): free space, contact is
    /// re-detected. A no-op otherwise.
    pub fn resume(&self) -> Self {
        if !self.retracting() {
            return *self;
        }
        Self { retract_left: 0, retract_hold: None, phase: Phase::Free, below_exit: 0, ..*self }
    }

    /// The state a safe hold leaves (every held cycle): phase `Hold`, and the force law
    /// starts again from its configured weights (NAIC's `m_d`, `b_d`, `σ`, eq 10–15; the
    /// scheduled law's estimator and integral); a force-limit retraction, in progress or
    /// latched, is kept. What was learned before the fault is not carried into the next
    /// contact: the hold let the tool leave the surface, and NAIC's weights, which drift
    /// with every contact transient (m_d down, σ up), had reached m_d = 0.05 kg and
    /// σ = 0.22 after two holds on `flat`, where the re-contact limit-cycles at 25 Hz and
    /// spins joint 4 past its 6.28 rad/s limit (`nodes/naic_controller/tests/faults_in_process.rs`).
    pub fn hold(&self, p: &ControlParams) -> Self {
        let fresh = Self::new(p);
        let sched = ScheduledState { k_known: self.sched.k_known, shaper: self.sched.shaper, ..fresh.sched };
        Self { phase: Phase::Hold, below_exit: 0, law: fresh.law, sched, ..*self }
    }

    /// A force-limit retraction is in progress or latched.
    pub fn retracting(&self) -> bool {
        self.retract_left > 0 || self.retract_hold.is_some()
    }
}

/// Task-space inputs of one cycle, base frame, world-aligned at the tip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskInputs {
    /// Measured tip position `p` [m] (the scheduled law's stiffness estimator regresses
    /// the force on it).
    pub p: Vector3<f64>,
    /// `E = X_d − X` (position; rotation vector of `R_d Rᵀ`).
    pub e: Vector6<f64>,
    /// `Ė = Ẋ_d − Ẋ`.
    pub e_dot: Vector6<f64>,
    /// Measured `Ẋ` (tip twist).
    pub x_dot: Vector6<f64>,
    /// `Ẍ_d`.
    pub a_d: Vector6<f64>,
    /// `F_e`: wrench the robot applies to the environment.
    pub f_e: Vector6<f64>,
    /// `f_d` along the force axis [N].
    pub f_d: f64,
}

/// Task-space outputs of one cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskOutputs {
    /// Commanded task acceleration `V` (eq 6).
    pub v: Vector6<f64>,
    /// `f_ext` along the force axis [N].
    pub f_ext: f64,
    /// `k_d` in force on the force axis this cycle.
    pub k_d: f64,
    /// The force law's report (zeros in free space).
    pub law: ForceLawOutputs,
    /// The force limit was exceeded: the tool is retracting, or latched off the surface.
    pub retracting: bool,
    /// The twist the controller means the tip to move at (base frame): the reference's
    /// `Ẋ_d = Ė + Ẋ`, along the force axis the retraction speed while retracting and, in
    /// scheduled mode, out of contact the approach servo's target speed
    /// ([`scheduled::approach_target`]), in contact the law's velocity observer `v̄` (the
    /// commanded accelerations integrated, corrected slowly by the measurement:
    /// [`scheduled::predictor::Observer`]) where the observer runs, and the reference's
    /// velocity where it is off (soft surfaces: there `v̄` is the raw encoder velocity,
    /// [`scheduled::ScheduledOutputs::v_bar`]). The scheduled law's friction feedforward is
    /// evaluated at its joint velocity ([`crate::pipeline::feedforward::blend`]).
    pub v_ref: Vector6<f64>,
}

/// `(k̂_e, confidence)` of the scheduled law's estimator (the oracle's known k_e if set).
fn estimator_report(p: &scheduled::ScheduledParams, s: &ScheduledState) -> (f64, f64) {
    if let Some(k) = s.k_known {
        return (k, 1.0);
    }
    let e = scheduled::estimator::estimate(&p.estimator, &s.est);
    (e.k_e, e.confidence)
}

/// Eq 6 per axis with stiffness `k` and no force target:
/// `V_i = ẍ_d,i + (b_d,i ė_i + k_i e_i − F_e,i) / m_d,i`.
fn eq6(imp: &ImpedanceParams, k: &[f64; 6], u: &TaskInputs) -> Vector6<f64> {
    Vector6::from_fn(|i, _| u.a_d[i] + (imp.b_d[i] * u.e_dot[i] + k[i] * u.e[i] - u.f_e[i]) / imp.m_d[i])
}

/// One cycle of the control stage (contact detection + eq 6/8 per axis).
/// Pure: `(params, state, inputs) -> (state, outputs)`.
pub fn step(p: &ControlParams, s: &ControlState, u: &TaskInputs) -> (ControlState, TaskOutputs) {
    let (mut next, out) = step_phases(p, s, u);
    if p.force_law.mode != Mode::Scheduled {
        return (next, out);
    }
    let (ax, sign) = (p.force_axis.axis, p.force_axis.sign);
    let sp = &p.force_law.scheduled;
    // The ĝ this cycle's commands were made with (in realised units for the predictor).
    let g = s.sched.gain.used(&sp.model_gain);
    if next.phase != Phase::Contact || out.retracting {
        // The scheduled law's predictor remembers every command along n; in contact the
        // law pushes its own (without the feedforward correction).
        next.sched = next.sched.commanded(g * sign * out.v[ax]);
    }
    // The model's gain along n: learnt in free space only (no contact force).
    let learn = s.phase == Phase::Free && next.phase == Phase::Free && !out.retracting && out.f_ext < p.contact.scheduled_enter_n;
    next.sched.gain = next.sched.gain.cycle(&sp.model_gain, p.force_law.lambda, sign * u.x_dot[ax], learn, sign * out.v[ax]);
    (next, out)
}

fn step_phases(p: &ControlParams, s: &ControlState, u: &TaskInputs) -> (ControlState, TaskOutputs) {
    let ax = p.force_axis.axis;
    let sign = p.force_axis.sign;
    let f_ext = sign * u.f_e[ax];
    let mut next = *s;
    let mut v_ref = u.e_dot + u.x_dot;

    // Force limit: stop pushing, leave contact, back off along −n for a while.
    if f_ext > p.force_limit.limit_n {
        next.retract_left = p.force_limit.retract_cycles.max(1);
        next.retract_hold = None;
        next.phase = Phase::Free;
    }
    let bounded;
    let imp = if p.force_law.mode == Mode::Scheduled {
        // The scheduled law bounds every axis' damping-to-mass ratio by the loop delay.
        let sp = &p.force_law.scheduled.schedule;
        bounded = ImpedanceParams { m_d: scheduled::schedule::axis_masses(sp, &p.impedance.m_d, &p.impedance.b_d, p.force_law.lambda), ..p.impedance };
        &bounded
    } else {
        &p.impedance
    };
    if next.retract_left > 0 {
        next.retract_left -= 1;
        next.phase = Phase::Free;
        let mut v = eq6(imp, &imp.k_free, u);
        // Velocity servo along n to −retract_speed, with the free-space damping.
        let xdot_n = sign * u.x_dot[ax];
        v[ax] = sign * imp.b_d[ax] * (-p.force_limit.retract_speed - xdot_n) / imp.m_d[ax];
        if next.retract_left == 0 && p.force_limit.latch {
            next.retract_hold = Some(u.e[ax]);
        }
        let law = ForceLawOutputs { e_f: f_ext - u.f_d, ..Default::default() };
        v_ref[ax] = -sign * p.force_limit.retract_speed;
        return (next, TaskOutputs { v, f_ext, k_d: imp.k_free[ax], law, retracting: true, v_ref });
    }
    if let Some(e_hold) = next.retract_hold {
        // Latched: free-space impedance on every axis, the force axis about the held offset.
        next.phase = Phase::Free;
        let mut held = *u;
        held.e[ax] -= e_hold;
        let v = eq6(imp, &imp.k_free, &held);
        let law = ForceLawOutputs { e_f: f_ext - u.f_d, ..Default::default() };
        return (next, TaskOutputs { v, f_ext, k_d: imp.k_free[ax], law, retracting: true, v_ref });
    }

    // Phase transitions (a hold ends in free space: contact is re-detected).
    let enter_n = if p.force_law.mode == Mode::Scheduled { p.contact.scheduled_enter_n } else { p.contact.enter_n };
    match s.phase {
        Phase::Free | Phase::Hold => {
            next.phase = Phase::Free;
            if f_ext > enter_n {
                next.phase = Phase::Contact;
                next.below_exit = 0;
                next.law = s.law.rearm(f_ext - u.f_d);
                next.sched = s.sched.rearm(&p.force_law.scheduled, sign * u.p[ax], f_ext);
            }
        }
        Phase::Contact => {
            next.below_exit = if f_ext < p.contact.exit_n { s.below_exit + 1 } else { 0 };
            if p.contact.exit_cycles > 0 && next.below_exit >= p.contact.exit_cycles {
                next.phase = Phase::Free;
            }
        }
    }

    let contact = next.phase == Phase::Contact;
    let k = if contact { &imp.k_contact } else { &imp.k_free };
    let v = eq6(imp, k, u);
    let mut out = TaskOutputs {
        v,
        f_ext,
        k_d: k[ax],
        law: ForceLawOutputs { e_f: f_ext - u.f_d, ..Default::default() },
        retracting: false,
        v_ref,
    };
    let scheduled = p.force_law.mode == Mode::Scheduled;
    if contact && scheduled {
        let fl = &p.force_law;
        let inputs =
            ScheduledInputs { x: sign * u.p[ax], x_dot: sign * u.x_dot[ax], e_dot: sign * u.e_dot[ax], f_ext, f_d: u.f_d, xdd_d: sign * u.a_d[ax] };
        let (sched, r) = scheduled::step(&fl.scheduled, fl.lambda, fl.integral_limit_n, &next.sched, &inputs);
        next.sched = sched;
        let g = &sched.gains;
        // The shared law state reports the scheduled weights (Status, /naic/params).
        next.law = ForceLawState { m_d: g.m_d, b_d: g.b_d, sigma: g.sigma, phi: sched.integral / g.b_d, e_f_prev: r.e_f, edd_prev: r.e_ddot };
        // Divided by the model's gain along n: the arm realises what the law asks.
        out.v[ax] = (u.a_d[ax] - sign * r.e_ddot) / s.sched.gain.used(&fl.scheduled.model_gain);
        // The friction feedforward's velocity along n: the observer's v̄ where it runs, the
        // reference's where v̄ would be the raw encoder velocity (ScheduledOutputs::v_bar).
        if let Some(v) = r.v_bar {
            out.v_ref[ax] = sign * v;
        }
        out.k_d = 0.0;
        out.law = ForceLawOutputs {
            e_ddot: r.e_ddot,
            e_f: r.e_f,
            gamma: r.gamma,
            gamma_bound: r.gamma_bound,
            gamma_clipped: r.gamma_clipped,
            weights_projected: r.weights_projected,
            k_e_hat: r.estimate.k_e,
            k_e_confidence: r.estimate.confidence,
        };
    } else if contact {
        let inputs = ForceLawInputs { e_dot: sign * u.e_dot[ax], f_ext, f_d: u.f_d };
        let (law, report) = force_law::step(&p.force_law, &next.law, &inputs);
        next.law = law;
        out.v[ax] = u.a_d[ax] - sign * report.e_ddot;
        out.k_d = 0.0;
        out.law = report;
    } else if scheduled {
        // Free space: a PI velocity servo along n toward the reference (robust to a model
        // error), slower near an expected surface (`scheduled::approach_accel`).
        let a = &p.force_law.scheduled.approach;
        let free = scheduled::ApproachAxis {
            m: imp.m_d[ax],
            b: imp.b_d[ax],
            k: imp.k_free[ax],
            e: sign * u.e[ax],
            v_d: sign * (u.e_dot[ax] + u.x_dot[ax]),
            a_d: sign * u.a_d[ax],
        };
        let surface_n = a.expected_surface.map_or(f64::NAN, |z| sign * z);
        let (a_n, e) = scheduled::approach_accel(
            a,
            surface_n,
            sign * u.p[ax],
            sign * u.x_dot[ax],
            free,
            sign * out.v[ax],
            next.sched.approach_integral,
            p.force_law.lambda,
        );
        next.sched.approach_integral = e;
        out.v[ax] = sign * a_n;
        out.v_ref[ax] = sign * scheduled::approach_target(a, surface_n, sign * u.p[ax], &free);
    }
    if scheduled {
        let e = estimator_report(&p.force_law.scheduled, &next.sched);
        out.law.k_e_hat = e.0;
        out.law.k_e_confidence = e.1;
    }
    (next, out)
}

#[cfg(test)]
mod tests {
    use super::force_law::{Mode, WeightBounds};
    use super::*;

    fn params(mode: Mode) -> ControlParams {
        ControlParams {
            impedance: ImpedanceParams {
                m_d: [1.0; 6],
                b_d: [500.0, 500.0, 40.0, 500.0, 500.0, 500.0],
                k_free: [500.0, 500.0, 50.0, 1000.0, 1000.0, 1000.0],
                k_contact: [100.0, 100.0, 0.0, 1000.0, 1000.0, 1000.0],
            },
            force_axis: ForceAxis { axis: 2, sign: -1.0 },
            force_law: ForceLawParams { mode, sigma: 0.01, gamma: 0.0, bounds: WeightBounds::default(), lambda: 1e-3, sigma_margin: 0.5, integral_limit_n: f64::INFINITY, scheduled: Default::default() },
            contact: ContactDetect { enter_n: 1.0, scheduled_enter_n: SCHEDULED_CONTACT_ENTER_N, exit_n: 0.2, exit_cycles: 0 },
            force_limit: ForceLimit { limit_n: 50.0, retract_speed: 0.02, retract_cycles: 500, latch: false },
        }
    }

    /// A unit point mass in 3-D (orientation ignored) realising V exactly,
    /// above a spring floor at z = 0 with stiffness k_e: the target impedance
    /// relation must hold and the contact force must reach f_d.
    fn run(mode: Mode, steps: usize) -> (Vec<f64>, ControlState) {
        let p = params(mode);
        p.validate().unwrap();
        let mut s = ControlState::new(&p);
        let (k_e, dt) = (2000.0, 1e-3);
        let (mut x, mut v) = (Vector6::<f64>::zeros(), Vector6::<f64>::zeros());
        x[2] = 0.02;
        let mut x_d = Vector6::zeros();
        x_d[2] = -0.03; // below the surface, as in §4.1
        let mut forces = vec![];
        for _ in 0..steps {
            let pen = (-x[2]).max(0.0);
            let mut f_e = Vector6::zeros();
            f_e[2] = -k_e * pen; // the robot pushes down: F_e,z < 0, f_ext = −F_e,z > 0
            let u = TaskInputs { p: x.fixed_rows::<3>(0).into(), e: x_d - x, e_dot: -v, x_dot: v, a_d: Vector6::zeros(), f_e, f_d: 10.0 };
            let (n, o) = step(&p, &s, &u);
            s = n;
            v += o.v * dt;
            x += v * dt;
            forces.push(o.f_ext);
        }
        (forces, s)
    }

    #[test]
    fn two_phase_controller_tracks_the_desired_force_with_every_law() {
        for mode in Mode::ALL {
            let (f, s) = run(mode, 4000);
            assert_eq!(s.phase, Phase::Contact, "{mode:?}");
            let last = *f.last().unwrap();
            assert!((last - 10.0).abs() < 0.05, "{mode:?}: final force {last}");
        }
    }

    #[test]
    fn free_space_axes_follow_the_target_impedance_relation() {
        // No contact, no force: m ë + b ė + k e = 0 on every axis (eq 7 with F_e = 0).
        let p = params(Mode::Naic);
        let s = ControlState::new(&p);
        let u = TaskInputs {
            p: Vector3::zeros(),
            e: Vector6::new(0.01, -0.02, 0.03, 0.1, -0.1, 0.05),
            e_dot: Vector6::new(0.1, 0.0, -0.2, 0.0, 0.3, 0.0),
            x_dot: -Vector6::new(0.1, 0.0, -0.2, 0.0, 0.3, 0.0),
            a_d: Vector6::zeros(),
            f_e: Vector6::zeros(),
            f_d: 10.0,
        };
        let (_, o) = step(&p, &s, &u);
        let imp = &p.impedance;
        for i in 0..6 {
            let e_ddot = -o.v[i]; // ë = ẍ_d − ẍ
            let residual = imp.m_d[i] * e_ddot + imp.b_d[i] * u.e_dot[i] + imp.k_free[i] * u.e[i];
            assert!(residual.abs() < 1e-9, "axis {i}: residual {residual}");
        }
    }

    #[test]
    fn contact_can_be_left_after_the_exit_dwell() {
        let mut p = params(Mode::Aic);
        p.contact.exit_cycles = 3;
        let mut s = ControlState::new(&p);
        let mut u = TaskInputs {
            p: Vector3::zeros(),
            e: Vector6::zeros(),
            e_dot: Vector6::zeros(),
            x_dot: Vector6::zeros(),
            a_d: Vector6::zeros(),
            f_e: Vector6::new(0.0, 0.0, -5.0, 0.0, 0.0, 0.0),
            f_d: 10.0,
        };
        s = step(&p, &s, &u).0;
        assert_eq!(s.phase, Phase::Contact);
        u.f_e[2] = 0.0;
        for k in 0..3 {
            assert_eq!(s.phase, Phase::Contact, "cycle {k}");
            s = step(&p, &s, &u).0;
        }
        assert_eq!(s.phase, Phase::Free);
    }

    #[test]
    fn above_the_force_limit_the_tool_backs_off_then_free_space_resumes() {
        let p = params(Mode::Naic);
        let mut s = ControlState::new(&p);
        let mut u = TaskInputs {
            p: Vector3::zeros(),
            e: Vector6::new(0.0, 0.0, -0.03, 0.0, 0.0, 0.0),
            e_dot: Vector6::zeros(),
            x_dot: Vector6::zeros(),
            a_d: Vector6::zeros(),
            f_e: Vector6::new(0.0, 0.0, -20.0, 0.0, 0.0, 0.0),
            f_d: 10.0,
        };
        s = step(&p, &s, &u).0;
        assert_eq!(s.phase, Phase::Contact);
        u.f_e[2] = -80.0; // 80 N pushing down, limit 50 N
        let (n, o) = step(&p, &s, &u);
        assert!(o.retracting && n.phase == Phase::Free);
        // Retraction = upward (−n = +z) acceleration while at rest.
        assert!(o.v[2] > 0.0, "retract along −n: V_z = {}", o.v[2]);
        // At the retract speed the force axis command vanishes.
        u.f_e[2] = 0.0;
        u.x_dot[2] = 0.02;
        let (mut s2, o) = step(&p, &n, &u);
        assert!(o.retracting && o.v[2].abs() < 1e-12);
        for _ in 0..600 {
            s2 = step(&p, &s2, &u).0;
        }
        assert_eq!(s2.retract_left, 0);
        assert!(!step(&p, &s2, &u).1.retracting, "free space resumes after the retraction");
    }

    /// The latched variant (what the ROS node uses), on the point-mass rig of `run`:
    /// pressed above the limit, the tool backs off the surface, then stays there (no
    /// contact, no force, still after 3 s), until `resume`; then it approaches, re-detects
    /// contact and tracks f_d again.
    #[test]
    fn a_latched_force_limit_keeps_the_tool_off_until_resumed() {
        let mut p = params(Mode::Naic);
        p.force_limit = ForceLimit { limit_n: 15.0, retract_speed: 0.02, retract_cycles: 500, latch: true };
        p.validate().unwrap();
        let (k_e, dt) = (2000.0, 1e-3);
        let mut s = ControlState::new(&p);
        let (mut x, mut v) = (Vector6::<f64>::zeros(), Vector6::<f64>::zeros());
        x[2] = 0.02;
        let mut x_d = Vector6::zeros();
        x_d[2] = -0.03;
        let mut step_rig = |s: &ControlState, f_d: f64| {
            let mut f_e = Vector6::zeros();
            f_e[2] = -k_e * (-x[2]).max(0.0);
            let u = TaskInputs { p: x.fixed_rows::<3>(0).into(), e: x_d - x, e_dot: -v, x_dot: v, a_d: Vector6::zeros(), f_e, f_d };
            let (n, o) = step(&p, s, &u);
            v += o.v * dt;
            x += v * dt;
            (n, o, x[2])
        };
        // f_d = 20 N > the 15 N limit: contact, the force passes the limit, retract.
        let mut triggered = false;
        for _ in 0..3000 {
            let (n, o, _) = step_rig(&s, 20.0);
            s = n;
            if o.retracting && !triggered {
                triggered = true;
                assert!(o.f_ext > 15.0, "{o:?}");
            }
        }
        assert!(triggered, "the limit never triggered");
        assert!(s.retract_hold.is_some() && s.retracting(), "{s:?}");
        // Latched: 3 s later still off the surface, no force, not in contact.
        let mut z = vec![];
        for _ in 0..3000 {
            let (n, o, zk) = step_rig(&s, 20.0);
            s = n;
            assert!(o.retracting && o.f_ext == 0.0 && s.phase == Phase::Free, "{o:?}");
            z.push(zk);
        }
        let min_z = z.iter().cloned().fold(1.0, f64::min);
        assert!(min_z > 0.002, "the tool came back down: min z {min_z}");
        let drift = (z[z.len() - 1] - z[z.len() - 1000]).abs();
        assert!(drift < 1e-4, "the latched tool drifts {drift} m in 1 s");
        // Resume with f_d = 10 N (below the limit): contact again, tracking f_d.
        s = s.resume();
        assert!(!s.retracting() && s.phase == Phase::Free);
        let mut f = 0.0;
        for _ in 0..4000 {
            let (n, o, _) = step_rig(&s, 10.0);
            s = n;
            f = o.f_ext;
            assert!(!o.retracting, "retracted again at {} N", o.f_ext);
        }
        assert_eq!(s.phase, Phase::Contact);
        assert!((f - 10.0).abs() < 0.05, "force after resume {f}");
        // resume() outside a retraction changes nothing.
        assert_eq!(s.resume(), s);
    }


    /// The scheduled law enters contact at its own threshold (0.5 N), the paper's laws at
    /// `enter_n` (1 N) as before.
    #[test]
    fn the_scheduled_law_has_its_own_contact_threshold() {
        let u = |f: f64| TaskInputs {
            p: Vector3::zeros(),
            e: Vector6::zeros(),
            e_dot: Vector6::zeros(),
            x_dot: Vector6::zeros(),
            a_d: Vector6::zeros(),
            f_e: Vector6::new(0.0, 0.0, -f, 0.0, 0.0, 0.0),
            f_d: 10.0,
        };
        for mode in Mode::ALL {
            let p = params(mode);
            assert_eq!(p.contact.scheduled_enter_n, SCHEDULED_CONTACT_ENTER_N);
            let s = ControlState::new(&p);
            let (below, _) = step(&p, &s, &u(0.45));
            assert_eq!(below.phase, Phase::Free, "{mode:?} at 0.45 N");
            let (mid, _) = step(&p, &s, &u(0.7));
            let expect = if mode == Mode::Scheduled { Phase::Contact } else { Phase::Free };
            assert_eq!(mid.phase, expect, "{mode:?} at 0.7 N");
            assert_eq!(step(&p, &s, &u(1.2)).0.phase, Phase::Contact, "{mode:?} at 1.2 N");
        }
    }

    /// In contact the friction feedforward's velocity along n is the observer's v̄ where the
    /// observer runs (a stiff schedule) and the reference's where it is off (soft surfaces,
    /// where v̄ would be the raw encoder velocity).
    #[test]
    fn the_feedforward_velocity_along_n_is_the_reference_where_the_observer_is_off() {
        let p = params(Mode::Scheduled);
        let mut u = TaskInputs {
            p: Vector3::new(0.0, 0.0, -1e-3),
            e: Vector6::zeros(),
            e_dot: Vector6::new(0.0, 0.0, 0.003, 0.0, 0.0, 0.0),
            x_dot: Vector6::new(0.0, 0.0, -0.003, 0.0, 0.0, 0.0),
            a_d: Vector6::zeros(),
            f_e: Vector6::new(0.0, 0.0, -2.0, 0.0, 0.0, 0.0),
            f_d: 2.0,
        };
        for (k, observed) in [(1000.0, false), (50_000.0, true)] {
            let mut s = ControlState::new(&p);
            s.sched.k_known = Some(k);
            let mut o = None;
            for _ in 0..5 {
                let (n, out) = step(&p, &s, &u);
                s = n;
                o = Some(out);
                u.x_dot[2] = -0.003; // the tool moves down at 3 mm/s; the reference stands
            }
            let o = o.unwrap();
            assert_eq!(s.phase, Phase::Contact);
            if observed {
                assert_eq!(o.v_ref[2], -s.sched.observer.v, "k = {k}");
                assert!(o.v_ref[2] != 0.0);
            } else {
                assert_eq!(o.v_ref[2], 0.0, "k = {k}: the reference's velocity along n");
            }
        }
    }

    #[test]
    fn invalid_parameters_name_themselves() {
        let mut p = params(Mode::Naic);
        p.force_law.gamma = -1.0;
        assert!(p.validate().unwrap_err().to_string().contains("learning_rate"));
        let mut p = params(Mode::Naic);
        p.impedance.m_d[3] = 0.0;
        assert!(p.validate().unwrap_err().to_string().contains("m_d[3]"));
        let mut p = params(Mode::Naic);
        p.force_axis.axis = 4;
        assert!(p.validate().unwrap_err().to_string().contains("force_axis"));
        for bad in [0.0, -1.0, 0.1, f64::NAN, f64::INFINITY, 60.0] {
            let mut p = params(Mode::Scheduled);
            p.contact.scheduled_enter_n = bad;
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains("scheduled_contact_threshold") || e.contains("scheduled law's contact threshold"), "{bad}: {e}");
        }
    }
}
