//! The paper's tasks: what each of its experiments asks of the *controller* —
//! start joints, the reference trajectory `p_d(t)` with its orientation,
//! velocity and acceleration targets, the desired force schedule `f_d(t)`,
//! the impedance settings, the control period and the duration. Nothing here
//! involves the environment or the plant: `naic_sim::scenario` puts each task
//! on a simulated surface (materials, slope, phase events, plant), the
//! `naic_controller` node follows a task's [`Task::reference`].
//!
//! Facts and where they come from:
//! * §4.1 from the authors' JK5 code (issue 3): initial joints
//!   (0, −30°, 120°, 0, −90°, 0) — tip at (−0.284, −0.1135, 0.247) m, tool
//!   pointing down; desired tip x from −0.3 to −0.75 m at y = −0.1135 m,
//!   z_d = 0.05 m (3 cm below the surface at 0.08 m); M_d = I;
//!   B_d = diag(500, 500, 40, 500, 500, 500); K_d free diag(500, 500, 50, 1000, 1000, 1000),
//!   contact diag(100, 100, 0, 1000, 1000, 1000); σ = 0.01; f_d = 10 N, 20 N
//!   after 3000 steps of 1 ms (t = 3 s, §4.1 text).
//! * Reference: the x target moves at constant speed over the whole run
//!   (0.45 m / 5 s = 0.09 m/s for flat, stiffness-step and slope), with the
//!   matching `v_d` and `a_d = 0`; the orientation target is the initial tip
//!   orientation (tool down).
//! * eq 22 (stiffness-step) and §4.2 (slope): the §4.1 trajectory with f_d = 10 N; 5 s.
//! * §5.2.1 foam: surface 0.3813 m, start 0.538 m (tip straight above the
//!   contact point, tool down; joints by inverse kinematics), desired −10 N in
//!   the sensor frame = 10 N pushing down. The paper's desired position is the
//!   surface itself; an overdamped free-space impedance only reaches such a
//!   target asymptotically, so — as in §4.1 — z_d is 3 cm below the surface.
//! * §5.2.2 two materials: surface 0.3648 m, desired −3 N (3 N pushing);
//!   after 5 s the x target moves 0.06 m towards −x at 0.02 m/s. Start
//!   height 0.538 m as in §5.2.1 (the paper gives none for §5.2.2).

use crate::dynamics;
use crate::model::{DataN, Model};
use crate::pipeline::control::ImpedanceParams;
use crate::{JointVec, N_JOINTS};
pub use crate::pipeline::controller::Reference;
use nalgebra::{SVector, UnitQuaternion, Vector3, Vector6};

/// The preset names of [`preset`] (`naic sim --scenario`).
pub const PRESETS: [&str; 6] = ["flat", "stiffness-step", "slope", "foam", "two-material", "acrylic"];

/// The impedance a task sets: the controller's [`ImpedanceParams`] and σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceSettings {
    /// M_d, B_d, K_d free and in contact, per Cartesian axis.
    pub params: ImpedanceParams,
    /// σ of eq 9 (initial NAIC weight w₃).
    pub sigma: f64,
}

/// §4.1 (the authors' code): M_d = I, B_d, K_d free / contact, σ = 0.01.
pub const PAPER_IMPEDANCE: ImpedanceSettings = ImpedanceSettings {
    params: ImpedanceParams {
        m_d: [1.0; 6],
        b_d: [500.0, 500.0, 40.0, 500.0, 500.0, 500.0],
        k_free: [500.0, 500.0, 50.0, 1000.0, 1000.0, 1000.0],
        k_contact: [100.0, 100.0, 0.0, 1000.0, 1000.0, 1000.0],
    },
    sigma: 0.01,
};

/// §4.1 initial joints (authors' code): (0, −30°, 120°, 0, −90°, 0).
pub const Q0_FLAT_DEG: JointVec = [0.0, -30.0, 120.0, 0.0, -90.0, 0.0];

