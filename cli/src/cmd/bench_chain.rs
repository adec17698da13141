//! `naic bench chain`: latency of the 1 kHz control chain across three processes.
//!
//! Measures, for every `/joint_states` sample the driver publishes, the time until the
//! driver receives the matching `/joint_effort_cmd` (driver → controller → friction
//! compensation → driver; the stamp travels in the command's dimension label), plus the
//! missed cycles (the command for the previous state had not arrived by the next tick).
//! First the Rust nodes, then the same topology in rclpy (`tests/ros/rclpy_chain.py`), in
//! the same run, each on its own loopback-only DDS domain. With `--composed`, also the three
//! nodes in one process (`naic launch --composed`, the same cores, the same report) on a
//! third domain. With `--floor`, then the machine's floor on the same CPU and priority:
//! `cyclictest` and a 1 kHz loop doing the chain's median latency in CPU work per cycle. The
//! driver's report splits the missed cycles into those with a late wake-up of the driver
//! itself and those with the driver on time. Prints one JSON object.

use std::{
    path::{Path, PathBuf},
    process::Command,
    time::{Duration, Instant},
};

use super::{
    launch::{self, node_binary, spawn_node, stop_all},
    CliError, CliResult,
};

#[derive(clap::Args, Debug)]
pub struct ChainArgs {
    /// Measured seconds per chain (after a 2 s warm-up).
    #[arg(long, default_value_t = 60.0)]
    pub duration: f64,
    /// Python with rclpy for the reference chain (default: $NAIC_PYTHON, else python3).
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// Only the Rust chain.
    #[arg(long)]
    pub skip_rclpy: bool,
    /// SCHED_RR priority for the Rust nodes (0: normal scheduling, as the rclpy chain;
    /// overrides params/).
    #[arg(long, default_value_t = 0)]
    pub realtime_priority: u8,
    /// Pin the Rust nodes to this CPU (-1: no pinning; default: params/, CPU 1). On the 2-core
    /// test VM one CPU avoids cross-CPU wake-ups (BENCHMARKS.md). The rclpy chain is never
    /// pinned: on one CPU it cannot keep up with 1 kHz (median 9.5 ms), so unpinned is its best.
    #[arg(long, allow_negative_numbers = true)]
    pub cpu: Option<i64>,
    /// QoS of the chain's data topics on the Rust nodes: reliable (the default), or
    /// sensor_data (ROS's sensor-data profile: best effort, keep last 5).
    #[arg(long, default_value = "reliable", value_parser = ["reliable", "sensor_data"])]
    pub qos: String,
    /// Also run the three nodes in one process (`naic launch --composed`) with the same
    /// priority and CPU, after the three processes.
    #[arg(long)]
    pub composed: bool,
    /// Also measure the machine's floor right after the chains, each for the same duration, at
    /// the same priority, on the same CPU: `cyclictest` (rt-tests, if installed; how often a
    /// lone SCHED_RR thread woke up late), and a 1 kHz loop in this process that does the
    /// chain's median latency in fixed CPU work after each wake-up (how often that work ended
    /// after the next deadline). The honest references for the missed cycles.
    #[arg(long)]
    pub floor: bool,
    /// ROS_DOMAIN_ID of the Rust chain (the rclpy chain uses the next one, the composed run
    /// the one after).
    #[arg(long, default_value_t = 211)]
    pub domain: u16,
    /// DDS Security's cost: also run the Rust chain (and the composed run, with --composed)
    /// with every node in this SROS2 enclave (KEYSTORE/enclaves/NAME, e.g. from `naic security
    /// init`), right after the same chain without security; reports both and their median
    /// ratio. Needs a build with --features naic_ros/security.
    #[arg(long)]
    pub enclave: Option<PathBuf>,
}

