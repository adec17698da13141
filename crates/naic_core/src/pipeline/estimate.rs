//! Stage 2 of the pipeline: from the raw F/T reading to the contact wrench
//! the controller needs.
//!
//! The ATI mini45 sits between the flange and the tool (sensor + rod,
//! 0.424 kg in the authors' model). It reports, in the `ft_sensor` frame, the
//! wrench applied to its tool side: the contact wrench the environment exerts
//! on the tip, plus the weight of the tool, plus the sensor's bias. So with
//! `R` the sensor orientation in the base frame, `g` gravity, `m`/`c` the tool
//! mass and centre of mass and `r` the tip, both in the sensor frame:
//!
//! ```text
//! f_raw = Rᵀ (F_c + m g) + b_f
//! τ_raw = r × Rᵀ F_c + τ_c,s + c × Rᵀ m g + b_τ        (moments about the sensor origin)
//! ```
//!
//! This stage removes the bias (a tare: the mean over `tare_samples` consecutive
//! samples with the tool in free space and the arm at rest, minus the tool weight
//! expected there; see [`TARE_REST_VELOCITY`], [`TARE_REST_ACCELERATION`]) and the
//! tool weight at the current orientation, and returns `F_e = −F_c`, the
//! wrench the robot applies to the environment at the tip, in the base frame
//! (eq 3's `F_ext`). Tool inertial forces are left in `F_e`: in steady force tracking they
//! are below 0.05 N, but while the arm accelerates in free space or bounces on a stiff
//! surface a sensor that reads them (MuJoCo's, a real one) reads 1.5–6 N on the JK5. A tare
//! taken while the arm accelerates can take them out of its samples ([`TareInertia`]), and
//! the contact decisions read a contact force without them ([`ToolMotion`]).
//!
//! The tool is a rod along the sensor z axis touching at its tip, on that axis:
//! no contact force at the tip has a moment about the tool axis. So the moment
//! the sensor reads about its z axis is never contact: it is the tool's inertial
//! moment (`I α + ω × I ω` when joint 6 turns the tool) and the sensor's errors.
//! Fed back through `Jᵀ F_e` and eq 6's rotational rows it would drive the joint
//! that turns the tool with the tool's own inertia (on MuJoCo's physical sensor
//! `τ₆ ≈ −2·t_z`, a loop gain near 1 that oscillates); so `F_e` carries no moment
//! about the tool axis (the component along the sensor z axis is removed before
//! the moment is expressed in the base frame).

use nalgebra::{Matrix3, Vector3, Vector6};

use crate::{JointVec, N_JOINTS};

/// The tare takes only samples at rest: every joint's (filtered) speed at most this
/// [rad/s] in every sample of the window. 10× the simulator's encoder velocity noise
/// (0.002 rad/s); at 1 m from the base it is 2 cm/s.
pub const TARE_REST_VELOCITY: f64 = 0.02;

/// ... and every joint's acceleration over the window at most this [rad/s²]: the mean
/// velocity of the window's second half minus that of its first half, over half the
/// window's duration (averaging keeps the encoder noise out: 0.002 rad/s white noise
/// gives about 0.01 rad/s² over 100 samples at 1 kHz). The tool's inertial force
/// `m a` is then at most 0.424 kg × 0.1 rad/s² × 1 m ≈ 0.04 N, below the 0.05 N a
/// zeroing is to reach; a tare over an accelerating arm (the controller's first
/// 100 ms used to be) left a bias of about 1 N.
pub const TARE_REST_ACCELERATION: f64 = 0.1;

/// Why the last tare window was started again (the arm was not at rest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NotAtRest {
    /// Joint `joint` (0-based) moved at `speed` [rad/s] (> [`TARE_REST_VELOCITY`]).
    Moving { joint: usize, speed: f64 },
    /// Joint `joint` accelerated at `accel` [rad/s²] over the window (> [`TARE_REST_ACCELERATION`]).
    Accelerating { joint: usize, accel: f64 },
}

