//! The robot model (immutable, loaded once from a URDF) and its preallocated
//! workspace [`Data`], in Pinocchio's Model/Data style.
//!
//! ```no_run
//! use naic_core::model::{Model, Data, FrameId};
//! let model = Model::from_urdf_file("urdf/jk5.urdf")?;
//! let mut data = Data::new(&model);            // any number of joints (heap buffers, allocated once)
//! let tip: FrameId = model.frame_id("tip").unwrap();
//! # Ok::<(), naic_core::model::ModelError>(())
//! ```
//!
//! # What a `Model` is
//!
//! * **Joints** ([`JointModel`]): the moving joints of the URDF (revolute,
//!   continuous, prismatic) in chain order; joint `i` is degree of freedom `i`
//!   (`nq = nv = n`). Its frame is the URDF child link frame of that joint;
//!   `placement` is that frame in the previous joint's frame at zero position
//!   (for joint 0: in the root link frame, which is the world/base frame).
//! * **Bodies**: each joint carries one rigid body, the inertia of its child
//!   link *plus every link attached to it through fixed joints* (merged like
//!   Pinocchio does), expressed in the joint frame. Links fixed to the root
//!   (e.g. `world`, `base_link`) belong to the fixed base and carry no dynamics.
//! * **Frames** ([`Frame`]): every URDF link and every joint is a named frame
//!   (a fixed joint's frame coincides with its child link's), attached to a
//!   joint (or to the base, `parent = None`) at a constant placement.
//! * Joint limits (position, velocity, effort) and gravity `(0, 0, −9.81)` m/s².
//!
//! Supported: any serial chain (each body has at most one moving child joint;
//! side branches made only of fixed joints are fine). Everything else is a
//! [`ModelError`] naming the link/joint and the fix; loading never panics.

mod data;
mod error;
mod urdf;

pub use data::{Data, Data6, DataN};
pub use error::ModelError;

use crate::dynamics::spatial::{Inertia, Motion, Se3};
use nalgebra::{Matrix3, Vector3};

/// Index of a frame in [`Model::frames`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameId(pub usize);

/// What a frame stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    /// A URDF link.
    Link,
    /// A moving joint (coincides with its child link frame).
    Joint,
    /// A fixed joint (coincides with its child link frame).
    FixedJoint,
}

/// A named frame rigidly attached to a joint's body (or the base).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub name: String,
    pub kind: FrameKind,
    /// The joint (degree of freedom) whose body carries the frame; `None`: the fixed base.
    pub parent: Option<usize>,
    /// Frame pose in the parent joint frame (or in the base frame).
    pub placement: Se3,
}

/// Revolute (continuous included) or prismatic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointType {
    Revolute,
    /// A revolute joint without position limits (URDF `continuous`).
    Continuous,
    Prismatic,
}

/// Axis specialisation used to build the joint rotation cheaply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AxisKind {
    X,
    Y,
    Z,
    General,
}

/// Joint limits from the URDF `<limit>` element (SI units; ±∞ where absent or continuous).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
    pub effort: f64,
}

/// One moving joint and the body it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct JointModel {
    pub name: String,
    pub jtype: JointType,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    pub(crate) axis_kind: AxisKind,
    /// Joint frame in the parent joint's frame at q = 0 (base frame for joint 0).
    pub placement: Se3,
    /// Body inertia (child link + fixed descendants) in the joint frame.
    pub inertia: Inertia,
    pub limits: JointLimits,
    /// Name of the URDF child link of this joint.
    pub child_link: String,
}

impl JointModel {
    /// `parent_M_joint(q) = placement · M_axis(q)`.
    #[inline(always)]
    pub(crate) fn transform(&self, q: f64) -> Se3 {
        let p = &self.placement;
        match self.jtype {
            JointType::Prismatic => Se3 { rot: p.rot, trans: p.trans + p.rot * (self.axis * q) },
            JointType::Revolute | JointType::Continuous => {
                let (s, c) = q.sin_cos();
                let r = &p.rot;
                let rot = match self.axis_kind {
                    AxisKind::Z => {
                        let c0 = r.column(0) * c + r.column(1) * s;
                        let c1 = r.column(1) * c - r.column(0) * s;
                        Matrix3::from_columns(&[c0, c1, r.column(2).into_owned()])
                    }
                    AxisKind::X => {
                        let c1 = r.column(1) * c + r.column(2) * s;
                        let c2 = r.column(2) * c - r.column(1) * s;
                        Matrix3::from_columns(&[r.column(0).into_owned(), c1, c2])
                    }
                    AxisKind::Y => {
                        let c0 = r.column(0) * c - r.column(2) * s;
                        let c2 = r.column(2) * c + r.column(0) * s;
                        Matrix3::from_columns(&[c0, r.column(1).into_owned(), c2])
                    }
                    AxisKind::General => {
                        let k = crate::dynamics::spatial::skew(&self.axis);
                        r * (Matrix3::identity() + k * s + k * k * (1.0 - c))
                    }
                };
                Se3 { rot, trans: p.trans }
            }
        }
    }

