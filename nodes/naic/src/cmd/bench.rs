//! `naic bench …` (in progress).
use super::{CliError, CliResult};

#[derive(clap::Subcommand)]
pub enum BenchCmd {
    /// Median ns per call of the dynamics algorithms and one NAIC controller step.
    Dynamics,
    /// Bag read+decode messages/s (1 kHz, 4 topics, 60 s) against Python mcap_ros2, same file.
    Bag {
        #[arg(long)]
        json: bool,
        /// Length of the generated bag [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
    },
    /// Latency of the 1 kHz DDS chain across the three node processes, Rust vs rclpy.
    Chain(super::bench_chain::ChainArgs),
    /// Record 4 topics at 1 kHz over DDS (naic replay -> naic record): drops and timing.
    Record {
        #[arg(long)]
        json: bool,
        /// Length of the replayed bag [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
    },
}

pub fn run(c: BenchCmd) -> CliResult {
    match c {
        BenchCmd::Bag { json, seconds } => super::bag::bench(json, seconds),
        BenchCmd::Chain(a) => super::bench_chain::run(a),
        BenchCmd::Record { json, seconds } => super::record::bench_record(json, seconds),
        BenchCmd::Dynamics => Err(CliError::failure("naic bench dynamics is not implemented yet")),
    }
}