impl std::fmt::Display for NotAtRest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            NotAtRest::Moving { joint, speed } => write!(
                f,
                "joint {} moves at {speed:.3} rad/s (rest: at most {TARE_REST_VELOCITY} rad/s)",
                joint + 1
            ),
            NotAtRest::Accelerating { joint, accel } => write!(
                f,
                "joint {} accelerates at {accel:.3} rad/s² (rest: at most {TARE_REST_ACCELERATION} rad/s²)",
                joint + 1
            ),
        }
    }
}

/// The tool beyond the sensor's measuring plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolParams {
    /// Mass of sensor + rod [kg] (0.424 kg in the authors' MJCF).
    pub mass: f64,
    /// Centre of mass in the sensor frame [m].
    pub com: Vector3<f64>,
    /// Contact point (`tip`) in the sensor frame [m] (0.169 m along z).
    pub tip: Vector3<f64>,
    /// Gravity in the base frame [m/s²].
    pub gravity: Vector3<f64>,
}

/// The tare: the sensor bias, estimated over `samples` consecutive readings at rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TareState<const N: usize = N_JOINTS> {
    /// Readings accumulated so far.
    pub count: u32,
    sum: [f64; 6],
    /// Joint velocities summed over the window's first and second half, and the times of
    /// its first and last sample [s] (the rest check).
    dq_first: JointVec<N>,
    dq_second: JointVec<N>,
    t_first: f64,
    t_last: f64,
    /// Why the window was last started again (`None`: never).
    pub not_at_rest: Option<NotAtRest>,
    /// Windows started again since the tare began.
    pub restarts: u32,
    /// Where the arm is held while taring: the joint position of the tare's first cycle
    /// (kept when a window starts again).
    pub q_hold: Option<JointVec<N>>,
    /// The time [s] and the tool's centre-of-mass velocity [m/s, base frame] of the last
    /// sample, with [`TareInertia`] given (the next sample's acceleration).
    pub v_com_last: Option<(f64, [f64; 3])>,
}

/// The tool's motion at a tare sample, for a sensor that reads the tool's inertial force
/// (a real one; MuJoCo's): the time [s] and the velocity of the tool's centre of mass [m/s,
/// base frame]. The tare takes `m·a` out of each sample, `a` the change of that velocity
/// since the last sample over the time between them (zero at the first): summed over the
/// window the accelerations telescope to `(v_last − v_first)/Δt`, so the bias is free of the
/// tool's mean inertial force however the arm moves, with no second derivative of the
/// encoders. The tool's rotational inertia (`I α`, about 2·10⁻⁴ kg·m² on the JK5) is left out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TareInertia {
    pub t: f64,
    pub v_com: Vector3<f64>,
}

impl<const N: usize> Default for TareState<N> {
    fn default() -> Self {
        TareState {
            count: 0,
            sum: [0.0; 6],
            dq_first: [0.0; N],
            dq_second: [0.0; N],
            t_first: 0.0,
            t_last: 0.0,
            not_at_rest: None,
            restarts: 0,
            q_hold: None,
            v_com_last: None,
        }
    }
}

impl<const N: usize> TareState<N> {
    /// True once `samples` readings have been averaged.
    pub fn done(&self, samples: u32) -> bool {
        self.count >= samples
    }

    /// The bias estimate so far (zero before the first sample).
    pub fn bias(&self) -> [f64; 6] {
        let n = self.count.max(1) as f64;
        self.sum.map(|s| s / n)
    }
}

/// The weight of the tool as the sensor sees it (force, moment about the
/// sensor origin), in the sensor frame, at orientation `r_ws`.
pub fn tool_weight_wrench(tool: &ToolParams, r_ws: &Matrix3<f64>) -> Vector6<f64> {
    tool_wrench(tool, r_ws, &Vector3::zeros())
}

/// The wrench the tool exerts on the sensor with its centre of mass accelerating at `a`
/// [m/s², base frame]: `m (g − a)` at the centre of mass, in the sensor frame (force,
/// moment about the sensor origin); its rotational inertia left out.
pub fn tool_wrench(tool: &ToolParams, r_ws: &Matrix3<f64>, a: &Vector3<f64>) -> Vector6<f64> {
    let w = r_ws.transpose() * (tool.mass * (tool.gravity - a));
    let m = tool.com.cross(&w);
    Vector6::new(w.x, w.y, w.z, m.x, m.y, m.z)
}