    /// Joint motion subspace times a joint rate: `S · qd` (in the joint frame).
    #[inline(always)]
    pub(crate) fn s_mul(&self, qd: f64) -> Motion {
        match self.jtype {
            JointType::Prismatic => Motion { v: self.axis * qd, w: Vector3::zeros() },
            _ => Motion { v: Vector3::zeros(), w: self.axis * qd },
        }
    }

    /// `Sᵀ f` for a spatial force in the joint frame.
    #[inline(always)]
    pub(crate) fn s_t_force(&self, f: &crate::dynamics::spatial::Force) -> f64 {
        match (self.jtype, self.axis_kind) {
            (JointType::Prismatic, _) => self.axis.dot(&f.f),
            (_, AxisKind::Z) => f.n.z,
            (_, AxisKind::X) => f.n.x,
            (_, AxisKind::Y) => f.n.y,
            (_, AxisKind::General) => self.axis.dot(&f.n),
        }
    }

    /// `I · S` for a body inertia in the joint frame (the momentum of a unit joint rate).
    #[inline(always)]
    pub(crate) fn inertia_s(&self, y: &Inertia) -> crate::dynamics::spatial::Force {
        use crate::dynamics::spatial::Force;
        match (self.jtype, self.axis_kind) {
            (JointType::Prismatic, _) => {
                let f = self.axis * y.mass;
                Force { f, n: y.com.cross(&f) }
            }
            (_, AxisKind::Z) => {
                let f = Vector3::new(-y.com.y, y.com.x, 0.0) * y.mass;
                Force { f, n: y.inertia.column(2) + y.com.cross(&f) }
            }
            (_, AxisKind::X) => {
                let f = Vector3::new(0.0, -y.com.z, y.com.y) * y.mass;
                Force { f, n: y.inertia.column(0) + y.com.cross(&f) }
            }
            (_, AxisKind::Y) => {
                let f = Vector3::new(y.com.z, 0.0, -y.com.x) * y.mass;
                Force { f, n: y.inertia.column(1) + y.com.cross(&f) }
            }
            (_, AxisKind::General) => y.mul_motion(&self.s_mul(1.0)),
        }
    }

    /// True for revolute and continuous joints.
    pub fn is_revolute(&self) -> bool {
        !matches!(self.jtype, JointType::Prismatic)
    }
}

/// The immutable robot model: a serial chain of `nv` moving joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// `<robot name>` of the URDF.
    pub name: String,
    pub(crate) joints: Vec<JointModel>,
    pub(crate) frames: Vec<Frame>,
    /// Gravity in the base frame, m/s² (default (0, 0, −9.81)).
    pub gravity: Vector3<f64>,
}

impl Model {
    /// Load a serial-chain URDF file. Never panics; see [`ModelError`].
    pub fn from_urdf_file(path: impl AsRef<std::path::Path>) -> Result<Model, ModelError> {
        urdf::from_file(path.as_ref())
    }

    /// Load a serial-chain URDF from its XML text.
    pub fn from_urdf_str(xml: &str) -> Result<Model, ModelError> {
        urdf::from_str(xml, "")
    }