/// The security variables of `--enclave DIR` for the nodes (after checking its files).
fn enclave_env(dir: &Path) -> Result<Vec<(String, String)>, CliError> {
    let (keystore, name) = launch::split_enclave_dir(dir)?;
    let keystore = std::fs::canonicalize(&keystore).map_err(|e| CliError::usage(format!("--enclave {}: keystore {}: {e}", dir.display(), keystore.display())))?;
    let enclave = naic_ros::security::Enclave { name: name.clone(), dir: keystore.join("enclaves").join(name.trim_start_matches('/')) };
    enclave.check().map_err(|e| CliError::usage(format!("--enclave {}: {e}", dir.display())))?;
    if !naic_ros::security::AVAILABLE {
        return Err(CliError::usage("--enclave: this naic was built without DDS Security; rebuild with `cargo build --release --workspace --features naic_ros/security`"));
    }
    Ok(vec![
        ("ROS_SECURITY_ENABLE".into(), "true".into()),
        ("ROS_SECURITY_KEYSTORE".into(), keystore.display().to_string()),
        ("ROS_SECURITY_ENCLAVE_OVERRIDE".into(), name),
    ])
}

const WARMUP: f64 = 2.0;

fn env(domain: u16) -> Vec<(String, String)> {
    vec![
        ("ROS_DOMAIN_ID".into(), domain.to_string()),
        ("ROS_AUTOMATIC_DISCOVERY_RANGE".into(), "LOCALHOST".into()),
    ]
}

fn read_report(path: &Path) -> Result<serde_json::Value, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::failure(format!("no latency report at {}: {e}", path.display())))?;
    serde_json::from_str(&text).map_err(|e| CliError::failure(format!("bad latency report {}: {e}", path.display())))
}

fn rust_chain(a: &ChainArgs, dir: &Path, security: &[(String, String)]) -> Result<serde_json::Value, CliError> {
    let report = dir.join("rust_chain.json");
    let _ = std::fs::remove_file(&report);
    let mut procs = vec![];
    for node in launch::NODES {
        let mut args = vec!["--ros-args".to_string(), "--params-file".into(), format!("params/{node}.yaml")];
        args.extend(["-p".into(), format!("realtime_priority:={}", a.realtime_priority)]);
        args.extend(["-p".into(), format!("data_qos:={}", a.qos)]);
        if let Some(cpu) = a.cpu {
            args.extend(["-p".into(), format!("cpu_affinity:={cpu}")]);
        }
        if node == "jk5_sim_driver" {
            args.extend([
                "-p".into(),
                format!("latency_report:={}", report.display()),
                "-p".into(),
                format!("latency_warmup:={WARMUP}"),
            ]);
        }
        let bin = node_binary(node)?;
        let envs: Vec<(String, String)> = env(a.domain).into_iter().chain(security.iter().cloned()).collect();
        match spawn_node(node, &bin, &args, &envs) {
            Ok(p) => procs.push(p),
            Err(e) => {
                stop_all(&mut procs, Duration::from_secs(3));
                return Err(e);
            }
        }
    }
    wait(a.duration + WARMUP, &mut procs)?;
    // The driver first (it writes the report as it exits). Stopped last, as `naic launch`
    // stops the chain, it counted every cycle between the controller's exit and its own as
    // missed: 140-180 of them per run, half of what this bench used to report.
    let (driver, others) = procs.split_at_mut(1);
    stop_all(driver, Duration::from_secs(5));
    stop_all(others, Duration::from_secs(5));
    read_report(&report)
}