/// What a tare sample expects the sensor to read besides its bias: the tool's weight and,
/// with `inertia`, its inertial force ([`TareInertia`]); and the state's motion memory for
/// the next sample.
fn expected_tool_wrench<const N: usize>(
    tool: &ToolParams,
    s: &TareState<N>,
    r_ws: &Matrix3<f64>,
    inertia: Option<&TareInertia>,
) -> (Vector6<f64>, Option<(f64, [f64; 3])>) {
    let Some(i) = inertia else {
        return (tool_weight_wrench(tool, r_ws), None);
    };
    let a = match s.v_com_last {
        Some((t0, v0)) if i.t > t0 => (i.v_com - Vector3::from(v0)) / (i.t - t0),
        _ => Vector3::zeros(),
    };
    (tool_wrench(tool, r_ws, &a), Some((i.t, [i.v_com.x, i.v_com.y, i.v_com.z])))
}

/// Adds one free-space reading to the tare (until `samples` are in). With `rest = Some((t,
/// dq))` (time [s], joint velocity) the tare takes readings at rest only: a sample with a
/// joint faster than [`TARE_REST_VELOCITY`], or a full window whose joints accelerated more
/// than [`TARE_REST_ACCELERATION`], starts the window again (the reason in
/// [`TareState::not_at_rest`]), so the bias is the mean of `samples` consecutive readings at
/// rest. `None`: every reading counts. With `inertia` each sample's expected reading also
/// has the tool's inertial force ([`TareInertia`]); `None`: the sensor is taken to read the
/// tool's weight alone.
pub fn tare_step<const N: usize>(
    tool: &ToolParams,
    samples: u32,
    s: &TareState<N>,
    raw: &[f64; 6],
    r_ws: &Matrix3<f64>,
    rest: Option<(f64, &JointVec<N>)>,
    inertia: Option<&TareInertia>,
) -> TareState<N> {
    if s.done(samples) {
        return *s;
    }
    let Some((t, dq)) = rest else {
        let (expected, v_com_last) = expected_tool_wrench(tool, s, r_ws, inertia);
        let mut next = *s;
        for i in 0..6 {
            next.sum[i] += raw[i] - expected[i];
        }
        next.count += 1;
        next.v_com_last = v_com_last;
        return next;
    };
    let restart =
        |why: NotAtRest| TareState { not_at_rest: Some(why), restarts: s.restarts.saturating_add(1), q_hold: s.q_hold, ..TareState::default() };
    if let Some((joint, speed)) = dq.iter().map(|v| v.abs()).enumerate().find(|(_, v)| !(*v <= TARE_REST_VELOCITY)) {
        return restart(NotAtRest::Moving { joint, speed });
    }
    let (expected, v_com_last) = expected_tool_wrench(tool, s, r_ws, inertia);
    let mut next = *s;
    next.v_com_last = v_com_last;
    for i in 0..6 {
        next.sum[i] += raw[i] - expected[i];
    }
    if next.count == 0 {
        next.t_first = t;
    }
    next.t_last = t;
    let half = samples / 2;
    let dq_sum = if next.count < half { &mut next.dq_first } else { &mut next.dq_second };
    for i in 0..N {
        dq_sum[i] += dq[i];
    }
    next.count += 1;
    if next.done(samples) && half > 0 {
        // The window's acceleration: second half's mean velocity minus the first's, over
        // the time between the two halves' centres (half the window).
        let span = 0.5 * (next.t_last - next.t_first) * samples as f64 / (samples - 1).max(1) as f64;
        let (n1, n2) = (half as f64, (samples - half) as f64);
        for i in 0..N {
            let accel = (next.dq_second[i] / n2 - next.dq_first[i] / n1) / span.max(f64::MIN_POSITIVE);
            if !(accel.abs() <= TARE_REST_ACCELERATION) {
                return restart(NotAtRest::Accelerating { joint: i, accel });
            }
        }
    }
    next
}

/// Most cycles [`ToolMotion`] keeps.
pub const TOOL_MOTION_SAMPLES: usize = 32;

