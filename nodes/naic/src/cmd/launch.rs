//! `naic launch`: the three ROS 2 nodes as separate processes.
//!
//! Starts `jk5_sim_driver`, `naic_controller` and `friction_compensation` (found next to
//! the `naic` executable) with `--params-file params/<node>.yaml`, prefixes every log line
//! with the node name, and stops all of them cleanly (SIGINT, then SIGKILL after a grace
//! period) on Ctrl-C / SIGTERM, when `--duration` has passed, or when one of them fails.
//!
//! Chain: jk5_sim_driver → /joint_states, /wrench → naic_controller → /naic/effort →
//! friction_compensation → /joint_effort_cmd → jk5_sim_driver.

use std::{
    io::{BufRead, BufReader, Write},
    path::{Path, PathBuf},
    process::{Child, Command, Stdio},
    sync::atomic::{AtomicBool, Ordering},
    time::{Duration, Instant},
};

use super::{CliError, CliResult};

/// The node binaries, in start order (the driver last, so the chain is ready when the
/// first state arrives).
pub const NODES: [&str; 3] = ["naic_controller", "friction_compensation", "jk5_sim_driver"];

#[derive(clap::Args, Debug, Default)]
pub struct LaunchArgs {
    /// Directory with <node>.yaml parameter files.
    #[arg(long, default_value = "params")]
    pub params_dir: PathBuf,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Run the driver in lockstep with the controller (simulated time, as fast as the chain allows).
    #[arg(long)]
    pub lockstep: bool,
    /// Extra parameter for one node: NODE:NAME:=VALUE (repeatable), e.g.
    /// naic_controller:desired_force:=15.0
    #[arg(long = "param", short = 'p')]
    pub params: Vec<String>,
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

/// Install SIGINT/SIGTERM handlers that request a clean stop.
pub fn install_signal_handlers() {
    // SAFETY: the handler only stores to an atomic (async-signal-safe).
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
}

pub fn stop_requested() -> bool {
    STOP.load(Ordering::Relaxed)
}

/// Where the node binaries are: beside the running `naic`.
pub fn node_binary(name: &str) -> Result<PathBuf, CliError> {
    let exe = std::env::current_exe().map_err(|e| CliError::failure(format!("cannot locate naic itself: {e}")))?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let p = dir.join(name);
    if p.is_file() {
        Ok(p)
    } else {
        Err(CliError::failure(format!(
            "node binary {} not found; build the nodes with `cargo build --release` (they sit beside naic)",
            p.display()
        )))
    }
}

/// A running node process whose output is copied with a `[name]` prefix.
pub struct NodeProcess {
    pub name: String,
    pub child: Child,
}

/// Spawn one node binary with `args`, its stdout/stderr prefixed by `[name]` on our stderr.
pub fn spawn_node(name: &str, bin: &Path, args: &[String], envs: &[(String, String)]) -> Result<NodeProcess, CliError> {
    let mut cmd = Command::new(bin);
    cmd.args(args).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    for (k, v) in envs {
        cmd.env(k, v);
    }
    // If naic itself dies (even by SIGKILL), the kernel stops the node too: no orphans.
    // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        use std::os::unix::process::CommandExt;
        cmd.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGINT as libc::c_ulong);
            Ok(())
        });
    }
    let mut child = cmd
        .spawn()
        .map_err(|e| CliError::failure(format!("cannot start {}: {e}", bin.display())))?;
    for stream in [child.stdout.take().map(|s| Box::new(s) as Box<dyn std::io::Read + Send>),
                   child.stderr.take().map(|s| Box::new(s) as Box<dyn std::io::Read + Send>)]
        .into_iter()
        .flatten()
    {
        let prefix = format!("[{name}] ");
        std::thread::spawn(move || {
            for line in BufReader::new(stream).lines().map_while(Result::ok) {
                let mut err = std::io::stderr().lock();
                let _ = writeln!(err, "{prefix}{line}");
            }
        });
    }
    Ok(NodeProcess { name: name.to_string(), child })
}