/// A piecewise-linear tip position target: `p_d(t)` moves from `from` to `to`
/// between `t0` and `t1` at constant speed and holds outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ramp {
    pub from: Vector3<f64>,
    pub to: Vector3<f64>,
    pub t0: f64,
    pub t1: f64,
}

/// One of the paper's tasks, as the controller sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Task<const N: usize = N_JOINTS> {
    /// The preset name (one of [`PRESETS`]).
    pub name: String,
    /// Duration of the task [s].
    pub duration: f64,
    /// Control period [s].
    pub dt: f64,
    /// Start joints [rad].
    pub q0: JointVec<N>,
    /// Force axis `n`, base frame (−z: pushing down).
    pub force_axis: Vector3<f64>,
    /// `(t, f_d)` steps, ascending, first at t = 0.
    pub f_d_steps: Vec<(f64, f64)>,
    pub ramp: Ramp,
    pub r_d: UnitQuaternion<f64>,
    pub impedance: ImpedanceSettings,
    /// Height z [m] of the horizontal surface the paper sets the task against (z_d lies
    /// 3 cm below it); for §4.2 the height where the slope ends, at the end of the path.
    pub surface: f64,
    /// Where the task expects the surface: its coordinate along the force axis' base-frame
    /// axis [m] (z for the presets), given to the scheduled law's approach speed limit
    /// (`approach.expected_surface`); `None`: no expectation. Only the scheduled law reads it.
    pub expected_surface: Option<f64>,
}

impl<const N: usize> Task<N> {
    /// Desired force at time `t`.
    pub fn f_d(&self, t: f64) -> f64 {
        let mut f = self.f_d_steps.first().map_or(0.0, |s| s.1);
        for &(ts, fs) in &self.f_d_steps {
            if t >= ts - 1e-12 {
                f = fs;
            }
        }
        f
    }

    /// Reference at time `t` (allocation-free).
    pub fn reference(&self, t: f64) -> Reference {
        let r = &self.ramp;
        let (p_d, v) = if t < r.t0 || r.t1 <= r.t0 {
            (r.from, Vector3::zeros())
        } else if t >= r.t1 {
            (r.to, Vector3::zeros())
        } else {
            let v = (r.to - r.from) / (r.t1 - r.t0);
            (r.from + v * (t - r.t0), v)
        };
        let mut v_d = Vector6::zeros();
        v_d.fixed_rows_mut::<3>(0).copy_from(&v);
        Reference { p_d, r_d: self.r_d, v_d, a_d: Vector6::zeros(), f_d: self.f_d(t) }
    }

    /// Number of control steps.
    pub fn steps(&self) -> usize {
        (self.duration / self.dt).round() as usize
    }
}

/// Why a task preset cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TaskError {
    /// The presets are set on the six joints of the JK5.
    #[error("the scenarios need the 6-joint JK5; this URDF has {joints} moving joints")]
    JointCount { joints: usize },
    /// The robot model lacks a frame the presets place the tool by.
    #[error("the URDF has no frame '{frame}' (add a link named '{frame}', see urdf/jk5.urdf)")]
    MissingFrame { frame: String },
    #[error("unknown scenario '{name}': use one of {}", PRESETS.join(", "))]
    UnknownPreset { name: String },
    /// The start pose is out of reach of this model.
    #[error("inverse kinematics for the {name} start pose failed (error {error:.2e} m)")]
    InverseKinematics { name: String, error: f64 },
    /// A relative preset needs the tool along a base axis at the start joints.
    #[error("at the start joints (start_q) the tool's z axis is {angle_deg:.1}° from the nearest base axis; the scenarios push along a base axis (±x, ±y or ±z): choose a start_q with the tool pointing along one (within {max_deg}°)")]
    ToolAxis { angle_deg: f64, max_deg: f64 },
    /// A relative preset needs start joints and the robot file gives none.
    #[error("the robot file {file} has no start_q: the scenarios start there; add start_q (joints [rad], the tool pointing along a base axis)")]
    NoStartJoints { file: String },
    /// The path of a relative preset leaves the arm's reach.
    #[error("the {name} path leaves the arm's reach at {point} m (inverse kinematics error {error:.2e} m): choose a start_q closer to the base or the arm's middle")]
    OutOfReach { name: String, point: String, error: f64 },
}

