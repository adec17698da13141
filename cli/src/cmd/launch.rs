//! `naic launch`: the three ROS 2 nodes as separate, supervised processes.
//!
//! Starts `jk5_sim_driver`, `friction_compensation` and `naic_controller` (found next to
//! the `naic` executable), in that order, each with `--params-file params/<node>.yaml`,
//! and prefixes every log line with the node name. The driver (the robot side) comes
//! first: it holds the arm until commands arrive.
//!
//! Supervision (`params/launch.yaml`, `--respawn`):
//! - a node that dies is reported with its exit status (code or signal);
//! - the driver keeps running and holds the arm (its command watchdog);
//! - with `respawn: true` (or `--respawn`) a dead `naic_controller` or
//!   `friction_compensation` is started again after `respawn_delay`; it takes over through
//!   friction_compensation's rate limit from the measured torque, as any restart does;
//! - a node that exits with code 2 refused its configuration: it is never respawned, and
//!   at the launch's first start everything is stopped (exit 2);
//! - if the driver dies nothing holds the arm any more: the other nodes are stopped (exit 4);
//! - Ctrl-C / SIGTERM / `--duration` stop the nodes one at a time in reverse start order,
//!   the driver last (SIGINT, then SIGKILL after a grace period).
//!
//! Exit codes: see [`Outcome::exit_code`].
//!
//! Chain: jk5_sim_driver → /joint_states, /wrench → naic_controller → /naic/effort →
//! friction_compensation → /joint_effort_cmd → jk5_sim_driver.

use std::{
    collections::BTreeMap,
    io::{BufRead, BufReader, Write},
    path::{Path, PathBuf},
    process::{Child, Command, ExitStatus, Stdio},
    sync::atomic::{AtomicBool, Ordering},
    time::{Duration, Instant},
};

use super::{CliError, CliResult};

/// The node binaries, in start order: the driver first (it holds the arm until commands
/// arrive), the controller last. They are stopped in the reverse order, the driver last.
pub const NODES: [&str; 3] = ["jk5_sim_driver", "friction_compensation", "naic_controller"];

/// The robot side: never respawned; when it dies the launch stops.
const DRIVER: &str = "jk5_sim_driver";

/// How long a node gets to stop on SIGINT before it is killed.
const STOP_GRACE: Duration = Duration::from_secs(5);

#[derive(clap::Args, Debug, Default)]
pub struct LaunchArgs {
    /// Directory with <node>.yaml parameter files.
    #[arg(long, default_value = "params")]
    pub params_dir: PathBuf,
    /// Launch parameters (per node: respawn, respawn_delay); default: PARAMS_DIR/launch.yaml
    /// if it exists.
    #[arg(long)]
    pub launch_file: Option<PathBuf>,
    /// Restart naic_controller and friction_compensation when they die (overrides the
    /// launch file's respawn: false).
    #[arg(long)]
    pub respawn: bool,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Run the driver in lockstep with the controller (simulated time, as fast as the chain allows).
    #[arg(long)]
    pub lockstep: bool,
    /// With --lockstep: simulated time runs at most this many times wall time (1: real
    /// time), so slower participants such as an rclpy script keep up (the driver's
    /// `real_time_factor`; default: as fast as the chain allows).
    #[arg(long, requires = "lockstep", value_parser = parse_real_time_factor)]
    pub real_time_factor: Option<f64>,
    /// Extra parameter for one node: NODE:NAME:=VALUE (repeatable), e.g.
    /// naic_controller:desired_force:=15.0
    #[arg(long = "param", short = 'p')]
    pub params: Vec<String>,
    /// Topic remap for one node: NODE:FROM:=TO (repeatable), e.g.
    /// friction_compensation:/joint_effort_cmd:=/effort_controller/commands
    #[arg(long = "remap", short = 'r')]
    pub remaps: Vec<String>,
    /// The three nodes in one process (one thread runs the control path, no DDS on it;
    /// every topic still on DDS): see docs/nodes.md, "One process or three".
    #[arg(long)]
    pub composed: bool,
    /// QoS of the chain's data topics on all three nodes (their `data_qos` parameter):
    /// reliable, or sensor_data (ROS's sensor-data profile, best effort).
    #[arg(long, value_parser = ["reliable", "sensor_data"])]
    pub qos: Option<String>,
    /// DDS Security: run every node in this SROS2 enclave, a directory
    /// KEYSTORE/enclaves/NAME (e.g. from `naic security init KEYSTORE`:
    /// KEYSTORE/enclaves/naic/chain). Sets ROS_SECURITY_ENABLE=true, ROS_SECURITY_KEYSTORE
    /// and ROS_SECURITY_ENCLAVE_OVERRIDE for the nodes; a node that cannot load it exits
    /// (never runs unsecured).
    #[arg(long)]
    pub enclave: Option<PathBuf>,
    /// The arm: a robot file (docs/robots.md), given to every node as `-p robot:=FILE`
    /// (URDF, joint names, frames, friction, start joints); default: the JK5. The simulated
    /// driver steps this arm in the scenario placed relative to its `start_q`.
    #[arg(long)]
    pub robot: Option<PathBuf>,
    /// A real arm: its ros2_control driver is the robot side, so no jk5_sim_driver is
    /// started, and the controller runs `scenario:=none` (it holds its start pose and follows
    /// /naic/target_pose and /naic/desired_wrench; never a simulated table's trajectory).
    /// Remap the topics onto the arm's controllers with -r (docs/deploy.md).
    #[arg(long, requires = "robot", conflicts_with_all = ["lockstep", "composed"])]
    pub real_arm: bool,
}

