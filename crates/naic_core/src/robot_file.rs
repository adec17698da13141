//! The robot file: one YAML that says which arm naic drives, loaded and checked here
//! and nowhere else (`naic sim/launch/bench --robot FILE`, `-p robot:=FILE` of the nodes).
//!
//! ```yaml
//! urdf: ../../urdf/jk5.urdf        # relative to this file, or package://pkg/path
//! base_frame: base_link            # optional: the URDF's root link
//! tip_frame: tip                   # a URDF frame, or {parent: link, xyz: [..], rpy: [..]}
//! sensor_frame: ft_sensor          # the same two forms
//! joints: [joint1, ..., joint6]    # optional: the actuated chain root -> tip, in chain order
//! start_q: [0, -0.52, 2.09, 0, -1.57, 0]   # optional [rad], in `joints` order
//! friction: ../friction_jk5.yaml   # a friction YAML (relative to this file) or none (default)
//! limits: {effort: [...], velocity: [...]}  # optional [N m], [rad/s]: default the URDF's <limit>
//! sensor: {range: [6], resolution: [6], noise: [6]}   # optional: ATI mini45 SI-145-5
//! tool: {mass: 0.424, com: [0, 0, 0.015]}   # optional [kg], [m] in sensor_frame
//! ```
//!
//! What the loaded [`Robot`] guarantees (so that everything downstream can rely on it):
//! * `model` is the actuated chain from the root to the tip (moving joints off that chain
//!   are locked at 0, see [`Model::from_urdf_file_chain`]) with 3 to 7 joints;
//! * `model` has a frame named [`TIP_FRAME`] (`tip`) at `tip_frame` and one named
//!   [`SENSOR_FRAME`] (`ft_sensor`) at `sensor_frame` (added when the URDF names them
//!   otherwise or lacks them), the names the controller and simulator look up;
//! * `model`'s effort and velocity limits are `limits` where given;
//! * when `sensor_frame` is a new frame (a stock URDF without the tool), the tool's mass
//!   is added to the last body as a point mass at its centre of mass; a URDF link as
//!   sensor frame is taken to model the sensor and tool already (the JK5's `ft_sensor`).
//!
//! `package://pkg/rest` is resolved as ROS tools do, first match wins:
//! 1. each directory of `NAIC_PACKAGE_PATH` (`:`-separated): `DIR/pkg`, then `DIR/share/pkg`;
//! 2. each prefix of `AMENT_PREFIX_PATH`: `PREFIX/share/pkg` (ROS 2);
//! 3. each directory of `ROS_PACKAGE_PATH`: `DIR/pkg`, or `DIR` itself when it is named `pkg` (ROS 1);
//! 4. the Python environment of `NAIC_VENV`, then `VIRTUAL_ENV`: `VENV/share/pkg` and
//!    `VENV/lib/python3.*/site-packages/cmeel.prefix/share/pkg` (where `pip install
//!    example-robot-data` puts its robots).

use crate::friction::{FrictionModel, FrictionParams};
use crate::model::{FrameId, Model};
use crate::dynamics::spatial::Se3;
use nalgebra::{Rotation3, Vector3};
use serde_yaml::Value;
use std::path::{Path, PathBuf};

/// The robot file used when none is given, relative to the repository root.
pub const DEFAULT_ROBOT_FILE: &str = "params/robots/jk5.yaml";
/// The name of the tip frame in a loaded [`Robot`]'s model.
pub const TIP_FRAME: &str = crate::pipeline::controller::TIP_FRAME;
/// The name of the F/T sensor frame in a loaded [`Robot`]'s model.
pub const SENSOR_FRAME: &str = crate::pipeline::controller::SENSOR_FRAME;

/// What is wrong with a robot file: the file, the field and the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("robot file {file}: `{field}`: {problem}")]
pub struct RobotFileError {
    pub file: String,
    pub field: String,
    /// What is wrong and how to fix it.
    pub problem: String,
}

