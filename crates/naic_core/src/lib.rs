//! # naic_core
//!
//! The foundation of naic, with no middleware in it: the robot model and its
//! rigid-body dynamics, joint friction, and the force-tracking controllers of
//! the NAIC paper (`../shared/seed/naic-paper.md`).
//!
//! Layout (Pinocchio's Model/Data split; data flows one way through `pipeline`):
//!
//! * [`model`]    — immutable [`model::Model`] loaded from a serial-chain URDF,
//!   and the preallocated workspace [`model::Data`].
//! * [`dynamics`] — algorithms as plain functions over `(&Model, &mut Data)`:
//!   forward kinematics, frame Jacobians, J̇q̇, RNEA, CRBA, ABA, and the
//!   Cartesian terms of equation 3.
//! * [`friction`] — joint friction models (equations 4 and 5, per direction as
//!   in Table 1, and a smooth variant) and their parameter files; identifying
//!   them from data is offline work, in the `naic_ident` crate.
//! * [`pipeline`] — the 1 kHz control path, one stage per folder, in the order
//!   the data flows: `sense → estimate → control → feedforward → actuate`.
//! * [`task`]     — the paper's tasks as the controller sees them: start joints,
//!   reference trajectory, desired force schedule, impedance settings.

pub mod alloc_count;
pub mod dynamics;
pub mod force_design;
pub mod friction;
pub mod model;
pub mod pipeline;
pub mod rng;
pub mod task;

/// Joints of the arm (the JK5 has six revolute joints).
///
/// The one joint count of the fixed-size code paths: [`JointVec`], the
/// pipeline stages, the simulator plant. [`model::Data6`] is the matching
/// 6-DOF workspace; its joint-space vectors (`data.tau`, `data.ddq`) are
/// nalgebra `Vector6<f64>` = `SVector<f64, N_JOINTS>`, convertible to and from a
/// [`JointVec`] with `.into()` / `Vector6::from(q)`.
///
/// Not every six in the code is this one: a wrench (Fx, Fy, Fz, Tx, Ty, Tz), a
/// twist, a pose error (3 position + 3 orientation) and the Cartesian impedance
/// diagonals (`m_d`, `b_d`, `k_*`) have six components because space has six
/// degrees of freedom, and stay `[f64; 6]` / `Vector6<f64>`.
pub const N_JOINTS: usize = 6;

/// One value per joint [SI unit of the quantity: rad, rad/s, N·m, ...], joint 1 first.
///
/// The plain-array form of a joint-space vector (positions, velocities,
/// torques, per-joint limits and gains); see [`N_JOINTS`] for its nalgebra
/// counterpart and for the six-component quantities that are not joint vectors.
pub type JointVec = [f64; N_JOINTS];
