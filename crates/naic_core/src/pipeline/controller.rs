//! The controller node's half of the pipeline in one pure step:
//! `sense → estimate → control → inverse dynamics`.
//!
//! # Eq 6 → joint torques
//!
//! Eq 6 asks for the Cartesian force `F = D V + h + F_f + F_e` and the joint
//! torque `τ = Jᵀ F`. With eq 3's `D = J⁻ᵀ M J⁻¹` and
//! `h = J⁻ᵀ (C q̇ + G) − D J̇ q̇`:
//!
//! ```text
//! Jᵀ (D V + h) = M J⁻¹ (V − J̇ q̇) + C q̇ + G = RNEA(q, q̇, q̈*)   with   q̈* = J⁻¹ (V − J̇ q̇)
//! ```
//!
//! so the controller solves `J q̈* = V − J̇ q̇` (damped near singularities, see
//! [`crate::dynamics::Damping`]) and calls RNEA once — no `D`, no `M`, no
//! explicit inverse — then adds `Jᵀ F_e` (the contact wrench feedforward of
//! eq 6). The friction term `Jᵀ F_f = τ_f` is the next stage
//! ([`super::feedforward`]), which the ROS graph runs in its own node.
//! `J` is the `tip` frame Jacobian, world-aligned, rows linear then angular;
//! `V`'s rotational rows are angular accelerations.
//!
//! # Safe hold
//!
//! When the sense stage rejects the measurements (non-finite, implausible,
//! stale), the output is `τ = G(q) − D_hold q̇` at the last valid state
//! (gravity compensation plus joint damping, capped per joint for stability at
//! the control period: [`super::hold`]; no force command), the phase is
//! `Hold`, the force law forgets what it learned ([`ControlState::hold`]), and
//! the fault is reported; the next valid cycle resumes in free space and
//! re-detects contact.

use nalgebra::{Matrix3, Matrix6, Rotation3, SMatrix, SVector, UnitQuaternion, Vector3, Vector6};

use super::control::force_law::Mode;
use super::ConfigError;
use super::control::{self, ControlParams, ControlState, Phase, TaskInputs};
use super::estimate::{self, TareState, ToolParams};
use super::feedforward;
use super::sense::{self, Fault, RawMeasurements, SenseParams, SenseState};
use crate::dynamics::{self, Damping};
use crate::model::{DataN, FrameId, Model};
use crate::{JointVec, N_JOINTS};

/// Everything the controller needs besides the robot model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerParams<const N: usize = N_JOINTS> {
    pub sense: SenseParams<N>,
    pub tool: ToolParams,
    /// Free-space samples averaged for the F/T tare at start.
    pub tare_samples: u32,
    /// The tare takes only consecutive samples at rest ([`estimate::tare_step`]) and holds
    /// the arm meanwhile ([`TARE_HOLD_OMEGA`]); off: the first `tare_samples` cycles,
    /// controlled as usual with no force (the simulator's setting: its sensor has no tool
    /// inertia, so an accelerating arm leaves no bias there, and its goals were measured so).
    pub tare_at_rest: bool,
    /// The sensor reads the tool's inertial force (a real one does; MuJoCo's does): the tare
    /// takes the force the model predicts from the tool's motion out of each sample
    /// ([`estimate::TareInertia`]), so that an arm moving while taring leaves no bias; and the
    /// contact decisions (the free-space → contact entry of every law, the `derived` law's
    /// contact in evidence) read the contact force with the tool's inertial force taken out
    /// over [`estimate::CONTACT_FORCE_WINDOW`] cycles ([`estimate::ToolMotion`]). The force
    /// the laws act on (`F_e`, eq 6's feedforward, the force errors) is the reading as before.
    /// Off: the samples are weight and bias alone (the own simulator's sensor without
    /// `--inertial-wrench`, which reads no inertia). Formerly `tare_inertial`.
    pub sensor_reads_tool_inertia: bool,
    pub control: ControlParams,
    /// Joint damping of the safe hold [N·m·s/rad].
    pub hold_damping: JointVec<N>,
    /// Jacobian inverse near singularities.
    pub damping: Damping,
    /// The null-space posture task of an arm with more than 6 joints (unused on 6).
    pub nullspace: NullSpace<N>,
}