/// Ask every process to stop (SIGINT), wait up to `grace`, then kill what is left.
/// Returns the names of the processes that had to be killed.
pub fn stop_all(procs: &mut [NodeProcess], grace: Duration) -> Vec<String> {
    for p in procs.iter() {
        if let Ok(pid) = i32::try_from(p.child.id()) {
            // SAFETY: sending a signal to our own child process id.
            unsafe { libc::kill(pid, libc::SIGINT) };
        }
    }
    let t0 = Instant::now();
    let mut killed = vec![];
    for p in procs.iter_mut() {
        loop {
            match p.child.try_wait() {
                Ok(Some(_)) => break,
                Ok(None) if t0.elapsed() < grace => std::thread::sleep(Duration::from_millis(20)),
                _ => {
                    let _ = p.child.kill();
                    let _ = p.child.wait();
                    killed.push(p.name.clone());
                    break;
                }
            }
        }
    }
    killed
}

/// Command-line arguments of `node`: its params file, the launch overrides.
fn node_args(node: &str, a: &LaunchArgs) -> Result<Vec<String>, CliError> {
    let file = a.params_dir.join(format!("{node}.yaml"));
    if !file.is_file() {
        return Err(CliError::usage(format!(
            "parameter file {} not found: run naic launch from the repository root or pass --params-dir",
            file.display()
        )));
    }
    let mut args = vec!["--ros-args".to_string(), "--params-file".to_string(), file.display().to_string()];
    if a.lockstep && node == "jk5_sim_driver" {
        args.extend(["-p".into(), "lockstep:=true".into()]);
    }
    if a.lockstep {
        args.extend(["-p".into(), "use_sim_time:=true".into()]);
    }
    for p in &a.params {
        let Some((n, rest)) = p.split_once(':') else {
            return Err(CliError::usage(format!("--param '{p}': expected NODE:NAME:=VALUE")));
        };
        if !NODES.contains(&n) {
            return Err(CliError::usage(format!("--param '{p}': unknown node '{n}' (nodes: {})", NODES.join(", "))));
        }
        if !rest.contains(":=") {
            return Err(CliError::usage(format!("--param '{p}': expected NODE:NAME:=VALUE")));
        }
        if n == node {
            args.extend(["-p".into(), rest.to_string()]);
        }
    }
    Ok(args)
}

pub fn run(a: LaunchArgs) -> CliResult {
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::usage(format!("--duration {d}: give a positive number of seconds")));
        }
    }
    // Check everything before starting anything.
    let mut plan = vec![];
    for node in NODES {
        plan.push((node, node_binary(node)?, node_args(node, &a)?));
    }
    install_signal_handlers();
    let mut procs = vec![];
    for (node, bin, args) in &plan {
        eprintln!("naic launch: starting {node}");
        match spawn_node(node, bin, args, &[]) {
            Ok(p) => procs.push(p),
            Err(e) => {
                stop_all(&mut procs, Duration::from_secs(3));
                return Err(e);
            }
        }
    }
    let t0 = Instant::now();
    let mut failed: Option<String> = None;
    while !stop_requested() {
        if a.duration.is_some_and(|d| t0.elapsed().as_secs_f64() >= d) {
            break;
        }
        for p in procs.iter_mut() {
            if let Ok(Some(status)) = p.child.try_wait() {
                failed = Some(format!("{} exited ({status})", p.name));
            }
        }
        if failed.is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    eprintln!("naic launch: stopping");
    let killed = stop_all(&mut procs, Duration::from_secs(5));
    if !killed.is_empty() {
        eprintln!("naic launch: had to kill {}", killed.join(", "));
    }
    match failed {
        Some(f) => Err(CliError::failure(format!("{f}; stopped the other nodes"))),
        None => Ok(()),
    }
}
