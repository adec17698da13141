//! The simulated JK5 + ATI mini45: rigid-body dynamics of `urdf/jk5.urdf`
//! with joint friction, torque saturation, a compliant contact at `tip`,
//! encoders and the F/T sensor, as a pure step function
//! `step(&PlantParams, &PlantState, &tau_cmd, &mut PlantWorkspace) -> (PlantState<N>, Observation<N>)`.
//!
//! Equation 1 of the paper, `M q̈ + C q̇ + G + τ_f = τ + τ_ext`, with
//! `τ_ext = J_tip,linᵀ F_contact` (eq 2; `F_contact` acts at the tip origin, so
//! there is no contact torque) and `τ` the commanded torque saturated at the
//! URDF effort limits. Torque is held constant over the control period (zero-
//! order hold); the period is split into `substeps` integration steps, each
//! re-evaluating the contact.
//!
//! Integrators ([`Integrator`]):
//! * `SemiImplicitEuler`: `v⁺ = v + h·ABA(q, v, τ_tot)`, `q⁺ = q + h v⁺` — what
//!   MuJoCo's default `Euler` integrator does for a model without joint damping
//!   (used for the MuJoCo cross-check). Friction is explicit: unusable with the
//!   stiff smooth friction of the JK5 at 1 ms.
//! * `ImplicitFriction` (default for scenarios): the same, but the joint
//!   friction is evaluated at the *new* velocity (backward Euler in the
//!   friction only): solve `M (v⁺ − v) = h (τ + τ_ext − C q̇ − G − τ_f(v⁺))`
//!   by Newton's method (Jacobian `M + h diag(max(0, ∂τ_f/∂q̇))`: negative
//!   Stribeck slopes can cancel a light link's inertia and make the exact
//!   Jacobian singular), a per-joint trust region of 2 v_s inside the tanh
//!   zone (|q̇| < 3 v_s) and backtracking on the residual; it stops at a
//!   residual of 1e-10 N·m·s (1e-7 N·m) or when no descent is possible (then
//!   the best point found is used; in the bench scenario that happens in ~4 %
//!   of the steps, with a median residual of 1.5e-5 N·m·s = 0.015 N·m, all in
//!   joint 5's negative-slope Stribeck band). The tanh friction of
//!   Table 1 with v_s = 1 mrad/s has slopes up to ~2·10⁴ N·m·s/rad at rest,
//!   time constants of tens of µs: explicit friction would need µs steps.
//! * `Rk4`: classical Runge–Kutta on `(q, v)` with ABA, contact re-evaluated
//!   at every stage (for accuracy checks with small steps).
//!
//! Joint position limits are not enforced (the scenarios stay far from the
//! ±3.14 rad MJCF limits); [`Truth::limit_violation`] reports if they are left.

use crate::environment::{Contact, Environment};
use crate::rng::Rng;
use crate::sensor::{Encoders, Mini45, SensorMotion};
use naic_core::dynamics;
use naic_core::friction::FrictionModel;
use naic_core::model::{DataN, FrameId, Model};
use naic_core::{JointVec, N_JOINTS};
use nalgebra::{Isometry3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion, Vector3};

mod implicit;

/// Integration scheme of the plant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    SemiImplicitEuler,
    ImplicitFriction,
    Rk4,
}

impl Integrator {
    pub fn parse(s: &str) -> Result<Self, PlantError> {
        match s {
            "euler" | "semi-implicit-euler" => Ok(Self::SemiImplicitEuler),
            "implicit-friction" => Ok(Self::ImplicitFriction),
            "rk4" => Ok(Self::Rk4),
            o => Err(PlantError::Integrator { name: o.to_string() }),
        }
    }
}

