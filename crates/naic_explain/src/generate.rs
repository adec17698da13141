//! Seeded synthetic "measured" data with hidden effects (for the tests and the benchmark).
//!
//! Truth model: rigid body of the given URDF (`urdf/jk5.urdf` for the tests; any serial
//! arm, the joint count N comes from the model) by inverse dynamics along a known smooth
//! trajectory, symmetric Coulomb + viscous friction per joint in the simulator's smooth
//! form (`tanh(q̇/v_s)`, v_s = 1 mrad/s; levels drawn from the seed), plus the injected
//! effects, plus measurement errors: white torque noise (σ drawn from the seed),
//! encoder quantisation of q (2²⁰ counts per turn), white noise on the drive velocity.
//!
//! Excitation: each joint in turn moves back and forth at stepped speeds with rests in
//! between (cosine velocity ramps), then all joints move together (sum of sines); one
//! period lasts [`excitation_period_s`] (101.6 s for six joints, 115.2 s for seven).
//! Contact data ([`generate_contact`]) is scripted for the JK5's six joints only
//! ([`N_JOINTS`]). Every draw comes from the workspace's one generator, [`naic_core::rng`].

use crate::catalogue::Effect;
use crate::input::{Rows, TimeSeries};
use nalgebra::{DVector, SVector, Vector3};
use naic_core::dynamics::{frame_jacobian, frame_jdot_qdot, rnea};
use naic_core::model::{Data, Data6, Model};
use naic_core::rng::Rng;
use naic_core::{JointVec, N_JOINTS};

/// A uniform index in `0..n` drawn from `rng`.
pub fn pick(rng: &mut Rng, n: usize) -> usize {
    (rng.uniform() * n as f64) as usize % n
}

/// −1 or +1 with equal probability, drawn from `rng`.
pub fn sign(rng: &mut Rng) -> f64 {
    if rng.uniform() < 0.5 {
        -1.0
    } else {
        1.0
    }
}