/// `--enclave DIR` → (keystore, enclave name): DIR is KEYSTORE/enclaves/NAME.
pub fn split_enclave_dir(dir: &Path) -> Result<(PathBuf, String), CliError> {
    let comps: Vec<_> = dir.components().collect();
    let at = comps.iter().rposition(|c| c.as_os_str() == "enclaves").ok_or_else(|| {
        CliError::usage(format!(
            "--enclave {}: expected an enclave directory KEYSTORE/enclaves/NAME (e.g. keystore/enclaves/naic/chain from `naic security init keystore`)",
            dir.display()
        ))
    })?;
    let keystore: PathBuf = comps[..at].iter().collect();
    let name: Vec<String> = comps[at + 1..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if name.is_empty() {
        return Err(CliError::usage(format!("--enclave {}: name the enclave below enclaves/, e.g. {}/naic/chain", dir.display(), dir.display())));
    }
    Ok((if keystore.as_os_str().is_empty() { PathBuf::from(".") } else { keystore }, format!("/{}", name.join("/"))))
}

/// `--enclave`: the ROS security variables for every node (and the composed process), after
/// checking the enclave's files, so a bad keystore stops the launch before any node starts.
fn apply_enclave(a: &LaunchArgs) -> CliResult {
    let Some(dir) = &a.enclave else { return Ok(()) };
    let (keystore, name) = split_enclave_dir(dir)?;
    let keystore = std::fs::canonicalize(&keystore).map_err(|e| CliError::usage(format!("--enclave {}: keystore {}: {e}", dir.display(), keystore.display())))?;
    let enclave = naic_ros::security::Enclave { name: name.clone(), dir: keystore.join("enclaves").join(name.trim_start_matches('/')) };
    enclave.check().map_err(|e| CliError::usage(format!("--enclave {}: {e}", dir.display())))?;
    if !naic_ros::security::AVAILABLE {
        return Err(CliError::usage(format!(
            "--enclave {}: this naic was built without DDS Security; rebuild with `cargo build --release --features naic_ros/security` (needs libssl-dev and pkg-config)",
            dir.display()
        )));
    }
    std::env::set_var("ROS_SECURITY_ENABLE", "true");
    std::env::set_var("ROS_SECURITY_KEYSTORE", &keystore);
    std::env::set_var("ROS_SECURITY_ENCLAVE_OVERRIDE", &name);
    eprintln!("naic launch: DDS Security on, enclave {name} of keystore {}", keystore.display());
    Ok(())
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
    /// The threads copying its stdout and stderr (done at the end of its output).
    copying: Vec<std::thread::JoinHandle<()>>,
}

impl NodeProcess {
    /// After the process has exited: wait up to `within` for its last lines to be copied.
    /// Without this a launch that stopped its nodes could exit before the copying threads
    /// had written what the nodes printed last (which fits, unproven, a loaded lockstep test
    /// whose log lacked the driver's stop report; docs/nodes.md).
    fn drain(&mut self, within: Duration) {
        let t0 = Instant::now();
        while self.copying.iter().any(|h| !h.is_finished()) && t0.elapsed() < within {
            std::thread::sleep(Duration::from_millis(5));
        }
        for h in self.copying.drain(..).filter(|h| h.is_finished()) {
            let _ = h.join();
        }
    }
}

/// Spawn one node binary with `args`, its stdout/stderr prefixed by `[name]` on our stderr.
///
/// The node gets its own process group, so a Ctrl-C in the terminal reaches only the
/// launcher, which then stops the nodes in order; and SIGINT when the launcher dies.
pub fn spawn_node(name: &str, bin: &Path, args: &[String], envs: &[(String, String)]) -> Result<NodeProcess, CliError> {
    let mut cmd = Command::new(bin);
    cmd.args(args).stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    for (k, v) in envs {
        cmd.env(k, v);
    }
    // If naic itself dies (even by SIGKILL), the kernel stops the node too: no orphans.
    // SIGINT, with which the launch stops a node, back to its default: a launch started in
    // the background of a script (`naic launch &`, nohup) inherits it ignored, a node would
    // too, and a node that is a shell script could not trap it (POSIX), so it would be
    // killed after the stop timeout instead of stopping cleanly.
    // SAFETY: prctl, setpgid and signal are async-signal-safe; nothing else runs between
    // fork and exec.
    unsafe {
        use std::os::unix::process::CommandExt;
        cmd.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            libc::setpgid(0, 0);
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGINT as libc::c_ulong);
            Ok(())
        });
    }
    let mut child = cmd
        .spawn()
        .map_err(|e| CliError::failure(format!("cannot start {}: {e}", bin.display())))?;
    let mut copying = vec![];
    for stream in [child.stdout.take().map(|s| Box::new(s) as Box<dyn std::io::Read + Send>),
                   child.stderr.take().map(|s| Box::new(s) as Box<dyn std::io::Read + Send>)]
        .into_iter()
        .flatten()
    {
        let prefix = format!("[{name}] ");
        copying.push(std::thread::spawn(move || {
            for line in BufReader::new(stream).lines().map_while(Result::ok) {
                let mut err = std::io::stderr().lock();
                let _ = writeln!(err, "{prefix}{line}");
            }
        }));
    }
    Ok(NodeProcess { name: name.to_string(), child, copying })
}

