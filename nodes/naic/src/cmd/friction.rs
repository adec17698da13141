//! `naic friction …` (in progress).
use super::{CliError, CliResult};

#[derive(clap::Subcommand)]
pub enum FrictionCmd {
    /// Fit a friction model to steady-state (velocity, torque) points.
    Fit,
}

pub fn run(_c: FrictionCmd) -> CliResult {
    Err(CliError::failure("naic friction fit is not implemented yet"))
}
