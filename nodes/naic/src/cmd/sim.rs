//! `naic sim` (in progress).
use super::{CliError, CliResult};

#[derive(clap::Args, Default)]
pub struct SimArgs {}

pub fn run(_a: SimArgs) -> CliResult {
    Err(CliError::failure("naic sim is not implemented yet"))
}