/// Errors building a plant (bad URDF, missing frames, bad settings).
#[derive(Debug, thiserror::Error)]
pub enum PlantError {
    #[error("robot model: {0}")]
    Model(String),
    #[error("{0}")]
    Config(String),
    /// The integrator `name` is not one of [`Integrator::parse`]'s.
    #[error("unknown integrator '{name}': use euler, implicit-friction or rk4")]
    Integrator { name: String },
    /// The plant `name` is not one of [`crate::plants::PLANTS`].
    #[error("unknown plant '{name}': use own or mujoco")]
    UnknownPlant { name: String },
    /// An MJCF file was given for the own plant.
    #[error("--mjcf {mjcf}: the MJCF is MuJoCo's model; add --plant mujoco or drop --mjcf")]
    MjcfWithoutMujoco { mjcf: String },
    /// `--plant mujoco` in a build without the `mujoco` feature.
    #[error("this naic was built without MuJoCo: build with `--features mujoco` (docs/simulation.md says how to link the libmujoco of the pinned `mujoco` wheel)")]
    MujocoNotBuilt,
    /// MuJoCo could not load or use the MJCF file `path` (`problem`: what and the fix).
    #[error("MJCF {path}: {problem}")]
    Mjcf { path: String, problem: String },
    /// The joint friction model has `friction` joints, the plant's arm `arm`.
    #[error("the friction model has {friction} joints; the arm has {arm} (give the arm's friction file, or --no-friction)")]
    FrictionJoints { friction: usize, arm: usize },
}

/// Immutable parameters of the simulated robot and its world.
#[derive(Clone, Debug)]
pub struct PlantParams<const N: usize = N_JOINTS> {
    pub model: Model,
    pub tip: FrameId,
    pub sensor_frame: FrameId,
    /// Joint friction acting on the plant (`None`: frictionless).
    pub friction: Option<FrictionModel>,
    pub integrator: Integrator,
    /// Control period (torque zero-order hold) [s].
    pub dt: f64,
    /// Integration steps per control period.
    pub substeps: u32,
    /// |τ_i| ≤ effort_limit[i] (URDF `<limit effort>`).
    pub effort_limit: JointVec<N>,
    pub env: Environment,
    pub ft: Mini45,
    pub encoders: Encoders,
}

/// The plant state: small and `Copy`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantState<const N: usize = N_JOINTS> {
    /// Control periods since the start (time is `k · dt`, no accumulated rounding).
    pub k: u64,
    pub t: f64,
    pub q: JointVec<N>,
    pub dq: JointVec<N>,
    pub rng: Rng,
}

impl<const N: usize> PlantState<N> {
    /// At rest at `q` at t = 0 with the RNG seeded from `seed`.
    pub fn at_rest(q: JointVec<N>, seed: u64) -> Self {
        Self { k: 0, t: 0.0, q, dq: [0.0; N], rng: Rng::seed(seed) }
    }
}

/// Preallocated workspace (scratch memory; results never depend on its contents).
#[derive(Clone, Debug)]
pub struct PlantWorkspace<const N: usize = N_JOINTS> {
    data: DataN<N>,
    /// The friction torques and slopes at the last implicit step's solution,
    /// reused when the next step starts from that bit-identical velocity.
    friction: implicit::FrictionAt<N>,
    /// What the last observation computed at its state, reused by the next step's
    /// first sub-step when that starts from the bit-identical `(t, q, q̇)`.
    observed: Option<AtState<N>>,
}

/// Contact, `M(q)` and `b(q, q̇)` at one `(t, q, q̇)`, the key compared bit for bit.
#[derive(Clone, Copy, Debug)]
struct AtState<const N: usize> {
    t: f64,
    q: SVector<f64, N>,
    v: SVector<f64, N>,
    jl: SMatrix<f64, 3, N>,
    contact: Contact,
    /// `M(q)` (CRBA).
    m: SMatrix<f64, N, N>,
    /// `b(q, q̇)`: Coriolis, centrifugal and gravity torques (RNEA at q̈ = 0).
    b: SVector<f64, N>,
}

impl<const N: usize> AtState<N> {
    fn is_at(&self, t: f64, q: &SVector<f64, N>, v: &SVector<f64, N>) -> bool {
        let same = |a: &SVector<f64, N>, b: &SVector<f64, N>| a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits());
        self.t.to_bits() == t.to_bits() && same(&self.q, q) && same(&self.v, v)
    }
}

