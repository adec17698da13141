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
//! `n · V = n · ẍ_d − ë` with `ë` from the law ([`law::step`], the one dispatch point), the
//! component of `V` along the force axis `n` (any unit vector, [`ForceAxis`]) replaced, and
//! the tangential impedance acting on the tangential errors.
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

pub mod contact;
pub mod derived;
pub mod force_law;
pub mod law;
pub mod scheduled;
pub mod stiction;

use force_law::{ForceLawOutputs, ForceLawParams, ForceLawState};
use nalgebra::{Vector3, Vector6};
use scheduled::ScheduledState;

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

/// The force axis: a unit vector `n` of the base frame, the direction in which the tool
/// pushes (`−z` to push down onto a table). Every quantity along `n` is a dot product with
/// it ([`ForceAxis::dot`]), and a command along `n` replaces the component of a vector along
/// it ([`ForceAxis::with_along`]); for an axis-aligned `n` both are exact (the same numbers
/// as indexing the axis and multiplying by its sign).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceAxis {
    /// Unit vector, base frame.
    pub n: Vector3<f64>,
}

impl ForceAxis {
    /// `n = sign · e_axis` (axis 0, 1, 2 = x, y, z; sign ±1).
    pub fn base(axis: usize, sign: f64) -> Self {
        let mut n = Vector3::zeros();
        n[axis.min(2)] = sign;
        Self { n }
    }

    /// `v / |v|`; an error naming `force_axis` for a zero or non-finite vector.
    pub fn new(v: Vector3<f64>) -> Result<Self, crate::pipeline::ConfigError> {
        let norm = v.norm();
        if !(norm.is_finite() && norm > 1e-9) {
            return Err(crate::pipeline::ConfigError::invalid(
                "force_axis",
                format!("[{}, {}, {}]", v.x, v.y, v.z),
                "must be a non-zero finite vector (the direction the tool pushes in, base frame, e.g. [0, 0, -1] or '-z')",
            ));
        }
        // An axis-aligned input stays exactly ±1 on its axis.
        Ok(Self { n: if norm == 1.0 { v } else { v / norm } })
    }

    /// The base axis with the largest |n_i| (x, y, z = 0, 1, 2; reported in `/naic/params`).
    pub fn dominant(&self) -> usize {
        (0..3).max_by(|&a, &b| self.n[a].abs().total_cmp(&self.n[b].abs()).then(b.cmp(&a))).unwrap_or(2)
    }

    /// The base axis `n` is (±) exactly, if it is one.
    pub fn aligned(&self) -> Option<usize> {
        let ax = self.dominant();
        (self.n[ax].abs() == 1.0 && (0..3).all(|i| i == ax || self.n[i] == 0.0)).then_some(ax)
    }

    /// `n · v` (written out: for an axis-aligned `n` it is `±v_axis` exactly).
    pub fn dot(&self, v: &Vector3<f64>) -> f64 {
        self.n.x * v.x + self.n.y * v.y + self.n.z * v.z
    }

    /// `n ·` the translational part of a twist or wrench.
    pub fn dot6(&self, v: &Vector6<f64>) -> f64 {
        self.n.x * v[0] + self.n.y * v[1] + self.n.z * v[2]
    }

    /// `v` with its component along `n` replaced by `a`: `v − n (n·v) + n a`.
    pub fn with_along(&self, v: &Vector3<f64>, a: f64) -> Vector3<f64> {
        let d = self.dot(v);
        Vector3::from_fn(|i, _| v[i] - self.n[i] * d + self.n[i] * a)
    }

    /// [`Self::with_along`] on the translational rows of a 6-vector.
    pub fn set6(&self, v: &mut Vector6<f64>, a: f64) {
        let d = self.dot6(v);
        for i in 0..3 {
            v[i] = v[i] - self.n[i] * d + self.n[i] * a;
        }
    }

    /// The translational rows of `v` without their component along `n`.
    pub fn tangential6(&self, v: &Vector6<f64>) -> Vector6<f64> {
        let mut t = *v;
        self.set6(&mut t, 0.0);
        t
    }