/// The posture task in the Jacobian's null space (eq 6 → τ below; an arm of N > 6 joints):
/// `τ₀ = k (q_n − q) − d q̇`, projected by `(I − Jᵀ J̄ᵀ)` so that it moves nothing of the task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NullSpace<const N: usize = N_JOINTS> {
    /// Stiffness towards the posture [N·m/rad].
    pub stiffness: f64,
    /// Joint damping [N·m·s/rad], capped per joint for stability at the control period
    /// as the hold's ([`super::hold::stable_damping`]).
    pub damping: f64,
    /// The posture `q_n` [rad]; `None`: the first valid joint position (the start pose).
    pub q: Option<JointVec<N>>,
}

impl<const N: usize> Default for NullSpace<N> {
    fn default() -> Self {
        Self { stiffness: 20.0, damping: 2.0, q: None }
    }
}

/// The immutable half: the 6-joint model, its frames and the parameters.
#[derive(Clone, Debug)]
pub struct Controller<const N: usize = N_JOINTS> {
    model: Model,
    /// A workspace sized for the model, cloned by [`Controller::workspace`].
    blank: DataN<N>,
    tip: FrameId,
    sensor: FrameId,
    params: ControllerParams<N>,
}

/// Names of the frames the controller needs in the URDF.
pub const TIP_FRAME: &str = "tip";
pub const SENSOR_FRAME: &str = "ft_sensor";

impl<const N: usize> Controller<N> {
    /// Checks the model (N joints, `tip` and `ft_sensor` frames) and the parameters.
    pub fn new(model: Model, params: ControllerParams<N>) -> Result<Self, ConfigError> {
        if model.nv() != N {
            return Err(ConfigError::Model(format!("this controller was set up for a {N}-joint arm; this model has {} joints", model.nv())));
        }
        let frame = |name: &str| {
            model.frame_id(name).ok_or_else(|| ConfigError::Model(format!("the URDF has no frame '{name}': add a link named '{name}'")))
        };
        let (tip, sensor) = (frame(TIP_FRAME)?, frame(SENSOR_FRAME)?);
        params.sense.validate()?;
        params.control.validate()?;
        if !(params.tool.mass >= 0.0 && params.tool.mass.is_finite()) {
            return Err(ConfigError::invalid("tool mass", params.tool.mass, "kg must be finite and >= 0"));
        }
        if params.hold_damping.iter().any(|d| !(*d >= 0.0 && d.is_finite())) {
            return Err(ConfigError::invalid("hold_damping", format!("{:?}", params.hold_damping), "must be finite and >= 0"));
        }
        let ns = &params.nullspace;
        if !(ns.stiffness >= 0.0 && ns.stiffness.is_finite() && ns.damping >= 0.0 && ns.damping.is_finite()) {
            return Err(ConfigError::invalid("nullspace stiffness", format!("{} N·m/rad (damping {} N·m·s/rad)", ns.stiffness, ns.damping), "must both be finite and >= 0"));
        }
        if ns.q.is_some_and(|q| q.iter().any(|x| !x.is_finite())) {
            return Err(ConfigError::invalid("nullspace_q", format!("{:?}", ns.q), "must be finite joint positions [rad], one per joint"));
        }
        let blank = DataN::<N>::try_new(&model).map_err(|e| ConfigError::Model(e.to_string()))?;
        Ok(Self { model, blank, tip, sensor, params })
    }

    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn params(&self) -> &ControllerParams<N> {
        &self.params
    }

    /// A copy with other parameters (validated); the state stays compatible.
    pub fn with_params(&self, params: ControllerParams<N>) -> Result<Self, ConfigError> {
        Self::new(self.model.clone(), params)
    }

    /// The state before the first cycle.
    pub fn initial_state(&self) -> ControllerState<N> {
        ControllerState {
            sense: SenseState::default(),
            tare: TareState::default(),
            control: ControlState::new(&self.params.control),
            fault: None,
            fault_count: 0,
            last_q: None,
            q_posture: None,
            tool_motion: estimate::ToolMotion::default(),
        }
    }

    /// A preallocated workspace for [`step`].
    pub fn workspace(&self) -> Workspace<N> {
        Workspace { data: self.blank.clone() }
    }
}

/// Scratch memory of [`step`]: no state lives here.
#[derive(Clone, Debug)]
pub struct Workspace<const N: usize = N_JOINTS> {
    pub data: DataN<N>,
}