/// The cycles over which [`ToolMotion::contact_force`] takes the tool's inertial force out
/// of the contact force. The velocity difference brings the encoders' velocity noise into
/// the force: `√2 m σ_v / (L Δt)` with `σ_v = ‖J_n‖ σ_q̇` the noise of the tool's velocity
/// along n. On the JK5 (`m` = 0.424 kg, `‖J_n‖` 0.58–0.81 m at the tool's centre of mass
/// over the scenarios' poses, σ_q̇ = 0.002 rad/s, 1 ms) that is 0.70–0.97 N at `L = 1`;
/// 16 cycles bring it to at most 0.061 N, the F/T sensor's own resolution (1/16 N), and
/// 8 × below the 0.5 N contact entry level of `scheduled` and `derived`. The window's mean
/// is 7.5 cycles old. Shorter windows were measured to enter contact in free space on the
/// noise (MuJoCo, acrylic d = 2: `L` = 2 and 4 at 0.1 s; docs/notes/2026-12-07-tool-inertial-force.md).
pub const CONTACT_FORCE_WINDOW: usize = 16;

/// The contact force free of the tool's inertial force, for a sensor that reads it: per
/// cycle the time [s], the velocity of the tool's centre of mass [m/s, base frame, from the
/// unfiltered joint velocities: in step with the F/T reading] and the contact force `F_e`
/// with the tool's weight alone taken out and no bias ([`contact_wrench`] with a zero bias,
/// force part, base frame: the bias is added when read, so the cycles of the tare count).
/// The sensor reads `F_e + m a` (the tool's `m (g − a)` less its weight): over a window of
/// cycles the mean of `F_e` is the mean of those readings less `m` times the mean
/// acceleration, and the accelerations telescope to the window's change of velocity over its
/// time ([`ToolMotion::contact_force`]): no second derivative of the encoders, and no lag
/// between the force and the acceleration taken out of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolMotion {
    t: [f64; TOOL_MOTION_SAMPLES],
    v: [[f64; 3]; TOOL_MOTION_SAMPLES],
    f: [[f64; 3]; TOOL_MOTION_SAMPLES],
    /// Samples held, and the slot of the newest.
    len: usize,
    head: usize,
}

impl Default for ToolMotion {
    fn default() -> Self {
        Self { t: [0.0; TOOL_MOTION_SAMPLES], v: [[0.0; 3]; TOOL_MOTION_SAMPLES], f: [[0.0; 3]; TOOL_MOTION_SAMPLES], len: 0, head: 0 }
    }
}

impl ToolMotion {
    /// Adds the cycle of time `t`: the tool's centre-of-mass velocity `v` and the contact
    /// force `f_e` with its weight alone taken out (a sample not later than the newest, or
    /// not finite, is ignored).
    pub fn push(&mut self, t: f64, v: &Vector3<f64>, f_e: &Vector3<f64>) {
        let finite = t.is_finite() && v.iter().chain(f_e.iter()).all(|x| x.is_finite());
        if !finite || (self.len > 0 && !(t > self.t[self.head])) {
            return;
        }
        self.head = (self.head + 1) % TOOL_MOTION_SAMPLES;
        self.t[self.head] = t;
        self.v[self.head] = [v.x, v.y, v.z];
        self.f[self.head] = [f_e.x, f_e.y, f_e.z];
        self.len = (self.len + 1).min(TOOL_MOTION_SAMPLES);
    }

    /// The contact force [N, base frame] over the last `window` cycles, free of the tool's
    /// inertial force: the mean of their `F_e`, plus `offset` (the bias's share of `F_e`, `R
    /// b_f` at the current orientation `R`), less `m` times the mean acceleration, the
    /// newest velocity less the one `window` cycles before over the time between them.
    /// Over the cycles held where fewer than `window + 1` are (more noise, no bias); `None`
    /// with fewer than two.
    pub fn contact_force(&self, mass: f64, window: usize, offset: &Vector3<f64>) -> Option<Vector3<f64>> {
        let w = window.clamp(1, TOOL_MOTION_SAMPLES - 1).min(self.len.saturating_sub(1));
        if w == 0 {
            return None;
        }
        let slot = |back: usize| (self.head + TOOL_MOTION_SAMPLES - back) % TOOL_MOTION_SAMPLES;
        let dt = self.t[self.head] - self.t[slot(w)];
        if !(dt > 0.0) {
            return None;
        }
        let mean = (0..w).map(|k| Vector3::from(self.f[slot(k)])).sum::<Vector3<f64>>() / w as f64;
        let a = (Vector3::from(self.v[self.head]) - Vector3::from(self.v[slot(w)])) / dt;
        Some(mean + offset - mass * a)
    }
}