/// Stop one process: SIGINT, wait up to `grace`, then SIGKILL; then its last lines are
/// copied (at most 2 s more). Returns its exit status and whether it had to be killed.
fn stop_one(p: &mut NodeProcess, grace: Duration) -> (Option<ExitStatus>, bool) {
    let r = stop_child(p, grace);
    p.drain(Duration::from_secs(2));
    r
}

fn stop_child(p: &mut NodeProcess, grace: Duration) -> (Option<ExitStatus>, bool) {
    if let Ok(Some(st)) = p.child.try_wait() {
        return (Some(st), false);
    }
    if let Ok(pid) = i32::try_from(p.child.id()) {
        // SAFETY: sending a signal to our own child process id.
        unsafe { libc::kill(pid, libc::SIGINT) };
    }
    let t0 = Instant::now();
    loop {
        match p.child.try_wait() {
            Ok(Some(st)) => return (Some(st), false),
            Ok(None) if t0.elapsed() < grace => std::thread::sleep(Duration::from_millis(10)),
            _ => {
                let _ = p.child.kill();
                return (p.child.wait().ok(), true);
            }
        }
    }
}

/// Stop every process, one at a time from the last to the first (the reverse of the start
/// order), each with SIGINT then SIGKILL after `grace`. Returns the names of the processes
/// that had to be killed.
pub fn stop_all(procs: &mut [NodeProcess], grace: Duration) -> Vec<String> {
    let mut killed = vec![];
    for p in procs.iter_mut().rev() {
        if stop_one(p, grace).1 {
            killed.push(p.name.clone());
        }
    }
    killed
}

/// Supervision of one node, from the launch parameters (`params/launch.yaml`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeLaunch {
    /// Start the node again when it dies (not the driver).
    #[serde(default)]
    pub respawn: bool,
    /// Seconds between a death and the restart.
    #[serde(default = "default_respawn_delay")]
    pub respawn_delay: f64,
}

fn default_respawn_delay() -> f64 {
    0.5
}