/// What the controller remembers between cycles (all of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerState<const N: usize = N_JOINTS> {
    pub sense: SenseState<N>,
    pub tare: TareState<N>,
    pub control: ControlState,
    /// The fault of the last cycle, if it was rejected.
    pub fault: Option<Fault>,
    /// Fault events (transitions into a fault) since start.
    pub fault_count: u32,
    /// Last valid joint position (the hold uses it when q itself is bad).
    pub last_q: Option<JointVec<N>>,
    /// The null-space posture `q_n` in use (an arm of N > 6 joints; [`NullSpace::q`]).
    pub q_posture: Option<JointVec<N>>,
    /// The tool's recent motion and contact force (with [`ControllerParams::sensor_reads_tool_inertia`]).
    pub tool_motion: estimate::ToolMotion,
}

/// The reference of one cycle: where the tip should be and what force it should apply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference {
    /// Desired tip position `p_d` [m], base frame.
    pub p_d: Vector3<f64>,
    /// Desired tip orientation `R_d`.
    pub r_d: UnitQuaternion<f64>,
    /// Desired tip twist `Ẋ_d` (linear, angular), base frame.
    pub v_d: Vector6<f64>,
    /// Desired tip acceleration `Ẍ_d`.
    pub a_d: Vector6<f64>,
    /// Desired force `f_d` [N] along the force axis (pushing positive).
    pub f_d: f64,
}

/// The controller's report of one cycle (what `/naic/params` publishes, and more).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status {
    pub mode: Mode,
    pub phase: Phase,
    /// The base axis closest to the force axis n (0, 1, 2 = x, y, z; exactly n's axis for
    /// an axis-aligned n).
    pub force_axis: usize,
    /// `f_d`, `f_ext` along the force axis, and `e_f = f_ext − f_d` [N].
    pub f_d: f64,
    pub f_ext: f64,
    pub e_f: f64,
    /// Current impedance on the force axis and NAIC weights.
    pub m_d: f64,
    pub b_d: f64,
    pub k_d: f64,
    pub sigma: f64,
    pub phi: f64,
    /// Learning rate applied, its eq-15 bound, and whether it was clipped.
    pub gamma: f64,
    pub gamma_bound: f64,
    pub gamma_clipped: bool,
    pub weights_projected: bool,
    /// The scheduled law's stiffness estimate `k̂_e` [N/m] and its confidence [0, 1]
    /// (0 and 0 for the paper laws).
    pub k_e_hat: f64,
    pub k_e_confidence: f64,
    /// The gain of the dynamic model along n the scheduled law acts with (`scheduled::gain`;
    /// 1 for the paper laws and until it is learnt).
    pub model_gain: f64,
    /// The factor on the dynamic model's gravity torque the scheduled law applies
    /// (`scheduled::gain::GravityCorrection`: `1/ĝ` for a light model, `1/F̂_s` for a heavy
    /// one, ramped in; 1 for the paper laws, until it is learnt and in a hold).
    pub gravity_scale: f64,
    pub fault: Option<Fault>,
    pub fault_count: u32,
    /// The F/T tare is complete.
    pub tared: bool,
    /// Measured tip position [m] and the contact wrench `F_e` (robot on environment), base frame.
    pub tip_position: Vector3<f64>,
    pub f_e: Vector6<f64>,
    /// The Jacobian inverse was damped this cycle (near a singularity).
    pub jacobian_damped: bool,
    /// `f_ext` exceeded the force limit: the tool is retracting.
    pub force_limited: bool,
}

/// Output of one cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlOutputs<const N: usize = N_JOINTS> {
    /// Joint torques before friction feedforward and actuation limits [N·m].
    pub tau: JointVec<N>,
    /// The (median-filtered) joint velocity this cycle used [rad/s].
    pub dq: JointVec<N>,
    /// The joint velocity the friction feedforward is to be evaluated at [rad/s], when the
    /// law names one: with the scheduled law's `friction_reference`, the blend of `dq` and
    /// the reference twist's joint velocity `J⁻¹ Ẋ_ref` ([`super::feedforward::blend`]).
    /// `None`: at `dq` (the paper's laws). Over DDS it travels with the torque on
    /// `/naic/effort` to the friction node (`naic_ros::msgs::set_effort_msg`).
    pub dq_ff: Option<JointVec<N>>,
    pub status: Status,
}

/// Rotation vector of `R_d Rᵀ` (the orientation part of `E = X_d − X`).
fn orientation_error(r_d: &UnitQuaternion<f64>, r: &Matrix3<f64>) -> Vector3<f64> {
    let r_now = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    (r_d * r_now.inverse()).scaled_axis()
}

