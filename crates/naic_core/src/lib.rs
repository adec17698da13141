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

pub mod alloc_count;
pub mod dynamics;
pub mod friction;
pub mod model;
pub mod pipeline;
pub mod rng;