impl<const N: usize> PlantWorkspace<N> {
    pub fn new(p: &PlantParams<N>) -> Self {
        Self {
            data: DataN::<N>::try_new(&p.model).expect("PlantParams::new checked the model has N joints"),
            friction: implicit::FrictionAt::default(),
            observed: None,
        }
    }
}

/// What the controller may see (measured signals only): the controller's own
/// [`RawMeasurements`] (encoder positions quantised [rad], drive velocities noisy [rad/s],
/// the raw F/T reading at `ft_sensor`, sensor frame), stamped with the simulated time.
pub use naic_core::pipeline::sense::RawMeasurements;

/// Ground truth for logging and metrics (never fed to the controller).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth<const N: usize = N_JOINTS> {
    pub tip: Isometry3<f64>,
    pub tip_velocity: Vector3<f64>,
    pub contact: Contact,
    /// Torque applied to the joints after saturation (last period) [N·m].
    pub tau_applied: JointVec<N>,
    /// Joint friction torque at the end of the period [N·m].
    pub tau_friction: JointVec<N>,
    /// Some commanded torque was clipped at the effort limit.
    pub saturated: bool,
    /// Some joint is outside its position limits.
    pub limit_violation: bool,
    /// Sensor-frame wrench without bias/noise/quantisation.
    pub wrench_true: [f64; 6],
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation<const N: usize = N_JOINTS> {
    pub meas: RawMeasurements<N>,
    pub truth: Truth<N>,
}

impl<const N: usize> PlantParams<N> {
    /// Checks frames, joint count and settings. Never panics on input.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        model: Model,
        friction: Option<FrictionModel>,
        integrator: Integrator,
        dt: f64,
        substeps: u32,
        env: Environment,
        ft: Mini45,
        encoders: Encoders,
    ) -> Result<Self, PlantError> {
        if model.nv() != N {
            return Err(PlantError::Model(format!("this simulator was set up for a {N}-joint arm; the URDF has {} moving joints", model.nv())));
        }
        let frame = |name: &str| {
            model.frame_id(name).ok_or_else(|| {
                PlantError::Model(format!("the URDF has no frame '{name}' (needed by the simulator: add a link or fixed joint named '{name}')"))
            })
        };
        let tip = frame("tip")?;
        let sensor_frame = frame("ft_sensor")?;
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(PlantError::Config(format!("control period dt = {dt} s must be a positive number")));
        }
        if substeps == 0 {
            return Err(PlantError::Config("substeps must be at least 1".into()));
        }
        if let Some(f) = &friction {
            if f.n_joints() != N {
                return Err(PlantError::Config(format!("the friction model has {} joints; the arm has {N}", f.n_joints())));
            }
        }
        let mut effort_limit = [0.0; N];
        for (i, j) in model.joints().iter().enumerate() {
            let e = j.limits.effort;
            if !(e > 0.0) {
                return Err(PlantError::Model(format!("joint '{}' has effort limit {e}; set <limit effort> > 0 in the URDF", j.name)));
            }
            effort_limit[i] = e;
        }
        Ok(Self { model, tip, sensor_frame, friction, integrator, dt, substeps, effort_limit, env, ft, encoders })
    }

    /// Integration step [s].
    pub fn h(&self) -> f64 {
        self.dt / self.substeps as f64
    }

    /// Sub-steps per control period so that the stiffest contact is resolved:
    /// `ω h ≤ 0.1` with `ω = √(k_e,max / m_tip)`, `m_tip` the smallest apparent
    /// mass of the arm at the tip along the surface normal at `q`.
    pub fn substeps_for_contact(&self, q: &JointVec<N>, dt: f64) -> u32 {
        let mut data = DataN::<N>::try_new(&self.model).expect("checked");
        let qv = SVector::<f64, N>::from(*q);
        let m = dynamics::crba(&self.model, &mut data, &qv).clone_owned();
        let j = *dynamics::frame_jacobian(&self.model, &mut data, &qv, self.tip);
        let n = self.env.normal.into_inner();
        let jn = n.transpose() * j.fixed_rows::<3>(0);
        let minv = m.try_inverse().unwrap_or_else(SMatrix::<f64, N, N>::identity);
        let inv_mass = (jn * minv * jn.transpose())[(0, 0)];
        let m_tip = if inv_mass > 0.0 { 1.0 / inv_mass } else { 1.0 };
        let omega = (self.env.material.max_stiffness() / m_tip).sqrt();
        ((omega * dt / 0.1).ceil() as u32).max(1)
    }
}

