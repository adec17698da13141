//! `naic`: the command-line front end of the project.
//!
//! Every subcommand lives in its own module under `cmd/`; this file only
//! parses the command line and dispatches. Errors are reported as one clear
//! message on stderr and exit code 2 (bad input) or 1 (failure), never a panic.

use clap::{Parser, Subcommand};

mod cmd;

#[derive(Parser)]
#[command(name = "naic", version, about = "Neural adaptive impedance control for force tracking on a simulated JAKA JK5")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Joint friction: fit equation 4/5 models to measured data.
    #[command(subcommand)]
    Friction(cmd::friction::FrictionCmd),
    /// The tool on the F/T sensor: identify its mass and centre of mass from static poses.
    #[command(subcommand)]
    Tool(cmd::tool::ToolCmd),
    /// Benchmarks that print JSON numbers.
    #[command(subcommand)]
    Bench(cmd::bench::BenchCmd),
    /// MCAP bags: info, repair, export-csv.
    #[command(subcommand)]
    Bag(cmd::bag::BagCmd),
    /// Record naic topics from DDS into a rosbag2-compatible MCAP bag.
    Record(cmd::record::RecordArgs),
    /// Publish a bag's messages over DDS with their original timing.
    Replay(cmd::record::ReplayArgs),
    /// Force-tracking figures (SVG) of any recording.
    Plot(cmd::plot::PlotArgs),
    /// Run a paper scenario in the in-process simulator (default: flat, all controllers).
    Sim(cmd::sim::SimArgs),
    /// Explain measured data: where the nominal model is wrong, which extension fixes it, and by how much.
    Explain(cmd::explain::ExplainArgs),
    /// DDS Security: create an SROS2-layout keystore (`naic security init KEYSTORE`).
    #[command(subcommand)]
    Security(cmd::security::SecurityCmd),
    /// Start the three ROS 2 nodes (driver, controller, friction compensation) as processes.
    Launch(cmd::launch::LaunchArgs),
    /// Every ROS parameter of the three nodes, as they declare it (`--markdown`: docs/parameters.md).
    Params(cmd::params::ParamsArgs),
    /// Get or set one parameter of a running node over DDS (`ros2 param get|set`; honours the ROS security variables).
    #[command(subcommand)]
    Param(cmd::param::ParamCmd),
}

fn main() {
    let cli = Cli::parse();
    // With no subcommand, run the main job: the flat-surface reproduction with every controller.
    let command = cli.command.unwrap_or_else(|| Command::Sim(cmd::sim::SimArgs::default()));
    let result = match command {
        Command::Friction(c) => cmd::friction::run(c),
        Command::Bench(c) => cmd::bench::run(c),
        Command::Tool(c) => cmd::tool::run(c),
        Command::Sim(a) => cmd::sim::run(a),
        Command::Explain(a) => cmd::explain::run(a),
        Command::Bag(c) => cmd::bag::run(c),
        Command::Record(a) => cmd::record::record(a),
        Command::Replay(a) => cmd::record::replay(a),
        Command::Plot(a) => cmd::plot::run(a),
        Command::Launch(a) => cmd::launch::run(a),
        Command::Params(a) => cmd::params::run(a),
        Command::Param(c) => cmd::param::run(c),
        Command::Security(c) => cmd::security::run(c),
    };
    if let Err(e) = result {
        eprintln!("naic: error: {e}");
        std::process::exit(e.exit_code());
    }
}