/// The F/T sensor's model; `None`: the ATI mini45 SI-145-5's value (the simulator's default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorSpec {
    /// Measuring range per axis (Fx, Fy, Fz [N], Tx, Ty, Tz [N m]).
    pub range: Option<[f64; 6]>,
    /// Resolution per axis (same units).
    pub resolution: Option<[f64; 6]>,
    /// Noise standard deviation per axis (same units).
    pub noise: Option<[f64; 6]>,
}

/// What hangs below the F/T sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tool {
    /// [kg]
    pub mass: f64,
    /// Centre of mass in the sensor frame [m].
    pub com: Vector3<f64>,
}

/// A checked robot file (see the module documentation for what it guarantees).
#[derive(Clone, Debug)]
pub struct Robot {
    /// The robot file itself.
    pub file: PathBuf,
    /// The URDF, resolved.
    pub urdf: PathBuf,
    pub model: Model,
    pub base_frame: String,
    /// The frame names as the file gives them (a new frame: `tip` / `ft_sensor`).
    pub tip_frame: String,
    pub sensor_frame: String,
    /// The joint names in the order of `/joint_effort_cmd` (= the model's DOF order).
    pub joints: Vec<String>,
    /// Moving joints of the URDF off the chain, locked at 0.
    pub locked: Vec<String>,
    /// Start joints [rad], DOF order.
    pub start_q: Option<Vec<f64>>,
    /// The friction YAML and its feedforward model (`None`: no friction model).
    pub friction: Option<(PathBuf, FrictionModel)>,
    pub sensor: SensorSpec,
    pub tool: Tool,
    /// The sensor frame is a frame the robot file adds (the URDF has no tool).
    pub sensor_frame_added: bool,
}

/// One frame field: a URDF frame, or a new frame on a parent link.
enum FrameSpec {
    Named(String),
    New { parent: String, offset: Se3 },
}

type Env<'a> = &'a dyn Fn(&str) -> Option<String>;

impl Robot {
    /// Load and check `path` (package:// resolved with the process environment).
    pub fn load(path: impl AsRef<Path>) -> Result<Robot, RobotFileError> {
        Self::load_with_env(path.as_ref(), &|k| std::env::var(k).ok())
    }