/// Joint friction torques at velocity `v` (zero if the plant is frictionless).
fn friction_torques<const N: usize>(p: &PlantParams<N>, v: &SVector<f64, N>) -> SVector<f64, N> {
    match &p.friction {
        None => SVector::<f64, N>::zeros(),
        Some(f) => SVector::<f64, N>::from_fn(|i, _| f.tau_f(i, v[i])),
    }
}

/// Tip pose, tip velocity, linear Jacobian and contact at `(t, q, v)`.
fn tip_contact<const N: usize>(
    p: &PlantParams<N>,
    ws: &mut PlantWorkspace<N>,
    t: f64,
    q: &SVector<f64, N>,
    v: &SVector<f64, N>,
) -> (Vector3<f64>, Vector3<f64>, SMatrix<f64, 3, N>, Contact) {
    let j = dynamics::frame_jacobian(&p.model, &mut ws.data, q, p.tip);
    let jl: SMatrix<f64, 3, N> = j.fixed_rows::<3>(0).into_owned();
    let pos = ws.data.frame_se3(p.tip).trans;
    let vel = jl * v;
    let c = p.env.contact(t, &pos, &vel);
    (pos, vel, jl, c)
}

/// Joint accelerations for the explicit schemes: ABA with `τ + τ_ext − τ_f(v)`.
fn accel<const N: usize>(p: &PlantParams<N>, ws: &mut PlantWorkspace<N>, t: f64, q: &SVector<f64, N>, v: &SVector<f64, N>, tau: &SVector<f64, N>) -> SVector<f64, N> {
    let (_, _, jl, c) = tip_contact(p, ws, t, q, v);
    let tau_tot = tau + jl.transpose() * c.force - friction_torques(p, v);
    *dynamics::aba(&p.model, &mut ws.data, q, v, &tau_tot)
}

/// One integration step of length `h` from `(t, q, v)` with torque `tau`:
/// `(q⁺, q̇⁺)` and, if the scheme computed it, `τ_f(q̇⁺)`.
fn integrate<const N: usize>(
    p: &PlantParams<N>,
    ws: &mut PlantWorkspace<N>,
    t: f64,
    q: &SVector<f64, N>,
    v: &SVector<f64, N>,
    tau: &SVector<f64, N>,
    h: f64,
) -> (SVector<f64, N>, SVector<f64, N>, Option<SVector<f64, N>>) {
    match p.integrator {
        Integrator::SemiImplicitEuler => {
            let a = accel(p, ws, t, q, v, tau);
            let v1 = v + a * h;
            (q + v1 * h, v1, None)
        }
        Integrator::Rk4 => {
            let k1v = accel(p, ws, t, q, v, tau);
            let k1q = *v;
            let (q2, v2) = (q + k1q * (h / 2.0), v + k1v * (h / 2.0));
            let k2v = accel(p, ws, t + h / 2.0, &q2, &v2, tau);
            let (q3, v3) = (q + v2 * (h / 2.0), v + k2v * (h / 2.0));
            let k3v = accel(p, ws, t + h / 2.0, &q3, &v3, tau);
            let (q4, v4) = (q + v3 * h, v + k3v * h);
            let k4v = accel(p, ws, t + h, &q4, &v4, tau);
            let v1 = v + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
            let q1 = q + (k1q + v2 * 2.0 + v3 * 2.0 + v4) * (h / 6.0);
            (q1, v1, None)
        }
        Integrator::ImplicitFriction => {
            let (jl, c, b, m) = match ws.observed.take() {
                Some(a) if a.is_at(t, q, v) => (a.jl, a.contact, a.b, a.m),
                _ => {
                    let (_, _, jl, c) = tip_contact(p, ws, t, q, v);
                    let b = *dynamics::bias_torques(&p.model, &mut ws.data, q, v);
                    (jl, c, b, *dynamics::crba(&p.model, &mut ws.data, q))
                }
            };
            let rhs0 = tau + jl.transpose() * c.force - b;
            let sol = implicit::solve(p.friction.as_ref(), &m, v, &rhs0, h, &mut ws.friction);
            (q + sol.v1 * h, sol.v1, Some(sol.tau_f))
        }
    }
}