/// One cycle of the controller. Pure: `(params, state, inputs) -> (state, outputs)`;
/// the workspace is scratch memory only. No heap allocation.
pub fn step<const N: usize>(
    c: &Controller<N>,
    s: &ControllerState<N>,
    m: &RawMeasurements<N>,
    r: &Reference,
    ws: &mut Workspace<N>,
) -> (ControllerState<N>, ControlOutputs<N>) {
    let mut next = *s;
    let out = update(c, &mut next, m, r, ws);
    (next, out)
}

/// The tool's centre-of-mass velocity in the world frame at joint velocities `dq`: it moves
/// with the sensor frame (world-aligned Jacobian), `v + ω × (R_ws c)`.
fn tool_com_velocity<const N: usize>(c: &Controller<N>, ws: &mut Workspace<N>, q: &SVector<f64, N>, dq: &SVector<f64, N>, r_ws: &Matrix3<f64>) -> Vector3<f64> {
    let v6 = dynamics::frame_jacobian(&c.model, &mut ws.data, q, c.sensor) * dq;
    let (v, w) = (Vector3::new(v6[0], v6[1], v6[2]), Vector3::new(v6[3], v6[4], v6[5]));
    v + w.cross(&(r_ws * c.params.tool.com))
}

/// [`step`] on a state the caller keeps: `next` holds this cycle's state on entry and the
/// next cycle's on return, the same numbers as [`step`] returns, without copying the state
/// in and out (3.7 kB on 7 joints, a fifth of the Panda's cycle). Each stage reads its
/// part of the state before it writes it.
pub fn update<const N: usize>(
    c: &Controller<N>,
    next: &mut ControllerState<N>,
    m: &RawMeasurements<N>,
    r: &Reference,
    ws: &mut Workspace<N>,
) -> ControlOutputs<N> {
    let p = &c.params;
    // The sense stage keeps its state on a fault (the hold's state is the last valid one).
    let sensed = match sense::update(&p.sense, &mut next.sense, m) {
        Ok(x) => x,
        Err(fault) => return hold(c, next, m, r, ws, fault),
    };
    let q = SVector::<f64, N>::from(sensed.q);
    let dq = SVector::<f64, N>::from(sensed.dq);
    next.fault = None;
    next.last_q = Some(sensed.q);

    // Kinematics: sensor orientation and tip pose (only these two frames are placed).
    let r_ws = dynamics::frame_placement(&c.model, &mut ws.data, &q, c.sensor).rot;
    let tip = *dynamics::frame_placement(&c.model, &mut ws.data, &q, c.tip);

    // Estimate the contact wrench, after the tare. While taring the arm is held (gravity
    // compensation and joint damping: it comes to rest) and the tare takes only samples at
    // rest (estimate::tare_step); force control starts with the cycle after it.
    let tared = next.tare.done(p.tare_samples);
    let rest = p.tare_at_rest.then_some((m.t, &sensed.dq));
    // The contact force for the contact decisions, free of the tool's inertial force
    // (estimate::ToolMotion), on a sensor that reads it; its window fills while taring.
    let f_contact = if p.sensor_reads_tool_inertia {
        let v_com = tool_com_velocity(c, ws, &q, &SVector::<f64, N>::from(sensed.dq_raw), &r_ws);
        let f0 = estimate::contact_wrench(&p.tool, &[0.0; 6], &sensed.wrench, &r_ws);
        next.tool_motion.push(m.t, &v_com, &Vector3::new(f0[0], f0[1], f0[2]));
        let b = next.tare.bias();
        let offset = r_ws * Vector3::new(b[0], b[1], b[2]);
        if tared { next.tool_motion.contact_force(p.tool.mass, estimate::CONTACT_FORCE_WINDOW, &offset).map(|f| p.control.force_axis.dot(&f)) } else { None }
    } else {
        None
    };
    let f_e = if tared {
        estimate::contact_wrench(&p.tool, &next.tare.bias(), &sensed.wrench, &r_ws)
    } else {
        let inertia = p.sensor_reads_tool_inertia.then(|| estimate::TareInertia { t: m.t, v_com: tool_com_velocity(c, ws, &q, &dq, &r_ws) });
        next.tare = estimate::tare_step(&p.tool, p.tare_samples, &next.tare, &sensed.wrench, &r_ws, rest, inertia.as_ref());
        if p.tare_at_rest {
            return taring(c, next, &sensed.q, &sensed.dq, r, ws);
        }
        Vector6::zeros()
    };

    let j = *dynamics::frame_jacobian(&c.model, &mut ws.data, &q, c.tip);
    let jdot_qdot = dynamics::frame_jdot_qdot(&c.model, &mut ws.data, &q, &dq, c.tip);
    let x_dot = j * dq;
    // The force law's view of the reference (it may shape the tangential velocity in
    // contact: control::law::shape) and, where it asks, the model's free fall along n.
    let mut shaped = *r;
    let (pd, vd, ad, shaper) = control::law::shape(
        &p.control,
        &next.control.sched,
        next.control.phase,
        &r.p_d,
        &r.v_d.fixed_rows::<3>(0).into(),
        &r.a_d.fixed_rows::<3>(0).into(),
    );
    shaped.p_d = pd;
    shaped.v_d.fixed_rows_mut::<3>(0).copy_from(&vd);
    shaped.a_d.fixed_rows_mut::<3>(0).copy_from(&ad);
    let a_free = if control::law::needs_free_fall(&p.control) {
        let zero = SVector::<f64, N>::zeros();
        let qdd_free = *dynamics::aba(&c.model, &mut ws.data, &q, &zero, &zero);
        p.control.force_axis.dot6(&(j * qdd_free))
    } else {
        f64::NAN
    };
    let mass_n = if control::law::needs_apparent_mass(&p.control) { apparent_mass(c, ws, &q, &j, &p.control.force_axis) } else { f64::NAN };
    let r = &shaped;
    let e_p = r.p_d - tip.trans;
    let e_r = orientation_error(&r.r_d, &tip.rot);
    let task = TaskInputs {
        p: tip.trans,
        e: Vector6::new(e_p.x, e_p.y, e_p.z, e_r.x, e_r.y, e_r.z),
        e_dot: r.v_d - x_dot,
        x_dot,
        a_d: r.a_d,
        f_e,
        f_d: r.f_d,
        pre: control::law::Prepared { shaper, a_free, mass_n, tool_mass: p.tool.mass, f_contact },
    };
    let out = control::update(&p.control, &mut next.control, &task);

    // Eq 6 → τ: J q̈* = V − J̇q̇, τ = RNEA(q, q̇, q̈*) + Jᵀ F_e.
    let posture = if N == 6 { None } else { Some(next.q_posture.or(p.nullspace.q).unwrap_or(sensed.q)) };
    next.q_posture = posture;
    let (qdd, damped) = solve_eq6(c, ws, &q, &dq, &j, &(out.v - jdot_qdot), posture.as_ref());
    let tau_id = *dynamics::rnea(&c.model, &mut ws.data, &q, &dq, &qdd);
    // The contact wrench is fed forward (eq 6) except while the force limit retracts: there
    // cancelling it would hold the tool against the surface that pushes it off, and only the
    // retract's velocity servo would lift it (under a light model's gravity deficit, not at
    // all: the tool sank on at the force limit). Without it the surface's push lifts the tool.
    let f_ff = if out.retracting { Vector6::zeros() } else { f_e };
    let mut tau = tau_id + j.transpose() * f_ff;
    // A factor on the model's gravity torque, where the law asks for one.
    if out.gravity_factor != 0.0 {
        tau += *dynamics::gravity_torques(&c.model, &mut ws.data, &q) * out.gravity_factor;
    }
    let gravity_scale = 1.0 + out.gravity_factor;
    // The friction feedforward's velocity, where the law names one (control::law::FrictionVelocity):
    // from the reference twist's joint velocity; the measured one otherwise.
    let dq_ff = out.friction.map(|fr| {
        let (dq_ref, _) = solve_eq6(c, ws, &q, &dq, &j, &out.v_ref, None);
        let dq_ref = dq_ref.into();
        match &fr.fast {
            Some((f, gate, k_e)) => feedforward::blend_fast(&fr.blend, f, *gate, *k_e, &sensed.dq, &sensed.dq_raw, &sensed.dq_raw_prev, &dq_ref),
            None => feedforward::blend(&fr.blend, &sensed.dq, &dq_ref),
        }
    });

    let law = &next.control.law;
    let status = Status {
        mode: p.control.force_law.mode,
        phase: next.control.phase,
        force_axis: p.control.force_axis.dominant(),
        f_d: r.f_d,
        f_ext: out.f_ext,
        e_f: out.law.e_f,
        m_d: law.m_d,
        b_d: law.b_d,
        k_d: out.k_d,
        sigma: law.sigma,
        phi: law.phi,
        gamma: out.law.gamma,
        gamma_bound: out.law.gamma_bound,
        gamma_clipped: out.law.gamma_clipped,
        weights_projected: out.law.weights_projected,
        k_e_hat: out.law.k_e_hat,
        k_e_confidence: out.law.k_e_confidence,
        model_gain: control::law::model_gain(&p.control, &next.control.sched),
        gravity_scale,
        fault: None,
        fault_count: next.fault_count,
        tared,
        tip_position: tip.trans,
        f_e,
        jacobian_damped: damped,
        force_limited: out.retracting,
    };
    ControlOutputs { tau: tau.into(), dq: sensed.dq, dq_ff, status }
}