impl Default for NodeLaunch {
    fn default() -> Self {
        NodeLaunch { respawn: false, respawn_delay: default_respawn_delay() }
    }
}

/// The launch parameters of every node (missing nodes: no respawn).
pub fn parse_launch_file(text: &str, file: &Path) -> Result<BTreeMap<String, NodeLaunch>, CliError> {
    let bad = |msg: String| CliError::usage(format!("launch file {}: {msg}", file.display()));
    let map: BTreeMap<String, NodeLaunch> = if text.trim().is_empty() {
        BTreeMap::new()
    } else {
        serde_yaml::from_str(text).map_err(|e| {
            bad(format!("{e} (expected `<node>: {{respawn: true|false, respawn_delay: seconds}}` for the nodes {})", NODES.join(", ")))
        })?
    };
    for (node, l) in &map {
        if !NODES.contains(&node.as_str()) {
            return Err(bad(format!("unknown node '{node}' (nodes: {})", NODES.join(", "))));
        }
        if !(l.respawn_delay.is_finite() && (0.0..=3600.0).contains(&l.respawn_delay)) {
            return Err(bad(format!("{node}: respawn_delay {} must be 0..=3600 seconds", l.respawn_delay)));
        }
        if node == DRIVER && l.respawn {
            return Err(bad(format!(
                "{DRIVER}: respawn is not supported: the driver is the robot side, a restarted simulator \
                 would start the arm again from its initial pose; when it dies naic launch stops the other \
                 nodes (exit 4). Set respawn: false"
            )));
        }
    }
    Ok(map)
}

/// Launch parameters: the file given, else `params_dir/launch.yaml` if it exists, else
/// defaults; `--respawn` turns respawn on for every node but the driver.
fn launch_params(a: &LaunchArgs) -> Result<BTreeMap<String, NodeLaunch>, CliError> {
    let (file, required) = match &a.launch_file {
        Some(f) => (f.clone(), true),
        None => (a.params_dir.join("launch.yaml"), false),
    };
    let mut map = match std::fs::read_to_string(&file) {
        Ok(text) => parse_launch_file(&text, &file)?,
        Err(e) if required || e.kind() != std::io::ErrorKind::NotFound => {
            return Err(CliError::usage(format!("launch file {}: {e}", file.display())))
        }
        Err(_) => BTreeMap::new(),
    };
    for node in NODES {
        let l = map.entry(node.to_string()).or_default();
        if a.respawn && node != DRIVER {
            l.respawn = true;
        }
    }
    Ok(map)
}

/// A `--real-time-factor` value outside the driver parameter's range (clap prints it after
/// naming the flag).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{given}' is not a real-time factor: give a number in (0, 1000], e.g. 1.0 for real time")]
pub struct RealTimeFactorError {
    given: String,
}

/// `--real-time-factor`: a finite number in (0, 1000] (the driver parameter's range).
fn parse_real_time_factor(s: &str) -> Result<f64, RealTimeFactorError> {
    match s.parse::<f64>() {
        Ok(f) if f > 0.0 && f <= 1000.0 => Ok(f),
        _ => Err(RealTimeFactorError { given: s.to_string() }),
    }
}