impl From<TaskError> for String {
    /// The message, where a caller reports errors as text (CLI, logs).
    fn from(e: TaskError) -> String {
        e.to_string()
    }
}

/// Degrees to radians for a joint vector.
pub fn deg<const N: usize>(q: JointVec<N>) -> JointVec<N> {
    q.map(f64::to_radians)
}

/// Tip position and orientation at `q`.
///
/// # Panics
/// If `model` has another joint count than `N` or no `tip` frame (a programming error:
/// the robot is checked when loaded).
pub fn tip_pose<const N: usize>(model: &Model, q: &JointVec<N>) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let mut data = DataN::<N>::try_new(model).expect("an N-joint model");
    let tip = model.frame_id("tip").expect("tip frame");
    dynamics::forward_kinematics(model, &mut data, &SVector::<f64, N>::from(*q));
    let iso = data.frame_placement(tip);
    (iso.translation.vector, iso.rotation)
}

/// Damped-least-squares inverse kinematics of the tip pose (position +
/// orientation) from `q_start`. Returns the joints and the final position error.
pub fn inverse_kinematics<const N: usize>(
    model: &Model,
    q_start: &JointVec<N>,
    p_target: &Vector3<f64>,
    r_target: &UnitQuaternion<f64>,
) -> (JointVec<N>, f64) {
    let mut data = DataN::<N>::try_new(model).expect("an N-joint model");
    let tip = model.frame_id("tip").expect("tip frame");
    let mut q = SVector::<f64, N>::from(*q_start);
    let mut err_p = f64::INFINITY;
    for _ in 0..200 {
        let j = *dynamics::frame_jacobian(model, &mut data, &q, tip);
        let iso = data.frame_placement(tip);
        let ep = p_target - iso.translation.vector;
        let er = (r_target * iso.rotation.inverse()).scaled_axis();
        err_p = ep.norm();
        if err_p < 1e-10 && er.norm() < 1e-10 {
            break;
        }
        let mut e = Vector6::zeros();
        e.fixed_rows_mut::<3>(0).copy_from(&ep);
        e.fixed_rows_mut::<3>(3).copy_from(&er);
        let lambda2 = 1e-6;
        let jjt = j * j.transpose() + nalgebra::Matrix6::identity() * lambda2;
        let Some(ch) = jjt.cholesky() else { break };
        q += j.transpose() * ch.solve(&e);
    }
    (q.into(), err_p)
}