/// How stiffly the arm is held while taring [rad/s]: per joint a critically damped spring
/// about the tare's first position, `τ_i = G_i(q) + M_ii (ω² (q_hold,i − q_i) − 2 ω q̇_i)`.
/// Gravity compensation alone lets a wrong model (a mass error) drift the arm for ever;
/// the spring stops it at `ΔG_i / (M_ii ω²)` (a 25 % heavy JK5 model: about 0.01 rad on
/// joint 2), so it comes to rest and the tare completes. ω λ = 0.02 at 1 kHz: far from the
/// discrete stability limit, also with a few cycles of delay.
pub const TARE_HOLD_OMEGA: f64 = 20.0;

/// The model's apparent mass along the force axis at `q`, `D̂ = 1 / (nᵀ J M⁻¹ Jᵀ n)` [kg]:
/// `M⁻¹ Jᵀ n` as the forward dynamics' answer to the torque `Jᵀ n` at rest, less its free
/// fall. NaN where `n` is not reachable (`nᵀ J M⁻¹ Jᵀ n ≤ 0`). No allocation.
fn apparent_mass<const N: usize>(c: &Controller<N>, ws: &mut Workspace<N>, q: &SVector<f64, N>, j: &SMatrix<f64, 6, N>, n: &control::ForceAxis) -> f64 {
    let zero = SVector::<f64, N>::zeros();
    let qdd_free = *dynamics::aba(&c.model, &mut ws.data, q, &zero, &zero);
    let mut n6 = Vector6::zeros();
    n.set6(&mut n6, 1.0);
    let tau_n = j.transpose() * n6;
    let qdd_n = *dynamics::aba(&c.model, &mut ws.data, q, &zero, &tau_n);
    let inv = n.dot6(&(j * (qdd_n - qdd_free)));
    if inv > 0.0 && inv.is_finite() { 1.0 / inv } else { f64::NAN }
}