/// Command-line arguments of `node`: its params file, the launch overrides.
pub(super) fn node_args(node: &str, a: &LaunchArgs) -> Result<Vec<String>, CliError> {
    let file = a.params_dir.join(format!("{node}.yaml"));
    if !file.is_file() {
        return Err(CliError::usage(format!(
            "parameter file {} not found: run naic launch from the repository root or pass --params-dir",
            file.display()
        )));
    }
    let mut args = vec!["--ros-args".to_string(), "--params-file".to_string(), file.display().to_string()];
    if let Some(r) = &a.robot {
        args.extend(["-p".into(), format!("robot:={}", r.display())]);
    }
    if a.real_arm && node == "naic_controller" {
        args.extend(["-p".into(), "scenario:=none".into()]);
    }
    if a.lockstep && node == DRIVER {
        args.extend(["-p".into(), "lockstep:=true".into()]);
        if let Some(f) = a.real_time_factor {
            args.extend(["-p".into(), format!("real_time_factor:={f:?}")]);
        }
    }
    if a.lockstep {
        args.extend(["-p".into(), "use_sim_time:=true".into()]);
    }
    if let Some(q) = &a.qos {
        args.extend(["-p".into(), format!("data_qos:={q}")]);
    }
    for r in &a.remaps {
        let bad = || CliError::usage(format!("--remap '{r}': expected NODE:FROM:=TO, e.g. friction_compensation:/joint_effort_cmd:=/effort_controller/commands"));
        let (n, rest) = r.split_once(':').ok_or_else(bad)?;
        if !NODES.contains(&n) {
            return Err(CliError::usage(format!("--remap '{r}': unknown node '{n}' (nodes: {})", NODES.join(", "))));
        }
        if !rest.split_once(":=").is_some_and(|(f, t)| !f.is_empty() && !t.is_empty()) {
            return Err(bad());
        }
        if n == node {
            args.extend(["-r".into(), rest.to_string()]);
        }
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

/// What the launcher does when a node has exited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnExit {
    /// Start it again after its respawn delay.
    Respawn,
    /// Leave it dead; the others (the driver holding the arm) keep running.
    Leave,
    /// A node refused its configuration at the first start: stop everything (exit 2).
    StopConfig,
    /// The driver died: nothing holds the arm; stop the others (exit 4).
    StopDriverDied,
}

/// The supervision rule. `code`: the node's exit code (None: killed by a signal);
/// `first_start`: the launch's original instance of the node (not a respawn).
pub fn on_exit(node: &str, code: Option<i32>, first_start: bool, respawn: bool) -> OnExit {
    if node == DRIVER {
        OnExit::StopDriverDied
    } else if code == Some(2) && first_start {
        OnExit::StopConfig
    } else if code == Some(2) || !respawn {
        OnExit::Leave
    } else {
        OnExit::Respawn
    }
}

/// What happened during a launch, for the exit code and the final message.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Outcome {
    /// Deaths of nodes other than the driver (`name (status)`).
    pub deaths: Vec<String>,
    /// How many of them were respawned.
    pub respawns: usize,
    /// The driver died (its status).
    pub driver_died: Option<String>,
    /// A node refused its configuration at the first start (its name and status).
    pub config_refused: Option<String>,
    /// Nodes that did not stop on SIGINT within the grace period, or exited non-zero when
    /// asked to stop.
    pub unclean_stops: Vec<String>,
}

impl Outcome {
    /// The exit code of `naic launch`:
    /// - 0: ran until Ctrl-C / SIGTERM / `--duration`; no node died; every node exited 0
    ///   when asked to stop;
    /// - 1: could not start a node (binary missing, spawn failed);
    /// - 2: bad input: command line, launch or parameter file, or a node refused its
    ///   configuration at the first start (its own exit code 2);
    /// - 3: a node other than the driver died during the run (respawned or not) while the
    ///   driver held the arm;
    /// - 4: the driver died; the other nodes were stopped;
    /// - 5: no node died, but one did not stop cleanly (killed after the grace period, or a
    ///   non-zero exit on SIGINT).
    pub fn exit_code(&self) -> i32 {
        if self.driver_died.is_some() {
            4
        } else if self.config_refused.is_some() {
            2
        } else if !self.deaths.is_empty() {
            3
        } else if !self.unclean_stops.is_empty() {
            5
        } else {
            0
        }
    }

    fn into_result(self) -> CliResult {
        let code = self.exit_code();
        let mut parts = vec![];
        if let Some(d) = &self.driver_died {
            parts.push(format!("{d}: nothing held the arm any more, stopped the other nodes"));
        }
        if let Some(c) = &self.config_refused {
            parts.push(format!("{c}: it refused its configuration (see its message above); stopped the other nodes"));
        }
        if !self.deaths.is_empty() {
            parts.push(format!(
                "{} node exit(s) during the run: {} ({} respawned); the driver held the arm",
                self.deaths.len(),
                self.deaths.join(", "),
                self.respawns
            ));
        }
        if !self.unclean_stops.is_empty() {
            parts.push(format!("did not stop cleanly: {}", self.unclean_stops.join(", ")));
        }
        match code {
            0 => Ok(()),
            c => Err(CliError::with_code(c, parts.join("; "))),
        }
    }
}

/// One supervised node.
struct Slot {
    name: &'static str,
    bin: PathBuf,
    args: Vec<String>,
    launch: NodeLaunch,
    proc: Option<NodeProcess>,
    started: Instant,
    /// 0: the launch's original instance; n: the n-th respawn.
    instance: u32,
    respawn_at: Option<Instant>,
}

