//! Joint friction: the models of equations 4 and 5 of the NAIC paper, the
//! per-direction form of its Table 1, a smooth (tanh) variant for simulation,
//! their YAML parameter files, and their identification from steady-state
//! `(velocity, torque)` data.
//!
//! * [`model`]  — [`JointFriction`] (one joint) and [`FrictionModel`] (n joints),
//!   evaluated without allocation in the 1 kHz path.
//! * [`params`] — [`FrictionParams`], the YAML file format (`params/friction_*.yaml`),
//!   validated on load with messages that name the joint, the field and the fix.
//! * [`data`]   — [`FrictionData`], the CSV format `joint,velocity_rad_s,torque_nm`.
//! * [`fit`]    — bounded Levenberg–Marquardt fit with multiple starts, 95 %
//!   confidence intervals and RMSE per joint and direction.
//! * [`lm`], [`stats`] — the solver and the Student-t quantile behind [`fit`].
//!
//! Conventions: joints are numbered from 1 in files, tables and the CLI (the
//! paper's index i), and from 0 in the Rust API (`FrictionModel::tau_f(0, ..)` is
//! joint 1). Torques in N·m, velocities in rad/s, f_v in N·m·s/rad.

pub mod data;
pub mod fit;
pub mod lm;
pub mod model;
pub mod params;
pub mod stats;

pub use data::{FrictionData, FrictionSample};
pub use fit::{fit, residual_stats, BranchFit, Ci95, Direction, FitForm, FitOptions, FitReport, JointFit, ParamEstimate, ResidualStats};
pub use model::{FrictionModel, JointFriction, Smoothing, StribeckParams, DEFAULT_V_S};
pub use params::{BranchStats, FrictionParams, JointParams, JointStats};

/// Everything that can go wrong with friction models, parameter files, data and fits.
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