/// A cycle of the tare: the arm held at the tare's first position ([`TARE_HOLD_OMEGA`], no
/// fault), the tare already advanced in `next`; phase free, no force.
fn taring<const N: usize>(
    c: &Controller<N>,
    next: &mut ControllerState<N>,
    q: &JointVec<N>,
    dq: &JointVec<N>,
    r: &Reference,
    ws: &mut Workspace<N>,
) -> ControlOutputs<N> {
    let p = &c.params;
    let tip = ws.data.frame_se3(c.tip).trans; // placed at q by the caller
    let q_hold = next.tare.q_hold.unwrap_or(*q);
    next.tare.q_hold = Some(q_hold);
    let qv = SVector::<f64, N>::from(*q);
    let w = TARE_HOLD_OMEGA;
    let a = SVector::<f64, N>::from_fn(|i, _| w * w * (q_hold[i] - q[i]) - 2.0 * w * dq[i]);
    let m = *dynamics::crba(&c.model, &mut ws.data, &qv);
    let g = *dynamics::gravity_torques(&c.model, &mut ws.data, &qv);
    // Six joints: per joint with the diagonal of M (the JK5's hold, unchanged). Any other
    // count: with the whole M, `τ = G + M a`: a redundant arm's self-motion (the Panda's
    // joints 1 and 3 turning against each other) has an inertia far below M_ii, and the
    // diagonal law's damping made that mode unstable at 1 kHz (measured: 4.8 rad/s on joint
    // 1 within 49 cycles of the Panda's start); the whole M makes every mode `ä = a`.
    let tau: JointVec<N> = if N == 6 {
        std::array::from_fn(|i| g[i] + m[(i, i)] * a[i])
    } else {
        (g + m * a).into()
    };
    let status = status_without_force(p, next, r, next.control.phase, 0.0, None, tip, next.control.retracting());
    // The hold commands rest: with the controller's friction reference blend the friction
    // feedforward is evaluated at the blend of the measured velocity and the hold's, zero, so
    // that the encoders' velocity noise at rest is not turned into ±f_b of torque on every
    // joint (the wrist joints then stick and slip and the tare never sees rest); a joint that
    // slips above the blend's v_hi still gets it at its own velocity.
    let dq_ff = p.control.force_law.scheduled.friction_reference.map(|b| feedforward::blend(&b, dq, &[0.0; N]));
    ControlOutputs { tau, dq: *dq, dq_ff, status }
}