impl Slot {
    fn start(&mut self) -> CliResult {
        let p = spawn_node(self.name, &self.bin, &self.args, &[])?;
        let what = if self.instance == 0 { "started".to_string() } else { format!("respawned ({})", self.instance) };
        eprintln!("naic launch: {what} {} (pid {})", self.name, p.child.id());
        self.proc = Some(p);
        self.started = Instant::now();
        self.respawn_at = None;
        Ok(())
    }
}

/// `signal: 9 (SIGKILL)` / `exit status: 1`.
fn describe(st: &ExitStatus) -> String {
    st.to_string()
}

fn stop_slots(slots: &mut [Slot], outcome: &mut Outcome) {
    for s in slots.iter_mut().rev() {
        if let Some(p) = s.proc.as_mut() {
            eprintln!("naic launch: stopping {}", s.name);
            let (st, killed) = stop_one(p, STOP_GRACE);
            if killed {
                eprintln!("naic launch: had to kill {} (no exit within {} s of SIGINT)", s.name, STOP_GRACE.as_secs());
                outcome.unclean_stops.push(format!("{} (killed)", s.name));
            } else if let Some(st) = st.filter(|st| !st.success()) {
                eprintln!("naic launch: {} stopped with {}", s.name, describe(&st));
                outcome.unclean_stops.push(format!("{} ({})", s.name, describe(&st)));
            }
            s.proc = None;
        }
    }
}