    /// The actuated chain from the root to the link `tip_link` of the URDF file `path`:
    /// moving joints off that chain (a gripper's fingers, a second arm) are locked at 0,
    /// their links' mass kept on the body they hang from. Returns the model and the
    /// locked joints' names. A URDF that is already a chain to `tip_link` gives exactly
    /// [`Model::from_urdf_file`]'s model.
    pub fn from_urdf_file_chain(path: impl AsRef<std::path::Path>, tip_link: &str) -> Result<(Model, Vec<String>), ModelError> {
        let path = path.as_ref();
        if !path.exists() {
            return Err(ModelError::FileNotFound { path: path.to_path_buf() });
        }
        let text = std::fs::read_to_string(path).map_err(|e| ModelError::Io { path: path.to_path_buf(), reason: e.to_string() })?;
        urdf::from_str_chain(&text, &format!(" {}", path.display()), tip_link)
    }

    /// Add a frame `name` rigidly attached to the frame `parent` at `offset` (the new frame's
    /// pose in `parent`'s frame), e.g. a sensor or tool frame a stock URDF lacks.
    pub fn add_frame(&mut self, name: &str, parent: FrameId, offset: Se3) -> Result<FrameId, ModelError> {
        if self.frame_id(name).is_some() {
            return Err(ModelError::FrameExists { name: name.to_string() });
        }
        let p = &self.frames[parent.0];
        let frame = Frame { name: name.to_string(), kind: FrameKind::FixedJoint, parent: p.parent, placement: p.placement.compose(&offset) };
        self.frames.push(frame);
        Ok(FrameId(self.frames.len() - 1))
    }

    /// Add a point mass `mass` [kg] at `com` [m] in the frame `at` to the body carrying that
    /// frame (a tool the URDF does not model). A frame on the fixed base changes nothing.
    pub fn add_point_mass(&mut self, at: FrameId, mass: f64, com: Vector3<f64>) {
        let f = &self.frames[at.0];
        let Some(b) = f.parent else { return };
        let point = Inertia { mass, com: f.placement.act_point(&com), inertia: Matrix3::zeros() };
        self.joints[b].inertia = self.joints[b].inertia.add(&point);
    }

    /// Replace the effort [N·m or N] and velocity [rad/s or m/s] limits, joint `i` first.
    /// The slices have [`Model::nv`] entries (checked by the caller).
    pub fn set_effort_velocity_limits(&mut self, effort: &[f64], velocity: &[f64]) {
        for ((j, e), v) in self.joints.iter_mut().zip(effort).zip(velocity) {
            j.limits.effort = *e;
            j.limits.velocity = *v;
        }
    }

    /// Number of configuration variables (= `nv` for these joints).
    pub fn nq(&self) -> usize {
        self.joints.len()
    }
    /// Number of degrees of freedom.
    pub fn nv(&self) -> usize {
        self.joints.len()
    }
    /// The moving joints in chain order (joint `i` is DOF `i`).
    pub fn joints(&self) -> &[JointModel] {
        &self.joints
    }
    /// Joint names in DOF order.
    pub fn joint_names(&self) -> impl Iterator<Item = &str> {
        self.joints.iter().map(|j| j.name.as_str())
    }
    /// DOF index of a moving joint by name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }
    /// All frames (links, joints, fixed joints), in URDF tree order.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }
    /// Frame by name (first match: a link and a joint never share a name in sane URDFs).
    pub fn frame_id(&self, name: &str) -> Option<FrameId> {
        self.frames.iter().position(|f| f.name == name).map(FrameId)
    }
    /// The frame behind an id. Panics if the id is not from this model.
    pub fn frame(&self, id: FrameId) -> &Frame {
        &self.frames[id.0]
    }
    /// Lower position limits (−∞ for continuous joints).
    pub fn lower_limits(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.limits.lower).collect()
    }
    /// Upper position limits (+∞ for continuous joints).
    pub fn upper_limits(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.limits.upper).collect()
    }
    /// Velocity limits, rad/s or m/s.
    pub fn velocity_limits(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.limits.velocity).collect()
    }
    /// Effort limits, N·m or N.
    pub fn effort_limits(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.limits.effort).collect()
    }
    /// Total mass of the moving bodies, kg.
    /// The same robot with every body's mass and rotational inertia scaled by `factor`
    /// (a controller's model that is `factor` times too heavy, e.g. 0.8 or 1.25).
    pub fn with_scaled_inertias(&self, factor: f64) -> Model {
        let mut m = self.clone();
        for j in &mut m.joints {
            j.inertia.mass *= factor;
            j.inertia.inertia *= factor;
        }
        m
    }

    pub fn moving_mass(&self) -> f64 {
        self.joints.iter().map(|j| j.inertia.mass).sum()
    }
}