/// Solves eq 6's `J q̈ = b` for the joint acceleration (module docs), with whether the
/// inverse was damped. Six joints: the square solve of [`dynamics::solve_damped`] (the
/// JK5's path, unchanged). Any other count: the dynamically consistent damped inverse
/// `q̈ = J̄ b` ([`dynamics::consistent_inverse`]) plus, with a `posture`, the null-space
/// posture task `(I − J̄ J) M⁻¹ τ₀`, `τ₀ = k (q_n − q) − d q̇` ([`NullSpace`]), so that
/// `τ = M q̈ + C q̇ + G` adds `(I − Jᵀ J̄ᵀ) τ₀` to the task's torque. A failed
/// decomposition (non-finite state) gives `q̈ = 0` and `true`, as the square solve does.
fn solve_eq6<const N: usize>(
    c: &Controller<N>,
    ws: &mut Workspace<N>,
    q: &SVector<f64, N>,
    dq: &SVector<f64, N>,
    j: &SMatrix<f64, 6, N>,
    b: &Vector6<f64>,
    posture: Option<&JointVec<N>>,
) -> (SVector<f64, N>, bool) {
    let p = &c.params;
    if N == 6 {
        let j6 = Matrix6::from_fn(|r, k| j[(r, k)]);
        let (x, damped) = dynamics::solve_damped(&j6, b, &p.damping);
        return (SVector::<f64, N>::from_fn(|i, _| x[i]), damped);
    }
    let m = *dynamics::crba(&c.model, &mut ws.data, q);
    // One Cholesky factor of M for J̄ and the posture task's M⁻¹ τ₀.
    let Some((ch, inv)) = dynamics::task_inverse::factor(j, &m).and_then(|ch| {
        let inv = dynamics::task_inverse::consistent_inverse_factored(j, &m, &ch, &p.damping)?;
        Some((ch, inv))
    }) else {
        return (SVector::<f64, N>::zeros(), true);
    };
    let mut qdd = inv.j_bar * b;
    if let Some(q_n) = posture {
        let m_diag: JointVec<N> = std::array::from_fn(|i| m[(i, i)]);
        let d = super::hold::stable_damping(&m_diag, &[p.nullspace.damping; N], p.control.force_law.lambda);
        let tau0 = SVector::<f64, N>::from_fn(|i, _| p.nullspace.stiffness * (q_n[i] - q[i]) - d[i] * dq[i]);
        qdd += dynamics::task_inverse::null_space_project(&inv, j, &ch.solve(&tau0));
    }
    (qdd, inv.damped)
}

/// The safe hold: gravity compensation + joint damping at the last valid state.
fn hold<const N: usize>(
    c: &Controller<N>,
    next: &mut ControllerState<N>,
    m: &RawMeasurements<N>,
    r: &Reference,
    ws: &mut Workspace<N>,
    fault: Fault,
) -> ControlOutputs<N> {
    let p = &c.params;
    // Use q and q̇ only if they are plausible themselves (the fault reported may be another
    // signal's): an implausible q̇ times the damping could be an infinite torque.
    let sp = &p.sense;
    let q_ok = (0..N).all(|i| m.q[i] >= sp.q_min[i] - sp.q_margin && m.q[i] <= sp.q_max[i] + sp.q_margin);
    let q = if q_ok { Some(m.q) } else { next.last_q };
    let mut tau = [0.0; N];
    if let Some(q) = q {
        // Damping at q̇ clamped to its plausible range (a finite reading beyond it may be a
        // real spin, which must be damped, not left to run: seen on the JK5's joint 4 after
        // a hold), none at a non-finite q̇; capped per joint for stability at the period λ.
        let dq: JointVec<N> = std::array::from_fn(|i| if m.dq[i].is_finite() { m.dq[i].clamp(-sp.dq_max[i], sp.dq_max[i]) } else { 0.0 });
        tau = super::hold::torque(&c.model, &mut ws.data, &q, &dq, &p.hold_damping, p.control.force_law.lambda);
    }
    next.fault_count += u32::from(next.fault.is_none());
    next.fault = Some(fault);
    next.control = next.control.hold(&p.control);
    next.last_q = q;
    let status = status_without_force(p, next, r, Phase::Hold, f64::NAN, Some(fault), Vector3::repeat(f64::NAN), false);
    ControlOutputs { tau, dq: [0.0; N], dq_ff: None, status }
}

