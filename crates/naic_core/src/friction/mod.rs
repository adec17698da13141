//! Joint friction: the models of equations 4 and 5 of the NAIC paper, the
//! per-direction form of its Table 1, a smooth (tanh) variant for simulation,
//! and their YAML parameter files.
//!
//! * [`model`]  — [`JointFriction`] (one joint) and [`FrictionModel`] (n joints),
//!   evaluated without allocation in the 1 kHz path.
//! * [`params`] — [`FrictionParams`], the YAML file format (`params/friction_*.yaml`),
//!   validated on load with messages that name the joint, the field and the fix.
//!
//! Identifying the parameters from measured `(velocity, torque)` data (CSV reader,
//! bounded Levenberg–Marquardt fit, confidence intervals) is offline work and lives in
//! the `naic_ident` crate, so the control path links neither it nor its dependencies.
//!
//! Conventions: joints are numbered from 1 in files, tables and the CLI (the
//! paper's index i), and from 0 in the Rust API (`FrictionModel::tau_f(0, ..)` is
//! joint 1). Torques in N·m, velocities in rad/s, f_v in N·m·s/rad.

pub mod model;
pub mod params;

pub use model::{FrictionModel, JointFriction, Smoothing, StribeckParams, DEFAULT_V_S};
pub use params::{BranchStats, Ci95, FrictionParams, JointParams, JointStats};

/// Everything that can go wrong with friction models, parameter files, data and fits
/// (the `Data` and `Fit` cases are raised by `naic_ident`, which shares this type).
/// Every message names the thing that is wrong and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum FrictionError {
    /// A parameter value or parameter file is invalid.
    #[error("{0}")]
    Params(String),
    /// A data file or data row is invalid.
    #[error("{0}")]
    Data(String),
    /// The fit could not be carried out on otherwise valid data.
    #[error("{0}")]
    Fit(String),
    /// A vector passed to [`FrictionModel::tau_f_into`] has the wrong length.
    #[error("friction model has {expected} joints but {what} has length {found}; pass one entry per joint")]
    Length { what: &'static str, expected: usize, found: usize },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io { path: String, source: std::io::Error },
}