/// `F_e`: the wrench the robot applies to the environment at the tip, in the
/// base frame (force [N], moment about the tip [N·m] without its component about
/// the tool axis — see the module docs).
pub fn contact_wrench(tool: &ToolParams, bias: &[f64; 6], raw: &[f64; 6], r_ws: &Matrix3<f64>) -> Vector6<f64> {
    let weight = tool_weight_wrench(tool, r_ws);
    let f_c_s = Vector3::new(raw[0] - bias[0] - weight[0], raw[1] - bias[1] - weight[1], raw[2] - bias[2] - weight[2]);
    let m_c_s = Vector3::new(raw[3] - bias[3] - weight[3], raw[4] - bias[4] - weight[4], 0.0);
    // Moment of the contact wrench about the tip instead of the sensor origin
    // (the tip is on the sensor z axis: r × f has no z component).
    let m_tip_s = m_c_s - tool.tip.cross(&f_c_s);
    let f = -(r_ws * f_c_s);
    let m = -(r_ws * m_tip_s);
    Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn tool() -> ToolParams {
        ToolParams {
            mass: 0.424,
            com: Vector3::new(0.0, 0.0, 0.015),
            tip: Vector3::new(0.0, 0.0, 0.169),
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }

    /// What an ideal sensor reads for a contact force `f_c` (base frame) at the tip.
    fn reading(t: &ToolParams, r: &Matrix3<f64>, f_c: Vector3<f64>, bias: [f64; 6]) -> [f64; 6] {
        let f_s = r.transpose() * f_c;
        let w = tool_weight_wrench(t, r);
        let m = t.tip.cross(&f_s);
        [
            f_s.x + w[0] + bias[0],
            f_s.y + w[1] + bias[1],
            f_s.z + w[2] + bias[2],
            m.x + w[3] + bias[3],
            m.y + w[4] + bias[4],
            m.z + w[5] + bias[5],
        ]
    }

    /// A tool accelerating in free space reads `m a` as force on a sensor that reads its
    /// inertia: the window's contact force is free of it (the reading alone is not), and a
    /// contact force is still read whole.
    #[test]
    fn the_windowed_contact_force_is_free_of_the_tools_inertial_force() {
        let t = tool();
        let r = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let dt = 1e-3;
        let n = Vector3::new(0.0, 0.0, -1.0);
        for f_c in [0.0, 3.0] {
            let mut tm = ToolMotion::default();
            let mut worst_raw: f64 = 0.0;
            let mut worst: f64 = 0.0;
            for k in 0..200 {
                // the tool swings along n at 8 m/s² peak (a 6 Hz sine), the reading of cycle k
                // with the acceleration of the step into it
                let w = 2.0 * std::f64::consts::PI * 6.0;
                let (tk, tp) = (k as f64 * dt, (k as f64 - 1.0) * dt);
                let v = |t: f64| n * (8.0 / w) * (w * t).sin();
                let a = (v(tk) - v(tp)) / dt;
                let w_s = tool_wrench(&t, &r, &a);
                let f_s = r.transpose() * (-n * f_c); // the surface pushes back along −n
                let raw = [f_s.x + w_s[0], f_s.y + w_s[1], f_s.z + w_s[2], w_s[3], w_s[4], w_s[5]];
                let f0 = contact_wrench(&t, &[0.0; 6], &raw, &r);
                tm.push(tk, &v(tk), &Vector3::new(f0[0], f0[1], f0[2]));
                worst_raw = worst_raw.max((n.dot(&Vector3::new(f0[0], f0[1], f0[2])) - f_c).abs());
                if let Some(f) = tm.contact_force(t.mass, CONTACT_FORCE_WINDOW, &Vector3::zeros()) {
                    worst = worst.max((n.dot(&f) - f_c).abs());
                } else {
                    assert!(k == 0, "two cycles give a force");
                }
            }
            assert!(worst_raw > 2.0, "the reading carries the inertial force: {worst_raw} N");
            assert!(worst < 1e-9, "the window's contact force is free of it: {worst} N off {f_c} N");
        }
    }

    #[test]
    fn tare_then_compensation_recovers_the_contact_force_at_any_orientation() {
        let t = tool();
        let bias = [0.7, -0.3, 1.9, 0.02, -0.01, 0.005];
        // Tare with the tool pointing down (sensor frame = base rotated 180° about y, paper Fig 7).
        let r0 = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let mut s: TareState = TareState::default();
        for _ in 0..50 {
            s = tare_step(&t, 50, &s, &reading(&t, &r0, Vector3::zeros(), bias), &r0, None, None);
        }
        assert!(s.done(50));
        for (k, b) in s.bias().iter().zip(bias) {
            assert!((k - b).abs() < 1e-12);
        }
        // Now tilt the tool and push: pushing down 10 N on a table means F_c = +10 z.
        let axis = Unit::new_normalize(Vector3::new(0.3, -0.2, 1.0));
        let r = *(Rotation3::from_axis_angle(&axis, 0.4) * Rotation3::from_axis_angle(&Vector3::y_axis(), 3.0)).matrix();
        let f_c = Vector3::new(1.0, -2.0, 10.0);
        let fe = contact_wrench(&t, &s.bias(), &reading(&t, &r, f_c, bias), &r);
        for i in 0..3 {
            assert!((fe[i] + f_c[i]).abs() < 1e-12, "F_e = −F_c");
            assert!(fe[3 + i].abs() < 1e-12, "a pure force at the tip has no moment about the tip");
        }
    }

    /// A tare taken while the arm accelerates the tool (the simulator's start: the approach
    /// begins with the first cycle) keeps the tool's mean inertial force as bias on a sensor
    /// that reads it, unless the samples' expected reading has it: the tool speeds up to
    /// 0.3 m/s down and sideways over the 100 samples (a mean 3 m/s², 1.3 N on 0.424 kg).
    #[test]
    fn a_tare_while_the_tool_accelerates_keeps_no_inertial_bias_with_the_tools_motion() {
        let t = tool();
        let bias = [0.7, -0.3, 1.9, 0.02, -0.01, 0.005];
        let r0 = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let (n, dt) = (100usize, 1e-3);
        let span = (n - 1) as f64 * dt;
        let dir = Vector3::new(0.3, 0.1, -1.0).normalize();
        // v(t) = 0.3 m/s · (1 − cos(π t / span)) / 2 along dir, the reading at its exact a(t)
        let v = |tt: f64| dir * 0.3 * (1.0 - (std::f64::consts::PI * tt / span).cos()) / 2.0;
        let a = |tt: f64| dir * 0.3 * std::f64::consts::PI / span * (std::f64::consts::PI * tt / span).sin() / 2.0;
        let run = |with: bool| {
            let mut s: TareState = TareState::default();
            for k in 0..n {
                let tt = k as f64 * dt;
                let w = tool_wrench(&t, &r0, &a(tt));
                let raw: [f64; 6] = std::array::from_fn(|i| w[i] + bias[i]);
                let inertia = TareInertia { t: tt, v_com: v(tt) };
                s = tare_step(&t, n as u32, &s, &raw, &r0, None, with.then_some(&inertia));
            }
            assert!(s.done(n as u32));
            let b = s.bias();
            (0..3).map(|i| (b[i] - bias[i]).powi(2)).sum::<f64>().sqrt()
        };
        let (with, without) = (run(true), run(false));
        assert!(without > 1.0, "the test's motion leaves a bias to remove: {without} N");
        assert!(with < 0.02, "force bias error with the tool's motion: {with} N (without: {without} N)");
    }

    #[test]
    fn a_torque_about_the_tool_axis_never_reaches_the_contact_wrench() {
        // The tool's inertial moment about its axis (joint 6 accelerating): measured by
        // the sensor, never a contact moment, so F_e carries none of it.
        let t = tool();
        let r = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let mut raw = reading(&t, &r, Vector3::new(0.0, 0.0, 10.0), [0.0; 6]);
        let clean = contact_wrench(&t, &[0.0; 6], &raw, &r);
        raw[5] += 0.5;
        let fe = contact_wrench(&t, &[0.0; 6], &raw, &r);
        assert!((fe[2] + 10.0).abs() < 1e-12, "{fe:?}");
        assert_eq!(fe, clean, "a torque about the tool axis must not change F_e");
        // the tool axis is base −z here: F_e's moment about it is zero
        assert!(fe[5].abs() < 1e-15, "{fe:?}");
        // a moment about a sensor axis across the tool still passes (not a contact moment
        // of a point tip either, but the controller's rotational impedance uses it)
        raw[3] += 0.3;
        let across = contact_wrench(&t, &[0.0; 6], &raw, &r);
        assert!(((across - clean).fixed_rows::<3>(3).norm() - 0.3).abs() < 1e-12, "{across:?}");
    }

    #[test]
    fn paper_sensor_frame_sign_of_the_desired_force() {
        // §5.2.1: pressing down with 10 N reads −10 N along the sensor z (sensor frame = base rotated 180° about y).
        let t = ToolParams { mass: 0.0, ..tool() };
        let r = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let raw = reading(&t, &r, Vector3::new(0.0, 0.0, 10.0), [0.0; 6]);
        assert!((raw[2] + 10.0).abs() < 1e-12);
    }

    /// The tare takes the mean of consecutive samples at rest only: a joint moving, or the
    /// arm accelerating over the window, starts the window again, with the reason.
    #[test]
    fn the_tare_waits_for_rest() {
        let t = tool();
        let r0 = Matrix3::identity();
        let raw = reading(&t, &r0, Vector3::zeros(), [0.5, -0.3, 1.0, 0.01, 0.0, -0.02]);
        let at = |s: &TareState, k: usize, dq: JointVec| tare_step(&t, 100, s, &raw, &r0, Some((k as f64 * 1e-3, &dq)), None);
        // 60 samples at rest, then joint 3 moves: the window starts again.
        let mut s: TareState = TareState::default();
        for k in 0..60 {
            s = at(&s, k, [0.0; N_JOINTS]);
        }
        assert_eq!(s.count, 60);
        s = at(&s, 60, [0.0, 0.0, 0.05, 0.0, 0.0, 0.0]);
        assert_eq!((s.count, s.restarts), (0, 1));
        assert_eq!(s.not_at_rest, Some(NotAtRest::Moving { joint: 2, speed: 0.05 }));
        assert!(s.not_at_rest.unwrap().to_string().contains("joint 3 moves at 0.050 rad/s"));
        // Slowly accelerating, always below the speed bound: 0.3 rad/s² on joint 1 over
        // 100 ms (0 → 0.03 rad/s would exceed the speed bound, so 0 → -0.015 → 0.015).
        let mut s: TareState = TareState::default();
        for k in 0..100 {
            let v = -0.015 + 0.3 * k as f64 * 1e-3;
            s = at(&s, k, [v, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        match s.not_at_rest {
            Some(NotAtRest::Accelerating { joint: 0, accel }) => assert!((accel - 0.3).abs() < 1e-6, "{accel}"),
            other => panic!("not refused for the acceleration: {other:?}"),
        }
        assert!(!s.done(100));
        // At rest with encoder-like noise (±0.004 rad/s): done, the bias exact.
        let mut s: TareState = TareState::default();
        for k in 0..100 {
            let v = if k % 2 == 0 { 0.004 } else { -0.004 };
            s = at(&s, k, [v; N_JOINTS]);
        }
        assert!(s.done(100) && s.not_at_rest.is_none());
        let b = s.bias();
        for (i, want) in [0.5, -0.3, 1.0, 0.01, 0.0, -0.02].iter().enumerate() {
            assert!((b[i] - want).abs() < 1e-12, "{i}: {} vs {want}", b[i]);
        }
    }
}