/// The status of a cycle whose force law did not run (the tare's hold, the safe hold):
/// the law's present impedance, no force estimate of its own (`e_f = f_ext − f_d`).
#[allow(clippy::too_many_arguments)]
fn status_without_force<const N: usize>(
    p: &ControllerParams<N>,
    next: &ControllerState<N>,
    r: &Reference,
    phase: Phase,
    f_ext: f64,
    fault: Option<Fault>,
    tip_position: Vector3<f64>,
    force_limited: bool,
) -> Status {
    let law = &next.control.law;
    Status {
        mode: p.control.force_law.mode,
        phase,
        force_axis: p.control.force_axis.dominant(),
        f_d: r.f_d,
        f_ext,
        e_f: f_ext - r.f_d,
        m_d: law.m_d,
        b_d: law.b_d,
        k_d: 0.0,
        sigma: law.sigma,
        phi: law.phi,
        gamma: 0.0,
        gamma_bound: f64::INFINITY,
        gamma_clipped: false,
        weights_projected: false,
        k_e_hat: 0.0,
        k_e_confidence: 0.0,
        model_gain: control::law::model_gain(&p.control, &next.control.sched),
        gravity_scale: 1.0,
        fault,
        fault_count: next.fault_count,
        tared: next.tare.done(p.tare_samples),
        tip_position,
        f_e: Vector6::zeros(),
        jacobian_damped: false,
        force_limited,
    }
}

impl<const N: usize> ControllerParams<N> {
    /// The paper's §4.1 settings on a model: the impedance and σ of
    /// [`crate::task::PAPER_IMPEDANCE`], force along −z (pushing
    /// down), 1 ms period; sense limits from the model's URDF limits; the
    /// tool of the authors' model (0.424 kg, CoM 0.015 m and tip 0.169 m
    /// along the sensor z); the ATI mini45 SI-145-5 range ×1.5 as the
    /// plausibility limit of the wrench. The learning rate γ has no value in
    /// the paper; `gamma` is the caller's choice.
    pub fn paper_defaults(model: &Model, mode: Mode, gamma: f64) -> Self {
        use super::control::force_law::{ForceLawParams, WeightBounds};
        use super::control::{ContactDetect, ForceAxis, ForceLimit};
        use crate::task::PAPER_IMPEDANCE;
        let lambda = 1e-3;
        ControllerParams {
            sense: SenseParams::for_model(model),
            tool: ToolParams {
                mass: 0.424,
                com: Vector3::new(0.0, 0.0, 0.015),
                tip: Vector3::new(0.0, 0.0, 0.169),
                gravity: Vector3::new(0.0, 0.0, -9.81),
            },
            tare_samples: 100,
            tare_at_rest: false,
            sensor_reads_tool_inertia: false,
            control: ControlParams {
                impedance: PAPER_IMPEDANCE.params,
                force_axis: ForceAxis::base(2, -1.0),
                force_law: ForceLawParams {
                    mode,
                    sigma: PAPER_IMPEDANCE.sigma,
                    gamma,
                    bounds: WeightBounds::default(),
                    lambda,
                    sigma_margin: 0.5,
                    // = force_limit.limit_n below (anti-windup of eq 9, see ForceLawParams).
                    integral_limit_n: 50.0,
                    scheduled: Default::default(),
                    derived: Default::default(),
                },
                contact: ContactDetect { enter_n: 1.0, scheduled_enter_n: control::SCHEDULED_CONTACT_ENTER_N, exit_n: 0.2, exit_cycles: 0 },
                force_limit: ForceLimit { limit_n: 50.0, retract_speed: 0.02, retract_cycles: 500, latch: false },
            },
            hold_damping: [5.0; N],
            damping: Damping::default(),
            nullspace: NullSpace::default(),
        }
    }
}
