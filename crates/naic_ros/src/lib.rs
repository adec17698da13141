//! `naic_ros`: the thin DDS shell every naic ROS 2 node shares (ros2-client 0.12 / RustDDS).
//!
//! - [`context`]: one DDS participant per process, honouring `ROS_DOMAIN_ID`,
//!   `ROS_LOCALHOST_ONLY=1` and `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST|OFF`
//!   (loopback-only networks, 127.0.0.1);
//! - [`args`]: `--ros-args` (`-p`, `--params-file`, `-r __node:=`, `-r __ns:=`, topic remaps);
//! - [`params_file`]: ROS 2 parameter YAML (`node: ros__parameters:`, `/**`);
//! - [`params`]: declared parameters with descriptors, ranges and validation;
//! - [`node`]: [`RosNode`], which serves the six `rcl_interfaces` parameter services
//!   itself (with descriptors, which ros2-client lacks) and publishes `/parameter_events`;
//! - [`msgs`]: the message types on the wire;
//! - [`service`]: a node's own `std_srvs/srv/Trigger` services (served from its loop);
//! - [`log`]: stderr logging with the node name;
//! - pieces every node core shares, one implementation each: [`replay`] (a repeated
//!   stamp gets the same answer), [`timebase`] (wall or simulated time), [`joints`]
//!   (`/joint_states` by joint name), [`throttle`] (rate-limited reports) and
//!   [`alloc_check`] (no heap allocation in the 1 kHz step);
//! - [`source`]: who may publish on a node's input topics (one owner of the command).
//!
//! Nodes are thin shells: they copy messages into preallocated step-function inputs,
//! call the core/simulator step functions and publish the outputs.

pub mod alloc_check;
pub mod args;
pub mod context;
pub mod handoff;
pub mod log;
pub mod msgs;
pub mod node;
pub mod params;
pub mod joints;
pub mod params_file;
pub mod replay;
pub mod robot;
pub mod security;
pub mod service;
pub mod source;
mod reply;
pub mod threads;
pub mod throttle;
pub mod time;
pub mod timebase;

pub use args::RosArgs;
pub use node::RosNode;
pub use params::{ParamSpec, ParamTable, ParamView, Range};
pub use ros2_client::ParameterValue;

/// Everything that can go wrong setting up a node; the message names the input and the fix.
#[derive(Debug, thiserror::Error)]
pub enum RosError {
    /// `--help` was given: the text is the usage.
    #[error("{0}")]
    Help(String),
    /// Bad command-line arguments.
    #[error("bad arguments: {0}")]
    Args(String),
    /// Unreadable or malformed `--params-file`.
    #[error("{0}")]
    ParamsFile(String),
    /// A parameter value from the command line or a file was rejected.
    #[error("bad parameter: {0}")]
    Param(#[from] params::ParamError),
    /// Bad ROS environment variable (e.g. `ROS_DOMAIN_ID=abc`).
    #[error("bad environment: {0}")]
    Env(String),
    /// DDS participant/topic/service creation failed.
    #[error("DDS: {0}")]
    Dds(String),
    /// Anything else a node reports at start-up (e.g. a model file it could not load).
    #[error("{0}")]
    Node(String),
}

impl RosError {
    /// A parameter (or a file it names) refused by a node's own rule, in its words.
    pub fn param(reason: impl Into<String>) -> Self {
        RosError::Param(params::ParamError::Rule(reason.into()))
    }

    /// Exit code: 0 for help, 2 for user input, 1 for failures.
    pub fn exit_code(&self) -> i32 {
        match self {
            RosError::Help(_) => 0,
            RosError::Args(_) | RosError::ParamsFile(_) | RosError::Param(_) | RosError::Env(_) => 2,
            RosError::Dds(_) | RosError::Node(_) => 1,
        }
    }
}

/// Run a node's `main` body: print errors as one line naming the node, exit with its code.
pub fn run_main(node_name: &str, f: impl FnOnce() -> Result<(), RosError>) -> ! {
    let started = std::time::Instant::now();
    let r = f();
    threads::warn_busy_threads(node_name, started.elapsed());
    match r {
        Ok(()) => std::process::exit(0),
        Err(RosError::Help(u)) => {
            println!("{u}");
            std::process::exit(0)
        }
        Err(e) => {
            eprintln!("{node_name}: error: {e}");
            std::process::exit(e.exit_code())
        }
    }
}

/// Set by SIGINT/SIGTERM; the nodes' loops check it and exit cleanly.
pub fn shutdown_requested() -> bool {
    SHUTDOWN.load(std::sync::atomic::Ordering::Relaxed)
}

static SHUTDOWN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Ask for shutdown from code (a tool whose run ended, e.g. `naic record --duration`): the
/// same flag SIGINT/SIGTERM set. From then on the DDS internals' complaints while the
/// participant is torn down are not logged (see `log.rs`).
pub fn request_shutdown() {
    SHUTDOWN.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Install SIGINT/SIGTERM handlers that set [`shutdown_requested`].
pub fn install_signal_handlers() {
    extern "C" fn on_signal(_: libc::c_int) {
        SHUTDOWN.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
}

pub mod wait;

#[cfg(test)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;