/// Build a task preset by name with the given robot model (for the initial
/// tip pose and inverse kinematics).
pub fn preset(name: &str, model: &Model) -> Result<Task, TaskError> {
    if model.nv() != 6 {
        return Err(TaskError::JointCount { joints: model.nv() });
    }
    for frame in ["tip", "ft_sensor"] {
        if model.frame_id(frame).is_none() {
            return Err(TaskError::MissingFrame { frame: frame.to_string() });
        }
    }
    let q0_flat = deg(Q0_FLAT_DEG);
    let (_p0, r0) = tip_pose(model, &q0_flat);
    let y = -0.1135;
    let flat_ramp = Ramp { from: Vector3::new(-0.3, y, 0.05), to: Vector3::new(-0.75, y, 0.05), t0: 0.0, t1: 5.0 };
    let base = Task {
        name: name.to_string(),
        duration: 5.0,
        dt: 1e-3,
        q0: q0_flat,
        force_axis: -Vector3::z(),
        f_d_steps: vec![(0.0, 10.0)],
        ramp: flat_ramp,
        r_d: r0,
        impedance: PAPER_IMPEDANCE,
        surface: 0.08,
        expected_surface: None,
    };
    let t = match name {
        "flat" => Task { f_d_steps: vec![(0.0, 10.0), (3.0, 20.0)], ..base },
        // issue 12: "a configurable approach speed near an expected surface"
        "acrylic" => Task { expected_surface: Some(0.08), ..base },
        "stiffness-step" | "slope" => base,
        "foam" | "two-material" => {
            let (surface, f_d, duration) = if name == "foam" { (0.3813, 10.0, 8.0) } else { (0.3648, 3.0, 10.0) };
            let start = Vector3::new(-0.45, y, 0.538);
            let (q0, err) = inverse_kinematics(model, &q0_flat, &start, &r0);
            if err > 1e-6 {
                return Err(TaskError::InverseKinematics { name: name.to_string(), error: err });
            }
            let z_d = surface - 0.03;
            let from = Vector3::new(start.x, y, z_d);
            let (ramp, expected_surface) = if name == "foam" {
                (Ramp { from, to: from, t0: 0.0, t1: duration }, None)
            } else {
                (Ramp { from, to: Vector3::new(start.x - 0.06, y, z_d), t0: 5.0, t1: 8.0 }, Some(surface))
            };
            Task { duration, q0, f_d_steps: vec![(0.0, f_d)], ramp, surface, expected_surface, ..base }
        }
        other => return Err(TaskError::UnknownPreset { name: other.to_string() }),
    };
    Ok(t)
}

/// Geometry of the paper's JK5 tasks that [`preset_relative`] carries over to any arm,
/// measured on the JK5's placements above (so that a JK5 run both ways agrees).
pub mod relative {
    /// Start tip height above the §4.1 table: 0.247 − 0.08 m.
    pub const FLAT_CLEARANCE: f64 = 0.167;
    /// §5.2.1: start 0.538 m, foam at 0.3813 m.
    pub const FOAM_CLEARANCE: f64 = 0.538 - 0.3813;
    /// §5.2.2: start 0.538 m, acrylic at 0.3648 m.
    pub const TWO_MATERIAL_CLEARANCE: f64 = 0.538 - 0.3648;
    /// z_d lies this far beyond the surface along the force axis (§4.1: 0.05 vs 0.08 m).
    pub const TARGET_DEPTH: f64 = 0.03;
    /// Length of the §4.1 path (−0.3 → −0.75 m) in its 5 s.
    pub const PATH_LENGTH: f64 = 0.45;
    /// §5.2.2: the target moves 0.06 m from t = 5 s to 8 s.
    pub const TWO_MATERIAL_SHIFT: f64 = 0.06;
    /// The tool's z may be this far from a base axis at the start [°].
    pub const MAX_TOOL_AXIS_DEG: f64 = 10.0;
}

/// The force axis and path direction of [`preset_relative`] at the start tip pose:
/// `n` is the base axis (±x, ±y or ±z) nearest the tool's z axis; the path runs along the
/// base axis perpendicular to `n` on which the start tip is nearer 0 (across the front of
/// the arm), towards and past 0.
pub fn relative_axes(p0: &Vector3<f64>, r0: &UnitQuaternion<f64>) -> Result<(Vector3<f64>, Vector3<f64>), TaskError> {
    let z = r0 * Vector3::z();
    let k = (0..3).max_by(|&a, &b| z[a].abs().total_cmp(&z[b].abs())).unwrap_or(2);
    let mut n = Vector3::zeros();
    n[k] = z[k].signum();
    let angle_deg = z.dot(&n).clamp(-1.0, 1.0).acos().to_degrees();
    if angle_deg > relative::MAX_TOOL_AXIS_DEG {
        return Err(TaskError::ToolAxis { angle_deg, max_deg: relative::MAX_TOOL_AXIS_DEG });
    }
    let others: Vec<usize> = (0..3).filter(|&a| a != k).collect();
    let a = if p0[others[0]].abs() <= p0[others[1]].abs() { others[0] } else { others[1] };
    let mut t = Vector3::zeros();
    t[a] = if p0[a] > 0.0 { -1.0 } else { 1.0 };
    Ok((n, t))
}