pub fn run(a: LaunchArgs) -> CliResult {
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::usage(format!("--duration {d}: give a positive number of seconds")));
        }
    }
    // Check everything before starting anything.
    let launch = launch_params(&a)?;
    if let Some(r) = &a.robot {
        // The nodes check it again; a bad file stops the launch here, named, before any starts.
        naic_core::robot_file::Robot::load(r).map_err(|e| CliError::usage(format!("--robot: {e}")))?;
    }
    apply_enclave(&a)?;
    if a.composed {
        return super::composed::run(&a);
    }
    let mut slots = vec![];
    // A real arm: its own driver is the robot side (it holds the arm when commands stop).
    for node in NODES.into_iter().filter(|n| !(a.real_arm && *n == DRIVER)) {
        slots.push(Slot {
            name: node,
            bin: node_binary(node)?,
            args: node_args(node, &a)?,
            launch: launch[node].clone(),
            proc: None,
            started: Instant::now(),
            instance: 0,
            respawn_at: None,
        });
    }
    install_signal_handlers();
    let mut outcome = Outcome::default();
    for i in 0..slots.len() {
        if let Err(e) = slots[i].start() {
            stop_slots(&mut slots[..i], &mut outcome);
            return Err(e);
        }
    }
    let respawning: Vec<&str> = slots.iter().filter(|s| s.launch.respawn).map(|s| s.name).collect();
    if !respawning.is_empty() {
        eprintln!("naic launch: respawn on for {}", respawning.join(", "));
    }
    let t0 = Instant::now();
    'run: while !stop_requested() {
        if a.duration.is_some_and(|d| t0.elapsed().as_secs_f64() >= d) {
            break;
        }
        for s in slots.iter_mut() {
            let Some(p) = s.proc.as_mut() else { continue };
            let Ok(Some(st)) = p.child.try_wait() else { continue };
            s.proc = None;
            let status = format!("{} exited ({}) after {:.1} s", s.name, describe(&st), s.started.elapsed().as_secs_f64());
            match on_exit(s.name, st.code(), s.instance == 0, s.launch.respawn) {
                OnExit::StopDriverDied => {
                    eprintln!("naic launch: {status}; nothing holds the arm any more: stopping the other nodes");
                    outcome.driver_died = Some(status);
                    break 'run;
                }
                OnExit::StopConfig => {
                    eprintln!("naic launch: {status}: it refused its configuration; stopping the other nodes");
                    outcome.config_refused = Some(status);
                    break 'run;
                }
                OnExit::Respawn => {
                    eprintln!(
                        "naic launch: {status}; {DRIVER} holds the arm; respawning in {} s",
                        s.launch.respawn_delay
                    );
                    outcome.deaths.push(format!("{} ({})", s.name, describe(&st)));
                    s.respawn_at = Some(Instant::now() + Duration::from_secs_f64(s.launch.respawn_delay));
                }
                OnExit::Leave => {
                    let why = if st.code() == Some(2) {
                        "it refused its configuration, not respawned"
                    } else {
                        "not respawned (respawn is off: --respawn or the launch file)"
                    };
                    eprintln!("naic launch: {status}; {why}; {DRIVER} holds the arm; Ctrl-C stops the launch");
                    outcome.deaths.push(format!("{} ({})", s.name, describe(&st)));
                }
            }
        }
        for s in slots.iter_mut() {
            if s.respawn_at.is_some_and(|t| Instant::now() >= t) {
                s.instance += 1;
                if let Err(e) = s.start() {
                    eprintln!("naic launch: cannot respawn {}: {e}; {DRIVER} holds the arm", s.name);
                    s.respawn_at = None;
                } else {
                    outcome.respawns += 1;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    eprintln!("naic launch: stopping");
    stop_slots(&mut slots, &mut outcome);
    outcome.into_result()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stopped_node_s_last_lines_are_copied_before_stop_all_returns() {
        // A "node" that prints 50 lines when it gets SIGINT, then exits.
        let script = "trap 'i=0; while [ $i -lt 50 ]; do echo last line $i; i=$((i+1)); done; exit 0' INT; \
                      echo ready; while :; do sleep 0.01; done";
        let mut p = spawn_node("printer", Path::new("/bin/sh"), &["-c".to_string(), script.to_string()], &[]).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert_eq!(p.copying.len(), 2, "one copying thread each for stdout and stderr");
        let killed = stop_all(std::slice::from_mut(&mut p), Duration::from_secs(10));
        assert!(killed.is_empty(), "the script should exit on SIGINT");
        assert!(p.copying.is_empty(), "stop_all returned while {} copying threads were still running", p.copying.len());
    }

    #[test]
    fn an_enclave_directory_names_its_keystore_and_enclave() {
        let (ks, name) = split_enclave_dir(Path::new("/srv/ks/enclaves/naic/chain")).unwrap();
        assert_eq!((ks, name.as_str()), (PathBuf::from("/srv/ks"), "/naic/chain"));
        let (ks, name) = split_enclave_dir(Path::new("enclaves/a")).unwrap();
        assert_eq!((ks, name.as_str()), (PathBuf::from("."), "/a"));
        let e = split_enclave_dir(Path::new("/srv/ks/naic/chain")).unwrap_err().message;
        assert!(e.contains("KEYSTORE/enclaves/NAME"), "{e}");
        assert!(split_enclave_dir(Path::new("/srv/ks/enclaves")).is_err());
    }

    #[test]
    fn supervision_rule() {
        // The driver's death always ends the launch.
        for code in [None, Some(0), Some(1), Some(2)] {
            assert_eq!(on_exit(DRIVER, code, false, true), OnExit::StopDriverDied);
        }
        // A refused configuration at the first start stops all; later it is left dead.
        assert_eq!(on_exit("naic_controller", Some(2), true, true), OnExit::StopConfig);
        assert_eq!(on_exit("naic_controller", Some(2), false, true), OnExit::Leave);
        // Crashes and kills are respawned only when asked.
        assert_eq!(on_exit("naic_controller", None, true, true), OnExit::Respawn);
        assert_eq!(on_exit("friction_compensation", Some(101), true, true), OnExit::Respawn);
        assert_eq!(on_exit("friction_compensation", None, true, false), OnExit::Leave);
        assert_eq!(on_exit("naic_controller", Some(0), false, true), OnExit::Respawn);
    }

    #[test]
    fn exit_codes_say_what_happened() {
        let mut o = Outcome::default();
        assert_eq!(o.exit_code(), 0);
        o.unclean_stops.push("naic_controller (killed)".into());
        assert_eq!(o.exit_code(), 5);
        o.deaths.push("friction_compensation (signal: 9 (SIGKILL))".into());
        assert_eq!(o.exit_code(), 3);
        o.driver_died = Some("jk5_sim_driver exited".into());
        assert_eq!(o.exit_code(), 4);
        let refused = Outcome { config_refused: Some("x".into()), ..Default::default() };
        assert_eq!(refused.exit_code(), 2);
        let e = o.into_result().unwrap_err();
        assert_eq!(e.exit_code(), 4);
        assert!(e.message.contains("friction_compensation (signal: 9 (SIGKILL))") && e.message.contains("jk5_sim_driver"), "{}", e.message);
    }

    #[test]
    fn launch_file_is_checked() {
        let f = Path::new("launch.yaml");
        let m = parse_launch_file("naic_controller: {respawn: true, respawn_delay: 2.0}\n", f).unwrap();
        assert_eq!(m["naic_controller"], NodeLaunch { respawn: true, respawn_delay: 2.0 });
        assert!(parse_launch_file("# nothing\n", f).unwrap().is_empty());
        let e = parse_launch_file("naic_controler: {respawn: true}\n", f).unwrap_err();
        assert!(e.exit_code() == 2 && e.message.contains("unknown node 'naic_controler'"), "{}", e.message);
        let e = parse_launch_file("naic_controller: {respawn: true, delay: 1}\n", f).unwrap_err();
        assert!(e.message.contains("launch.yaml") && e.message.contains("delay"), "{}", e.message);
        let e = parse_launch_file("jk5_sim_driver: {respawn: true}\n", f).unwrap_err();
        assert!(e.message.contains("respawn is not supported"), "{}", e.message);
        let e = parse_launch_file("friction_compensation: {respawn_delay: -1}\n", f).unwrap_err();
        assert!(e.message.contains("respawn_delay"), "{}", e.message);
    }

    #[test]
    fn real_time_factor_goes_to_the_driver_and_is_checked() {
        let params = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../params"));
        let a = LaunchArgs { params_dir: params, lockstep: true, real_time_factor: Some(1.0), ..Default::default() };
        let driver = node_args(DRIVER, &a).unwrap();
        assert!(driver.windows(2).any(|w| w == ["-p", "real_time_factor:=1.0"]), "{driver:?}");
        for n in NODES.iter().filter(|n| **n != DRIVER) {
            assert!(!node_args(n, &a).unwrap().iter().any(|x| x.contains("real_time_factor")), "{n}");
        }
        assert!(parse_real_time_factor("0").unwrap_err().to_string().contains("(0, 1000]"));
        assert!(parse_real_time_factor("nan").is_err() && parse_real_time_factor("x").is_err());
        assert_eq!(parse_real_time_factor("2.5"), Ok(2.5));
        let e = parse_real_time_factor("-3").unwrap_err();
        assert_eq!(e, RealTimeFactorError { given: "-3".into() });
        assert!(e.to_string().contains("'-3'") && e.to_string().contains("e.g. 1.0 for real time"), "{e}");
    }

    #[test]
    fn robot_real_arm_and_remaps_reach_their_nodes() {
        let params = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../params"));
        let a = LaunchArgs {
            params_dir: params.clone(),
            robot: Some(PathBuf::from("params/robots/panda.yaml")),
            real_arm: true,
            remaps: vec!["friction_compensation:/joint_effort_cmd:=/effort_controller/commands".into()],
            ..Default::default()
        };
        for n in NODES {
            let args = node_args(n, &a).unwrap();
            assert!(args.windows(2).any(|w| w == ["-p", "robot:=params/robots/panda.yaml"]), "{n}: {args:?}");
            assert_eq!(args.windows(2).any(|w| w == ["-p", "scenario:=none"]), n == "naic_controller", "{n}: {args:?}");
            let remapped = args.windows(2).any(|w| w == ["-r", "/joint_effort_cmd:=/effort_controller/commands"]);
            assert_eq!(remapped, n == "friction_compensation", "{n}: {args:?}");
        }
        for bad in ["friction_compensation:/a", "nobody:/a:=/b", "friction_compensation::=/b"] {
            let a = LaunchArgs { params_dir: params.clone(), remaps: vec![bad.into()], ..Default::default() };
            let e = node_args("friction_compensation", &a).unwrap_err().message;
            assert!(e.contains("--remap") && e.contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn respawn_flag_covers_all_but_the_driver() {
        let a = LaunchArgs { respawn: true, params_dir: PathBuf::from("/nonexistent"), ..Default::default() };
        let m = launch_params(&a).unwrap();
        assert!(m["naic_controller"].respawn && m["friction_compensation"].respawn && !m[DRIVER].respawn);
        let a = LaunchArgs { launch_file: Some(PathBuf::from("/nonexistent/launch.yaml")), ..Default::default() };
        assert!(launch_params(&a).unwrap_err().message.contains("/nonexistent/launch.yaml"));
    }
}