    /// [`Robot::load`] with the environment given (`env(name)`: the variable's value).
    pub fn load_with_env(path: &Path, env: Env) -> Result<Robot, RobotFileError> {
        let file = path.display().to_string();
        let err = |field: &str, problem: String| RobotFileError { file: file.clone(), field: field.to_string(), problem };
        let text = std::fs::read_to_string(path).map_err(|e| {
            err("(file)", format!("cannot read it: {e} (give the path of a robot file, e.g. {DEFAULT_ROBOT_FILE})"))
        })?;
        let doc: Value = serde_yaml::from_str(&text)
            .map_err(|e| err("(file)", format!("not valid YAML: {e} (see {DEFAULT_ROBOT_FILE} for the layout)")))?;
        let Value::Mapping(map) = doc else {
            return Err(err("(file)", format!("must be a YAML mapping of fields (urdf, tip_frame, ...; see {DEFAULT_ROBOT_FILE})")));
        };
        const FIELDS: [&str; 11] =
            ["urdf", "base_frame", "tip_frame", "sensor_frame", "joints", "start_q", "friction", "limits", "sensor", "tool", "description"];
        for k in map.keys() {
            let name = k.as_str().unwrap_or("?");
            if !FIELDS.contains(&name) {
                return Err(err(name, format!("not a robot file field; the fields are {}", FIELDS.join(", "))));
            }
        }
        let get = |k: &str| map.get(k).filter(|v| !v.is_null());
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();

        // urdf
        let urdf_s = match get("urdf") {
            Some(Value::String(s)) if !s.is_empty() => s.clone(),
            Some(_) => return Err(err("urdf", "must be a path (relative to the robot file) or a package://pkg/path URI".into())),
            None => return Err(err("urdf", "missing: give the robot's URDF (a path relative to the robot file, or package://pkg/path)".into())),
        };
        let urdf = resolve_uri(&urdf_s, &dir, env).map_err(|e| err("urdf", e.to_string()))?;
        if !urdf.is_file() {
            return Err(err("urdf", format!("'{}' is not a file (a path is relative to the robot file's folder {})", urdf.display(), dir.display())));
        }
        let xml = std::fs::read_to_string(&urdf).map_err(|e| err("urdf", format!("cannot read {}: {e}", urdf.display())))?;
        let robot = urdf_rs::read_from_string(&xml).map_err(|e| err("urdf", format!("{} is not a valid URDF: {e}", urdf.display())))?;

        // Frames.
        let tip_spec = frame_spec(get("tip_frame"), "tip_frame").map_err(|e| err("tip_frame", e.to_string()))?;
        let sensor_spec = frame_spec(get("sensor_frame"), "sensor_frame").map_err(|e| err("sensor_frame", e.to_string()))?;
        // The link the chain ends at: a link, a joint's child link, or a new frame's parent.
        let link_of = |spec: &FrameSpec, field: &str| -> Result<String, RobotFileError> {
            let name = match spec {
                FrameSpec::Named(n) | FrameSpec::New { parent: n, .. } => n,
            };
            if robot.links.iter().any(|l| &l.name == name) {
                return Ok(name.clone());
            }
            if let Some(j) = robot.joints.iter().find(|j| &j.name == name) {
                return Ok(j.child.link.clone());
            }
            let links: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
            Err(err(field, format!("{} has no link or joint '{name}'; its links are {}", urdf.display(), links.join(", "))))
        };
        let tip_link = link_of(&tip_spec, "tip_frame")?;
        link_of(&sensor_spec, "sensor_frame")?;
        let (mut model, locked) = Model::from_urdf_file_chain(&urdf, &tip_link).map_err(|e| err("urdf", e.to_string()))?;
        crate::with_joints!(model.nv(), N => N).map_err(|e| err("urdf", format!("{e} (the chain from the root to tip_frame '{tip_link}')")))?;

        // base_frame: on the fixed base, at the root's pose (naic expresses poses in the root frame).
        let root = model.frames()[0].name.clone();
        let base_frame = match get("base_frame") {
            None => root.clone(),
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(err("base_frame", "must be the name of a URDF frame".into())),
        };
        let Some(bid) = model.frame_id(&base_frame) else {
            return Err(err("base_frame", format!("{} has no frame '{base_frame}'; use its root link '{root}'", urdf.display())));
        };
        let b = model.frame(bid);
        if b.parent.is_some() || (b.placement.rot - nalgebra::Matrix3::identity()).norm() > 1e-12 || b.placement.trans.norm() > 1e-12 {
            return Err(err(
                "base_frame",
                format!("'{base_frame}' moves or is offset from the URDF root '{root}': naic works in the root's frame; use '{root}' or a link fixed to it at zero offset"),
            ));
        }

        // tip and sensor frames under the names naic looks up.
        let mut place = |spec: &FrameSpec, canonical: &str, field: &str| -> Result<(String, bool), RobotFileError> {
            match spec {
                FrameSpec::Named(n) => {
                    let Some(id) = model.frame_id(n) else {
                        return Err(err(field, format!("{} has no frame '{n}'", urdf.display())));
                    };
                    if canonical == SENSOR_FRAME && model.frame(id).parent.is_none() {
                        return Err(err(field, format!("'{n}' is on the fixed base: the F/T sensor sits between the last joint and the tool")));
                    }
                    if n != canonical {
                        if model.frame_id(canonical).is_some() {
                            return Err(err(field, format!("the URDF has another frame named '{canonical}', the name naic gives this frame: rename that frame in the URDF, or give {field}: {canonical}")));
                        }
                        model.add_frame(canonical, id, Se3::identity()).map_err(|e| err(field, e.to_string()))?;
                    }
                    Ok((n.clone(), false))
                }
                FrameSpec::New { parent, offset } => {
                    if model.frame_id(canonical).is_some() {
                        return Err(err(field, format!("the URDF has a frame named '{canonical}' already, the name naic gives the new frame: give {field}: {canonical} to use it, or rename it in the URDF")));
                    }
                    let id = model.frame_id(parent).ok_or_else(|| err(field, format!("{} has no link '{parent}'", urdf.display())))?;
                    model.add_frame(canonical, id, *offset).map_err(|e| err(field, e.to_string()))?;
                    Ok((canonical.to_string(), true))
                }
            }
        };
        let (tip_frame, _) = place(&tip_spec, TIP_FRAME, "tip_frame")?;
        let (sensor_frame, sensor_frame_added) = place(&sensor_spec, SENSOR_FRAME, "sensor_frame")?;
        let sensor_id = model.frame_id(SENSOR_FRAME).expect("placed above");
        if model.frame(sensor_id).parent.is_none() {
            return Err(err("sensor_frame", format!("'{sensor_frame}' is on the fixed base: the F/T sensor sits between the last joint and the tool")));
        }

        // joints
        let chain: Vec<String> = model.joint_names().map(String::from).collect();
        let joints = match get("joints") {
            None => chain.clone(),
            Some(v) => {
                let names = strings(v).ok_or_else(|| err("joints", "must be a list of joint names".into()))?;
                if names != chain {
                    return Err(err(
                        "joints",
                        format!(
                            "[{}] is not the actuated chain from the root to tip_frame, which is [{}] (in this order); give that list, or leave `joints` out{}",
                            names.join(", "),
                            chain.join(", "),
                            if locked.is_empty() { String::new() } else { format!(" (locked at 0: {})", locked.join(", ")) }
                        ),
                    ));
                }
                names
            }
        };
        let n = chain.len();

        // limits
        let mut effort = model.effort_limits();
        let mut velocity = model.velocity_limits();
        if let Some(l) = get("limits") {
            let Value::Mapping(lm) = l else { return Err(err("limits", "must be a mapping {effort: [...], velocity: [...]}".into())) };
            for k in lm.keys() {
                let k = k.as_str().unwrap_or("?");
                if k != "effort" && k != "velocity" {
                    return Err(err(&format!("limits.{k}"), "not a limits field; use effort [N m] and velocity [rad/s]".into()));
                }
            }
            for (key, dst) in [("effort", &mut effort), ("velocity", &mut velocity)] {
                if let Some(v) = lm.get(key).filter(|v| !v.is_null()) {
                    *dst = numbers(v, n, true).map_err(|p| err(&format!("limits.{key}"), format!("{p} ({n} joints: {})", chain.join(", "))))?;
                }
            }
        }
        for (key, vals) in [("effort", &effort), ("velocity", &velocity)] {
            if let Some(i) = vals.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(err(
                    &format!("limits.{key}"),
                    format!("joint '{}' has {key} limit {} from the URDF; give limits.{key} with {n} positive numbers", chain[i], vals[i]),
                ));
            }
        }
        model.set_effort_velocity_limits(&effort, &velocity);