/// Saturate the commanded torque at the effort limits.
fn saturate<const N: usize>(p: &PlantParams<N>, tau_cmd: &JointVec<N>) -> (JointVec<N>, bool) {
    let mut out = [0.0; N];
    let mut sat = false;
    for i in 0..N {
        let l = p.effort_limit[i];
        let v = if tau_cmd[i].is_finite() { tau_cmd[i] } else { 0.0 };
        out[i] = v.clamp(-l, l);
        sat |= out[i] != v || !tau_cmd[i].is_finite();
    }
    (out, sat)
}

/// Measure the current state (encoders, F/T sensor) and collect the truth.
/// Pure: returns the state with its RNG advanced.
pub fn observe<const N: usize>(p: &PlantParams<N>, s: &PlantState<N>, ws: &mut PlantWorkspace<N>, tau_applied: JointVec<N>, saturated: bool) -> (PlantState<N>, Observation<N>) {
    observe_with_friction(p, s, ws, tau_applied, saturated, None)
}

/// [`observe`], with `τ_f(q̇)` at the state if the integrator already has it.
fn observe_with_friction<const N: usize>(
    p: &PlantParams<N>,
    s: &PlantState<N>,
    ws: &mut PlantWorkspace<N>,
    tau_applied: JointVec<N>,
    saturated: bool,
    tau_f: Option<SVector<f64, N>>,
) -> (PlantState<N>, Observation<N>) {
    let q = SVector::<f64, N>::from(s.q);
    let v = SVector::<f64, N>::from(s.dq);
    let (pos, vel, jl, contact) = tip_contact(p, ws, s.t, &q, &v);
    let tip_se3 = *ws.data.frame_se3(p.tip);
    let tf = tau_f.unwrap_or_else(|| friction_torques(p, &v));
    // The sensor frame's motion at this state under the applied torque (the plant's own
    // forward dynamics, as in `accel`): what the tool's inertial wrench answers.
    let tau_tot = SVector::<f64, N>::from(tau_applied) + jl.transpose() * contact.force - tf;
    let ddq = match p.integrator {
        // The implicit step starting from this state needs M(q) and b(q, q̇) anyway: compute
        // them here, solve M q̈ = τ − b with M's Cholesky factor, and leave them for that step.
        Integrator::ImplicitFriction => {
            let b = *dynamics::bias_torques(&p.model, &mut ws.data, &q, &v);
            let m = *dynamics::crba(&p.model, &mut ws.data, &q);
            let ddq = match m.cholesky() {
                Some(c) => c.solve(&(tau_tot - b)),
                None => *dynamics::aba(&p.model, &mut ws.data, &q, &v, &tau_tot),
            };
            ws.observed = Some(AtState { t: s.t, q, v, jl, contact, m, b });
            ddq
        }
        Integrator::SemiImplicitEuler | Integrator::Rk4 => *dynamics::aba(&p.model, &mut ws.data, &q, &v, &tau_tot),
    };
    let jdqd = dynamics::frame_jdot_qdot(&p.model, &mut ws.data, &q, &v, p.sensor_frame);
    let js = dynamics::frame_jacobian(&p.model, &mut ws.data, &q, p.sensor_frame);
    let (a6, v6) = (js * ddq + jdqd, js * v);
    let motion = SensorMotion {
        accel: a6.fixed_rows::<3>(0).into_owned(),
        omega: v6.fixed_rows::<3>(3).into_owned(),
        alpha: a6.fixed_rows::<3>(3).into_owned(),
    };
    // frame_jacobian placed the sensor frame at q (the numbers forward_kinematics gives it).
    let sen = *ws.data.frame_se3(p.sensor_frame);
    let r_ws = Rotation3::from_matrix_unchecked(sen.rot);
    let r_tip = pos - sen.trans;
    let mut rng = s.rng;
    let wrench = p.ft.measure_moving(&r_ws, &r_tip, &contact.force, &motion, &mut rng);
    let wrench_true = p.ft.true_wrench_moving(&r_ws, &r_tip, &contact.force, &motion);
    let (qm, dqm) = p.encoders.measure(&s.q, &s.dq, &mut rng);
    let mut limit_violation = false;
    for (i, j) in p.model.joints().iter().enumerate() {
        limit_violation |= s.q[i] < j.limits.lower || s.q[i] > j.limits.upper;
    }
    let tip = Isometry3::from_parts(
        Translation3::from(tip_se3.trans),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(tip_se3.rot)),
    );
    let obs = Observation {
        meas: RawMeasurements { t: s.t, q: qm, dq: dqm, joints_stamp: s.t, wrench, wrench_stamp: s.t },
        truth: Truth {
            tip,
            tip_velocity: vel,
            contact,
            tau_applied,
            tau_friction: tf.into(),
            saturated,
            limit_violation,
            wrench_true,
        },
    };
    (PlantState { rng, ..*s }, obs)
}