/// A task preset placed relative to the arm (issue 37): the start joints `q0` (the robot
/// file's `start_q`), the force axis `n` and the path direction `t̂` from [`relative_axes`],
/// and the JK5 tasks' distances ([`relative`]) along them: the surface `FLAT_CLEARANCE`
/// beyond the start tip along `n` (foam and two-material: their own clearances), `z_d`
/// `TARGET_DEPTH` beyond the surface, the path `PATH_LENGTH` along `t̂` in 5 s starting
/// under the start tip; `f_d`, durations, impedance and the force steps as in [`preset`].
/// `surface` and `expected_surface` are coordinates along `n`'s base axis, as for the JK5.
/// Every point of the path is checked reachable (damped inverse kinematics).
pub fn preset_relative<const N: usize>(name: &str, model: &Model, q0: JointVec<N>) -> Result<Task<N>, TaskError> {
    if model.frame_id("tip").is_none() {
        return Err(TaskError::MissingFrame { frame: "tip".to_string() });
    }
    let (p0, r0) = tip_pose(model, &q0);
    let (n, t) = relative_axes(&p0, &r0)?;
    let k = (0..3).find(|&a| n[a] != 0.0).unwrap_or(2);
    let clearance = match name {
        "foam" => relative::FOAM_CLEARANCE,
        "two-material" => relative::TWO_MATERIAL_CLEARANCE,
        _ => relative::FLAT_CLEARANCE,
    };
    let surface_point = p0 + n * clearance;
    let surface = surface_point[k];
    let from = surface_point + n * relative::TARGET_DEPTH;
    let path = Ramp { from, to: from + t * relative::PATH_LENGTH, t0: 0.0, t1: 5.0 };
    let base = Task {
        name: name.to_string(),
        duration: 5.0,
        dt: 1e-3,
        q0,
        force_axis: n,
        f_d_steps: vec![(0.0, 10.0)],
        ramp: path,
        r_d: r0,
        impedance: PAPER_IMPEDANCE,
        surface,
        expected_surface: None,
    };
    let task = match name {
        "flat" => Task { f_d_steps: vec![(0.0, 10.0), (3.0, 20.0)], ..base },
        "acrylic" => Task { expected_surface: Some(surface), ..base },
        "stiffness-step" | "slope" => base,
        "foam" => Task { duration: 8.0, ramp: Ramp { from, to: from, t0: 0.0, t1: 8.0 }, ..base },
        "two-material" => Task {
            duration: 10.0,
            f_d_steps: vec![(0.0, 3.0)],
            ramp: Ramp { from, to: from + t * relative::TWO_MATERIAL_SHIFT, t0: 5.0, t1: 8.0 },
            expected_surface: Some(surface),
            ..base
        },
        other => return Err(TaskError::UnknownPreset { name: other.to_string() }),
    };
    // The path on the surface (the contact stops the tip there, short of z_d).
    let mut q = q0;
    for i in 0..=10 {
        let p = task.ramp.from + (task.ramp.to - task.ramp.from) * (i as f64 / 10.0) - n * relative::TARGET_DEPTH;
        let (qi, err) = inverse_kinematics(model, &q, &p, &r0);
        if !(err < 1e-6) {
            return Err(TaskError::OutOfReach { name: name.to_string(), point: format!("({:.3}, {:.3}, {:.3})", p.x, p.y, p.z), error: err });
        }
        q = qi;
    }
    Ok(task)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_preset_names_the_known_ones() {
        let e = TaskError::UnknownPreset { name: "moon".into() };
        assert_eq!(e.to_string(), "unknown scenario 'moon': use one of flat, stiffness-step, slope, foam, two-material, acrylic");
        let e = TaskError::InverseKinematics { name: "foam".into(), error: 1.5e-3 };
        assert_eq!(e.to_string(), "inverse kinematics for the foam start pose failed (error 1.50e-3 m)");
    }
}