        // start_q
        let start_q = match get("start_q") {
            None => None,
            Some(v) => {
                let q = numbers(v, n, false).map_err(|p| err("start_q", format!("{p} [rad], one per joint of [{}]", chain.join(", "))))?;
                for (i, j) in model.joints().iter().enumerate() {
                    if q[i] < j.limits.lower || q[i] > j.limits.upper {
                        return Err(err(
                            "start_q",
                            format!("joint '{}' = {} rad is outside its URDF limits [{}, {}]; choose a start inside them", j.name, q[i], j.limits.lower, j.limits.upper),
                        ));
                    }
                }
                Some(q)
            }
        };

        // friction
        let friction = match get("friction") {
            None => None,
            Some(Value::String(s)) if s == "none" => None,
            Some(Value::String(s)) => {
                let p = resolve_uri(s, &dir, env).map_err(|e| err("friction", e.to_string()))?;
                let m = FrictionParams::load_feedforward_model(&p)
                    .map_err(|e| err("friction", format!("{}: {e} (or give `friction: none`)", p.display())))?;
                if m.n_joints() != n {
                    return Err(err("friction", format!("{} has {} joints, the arm {n}; give this arm's friction file, or none", p.display(), m.n_joints())));
                }
                Some((p, m))
            }
            Some(_) => return Err(err("friction", "must be the path of a friction YAML (relative to the robot file) or none".into())),
        };

