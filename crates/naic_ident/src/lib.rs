//! # naic_ident
//!
//! Identification of joint friction from measured data, offline: the parameters of
//! the models in `naic_core::friction` (equations 4 and 5 of the NAIC paper, per
//! direction as in Table 1) fitted to steady-state `(joint, velocity, torque)` points.
//! The 1 kHz path never links this crate; it only evaluates the fitted model, loaded
//! from the parameter file that [`fit::FitReport::to_params`] produces.
//!
//! * [`data`]  — [`FrictionData`], the CSV format `joint,velocity_rad_s,torque_nm`.
//! * [`fit`]   — bounded Levenberg–Marquardt fit with multiple starts, 95 %
//!   confidence intervals and RMSE per joint and direction.
//! * [`tool`]  — the tool's mass and centre of mass and the F/T sensor's bias from static
//!   poses (linear least squares; `naic tool identify`).
//! * [`lm`], [`stats`] — the solver and the Student-t quantile behind [`fit`].
//!
//! Errors are `naic_core::friction::FrictionError` (`Data`, `Fit`, `Io`). Joints are
//! numbered from 1, as in the parameter files and the CLI.

pub mod data;
pub mod fit;
pub mod lm;
pub mod stats;
pub mod tool;

pub use data::{FrictionData, FrictionSample};
pub use fit::{fit, residual_stats, BranchFit, Ci95, Direction, FitForm, FitOptions, FitReport, JointFit, ParamEstimate, ResidualStats};