    /// A diagonal translational parameter along `n`: `Σ n_i² p_i` (exactly `p_axis` for an
    /// axis-aligned `n`).
    pub fn along(&self, p: &[f64; 6]) -> f64 {
        self.n.x * self.n.x * p[0] + self.n.y * self.n.y * p[1] + self.n.z * self.n.z * p[2]
    }
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
    /// Enter contact when `f_ext` exceeds this [N] in `Mode::Scheduled` and `Mode::Derived`
    /// ([`SCHEDULED_CONTACT_ENTER_N`] by default): 8 σ of the F/T noise (one count of the mini45)
    /// and the level from which the estimators take a force as evidence. The paper's 1 N (16 σ)
    /// would leave the law out for the time the force takes to rise from 0.5 to 1 N, an error the
    /// approach's impedance does not correct.
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
        let n = self.force_axis.n;
        if !(n.iter().all(|x| x.is_finite()) && (n.norm() - 1.0).abs() < 1e-9) {
            return Err(crate::pipeline::ConfigError::invalid("force_axis", format!("[{}, {}, {}]", n.x, n.y, n.z), "must be a unit vector of the base frame (ForceAxis::new normalises one)"));
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
        let (m_n, b_n) = (self.force_axis.along(&imp.m_d), self.force_axis.along(&imp.b_d));
        if !(b.m_d.0 > 0.0 && b.m_d.0 <= m_n && m_n <= b.m_d.1) {
            return Err(crate::pipeline::ConfigError::invalid("m_d on the force axis", m_n, format!("must lie in the NAIC weight bounds {:?}, lower bound > 0", b.m_d)));
        }
        if !(b.b_d.0 > 0.0 && b.b_d.0 <= b_n && b_n <= b.b_d.1) {
            return Err(crate::pipeline::ConfigError::invalid("b_d on the force axis", b_n, format!("must lie in the NAIC weight bounds {:?}, lower bound > 0", b.b_d)));
        }
        if !(b.sigma.0 <= fl.sigma && fl.sigma <= b.sigma.1) {
            return Err(crate::pipeline::ConfigError::invalid("sigma", fl.sigma, format!("must lie in the NAIC weight bounds {:?}", b.sigma)));
        }
        law::validate(self)?;
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
    /// Latched after a retraction ([`ForceLimit::latch`]): the error `n · e` along the force
    /// axis to keep, i.e. the tool stays at `X_d − n e_hold`.
    pub retract_hold: Option<f64>,
    /// The scheduled law's memory (estimator, gains, integral); idle for the paper laws.
    pub sched: ScheduledState,
    /// The derived law's memory (contact estimator, integral); idle for the other laws.
    pub derived: derived::DerivedState,
}

impl ControlState {
    pub fn new(p: &ControlParams) -> Self {
        let n = &p.force_axis;
        Self {
            phase: Phase::Free,
            below_exit: 0,
            law: ForceLawState::new(&p.force_law, n.along(&p.impedance.m_d), n.along(&p.impedance.b_d)),
            retract_left: 0,
            retract_hold: None,
            sched: law::new_sched(p),
            derived: derived::DerivedState::new(&p.force_law.derived),
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
        Self { phase: Phase::Hold, below_exit: 0, law: fresh.law, sched: law::after_hold(p, &self.sched), derived: fresh.derived, ..*self }
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
    /// What the controller computed for the force law before this stage ([`law::shape`],
    /// [`law::needs_free_fall`]); the default for a law that asks for nothing.
    pub pre: law::Prepared,
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
    /// `Ẋ_d = Ė + Ẋ`, along the force axis the retraction speed while retracting and the
    /// law's [`law::AxisOutputs::v_ref`] where it names one. The friction feedforward is
    /// evaluated at its joint velocity where the law asks for it ([`Self::friction`]).
    pub v_ref: Vector6<f64>,
    /// Factor on the model's gravity torque the law adds ([`law::AxisOutputs::gravity_factor`]).
    pub gravity_factor: f64,
    /// The model's gain along `n` the law divides its commands by.
    pub model_gain: f64,
    /// How the friction feedforward's velocity is formed (`None`: the measured one).
    pub friction: Option<law::FrictionVelocity>,
}

/// Eq 6 per axis with stiffness `k` and no force target:
/// `V_i = ẍ_d,i + (b_d,i ė_i + k_i e_i − F_e,i) / m_d,i`.
fn eq6(imp: &ImpedanceParams, k: &[f64; 6], u: &TaskInputs) -> Vector6<f64> {
    Vector6::from_fn(|i, _| u.a_d[i] + (imp.b_d[i] * u.e_dot[i] + k[i] * u.e[i] - u.f_e[i]) / imp.m_d[i])
}

/// One cycle of the control stage (contact detection, eq 6/8 on every axis, the force law
/// along `n` through [`law::update`], the one dispatch point).
/// Pure: `(params, state, inputs) -> (state, outputs)`; the copying form of [`update`].
pub fn step(p: &ControlParams, s: &ControlState, u: &TaskInputs) -> (ControlState, TaskOutputs) {
    let mut next = *s;
    let out = update(p, &mut next, u);
    (next, out)
}

/// [`step`] in place: `next` holds the previous cycle's state on entry and this cycle's on
/// return (the same numbers, without copying the state in and out).
pub fn update(p: &ControlParams, next: &mut ControlState, u: &TaskInputs) -> TaskOutputs {
    let n = &p.force_axis;
    let f_ext = n.dot6(&u.f_e);
    let (prev_phase, prev_below_exit) = (next.phase, next.below_exit);
    let mut v_ref = u.e_dot + u.x_dot;
    let imp = &law::impedance(p);
    let along = |u: &TaskInputs, regime: law::Regime, entered: bool, v_n: f64| law::AxisInputs {
        regime,
        prev_phase,
        entered,
        x: n.dot(&u.p),
        x_dot: n.dot6(&u.x_dot),
        e: n.dot6(&u.e),
        e_dot: n.dot6(&u.e_dot),
        v_d: n.dot6(&(u.e_dot + u.x_dot)),
        a_d: n.dot6(&u.a_d),
        f_ext,
        f_d: u.f_d,
        v_n,
        free_m: n.along(&imp.m_d),
        free_b: n.along(&imp.b_d),
        free_k: n.along(&imp.k_free),
        surface_n: law::surface_along(p),
        pre: u.pre,
    };
    let finish = |next: &mut ControlState, out: &mut TaskOutputs, a: &law::AxisInputs| {
        let r = law::update(p, &mut next.law, &mut next.sched, &mut next.derived, a);
        if let Some(x) = r.xdd {
            n.set6(&mut out.v, x);
        }
        if let Some(v) = r.v_ref {
            n.set6(&mut out.v_ref, v);
        }
        out.law = r.report;
        out.gravity_factor = r.gravity_factor;
        out.model_gain = r.model_gain;
        out.friction = r.friction;
    };

    // Force limit: stop pushing, leave contact, back off along −n for a while.
    if f_ext > p.force_limit.limit_n {
        next.retract_left = p.force_limit.retract_cycles.max(1);
        next.retract_hold = None;
        next.phase = Phase::Free;
    }
    let retracting = next.retract_left > 0 || next.retract_hold.is_some();
    if retracting {
        next.phase = Phase::Free;
        let mut v;
        if next.retract_left > 0 {
            next.retract_left -= 1;
            v = eq6(imp, &imp.k_free, u);
            // Velocity servo along n to −retract_speed, with the free-space damping.
            let (m_n, b_n) = (n.along(&imp.m_d), n.along(&imp.b_d));
            n.set6(&mut v, b_n * (-p.force_limit.retract_speed - n.dot6(&u.x_dot)) / m_n);
            if next.retract_left == 0 && p.force_limit.latch {
                next.retract_hold = Some(n.dot6(&u.e));
            }
            n.set6(&mut v_ref, -p.force_limit.retract_speed);
        } else {
            // Latched: free-space impedance on every axis, the force axis about the held offset.
            let mut held = *u;
            let e_hold = next.retract_hold.unwrap_or(0.0);
            for i in 0..3 {
                held.e[i] -= n.n[i] * e_hold;
            }
            v = eq6(imp, &imp.k_free, &held);
        }
        let a = along(u, law::Regime::Retracting, false, n.dot6(&v));
        let mut out = TaskOutputs {
            v,
            f_ext,
            k_d: n.along(&imp.k_free),
            law: Default::default(),
            retracting: true,
            v_ref,
            gravity_factor: 0.0,
            model_gain: 1.0,
            friction: None,
        };
        finish(next, &mut out, &a);
        return out;
    }

    // Phase transitions (a hold ends in free space: contact is re-detected).
    let mut entered = false;
    match prev_phase {
        Phase::Free | Phase::Hold => {
            next.phase = Phase::Free;
            if u.pre.f_contact.unwrap_or(f_ext) > law::contact_threshold(p) {
                next.phase = Phase::Contact;
                next.below_exit = 0;
                entered = true;
            }
        }
        Phase::Contact => {
            next.below_exit = if f_ext < p.contact.exit_n { prev_below_exit + 1 } else { 0 };
            if p.contact.exit_cycles > 0 && next.below_exit >= p.contact.exit_cycles {
                next.phase = Phase::Free;
            }
        }
    }

    let contact = next.phase == Phase::Contact;
    let v = if contact {
        // k_d = 0 along n (§3.1): the tangential impedance acts on the tangential errors;
        // the component along n is the law's.
        let t = TaskInputs { e: n.tangential6(&u.e), e_dot: n.tangential6(&u.e_dot), f_e: n.tangential6(&u.f_e), ..*u };
        eq6(imp, &imp.k_contact, &t)
    } else {
        eq6(imp, &imp.k_free, u)
    };
    let regime = if contact { law::Regime::Contact } else { law::Regime::Free };
    let a = along(u, regime, entered, n.dot6(&v));
    let mut out = TaskOutputs {
        v,
        f_ext,
        k_d: if contact { 0.0 } else { n.along(&imp.k_free) },
        law: Default::default(),
        retracting: false,
        v_ref,
        gravity_factor: 0.0,
        model_gain: 1.0,
        friction: None,
    };
    finish(next, &mut out, &a);
    out
}

#[cfg(test)]
mod tests {
    use super::force_law::{Mode, WeightBounds};
    use super::*;

    /// What the controller computes for a law on the unit point mass below: its apparent
    /// mass along any n is 1 kg (the derived law's `D̂`).
    const POINT_MASS: law::Prepared = law::Prepared { shaper: None, a_free: f64::NAN, mass_n: 1.0, tool_mass: 0.0, f_contact: None };

    fn params(mode: Mode) -> ControlParams {
        ControlParams {
            impedance: ImpedanceParams {
                m_d: [1.0; 6],
                b_d: [500.0, 500.0, 40.0, 500.0, 500.0, 500.0],
                k_free: [500.0, 500.0, 50.0, 1000.0, 1000.0, 1000.0],
                k_contact: [100.0, 100.0, 0.0, 1000.0, 1000.0, 1000.0],
            },
            force_axis: ForceAxis::base(2, -1.0),
            force_law: ForceLawParams { mode, sigma: 0.01, gamma: 0.0, bounds: WeightBounds::default(), lambda: 1e-3, sigma_margin: 0.5, integral_limit_n: f64::INFINITY, scheduled: Default::default(), derived: Default::default() },
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
            let u = TaskInputs { p: x.fixed_rows::<3>(0).into(), e: x_d - x, e_dot: -v, x_dot: v, a_d: Vector6::zeros(), f_e, f_d: 10.0, pre: POINT_MASS };
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

    /// The force axis as any unit vector: a point mass pushing on a spring surface whose
    /// normal is a tilted `n`; every law brings the force along n to f_d and the tangential
    /// position to the reference (k_d acts on the tangential error only).
    #[test]
    fn every_law_tracks_the_force_along_a_tilted_axis() {
        for mode in Mode::ALL {
            let mut p = params(mode);
            // An isotropic translational impedance, so that the tangential axes are alike.
            p.impedance.m_d[..3].copy_from_slice(&[1.0; 3]);
            p.impedance.b_d[..3].copy_from_slice(&[40.0; 3]);
            p.impedance.k_free[..3].copy_from_slice(&[50.0; 3]);
            p.impedance.k_contact[..3].copy_from_slice(&[100.0; 3]);
            p.force_axis = ForceAxis::new(Vector3::new(0.6, 0.0, -0.8)).unwrap();
            p.validate().unwrap();
            let n = p.force_axis.n;
            let (k_e, dt) = (2000.0, 1e-3);
            let mut s = ControlState::new(&p);
            let t = Vector3::new(0.8, 0.0, 0.6); // tangential, ⟂ n
            let mut x = -0.02 * n + 0.01 * t;
            let mut v = Vector3::zeros();
            let x_d = 0.03 * n; // below the surface n·x = 0, tangential offset 0
            let mut f = 0.0;
            for _ in 0..4000 {
                let pen = n.dot(&x).max(0.0);
                let mut f_e = Vector6::zeros();
                f_e.fixed_rows_mut::<3>(0).copy_from(&(k_e * pen * n));
                let mut e = Vector6::zeros();
                e.fixed_rows_mut::<3>(0).copy_from(&(x_d - x));
                let mut xd = Vector6::zeros();
                xd.fixed_rows_mut::<3>(0).copy_from(&v);
                let u = TaskInputs { p: x, e, e_dot: -xd, x_dot: xd, a_d: Vector6::zeros(), f_e, f_d: 10.0, pre: POINT_MASS };
                let (next, o) = step(&p, &s, &u);
                s = next;
                v += o.v.fixed_rows::<3>(0).into_owned() * dt;
                x += v * dt;
                f = o.f_ext;
            }
            assert_eq!(s.phase, Phase::Contact, "{mode:?}");
            assert!((f - 10.0).abs() < 0.05, "{mode:?}: force along n {f}");
            assert!(t.dot(&x).abs() < 1e-3, "{mode:?}: tangential offset {} m", t.dot(&x));
        }
    }

    /// Along an axis-aligned n the projections are the axis' entries exactly.
    #[test]
    fn an_axis_aligned_force_axis_projects_exactly() {
        let n = ForceAxis::base(2, -1.0);
        assert_eq!(n.aligned(), Some(2));
        assert_eq!(n.dominant(), 2);
        let v = Vector6::new(0.3, -1.7, 2.9, 4.0, 5.0, 6.0);
        assert_eq!(n.dot6(&v), -2.9);
        let mut w = v;
        n.set6(&mut w, 1.25);
        assert_eq!(w, Vector6::new(0.3, -1.7, -1.25, 4.0, 5.0, 6.0));
        assert_eq!(n.along(&[1.0, 2.0, 3.5, 4.0, 5.0, 6.0]), 3.5);
        assert_eq!(ForceAxis::new(Vector3::new(0.0, 0.0, -1.0)).unwrap(), n);
        let tilted = ForceAxis::new(Vector3::new(3.0, 0.0, -4.0)).unwrap();
        assert_eq!(tilted.aligned(), None);
        assert!((tilted.n.norm() - 1.0).abs() < 1e-15);
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
            pre: Default::default(),
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
            pre: Default::default(),
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
            pre: Default::default(),
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
            let u = TaskInputs { p: x.fixed_rows::<3>(0).into(), e: x_d - x, e_dot: -v, x_dot: v, a_d: Vector6::zeros(), f_e, f_d, pre: Default::default() };
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
            pre: Default::default(),
        };
        for mode in Mode::ALL {
            let p = params(mode);
            assert_eq!(p.contact.scheduled_enter_n, SCHEDULED_CONTACT_ENTER_N);
            let s = ControlState::new(&p);
            let (below, _) = step(&p, &s, &u(0.45));
            assert_eq!(below.phase, Phase::Free, "{mode:?} at 0.45 N");
            let (mid, _) = step(&p, &s, &u(0.7));
            let expect = if matches!(mode, Mode::Scheduled | Mode::Derived) { Phase::Contact } else { Phase::Free };
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
            pre: Default::default(),
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
        p.force_axis.n = Vector3::new(0.0, 0.0, -2.0);
        assert!(p.validate().unwrap_err().to_string().contains("force_axis"));
        for bad in [Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 1.0), Vector3::new(f64::INFINITY, 0.0, 0.0)] {
            let e = ForceAxis::new(bad).unwrap_err().to_string();
            assert!(e.contains("force_axis") && e.contains("non-zero"), "{bad:?}: {e}");
        }
        for bad in [0.0, -1.0, 0.1, f64::NAN, f64::INFINITY, 60.0] {
            let mut p = params(Mode::Scheduled);
            p.contact.scheduled_enter_n = bad;
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains("scheduled_contact_threshold") || e.contains("scheduled law's contact threshold"), "{bad}: {e}");
        }
    }
}