        // sensor
        let mut sensor = SensorSpec::default();
        if let Some(s) = get("sensor") {
            let Value::Mapping(sm) = s else { return Err(err("sensor", "must be a mapping {range, resolution, noise} of 6 numbers each".into())) };
            for k in sm.keys() {
                let k = k.as_str().unwrap_or("?");
                if !["range", "resolution", "noise"].contains(&k) {
                    return Err(err(&format!("sensor.{k}"), "not a sensor field; use range, resolution and noise (6 numbers each: Fx, Fy, Fz [N], Tx, Ty, Tz [N m])".into()));
                }
            }
            for (key, dst) in [("range", &mut sensor.range), ("resolution", &mut sensor.resolution), ("noise", &mut sensor.noise)] {
                if let Some(v) = sm.get(key).filter(|v| !v.is_null()) {
                    let x = numbers(v, 6, key != "noise").map_err(|p| err(&format!("sensor.{key}"), format!("{p} (Fx, Fy, Fz [N], Tx, Ty, Tz [N m])")))?;
                    if key == "noise" && x.iter().any(|v| *v < 0.0) {
                        return Err(err("sensor.noise", "a standard deviation is >= 0".into()));
                    }
                    *dst = Some(std::array::from_fn(|i| x[i]));
                }
            }
        }

        // tool
        let tool = match get("tool") {
            Some(t) => {
                let Value::Mapping(tm) = t else { return Err(err("tool", "must be a mapping {mass: kg, com: [x, y, z] m in sensor_frame}".into())) };
                for k in tm.keys() {
                    let k = k.as_str().unwrap_or("?");
                    if k != "mass" && k != "com" {
                        return Err(err(&format!("tool.{k}"), "not a tool field; use mass [kg] and com [x, y, z] [m, sensor frame]".into()));
                    }
                }
                let mass = match tm.get("mass").and_then(Value::as_f64) {
                    Some(m) if m >= 0.0 && m.is_finite() => m,
                    _ => return Err(err("tool.mass", "give the tool's mass in kg, a number >= 0".into())),
                };
                let com = match tm.get("com") {
                    Some(v) => numbers(v, 3, false).map_err(|p| err("tool.com", format!("{p} [m], in the sensor frame")))?,
                    None => return Err(err("tool.com", "give the tool's centre of mass [x, y, z] in m, in the sensor frame".into())),
                };
                Tool { mass, com: Vector3::new(com[0], com[1], com[2]) }
            }
            // The sensor link's <inertial> in the URDF (the JK5's ft_sensor: sensor and rod).
            None if !sensor_frame_added => match robot.links.iter().find(|l| l.name == sensor_frame) {
                Some(l) => {
                    let o = l.inertial.origin.xyz;
                    Tool { mass: l.inertial.mass.value, com: Vector3::new(o[0], o[1], o[2]) }
                }
                None => Tool { mass: 0.0, com: Vector3::zeros() },
            },
            None => Tool { mass: 0.0, com: Vector3::zeros() },
        };
        if sensor_frame_added && tool.mass > 0.0 {
            model.add_point_mass(sensor_id, tool.mass, tool.com);
        }
        Ok(Robot {
            file: path.to_path_buf(),
            urdf,
            model,
            base_frame,
            tip_frame,
            sensor_frame,
            joints,
            locked,
            start_q,
            friction,
            sensor,
            tool,
            sensor_frame_added,
        })
    }

    /// The tip frame of [`Robot::model`].
    pub fn tip(&self) -> FrameId {
        self.model.frame_id(TIP_FRAME).expect("checked when loaded")
    }

    /// The tip's position in the sensor frame [m] (the controller's `tool.tip`), when both
    /// frames ride on the same body (always, unless a joint lies between sensor and tip).
    pub fn tip_in_sensor(&self) -> Option<Vector3<f64>> {
        let tip = self.model.frame(self.tip());
        let sensor = self.model.frame(self.model.frame_id(SENSOR_FRAME)?);
        (tip.parent == sensor.parent).then(|| sensor.placement.inverse().compose(&tip.placement).trans)
    }

    /// The tool as `(mass, com)`.
    pub fn tool_tuple(&self) -> (f64, Vector3<f64>) {
        (self.tool.mass, self.tool.com)
    }

    /// Whether this is the JK5 of the paper (its URDF's robot name is `jk5`): the paper's
    /// scenario placements apply to it unchanged.
    pub fn is_paper_jk5(&self) -> bool {
        self.model.name == "jk5" && self.model.nv() == 6 && self.tip_frame == TIP_FRAME
    }
}

