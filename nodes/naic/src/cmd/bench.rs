//! `naic bench …` (in progress).
use super::{CliError, CliResult};

#[derive(clap::Subcommand)]
pub enum BenchCmd {
    /// Median ns per call of the dynamics algorithms and one NAIC controller step.
    Dynamics,
}

pub fn run(_c: BenchCmd) -> CliResult {
    Err(CliError::failure("naic bench is not implemented yet"))
}