/// One control period: saturate `tau_cmd`, integrate `substeps` steps, observe.
/// Pure: `(params, state, input) -> (state, outputs)`; allocation-free.
pub fn step<const N: usize>(p: &PlantParams<N>, s: &PlantState<N>, tau_cmd: &JointVec<N>, ws: &mut PlantWorkspace<N>) -> (PlantState<N>, Observation<N>) {
    let (tau, saturated) = saturate(p, tau_cmd);
    let tau_v = SVector::<f64, N>::from(tau);
    let h = p.h();
    let mut q = SVector::<f64, N>::from(s.q);
    let mut v = SVector::<f64, N>::from(s.dq);
    let mut tau_f = None;
    for k in 0..p.substeps {
        let t = s.t + k as f64 * h;
        (q, v, tau_f) = integrate(p, ws, t, &q, &v, &tau_v, h);
    }
    let next = PlantState { k: s.k + 1, t: (s.k + 1) as f64 * p.dt, q: q.into(), dq: v.into(), rng: s.rng };
    observe_with_friction(p, &next, ws, tau, saturated, tau_f)
}

/// Open-loop replay: from `(q0, dq0)` apply `torques[k]` over period `k` and
/// return the true state after every period (the first entry is the start).
/// For cross-checks against other simulators (contact and friction as in `p`).
pub fn replay<const N: usize>(p: &PlantParams<N>, q0: JointVec<N>, dq0: JointVec<N>, torques: &[JointVec<N>]) -> Vec<PlantState<N>> {
    let mut ws = PlantWorkspace::new(p);
    let mut s = PlantState { dq: dq0, ..PlantState::at_rest(q0, 0) };
    let mut out = Vec::with_capacity(torques.len() + 1);
    out.push(s);
    for tau in torques {
        s = step(p, &s, tau, &mut ws).0;
        out.push(s);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrator_names_parse_and_an_unknown_one_names_the_choices() {
        assert_eq!(Integrator::parse("euler").ok(), Some(Integrator::SemiImplicitEuler));
        assert_eq!(Integrator::parse("implicit-friction").ok(), Some(Integrator::ImplicitFriction));
        assert_eq!(Integrator::parse("rk4").ok(), Some(Integrator::Rk4));
        let e = Integrator::parse("verlet").unwrap_err();
        assert!(matches!(&e, PlantError::Integrator { name } if name == "verlet"), "{e:?}");
        let m = e.to_string();
        assert!(m.contains("'verlet'") && m.contains("use euler, implicit-friction or rk4"), "{m}");
    }
}