/// Why a frame field is not a frame (the field is named by the caller).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum FrameSpecError {
    #[error("missing: give a frame of the URDF, or {{parent: LINK, xyz: [x, y, z], rpy: [r, p, y]}} for a new one")]
    Missing,
    #[error("'{0}' is not a field of a new frame; use parent, xyz [m] and rpy [rad]")]
    UnknownKey(String),
    #[error("a new {0} needs `parent`: the URDF link it is fixed to")]
    NoParent(String),
    #[error("{key}: {source}")]
    Value { key: String, source: ValueError },
    #[error("must be a frame name or {{parent: LINK, xyz: [x, y, z], rpy: [r, p, y]}}")]
    NotAFrame,
}

fn frame_spec(v: Option<&Value>, field: &str) -> Result<FrameSpec, FrameSpecError> {
    match v {
        None => Err(FrameSpecError::Missing),
        Some(Value::String(s)) if !s.is_empty() => Ok(FrameSpec::Named(s.clone())),
        Some(Value::Mapping(m)) => {
            for k in m.keys() {
                let k = k.as_str().unwrap_or("?");
                if !["parent", "xyz", "rpy"].contains(&k) {
                    return Err(FrameSpecError::UnknownKey(k.to_string()));
                }
            }
            let parent = m.get("parent").and_then(Value::as_str).ok_or_else(|| FrameSpecError::NoParent(field.to_string()))?.to_string();
            let v3 = |k: &str| -> Result<[f64; 3], FrameSpecError> {
                match m.get(k).filter(|v| !v.is_null()) {
                    None => Ok([0.0; 3]),
                    Some(v) => numbers(v, 3, false).map(|x| [x[0], x[1], x[2]]).map_err(|source| FrameSpecError::Value { key: k.to_string(), source }),
                }
            };
            let xyz = v3("xyz")?;
            let rpy = v3("rpy")?;
            let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
            Ok(FrameSpec::New { parent, offset: Se3::new(*r.matrix(), Vector3::from(xyz)) })
        }
        Some(_) => Err(FrameSpecError::NotAFrame),
    }
}

fn strings(v: &Value) -> Option<Vec<String>> {
    v.as_sequence()?.iter().map(|x| x.as_str().map(String::from)).collect()
}

/// Why a value is not the list of numbers a field needs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum ValueError {
    #[error("must be a list of {0} numbers")]
    NotAList(usize),
    #[error("has {got} numbers; give {n}")]
    Count { got: usize, n: usize },
    #[error("{0} is not a positive number")]
    NotPositive(f64),
    #[error("{0} is not a finite number")]
    NotFinite(f64),
}