/// One injected effect and its true parameters.
#[derive(Clone, Debug)]
pub struct Injected {
    pub effect: Effect,
    /// 1-based joints it acts on.
    pub joints: Vec<usize>,
    /// Per joint: (name, true value), names as in the report's `params`.
    pub params: Vec<(usize, String, f64)>,
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct GenSpec {
    pub seed: u64,
    /// Effects to hide (0, 1 or more).
    pub effects: Vec<Effect>,
    /// Sample period [s].
    pub dt: f64,
    /// Repeat the whole excitation this many times (longer data).
    pub repeats: usize,
    /// Cruise time per speed step [s].
    pub cruise_s: f64,
    /// Duration of the multi-joint phase [s].
    pub multi_s: f64,
    /// Contact data (wrench columns; see [`generate_contact`]) even with no contact effect hidden.
    pub contact: bool,
    /// Tool frame a hidden payload sits on [default: the frame `tip`, else the model's last frame].
    pub tip: Option<String>,
}

impl GenSpec {
    pub fn new(seed: u64, effects: &[Effect]) -> Self {
        Self { seed, effects: effects.to_vec(), dt: 1e-3, repeats: 1, cruise_s: 1.0, multi_s: 20.0, contact: false, tip: None }
    }
    /// The number of repeats of the excitation that makes at least `seconds` of data for
    /// an arm of `nj` joints (at least one).
    pub fn repeats_for(&self, nj: usize, seconds: f64) -> usize {
        (seconds / excitation_period_s(nj, self)).ceil().max(1.0) as usize
    }
}

/// The generated data and its truth.
#[derive(Clone, Debug)]
pub struct Generated {
    pub ts: TimeSeries,
    pub injected: Vec<Injected>,
    /// True base friction per joint: (f_c, f_v).
    pub base: Vec<(f64, f64)>,
    pub noise_tau: f64,
}

/// Home posture of the JK5: arm bent, wrist away from singularities.
pub const HOME: JointVec = [0.2, 0.6, -1.1, 0.5, 0.9, 0.1];
const SPEEDS: [f64; 4] = [0.01, 0.04, 0.12, 0.35];
const RAMP: f64 = 0.15;
const REST: f64 = 0.4;

/// The rest posture the excitation moves about: [`HOME`] for a six-joint arm whose limits
/// contain it (the JK5's, the tests' data), else the middle of each joint's position limits
/// (0 for a joint without finite limits; the Panda: 0, 0, 0, −1.571, 0, 1.868, 0).
pub fn home(model: &Model) -> Vec<f64> {
    let (lo, hi) = (model.lower_limits(), model.upper_limits());
    if model.nv() == N_JOINTS && HOME.iter().zip(lo.iter().zip(&hi)).all(|(h, (l, u))| l <= h && h <= u) {
        return HOME.to_vec();
    }
    lo.iter().zip(&hi).map(|(l, u)| if l.is_finite() && u.is_finite() { 0.5 * (l + u) } else { 0.0 }).collect()
}

/// Length of one excitation period [s] for an arm of `nj` joints: `nj` single-joint phases
/// of 4 speeds × 2 directions × (2 ramps + cruise + rest), then the multi-joint phase.
pub fn excitation_period_s(nj: usize, spec: &GenSpec) -> f64 {
    nj as f64 * SPEEDS.len() as f64 * 2.0 * (2.0 * RAMP + spec.cruise_s + REST) + spec.multi_s
}

/// Joint trajectory (q, q̇, q̈) at time t of one excitation period.
struct Excitation {
    home: Vec<f64>,
    single_len: f64,
    per_joint: f64,
    multi: f64,
    cruise: f64,
    /// Multi-joint sines: per joint (amplitude, frequency Hz, phase) × 3.
    sines: Vec<[(f64, f64, f64); 3]>,
}

impl Excitation {
    fn new(home: Vec<f64>, cruise: f64, multi: f64, rng: &mut Rng) -> Self {
        let nj = home.len();
        let seg = 2.0 * RAMP + cruise + REST;
        let per_joint = SPEEDS.len() as f64 * 2.0 * seg;
        let mut sines = vec![[(0.0, 0.0, 0.0); 3]; nj];
        for s in sines.iter_mut() {
            for (k, x) in s.iter_mut().enumerate() {
                let f = [0.11, 0.23, 0.41][k] * rng.range(0.85, 1.15);
                // velocity amplitude ≈ 0.12 rad/s per component
                let a = 0.12 / (2.0 * std::f64::consts::PI * f);
                *x = (a, f, rng.range(0.0, 6.283));
            }
        }
        Self { home, single_len: nj as f64 * per_joint, per_joint, multi, cruise, sines }
    }
    fn period(&self) -> f64 {
        self.single_len + self.multi
    }
    /// Velocity profile of one segment (cosine ramps), returns (displacement, v, a) at τ.
    fn segment(&self, tau: f64, v: f64) -> (f64, f64, f64) {
        let c = self.cruise;
        let w = std::f64::consts::PI / RAMP;
        if tau < RAMP {
            let x = v * (tau / 2.0 - (w * tau).sin() / (2.0 * w));
            (x, v * (1.0 - (w * tau).cos()) / 2.0, v * w * (w * tau).sin() / 2.0)
        } else if tau < RAMP + c {
            (v * (RAMP / 2.0 + (tau - RAMP)), v, 0.0)
        } else if tau < 2.0 * RAMP + c {
            let u = tau - RAMP - c;
            let x = v * (RAMP / 2.0 + c) + v * (u / 2.0 + (w * u).sin() / (2.0 * w));
            (x, v * (1.0 + (w * u).cos()) / 2.0, -v * w * (w * u).sin() / 2.0)
        } else {
            (v * (RAMP + c), 0.0, 0.0)
        }
    }
    /// (q, q̇, q̈) at `t` into the three slices (one value per joint).
    fn at(&self, t: f64, q: &mut [f64], dq: &mut [f64], ddq: &mut [f64]) {
        let nj = self.home.len();
        q.copy_from_slice(&self.home);
        dq.fill(0.0);
        ddq.fill(0.0);
        let t = t % self.period();
        if t < self.single_len {
            let j = ((t / self.per_joint) as usize).min(nj - 1);
            let tj = t - j as f64 * self.per_joint;
            let seg = 2.0 * RAMP + self.cruise + REST;
            let k = (tj / seg) as usize;
            let speed = SPEEDS[(k / 2).min(SPEEDS.len() - 1)];
            let tau = tj - k as f64 * seg;
            let (x, v, a) = if k % 2 == 0 { self.segment(tau, speed) } else { self.segment(tau, -speed) };
            // odd segments start where the even one ended (back to home)
            let x0 = if k % 2 == 0 { 0.0 } else { speed * (RAMP + self.cruise) };
            q[j] += x0 + x;
            dq[j] = v;
            ddq[j] = a;
        } else {
            let tm = t - self.single_len;
            // fade in/out over 1 s so motion starts and ends at rest
            let env = fade(tm, self.multi);
            for j in 0..nj {
                let (x, v, a) = faded_sines(&self.sines[j], tm, env);
                q[j] += x;
                dq[j] = v;
                ddq[j] = a;
            }
        }
    }
}

/// One joint's sum of sines `Σ a·(sin(2πf·t + φ) − sin φ)` (0 at t = 0) under a fade
/// envelope `(e, ė, ë)` from [`fade`]: displacement, velocity and acceleration.
fn faded_sines(sines: &[(f64, f64, f64)], t: f64, (e, de, dde): (f64, f64, f64)) -> (f64, f64, f64) {
    let (mut s, mut ds, mut dds) = (0.0, 0.0, 0.0);
    for &(a, f, ph) in sines {
        let w = 2.0 * std::f64::consts::PI * f;
        s += a * ((w * t + ph).sin() - ph.sin());
        ds += a * w * (w * t + ph).cos();
        dds -= a * w * w * (w * t + ph).sin();
    }
    (e * s, de * s + e * ds, dde * s + 2.0 * de * ds + e * dds)
}

fn fade(t: f64, len: f64) -> (f64, f64, f64) {
    let r = 1.0f64.min(len / 4.0);
    let w = std::f64::consts::PI / r;
    if t < r {
        ((1.0 - (w * t).cos()) / 2.0, w * (w * t).sin() / 2.0, w * w * (w * t).cos() / 2.0)
    } else if t > len - r {
        let u = len - t;
        ((1.0 - (w * u).cos()) / 2.0, -w * (w * u).sin() / 2.0, w * w * (w * u).cos() / 2.0)
    } else {
        (1.0, 0.0, 0.0)
    }
}

/// Generates the data (see module docs) for `model`'s joints (`urdf/jk5.urdf` in the
/// tests; any serial arm). With `spec.contact` or any contact effect hidden, contact data
/// ([`generate_contact`], six-joint JK5 only).
pub fn generate(model: &Model, spec: &GenSpec) -> Generated {
    if spec.contact || spec.effects.iter().any(|e| e.is_contact()) {
        return generate_contact(model, spec);
    }
    let nj = model.nv();
    let mut rng = Rng::seed(spec.seed);
    let exc = Excitation::new(home(model), spec.cruise_s, spec.multi_s, &mut rng);
    let n = ((exc.period() * spec.repeats as f64) / spec.dt).round() as usize;
    let noise_tau = rng.range(0.02, 0.08);
    let mut base = vec![(0.0, 0.0); nj];
    for (j, b) in base.iter_mut().enumerate() {
        let big = j < 3;
        *b = (if big { rng.range(2.0, 6.0) } else { rng.range(1.0, 3.0) }, rng.range(1.0, 5.0));
    }
    let tip = spec
        .tip
        .as_deref()
        .and_then(|t| model.frame_id(t))
        .or_else(|| model.frame_id("tip"))
        .or_else(|| model.frames().last().map(|_| naic_core::model::FrameId(model.frames().len() - 1)));
    // draw the hidden effects
    let mut injected = Vec::new();
    let mut asym = vec![0.0; nj]; // f_c_neg − f_c_pos
    let mut strib = vec![(0.0, 0.02); nj];
    let mut ripple = vec![(0.0, 1.0, 0.0); nj];
    let mut offset = vec![0.0; nj];
    let mut drift = vec![0.0; nj];
    let mut rotor = vec![0.0; nj];
    let mut visc2 = vec![0.0; nj];
    let mut payload = 0.0;
    let mut delay = 0.0;
    let mut used_joints: Vec<usize> = Vec::new();
    let mut pick_joint = |rng: &mut Rng, allowed: &[usize]| -> usize {
        loop {
            let j = allowed[pick(rng, allowed.len())];
            if !used_joints.contains(&j) || used_joints.len() >= allowed.len() {
                used_joints.push(j);
                return j;
            }
        }
    };
    let all: Vec<usize> = (0..nj).collect();
    for &e in &spec.effects {
        let mut inj = Injected { effect: e, joints: vec![], params: vec![] };
        match e {
            Effect::FrictionAsymmetry => {
                let j = pick_joint(&mut rng, &all);
                let d = sign(&mut rng) * rng.range(0.3, 0.5) * base[j].0;
                asym[j] = d;
                inj.joints.push(j + 1);
                // report convention: f_c_difference = f_c_pos − f_c_neg
                inj.params.push((j + 1, "f_c_difference".into(), -d));
            }
            Effect::Stribeck => {
                let j = pick_joint(&mut rng, &all);
                let fs = rng.range(0.6, 1.0) * base[j].0;
                let qs = rng.range(0.015, 0.05);
                strib[j] = (fs, qs);
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "f_s".into(), fs));
                inj.params.push((j + 1, "q_s".into(), qs));
            }
            Effect::PositionRipple => {
                let j = pick_joint(&mut rng, &all);
                let a = rng.range(0.25, 0.45) * base[j].0;
                let k = rng.range(6.0, 40.0);
                ripple[j] = (a, k, rng.range(0.0, 6.283));
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "amplitude_nm".into(), a));
                inj.params.push((j + 1, "k_per_rad".into(), k));
            }
            Effect::Payload => {
                payload = rng.range(0.8, 2.0);
                // the joints whose torque a tool mass changes clearly (2..N−1; 2–5 on the JK5)
                for j in 2..nj {
                    inj.joints.push(j);
                }
                for j in 1..=nj {
                    inj.params.push((j, "mass_kg".into(), payload));
                }
            }
            Effect::TorqueOffset => {
                let j = pick_joint(&mut rng, &all);
                offset[j] = sign(&mut rng) * rng.range(0.3, 0.8);
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "offset_nm".into(), offset[j]));
            }
            Effect::Delay => {
                delay = rng.range(0.006, 0.02);
                inj.joints = (1..=nj).collect();
                for j in 1..=nj {
                    inj.params.push((j, "delay_s".into(), delay));
                }
            }
            Effect::Drift => {
                let j = pick_joint(&mut rng, &all);
                drift[j] = sign(&mut rng) * rng.range(0.3, 0.5) * base[j].0;
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "delta_f_c_nm".into(), drift[j]));
            }
            Effect::RotorInertia => {
                let j = pick_joint(&mut rng, &all);
                rotor[j] = rng.range(0.3, 0.8);
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "inertia_kgm2".into(), rotor[j]));
            }
            Effect::ViscousNonlinearity => {
                let j = pick_joint(&mut rng, &all);
                let c = rng.range(8.0, 15.0);
                inj.joints.push(j + 1);
                inj.params.push((j + 1, "f_v2".into(), c));
                visc2[j] = c;
            }
            // link inertials and drive gains: hidden by the independent generator (tests/python/explain_gen) only
            Effect::InertialParameters | Effect::TorqueScale | Effect::PositionTorque => {}
            // contact effects are generated by `generate_contact` (dispatched above)
            Effect::ContactNonlinearity | Effect::ContactDamping | Effect::FtBias | Effect::ToolGravity => {}
        }
        injected.push(inj);
    }
    let total_t = n as f64 * spec.dt;
    let mut data = Data::new(model);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut tau_true = Rows::with_capacity(nj, n);
    let mut ts = TimeSeries { t: Vec::with_capacity(n), q: Rows::with_capacity(nj, n), dq: Rows::with_capacity(nj, n), ..Default::default() };
    let quant = 2.0 * std::f64::consts::PI / (1u64 << 20) as f64;
    let v_s = 1e-3;
    let (mut qv, mut vv, mut av) = (DVector::zeros(nj), DVector::zeros(nj), DVector::zeros(nj));
    let mut tau = vec![0.0; nj];
    let mut enc = (vec![0.0; nj], vec![0.0; nj]);
    for i in 0..n {
        let t = i as f64 * spec.dt;
        exc.at(t, qv.as_mut_slice(), vv.as_mut_slice(), av.as_mut_slice());
        tau.copy_from_slice(rnea(model, &mut data, &qv, &vv, &av).as_slice());
        if payload != 0.0 {
            if let Some(tip) = tip {
                let jdqd = frame_jdot_qdot(model, &mut data, &qv, &vv, tip);
                let jac = frame_jacobian(model, &mut data, &qv, tip);
                let jl = jac.fixed_rows::<3>(0);
                let acc = jl * &av + Vector3::new(jdqd[0], jdqd[1], jdqd[2]);
                let f = payload * (acc - g);
                for j in 0..nj {
                    tau[j] += jl.column(j).dot(&f);
                }
            }
        }
        for j in 0..nj {
            let v = vv[j];
            let s = (v / v_s).tanh();
            let (fc, fv) = base[j];
            let mut f_c = fc + drift[j] * (t / total_t - 0.5);
            if v < 0.0 {
                f_c += asym[j];
            }
            let (fs, qs) = strib[j];
            let x = v / qs;
            let (ra, rk, rph) = ripple[j];
            let fric = s * (f_c + fs * (-x * x).exp() + ra * (rk * qv[j] + rph).sin()) + fv * v + visc2[j] * s * v * v;
            tau[j] += fric + offset[j] + rotor[j] * av[j];
        }
        tau_true.push(&tau);
        push_encoder_sample(&mut ts, t, qv.as_slice(), vv.as_slice(), quant, &mut rng, &mut enc);
    }
    // torque channel: delayed by `delay` (linear interpolation), plus noise
    ts.tau = Rows::with_capacity(nj, n);
    for i in 0..n {
        let ts_ = i as f64 - delay / spec.dt;
        let k = ts_.floor().max(0.0) as usize;
        let fr = (ts_ - ts_.floor()).clamp(0.0, 1.0);
        let a = &tau_true[k.min(n - 1)];
        let b = &tau_true[(k + 1).min(n - 1)];
        for j in 0..nj {
            let val = if ts_ < 0.0 { a[j] } else { a[j] * (1.0 - fr) + b[j] * fr };
            tau[j] = val + noise_tau * rng.gaussian();
        }
        ts.tau.push(&tau);
    }
    Generated { ts, injected, base, noise_tau }
}

