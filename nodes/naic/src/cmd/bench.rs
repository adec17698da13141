//! `naic bench …` (in progress).
use super::{CliError, CliResult};

#[derive(clap::Subcommand)]
pub enum BenchCmd {
    /// Median ns per call of the dynamics algorithms and one NAIC controller step.
    Dynamics,
    /// Latency of the 1 kHz DDS chain across the three node processes, Rust vs rclpy.
    Chain(super::bench_chain::ChainArgs),
}

pub fn run(c: BenchCmd) -> CliResult {
    match c {
        BenchCmd::Chain(a) => super::bench_chain::run(a),
        BenchCmd::Dynamics => Err(CliError::failure("naic bench dynamics is not implemented yet")),
    }
}