/// The three nodes in one process: `naic launch --composed` with the driver's latency
/// report, as [`rust_chain`] runs them.
fn composed_chain(a: &ChainArgs, dir: &Path, security: &[(String, String)]) -> Result<serde_json::Value, CliError> {
    let report = dir.join("composed_chain.json");
    let _ = std::fs::remove_file(&report);
    let exe = std::env::current_exe().map_err(|e| CliError::failure(format!("cannot locate naic itself: {e}")))?;
    let d = "jk5_sim_driver";
    let mut args: Vec<String> = vec!["launch".into(), "--composed".into(), "--duration".into(), format!("{}", a.duration + WARMUP)];
    let mut set = |kv: String| args.extend(["-p".to_string(), format!("{d}:{kv}")]);
    set(format!("realtime_priority:={}", a.realtime_priority));
    if let Some(cpu) = a.cpu {
        set(format!("cpu_affinity:={cpu}"));
    }
    set(format!("latency_report:={}", report.display()));
    set(format!("latency_warmup:={WARMUP}"));
    let envs: Vec<(String, String)> = env(a.domain + 2).into_iter().chain(security.iter().cloned()).collect();
    let mut p = vec![spawn_node("composed", &exe, &args, &envs)?];
    let t0 = Instant::now();
    let status = loop {
        if let Ok(Some(st)) = p[0].child.try_wait() {
            break Some(st);
        }
        if launch::stop_requested() || t0.elapsed().as_secs_f64() > a.duration + WARMUP + 30.0 {
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    match status {
        Some(st) if st.success() => read_report(&report),
        Some(st) => Err(CliError::failure(format!("naic launch --composed failed ({st})"))),
        None => {
            stop_all(&mut p, Duration::from_secs(5));
            Err(CliError::failure("naic launch --composed did not finish"))
        }
    }
}

fn wait(seconds: f64, procs: &mut [launch::NodeProcess]) -> CliResult {
    let t0 = Instant::now();
    while t0.elapsed().as_secs_f64() < seconds {
        if launch::stop_requested() {
            return Err(CliError::failure("interrupted"));
        }
        for p in procs.iter_mut() {
            if let Ok(Some(st)) = p.child.try_wait() {
                return Err(CliError::failure(format!("{} exited early ({st})", p.name)));
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

fn rclpy_chain(a: &ChainArgs, dir: &Path) -> Result<serde_json::Value, CliError> {
    let py = a
        .python
        .clone()
        .or_else(|| std::env::var_os("NAIC_PYTHON").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("python3"));
    let script = Path::new("tests/ros/rclpy_chain.py");
    if !script.is_file() {
        return Err(CliError::usage("tests/ros/rclpy_chain.py not found: run from the repository root"));
    }
    let report = dir.join("rclpy_chain.json");
    let _ = std::fs::remove_file(&report);
    let s = script.display().to_string();
    let mut procs = vec![];
    for role in ["controller", "friction"] {
        procs.push(spawn_node(&format!("rclpy_{role}"), &py, &[s.clone(), role.into()], &env(a.domain + 1))?);
    }
    let args = vec![
        s,
        "driver".into(),
        "--duration".into(),
        format!("{}", a.duration + WARMUP),
        "--warmup".into(),
        format!("{WARMUP}"),
        "--report".into(),
        report.display().to_string(),
    ];
    let mut driver = spawn_node("rclpy_driver", &py, &args, &env(a.domain + 1))?;
    let t0 = Instant::now();
    let status = loop {
        if let Ok(Some(st)) = driver.child.try_wait() {
            break Some(st);
        }
        if launch::stop_requested() || t0.elapsed().as_secs_f64() > a.duration + WARMUP + 60.0 {
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    stop_all(&mut procs, Duration::from_secs(5));
    match status {
        Some(st) if st.success() => read_report(&report),
        Some(st) => Err(CliError::failure(format!("rclpy driver failed ({st}); is rclpy installed in {}?", py.display()))),
        None => {
            stop_all(std::slice::from_mut(&mut driver), Duration::from_secs(3));
            Err(CliError::failure("rclpy chain did not finish"))
        }
    }
}

/// The floor: `cyclictest -m -p P --policy=rr -i 1000 -D S -a CPU`, one SCHED_RR thread waking every
/// millisecond and nothing else. Late wake-ups are counted over thresholds, and converted to
/// the cycles a chain whose median is `chain_median_us` would have missed: a wake-up L late
/// leaves the chain `1000 - L` µs, and cyclictest skips the periods it slept through, so a
/// wake-up later than the chain's budget costs ⌈(L - budget) / 1 ms⌉ cycles.
fn floor(a: &ChainArgs, dir: &Path, chain_median_us: f64) -> Result<serde_json::Value, CliError> {
    let hist = dir.join("cyclictest.hist");
    let mut args = vec!["-m".to_string(), "-q".into(), "-i".into(), "1000".into(), "-D".into(), format!("{}", a.duration.ceil() as u64)];
    args.extend(["-h".into(), "20000".into(), format!("--histfile={}", hist.display())]);
    if a.realtime_priority > 0 {
        args.extend(["-p".into(), a.realtime_priority.to_string(), "--policy=rr".into()]);
    }
    match a.cpu.unwrap_or(1) {
        -1 => {}
        cpu => args.extend(["-a".into(), cpu.to_string()]),
    }
    let st = Command::new("cyclictest")
        .args(&args)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| CliError::failure(format!("--floor needs cyclictest (rt-tests): {e}")))?;
    if !st.success() {
        return Err(CliError::failure(format!("cyclictest {} failed ({st})", args.join(" "))));
    }
    let text = std::fs::read_to_string(&hist).map_err(|e| CliError::failure(format!("no cyclictest histogram: {e}")))?;
    let header = |key: &str| -> Option<u64> {
        text.lines().find(|l| l.starts_with(key)).and_then(|l| l[key.len()..].split_whitespace().next()).and_then(|v| v.parse().ok())
    };
    let buckets: Vec<(u64, u64)> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let mut f = l.split_whitespace().map(|x| x.parse::<u64>());
            match (f.next(), f.next()) {
                (Some(Ok(us)), Some(Ok(n))) => Some((us, n)),
                _ => None,
            }
        })
        .collect();
    let overflows = header("# Histogram Overflows:").unwrap_or(0);
    let max_us = header("# Max Latencies:").unwrap_or(0);
    let n: u64 = buckets.iter().map(|b| b.1).sum::<u64>() + overflows;
    let over = |us: u64| buckets.iter().filter(|b| b.0 > us).map(|b| b.1).sum::<u64>() + overflows;
    let budget_us = (1000.0 - chain_median_us).max(0.0);
    let cost = |l: f64| ((l - budget_us) / 1000.0).ceil().max(0.0) as u64;
    let equivalent: u64 = buckets.iter().filter(|b| b.0 as f64 > budget_us).map(|b| b.1 * cost(b.0 as f64)).sum::<u64>()
        + overflows * cost(max_us as f64); // beyond 20 ms: counted at the maximum (an upper bound)
    let quantile = |f: f64| {
        let rank = (f * n as f64).ceil() as u64;
        let mut acc = 0;
        for &(us, c) in &buckets {
            acc += c;
            if acc >= rank {
                return us;
            }
        }
        max_us
    };
    Ok(serde_json::json!({
        "command": format!("cyclictest {}", args.join(" ")),
        "wakeups": n,
        "median_us": quantile(0.5),
        "p99_us": quantile(0.99),
        "p9999_us": quantile(0.9999),
        "max_us": max_us,
        "late_over_500us": over(500),
        "late_over_1ms": over(1000),
        "chain_budget_us": budget_us,
        "equivalent_missed_cycles": equivalent,
        "equivalent_missed_percent": if n > 0 { 100.0 * equivalent as f64 / n as f64 } else { f64::NAN },
    }))
}

/// The floor for a job with work: a SCHED_RR thread (the chain's priority and CPU) that
/// wakes every 1 ms (absolute deadlines, overdue periods run back to back, as the driver's
/// loop) and then does `work_us` of fixed CPU work (an iteration count calibrated before, on
/// the fastest of 30 tries). A cycle whose work ends after the next deadline is an overrun:
/// what a chain that needs `work_us` per cycle would miss on this CPU, with no DDS. The work's
/// wall time shows when the CPU itself ran slow (the same iterations taking many times longer).
fn work_floor(a: &ChainArgs, work_us: f64) -> Result<serde_json::Value, CliError> {
    use std::hint::black_box;
    fn spin(n: u64) -> u64 {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for i in 0..n {
            x = black_box(x.rotate_left(7) ^ i).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        }
        x
    }
    let (prio, cpu, seconds) = (a.realtime_priority as i32, a.cpu.unwrap_or(1), a.duration);
    let t = std::thread::spawn(move || -> Result<serde_json::Value, FloorError> {
        if cpu >= 0 {
            naic_ros::node::pin_to_cpu(cpu as usize).map_err(|e| FloorError::Pin { cpu, problem: e.to_string() })?;
        }
        if prio > 0 {
            naic_ros::node::set_realtime(prio).map_err(|e| FloorError::Realtime { priority: prio, problem: e.to_string() })?;
        }
        let calib = 20_000u64;
        let best = (0..30)
            .map(|_| {
                let t0 = Instant::now();
                black_box(spin(calib));
                t0.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        let iters = (work_us * 1e-6 / best * calib as f64).round().max(1.0) as u64;
        let now_ns = || {
            let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
            // SAFETY: valid pointer to a timespec.
            unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
            ts.tv_sec as i64 * 1_000_000_000 + ts.tv_nsec as i64
        };
        let period = 1_000_000i64;
        let (mut wake, mut work) = (Vec::with_capacity(seconds as usize * 1000 + 16), Vec::with_capacity(seconds as usize * 1000 + 16));
        let (mut overruns, mut episodes, mut in_episode) = (0u64, 0u64, false);
        let start = now_ns();
        let mut next = start;
        while next - start < (seconds * 1e9) as i64 {
            next += period;
            if now_ns() > next + 10 * period {
                next = now_ns(); // fell far behind: resynchronise, as the driver does
            }
            let ts = libc::timespec { tv_sec: (next / 1_000_000_000) as libc::time_t, tv_nsec: (next % 1_000_000_000) as libc::c_long };
            // SAFETY: absolute sleep on CLOCK_MONOTONIC with a valid timespec.
            unsafe { libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut()) };
            let woke = now_ns();
            black_box(spin(iters));
            let end = now_ns();
            wake.push(woke - next);
            work.push(end - woke);
            let over = end > next + period;
            overruns += over as u64;
            episodes += (over && !in_episode) as u64;
            in_episode = over;
        }
        let q = |v: &mut Vec<i64>, f: f64| {
            v.sort_unstable();
            v[((v.len() - 1) as f64 * f).round() as usize] as f64 / 1e3
        };
        let n = wake.len();
        Ok(serde_json::json!({
            "what": format!("1 kHz SCHED_RR {prio} loop on CPU {cpu}, {work_us:.0} us of fixed work per cycle, overruns = work ended after the next deadline"),
            "cycles": n,
            "work_iterations": iters,
            "overruns": overruns,
            "overrun_percent": 100.0 * overruns as f64 / n.max(1) as f64,
            "overrun_episodes": episodes,
            "wake_late_p99_us": q(&mut wake, 0.99),
            "wake_late_max_us": q(&mut wake, 1.0),
            "work_median_us": q(&mut work, 0.5),
            "work_p99_us": q(&mut work, 0.99),
            "work_p9999_us": q(&mut work, 0.9999),
            "work_max_us": q(&mut work, 1.0),
        }))
    });
    t.join().map_err(|_| CliError::failure("the floor loop panicked"))?.map_err(|e| CliError::failure(e.to_string()))
}

/// Why the work floor's 1 kHz thread could not be set up as asked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
enum FloorError {
    #[error("cannot pin to CPU {cpu}: {problem} (--cpu -1: no pinning)")]
    Pin { cpu: i64, problem: String },
    #[error("cannot use SCHED_RR {priority}: {problem} (needs CAP_SYS_NICE or an rtprio limit; --realtime-priority 0: normal scheduling)")]
    Realtime { priority: i32, problem: String },
}

fn machine() -> serde_json::Value {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string()))
        .unwrap_or_default();
    let nproc = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    serde_json::json!({ "nproc": nproc, "cpu": cpu, "loadavg_at_end": load.trim() })
}

pub fn run(a: ChainArgs) -> CliResult {
    if !(a.duration > 0.0 && a.duration.is_finite()) {
        return Err(CliError::usage(format!("--duration {}: give a positive number of seconds", a.duration)));
    }
    let ncpu = std::thread::available_parallelism().map(|n| n.get() as i64).unwrap_or(1);
    if let Some(cpu) = a.cpu.filter(|&c| c < -1 || c >= ncpu) {
        return Err(CliError::usage(format!("--cpu {cpu}: this machine has CPUs 0..={} (-1: no pinning)", ncpu - 1)));
    }
    if a.domain > 230 {
        return Err(CliError::usage(format!("--domain {}: use 0..=230 (the rclpy chain and the composed run take the next ids)", a.domain)));
    }
    if !Path::new("params").is_dir() {
        return Err(CliError::usage("params/ not found: run naic bench chain from the repository root"));
    }
    launch::install_signal_handlers();
    let dir = std::env::temp_dir().join(format!("naic-bench-chain-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::failure(format!("{}: {e}", dir.display())))?;
    eprintln!("naic bench chain: Rust chain, {} s (+{WARMUP} s warm-up)", a.duration);
    let security = a.enclave.as_deref().map(enclave_env).transpose()?;
    let rust = rust_chain(&a, &dir, &[])?;
    let rust_secure = match &security {
        Some(sec) => {
            eprintln!("naic bench chain: Rust chain with DDS Security, {} s (+{WARMUP} s warm-up)", a.duration);
            rust_chain(&a, &dir, sec)?
        }
        None => serde_json::Value::Null,
    };
    let rclpy = if a.skip_rclpy {
        serde_json::Value::Null
    } else {
        eprintln!("naic bench chain: rclpy chain, {} s (+{WARMUP} s warm-up)", a.duration);
        rclpy_chain(&a, &dir)?
    };
    let composed = if a.composed {
        eprintln!("naic bench chain: composed (one process), {} s (+{WARMUP} s warm-up)", a.duration);
        composed_chain(&a, &dir, &[])?
    } else {
        serde_json::Value::Null
    };
    let composed_secure = match (&security, a.composed) {
        (Some(sec), true) => {
            eprintln!("naic bench chain: composed with DDS Security, {} s (+{WARMUP} s warm-up)", a.duration);
            composed_chain(&a, &dir, sec)?
        }
        _ => serde_json::Value::Null,
    };
    let floor = if a.floor {
        eprintln!("naic bench chain: floor (cyclictest), {} s", a.duration.ceil());
        floor(&a, &dir, rust["median_us"].as_f64().unwrap_or(0.0))?
    } else {
        serde_json::Value::Null
    };
    let work_floor = if a.floor {
        let w = rust["median_us"].as_f64().unwrap_or(0.0);
        eprintln!("naic bench chain: floor with {w:.0} us of work per cycle, {} s", a.duration);
        work_floor(&a, w)?
    } else {
        serde_json::Value::Null
    };
    let ratio = |x: &serde_json::Value, y: &serde_json::Value| match (x["median_us"].as_f64(), y["median_us"].as_f64()) {
        (Some(r), Some(p)) if p > 0.0 => serde_json::json!(r / p),
        _ => serde_json::Value::Null,
    };
    let out = serde_json::json!({
        "bench": "chain",
        "what": "latency /joint_states stamp -> matching /joint_effort_cmd at the driver, 3 processes, 1 kHz",
        "rust": rust,
        "rust_realtime_priority": a.realtime_priority,
        "rust_data_qos": a.qos,
        "rust_cpu_affinity": a.cpu.map_or("params/".to_string(), |c| c.to_string()),
        "median_ratio_rust_over_rclpy": ratio(&rust, &rclpy),
        "rust_secure": rust_secure,
        "median_ratio_secure_over_plain": ratio(&rust_secure, &rust),
        "composed_secure": composed_secure,
        "composed": composed,
        "median_ratio_composed_over_rust": ratio(&composed, &rust),
        "rclpy": rclpy,
        "floor": floor,
        "work_floor": work_floor,
        "missed_over_floor": match (rust["missed_cycles"].as_f64(), floor["equivalent_missed_cycles"].as_f64()) {
            (Some(m), Some(f)) if f > 0.0 => serde_json::json!(m / f),
            _ => serde_json::Value::Null,
        },
        "machine": machine(),
        "git": Command::new("git").args(["rev-parse", "--short", "HEAD"]).output().ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string()),
    });
    println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_errors_name_the_setting_and_the_flag_that_avoids_it() {
        let m = FloorError::Pin { cpu: 7, problem: "Invalid argument (os error 22)".into() }.to_string();
        assert!(m.contains("CPU 7") && m.contains("os error 22") && m.contains("--cpu -1"), "{m}");
        let m = FloorError::Realtime { priority: 80, problem: "Operation not permitted (os error 1)".into() }.to_string();
        assert!(m.contains("SCHED_RR 80") && m.contains("CAP_SYS_NICE") && m.contains("--realtime-priority 0"), "{m}");
    }
}