/// `n` finite numbers (`positive`: each > 0).
fn numbers(v: &Value, n: usize, positive: bool) -> Result<Vec<f64>, ValueError> {
    let seq = v.as_sequence().ok_or(ValueError::NotAList(n))?;
    let x: Vec<f64> = seq.iter().map(Value::as_f64).collect::<Option<_>>().ok_or(ValueError::NotAList(n))?;
    if x.len() != n {
        return Err(ValueError::Count { got: x.len(), n });
    }
    if let Some(&bad) = x.iter().find(|v| !v.is_finite()) {
        return Err(ValueError::NotFinite(bad));
    }
    if let Some(&bad) = x.iter().find(|v| positive && **v <= 0.0) {
        return Err(ValueError::NotPositive(bad));
    }
    Ok(x)
}

/// Why a `package://` URI names no folder.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackageError {
    #[error("'{uri}' names no package: write package://PACKAGE/path")]
    NoPackage { uri: String },
    #[error("package '{package}' of '{uri}' not found (looked in {looked}); install it, or set NAIC_PACKAGE_PATH to a folder holding {package}/ or share/{package}/ (for pip's example-robot-data: set NAIC_VENV or activate the venv)")]
    NotFound { package: String, uri: String, looked: String },
}

/// A path relative to `dir`, or a `package://pkg/rest` URI (see the module documentation).
pub fn resolve_uri(s: &str, dir: &Path, env: Env) -> Result<PathBuf, PackageError> {
    let Some(rest) = s.strip_prefix("package://") else {
        let p = Path::new(s);
        return Ok(if p.is_absolute() { p.to_path_buf() } else { dir.join(p) });
    };
    let (pkg, inner) = rest.split_once('/').unwrap_or((rest, ""));
    if pkg.is_empty() {
        return Err(PackageError::NoPackage { uri: s.to_string() });
    }
    let candidates = package_dirs(pkg, env);
    if let Some(c) = candidates.iter().find(|c| c.is_dir()) {
        return Ok(c.join(inner));
    }
    let looked = if candidates.is_empty() {
        "no folder: NAIC_PACKAGE_PATH, AMENT_PREFIX_PATH, ROS_PACKAGE_PATH, NAIC_VENV and VIRTUAL_ENV are unset".to_string()
    } else {
        candidates.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    };
    Err(PackageError::NotFound { package: pkg.to_string(), uri: s.to_string(), looked })
}

/// Where `package://pkg` may be, in search order.
fn package_dirs(pkg: &str, env: Env) -> Vec<PathBuf> {
    let list = |k: &str| -> Vec<PathBuf> { env(k).map(|v| std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()).collect()).unwrap_or_default() };
    let mut out = Vec::new();
    for d in list("NAIC_PACKAGE_PATH") {
        out.push(d.join(pkg));
        out.push(d.join("share").join(pkg));
    }
    for d in list("AMENT_PREFIX_PATH") {
        out.push(d.join("share").join(pkg));
    }
    for d in list("ROS_PACKAGE_PATH") {
        if d.file_name().is_some_and(|n| n == pkg) {
            out.push(d.clone());
        }
        out.push(d.join(pkg));
    }
    for k in ["NAIC_VENV", "VIRTUAL_ENV"] {
        let Some(v) = env(k).filter(|v| !v.is_empty()) else { continue };
        let venv = PathBuf::from(v);
        out.push(venv.join("share").join(pkg));
        if let Ok(rd) = std::fs::read_dir(venv.join("lib")) {
            let mut pys: Vec<PathBuf> = rd.flatten().map(|e| e.path()).filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("python3"))).collect();
            pys.sort();
            for py in pys {
                out.push(py.join("site-packages").join("cmeel.prefix").join("share").join(pkg));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