/// Tool mass [kg] and centre of mass along the sensor z axis [m] of `urdf/jk5.urdf`'s
/// `ft_sensor` link (the generator's nominal tool; the analysis reads them from the URDF).
pub const JK5_TOOL_MASS: f64 = 0.424;
pub const JK5_TOOL_COM_Z: f64 = 0.015;

/// Unit move (0 → 1) over `dur` seconds with cosine velocity ramps of `ramp` seconds and
/// a constant-speed cruise between: (x, ẋ, ẍ) at `tau`. Short ramps keep the time spent
/// creeping below the rest threshold (1 mrad/s) inside the filter window that the
/// analysis leaves out around starts and stops.
fn trapezoid(tau: f64, dur: f64, ramp: f64) -> (f64, f64, f64) {
    let r = ramp.min(dur / 3.0);
    let v = 1.0 / (dur - r);
    let w = std::f64::consts::PI / r;
    let tau = tau.clamp(0.0, dur);
    if tau < r {
        (v * (tau / 2.0 - (w * tau).sin() / (2.0 * w)), v * (1.0 - (w * tau).cos()) / 2.0, v * w * (w * tau).sin() / 2.0)
    } else if tau < dur - r {
        (v * (r / 2.0 + (tau - r)), v, 0.0)
    } else {
        let u = tau - (dur - r);
        let x = v * (r / 2.0 + (dur - 2.0 * r)) + v * (u / 2.0 + (w * u).sin() / (2.0 * w));
        (x, v * (1.0 + (w * u).cos()) / 2.0, -v * w * (w * u).sin() / 2.0)
    }
}

