//! Everything that can be wrong with a robot description, each with the fix.

use std::path::PathBuf;

/// Why a URDF could not be turned into a [`super::Model`]. Every variant names
/// the link/joint involved and says how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("URDF file not found: {path} (give the path of an existing .urdf file, e.g. urdf/jk5.urdf)")]
    FileNotFound { path: PathBuf },
    #[error("could not read URDF file {path}: {reason}")]
    Io { path: PathBuf, reason: String },
    #[error("could not parse URDF{origin}: {reason} (check the XML: one <robot> element with <link>/<joint> children)")]
    Parse { origin: String, reason: String },
    #[error("joint '{joint}' has type '{kind}', which is not a URDF joint type naic knows; use revolute, continuous, prismatic or fixed")]
    UnknownJointType { joint: String, kind: String },
    #[error("joint '{joint}' has type '{kind}', which naic does not support (serial chains of revolute, continuous, prismatic and fixed joints only); replace it by one of those")]
    UnsupportedJointType { joint: String, kind: String },
    #[error("joint '{joint}' names {role} link '{link}', but no <link name=\"{link}\"> exists; add the link or fix the name")]
    MissingLink { joint: String, role: &'static str, link: String },
    #[error("two {what}s are named '{name}'; give each {what} a unique name")]
    DuplicateName { what: &'static str, name: String },
    #[error("link '{link}' is the child of two joints ('{first}' and '{second}'), so the URDF is not a tree; remove one of them")]
    MultipleParents { link: String, first: String, second: String },
    #[error("the URDF has no root link (every link is some joint's child, so the joints form a loop); break the loop")]
    NoRoot,
    #[error("links {} are not connected to the root link (their joints form a loop); break the loop", .links.join(", "))]
    Loop { links: Vec<String> },
    #[error("the URDF has {} root links ({}); a robot needs exactly one: connect the others with a joint or remove them", .links.len(), .links.join(", "))]
    MultipleRoots { links: Vec<String> },
    #[error("the kinematic tree branches at link '{link}': moving joints '{first}' and '{second}' both descend from it, but naic supports serial chains only; make one branch fixed or remove it")]
    Branching { link: String, first: String, second: String },
    #[error("the URDF has no revolute, continuous or prismatic joint, so there is nothing to move; add at least one moving joint")]
    NoMovingJoints,
    #[error("{what} is not a finite number ({value}); replace it with a real number")]
    NonFinite { what: String, value: f64 },
    #[error("link '{link}' has mass {mass} kg; a mass must be >= 0 (use 0 with a zero inertia for a massless frame link)")]
    NegativeMass { link: String, mass: f64 },
    #[error("link '{link}' has zero mass but a non-zero inertia tensor; give it its real mass, or set all six inertia entries to 0")]
    MassZeroWithInertia { link: String },
    #[error("link '{link}' has an inertia tensor that is not positive (semi-)definite: principal moments {moments:?} kg·m²; fix ixx..izz (check signs of ixy/ixz/iyz: URDF uses the tensor, not its negated products)")]
    InertiaNotPositive { link: String, moments: [f64; 3] },
    #[error("link '{link}' has principal moments {moments:?} kg·m² that break the triangle inequality (each must be <= the sum of the other two), which no real body has; fix the inertia tensor")]
    InertiaTriangle { link: String, moments: [f64; 3] },
    #[error("joint '{joint}' has a zero <axis xyz>; give a non-zero axis such as \"0 0 1\"")]
    ZeroAxis { joint: String },
    #[error("joint '{joint}' has lower limit {lower} > upper limit {upper}; swap them")]
    BadLimits { joint: String, lower: f64, upper: f64 },
    #[error("joint '{joint}' moves no mass or inertia about its axis (all links after it are massless or on its axis), so the mass matrix is singular; give the links after it an <inertial>")]
    SingularJoint { joint: String },
    #[error("the URDF has no link named '{link}'; name one of its links")]
    UnknownLink { link: String },
    #[error("a frame named '{name}' exists already; give the new frame another name")]
    FrameExists { name: String },
    #[error("this workspace is for {expected} joints but the model has {found}; use Data::new (dynamic size) or a model with {expected} joints")]
    WrongDof { expected: usize, found: usize },
}