/// A joint-space segment: from `a` to `b` over `dur` seconds (cosine blend), or a hold.
#[derive(Clone, Copy)]
struct Seg {
    a: JointVec,
    b: JointVec,
    dur: f64,
}

/// Seeded contact data ("measured" on the simulator, issue 6 item 4).
///
/// Scripted motion (1 kHz), tool pointing down as in the `flat` scenario
/// (`naic_core::task::Q0_FLAT_DEG`): 20 s of free-space wrist motion 0.15 m above the
/// surface (joints 1, 4, 5, 6 sum of sines: the sensor turns, so tool weight and sensor
/// bias can be told apart), then at three sites a pressing motion: from 10 mm above the
/// surface to a depth of 3–6 mm (drawn) and back, with down/up times 3, 1 and 0.4 s and
/// 0.5 s holds (joint targets by the simulator's inverse kinematics, straight lines in
/// joint space at constant speed with 0.15 s cosine ramps). Truth: a horizontal surface at a drawn height with a drawn stiffness
/// (`naic_sim::environment`, linear spring, 2000–6000 N/m) on the `tip` origin, the
/// ATI mini45 model (`naic_sim::sensor::Mini45`: the tool of the URDF's `ft_sensor` link,
/// white noise of 1–2 resolution steps, quantisation) plus the hidden effects:
/// * `contact_nonlinearity`: F_n = k_n·δⁿ, n ∈ [1.4, 1.8], k_n = k·(4 mm)^{1−n};
/// * `contact_damping`: F_n = k·δ + c·δ̇ (never pulling), c ∈ [60, 150] N·s/m;
/// * `ft_bias`: a bias on every axis, ±[0.3, 1] N and ±[0.01, 0.03] N·m;
/// * `tool_gravity`: the true tool mass differs by ±[0.1, 0.3] kg (same centre of mass).
///
/// The joint torques are the rigid body (with the true tool) plus symmetric friction minus
/// `J_tipᵀ F_contact`, with white noise, as in [`generate`].
pub fn generate_contact(model: &Model, spec: &GenSpec) -> Generated {
    use crate::contact::AXIS_BASE;
    use naic_sim::environment::{Environment, Material, MaterialMap};
    use naic_core::task::{deg, inverse_kinematics, tip_pose, Q0_FLAT_DEG};
    use naic_sim::sensor::Mini45;
    let mut rng = Rng::seed(spec.seed ^ 0xC0C7_AC7D_A7A0_0001);
    let noise_tau = rng.range(0.02, 0.08);
    let mut base = [(0.0, 0.0); N_JOINTS];
    for (j, b) in base.iter_mut().enumerate() {
        *b = (if j < 3 { rng.range(2.0, 6.0) } else { rng.range(1.0, 3.0) }, rng.range(1.0, 5.0));
    }
    let h = rng.range(0.06, 0.10);
    let k_e = rng.range(2000.0, 6000.0);
    let depth = rng.range(0.003, 0.006);
    let noise_mult = rng.range(1.0, 2.0);
    // the tool of `urdf/jk5.urdf` (ft_sensor link inertial, from the authors' MJCF)
    let (tool_mass, tool_com) = (JK5_TOOL_MASS, Vector3::new(0.0, 0.0, JK5_TOOL_COM_Z));
    let mut injected = Vec::new();
    let mut n_exp = 1.0;
    let mut k_n = k_e;
    let mut c_damp = 0.0;
    let mut bias = [0.0; 6];
    let mut d_mass = 0.0;
    let fz = AXIS_BASE + 3;
    for &e in &spec.effects {
        let mut inj = Injected { effect: e, joints: vec![], params: vec![] };
        match e {
            Effect::ContactNonlinearity => {
                n_exp = rng.range(1.4, 1.8);
                k_n = k_e * 0.004f64.powf(1.0 - n_exp);
                inj.joints.push(fz);
                inj.params.push((fz, "n".into(), n_exp));
                inj.params.push((fz, "k_n".into(), k_n));
            }
            Effect::ContactDamping => {
                c_damp = rng.range(60.0, 150.0);
                inj.joints.push(fz);
                inj.params.push((fz, "c_ns_per_m".into(), c_damp));
            }
            Effect::FtBias => {
                for (a, b) in bias.iter_mut().enumerate() {
                    *b = sign(&mut rng) * if a < 3 { rng.range(0.3, 1.0) } else { rng.range(0.01, 0.03) };
                    inj.joints.push(AXIS_BASE + a + 1);
                    inj.params.push((AXIS_BASE + a + 1, "bias".into(), *b));
                }
            }
            Effect::ToolGravity => {
                d_mass = sign(&mut rng) * rng.range(0.1, 0.3);
                for a in 0..3 {
                    inj.joints.push(AXIS_BASE + a + 1);
                    inj.params.push((AXIS_BASE + a + 1, "delta_mass_kg".into(), d_mass));
                }
            }
            // joint effects are not combined with contact data here
            _ => {}
        }
        injected.push(inj);
    }
    let mut srng = Rng::seed(rng.next_u64());
    let mut sensor = Mini45::si_145_5(tool_mass + d_mass, tool_com, &mut srng);
    sensor.bias = bias;
    for s in sensor.noise_sigma.iter_mut() {
        *s *= noise_mult;
    }
    let env = Environment::horizontal(h, MaterialMap::Uniform(Material { k_e, b_e: c_damp, mu: 0.0 }));
    // waypoints
    let q0 = deg(Q0_FLAT_DEG);
    let (p0, r0) = tip_pose(model, &q0);
    let ik = |p: Vector3<f64>, start: &JointVec| inverse_kinematics(model, start, &p, &r0).0;
    let y = p0.y;
    let q_high = ik(Vector3::new(-0.40, y, h + 0.15), &q0);
    let mut segs: Vec<Seg> = Vec::new();
    let mut last = q_high;
    let sites = [-0.36, -0.45, -0.54];
    for &x in &sites {
        let x = x + rng.range(-0.02, 0.02);
        let yy = y + rng.range(-0.03, 0.03);
        let top = ik(Vector3::new(x, yy, h + 0.010), &last);
        let bot = ik(Vector3::new(x, yy, h - depth), &top);
        segs.push(Seg { a: last, b: top, dur: 1.5 });
        for &t_press in &[3.0, 1.0, 0.4] {
            segs.push(Seg { a: top, b: bot, dur: t_press });
            segs.push(Seg { a: bot, b: bot, dur: 0.5 });
            segs.push(Seg { a: bot, b: top, dur: t_press });
            segs.push(Seg { a: top, b: top, dur: 0.3 });
        }
        last = top;
    }
    // free-space wrist motion: per joint (amplitude, frequency, phase) × 2
    let sweep_s = 20.0;
    let mut sines = [[(0.0, 0.0, 0.0); 2]; N_JOINTS];
    for j in [0usize, 3, 4, 5] {
        for (k, x) in sines[j].iter_mut().enumerate() {
            let f = [0.07, 0.19][k] * rng.range(0.85, 1.15);
            let amp = if j == 0 { 0.15 } else { 0.35 };
            *x = (amp, f, rng.range(0.0, std::f64::consts::TAU));
        }
    }
    let press_s: f64 = segs.iter().map(|s| s.dur).sum();
    let n = (((sweep_s + press_s) * spec.repeats.max(1) as f64) / spec.dt).round() as usize;
    let at = |t: f64| -> (JointVec, JointVec, JointVec) {
        let t = t % (sweep_s + press_s);
        let mut q = q_high;
        let mut dq = [0.0; N_JOINTS];
        let mut ddq = [0.0; N_JOINTS];
        if t < sweep_s {
            let env = fade(t, sweep_s);
            for j in 0..N_JOINTS {
                let (x, v, a) = faded_sines(&sines[j], t, env);
                q[j] += x;
                dq[j] = v;
                ddq[j] = a;
            }
            return (q, dq, ddq);
        }
        let mut tt = t - sweep_s;
        for sg in &segs {
            if tt < sg.dur {
                let (b, db, ddb) = trapezoid(tt, sg.dur, RAMP);
                for j in 0..N_JOINTS {
                    let d = sg.b[j] - sg.a[j];
                    q[j] = sg.a[j] + b * d;
                    dq[j] = db * d;
                    ddq[j] = ddb * d;
                }
                return (q, dq, ddq);
            }
            tt -= sg.dur;
        }
        (segs.last().map_or(q_high, |s| s.b), dq, ddq)
    };
    let tip = model.frame_id("tip").expect("contact data needs the `tip` frame");
    let sframe = model.frame_id("ft_sensor").expect("contact data needs the `ft_sensor` frame");
    let mut data = Data6::try_new(model).expect("the contact generator needs the JK5's six joints");
    let quant = 2.0 * std::f64::consts::PI / (1u64 << 20) as f64;
    let mut ts = TimeSeries::default();
    let mut enc = (vec![0.0; N_JOINTS], vec![0.0; N_JOINTS]);
    let mut wrench = Vec::with_capacity(n);
    let g = Vector3::new(0.0, 0.0, -9.81);
    for i in 0..n {
        let t = i as f64 * spec.dt;
        let (q, dq, ddq) = at(t);
        let qv = SVector::<f64, N_JOINTS>::from(q);
        let vv = SVector::<f64, N_JOINTS>::from(dq);
        let av = SVector::<f64, N_JOINTS>::from(ddq);
        let mut tau: JointVec = (*rnea(model, &mut data, &qv, &vv, &av)).into();
        naic_core::dynamics::forward_kinematics(model, &mut data, &qv);
        let ps = data.frame_placement(sframe);
        let pt = data.frame_placement(tip);
        let jt = *frame_jacobian(model, &mut data, &qv, tip);
        let v_tip = jt.fixed_rows::<3>(0) * vv;
        let r_ws = ps.rotation.to_rotation_matrix();
        let r_tip = pt.translation.vector - ps.translation.vector;
        let c = env.contact(t, &pt.translation.vector, &v_tip);
        let f_contact = if c.in_contact && n_exp != 1.0 {
            let f_n = (k_n * c.penetration.powf(n_exp) + c_damp * (-v_tip.z)).max(0.0);
            Vector3::new(0.0, 0.0, f_n)
        } else {
            c.force
        };
        wrench.push(sensor.measure(&r_ws, &r_tip, &f_contact, &mut srng));
        // joint torques: the contact force and the tool mass error (static weight at the tool's centre of mass)
        let ext = jt.fixed_rows::<3>(0).transpose() * f_contact;
        let js_ = *frame_jacobian(model, &mut data, &qv, sframe);
        let r_c = r_ws * tool_com;
        let j_com = js_.fixed_rows::<3>(0) - naic_core::dynamics::spatial::skew(&r_c) * js_.fixed_rows::<3>(3);
        let extra = j_com.transpose() * (-d_mass * g);
        for j in 0..N_JOINTS {
            let v = dq[j];
            let (fc, fv) = base[j];
            tau[j] += fc * (v / 1e-3).tanh() + fv * v - ext[j] + extra[j] + noise_tau * rng.gaussian();
        }
        push_encoder_sample(&mut ts, t, &q, &dq, quant, &mut rng, &mut enc);
        ts.tau.push(tau);
    }
    ts.wrench = Some(wrench);
    Generated { ts, injected, base: base.to_vec(), noise_tau }
}

/// One row of the motion channels as an encoder reports them: positions quantised to
/// `quant`, velocities with 1 mrad/s white noise (`buf`: two rows of scratch space).
fn push_encoder_sample(ts: &mut TimeSeries, t: f64, q: &[f64], dq: &[f64], quant: f64, rng: &mut Rng, buf: &mut (Vec<f64>, Vec<f64>)) {
    let (qm, dqm) = buf;
    for j in 0..q.len() {
        qm[j] = (q[j] / quant).round() * quant;
        dqm[j] = dq[j] + 1e-3 * rng.gaussian();
    }
    ts.t.push(t);
    ts.q.push(&qm[..]);
    ts.dq.push(&dqm[..]);
}
