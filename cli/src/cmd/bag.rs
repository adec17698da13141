//! `naic bag …`: inspect, repair and export MCAP bags; `naic bench bag`.
use super::{CliError, CliResult};
use naic_bag::{Bag, BagError, TimeRange};
use naic_msgs::*;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum BagCmd {
    /// Topics, types, counts, duration and rates of a bag (like `ros2 bag info`).
    Info {
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also read and decode every message (checks chunk CRCs and CDR) and report what is readable.
        #[arg(long)]
        verify: bool,
    },
    /// Recover every complete message of a damaged bag into a clean, indexed copy.
    Repair { input: PathBuf, output: PathBuf },
    /// Write one CSV per topic (for spreadsheets).
    ExportCsv {
        file: PathBuf,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
    },
    /// Write a deterministic bag of the four naic topics (tests and benchmarks).
    #[command(hide = true)]
    WriteSample {
        out: PathBuf,
        #[arg(long, default_value_t = 1.0)]
        seconds: f64,
        #[arg(long, default_value_t = 1000.0)]
        rate: f64,
        /// Also write every message as JSON lines `{"topic":…, "log_time":…, "msg":…}`.
        #[arg(long)]
        dump_json: Option<PathBuf>,
    },
}

fn bag_err(e: BagError) -> CliError {
    match e {
        BagError::Io { .. } | BagError::NotMcap { .. } | BagError::TopicNotFound { .. } | BagError::TypeMismatch { .. } => {
            CliError::usage(e.to_string())
        }
        _ => CliError::failure(e.to_string()),
    }
}

pub fn run(c: BagCmd) -> CliResult {
    match c {
        BagCmd::Info { file, json, verify } => info(&file, json, verify),
        BagCmd::Repair { input, output } => {
            let r = naic_bag::repair(&input, &output).map_err(bag_err)?;
            for d in &r.damage {
                eprintln!("naic bag repair: {}: {d}", input.display());
            }
            println!(
                "wrote {} message(s) on {} topic(s) to {} ({} problem(s) found in the input)",
                r.messages,
                r.topics,
                output.display(),
                r.damage.len()
            );
            Ok(())
        }
        BagCmd::ExportCsv { file, out } => export_csv(&file, &out),
        BagCmd::WriteSample { out, seconds, rate, dump_json } => write_sample(&out, seconds, rate, dump_json.as_deref()),
    }
}

/// "Nov 14 2023 22:13:20.000150000" (UTC) from ns since the epoch.
fn utc(ns: u64) -> String {
    let (y, m, d, hh, mm, ss) = super::utc_civil((ns / 1_000_000_000) as i64);
    const MONTHS: [&str; 12] = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
    format!(
        "{} {:02} {} {:02}:{:02}:{:02}.{:09} UTC",
        MONTHS[(m - 1) as usize],
        d,
        y,
        hh,
        mm,
        ss,
        ns % 1_000_000_000
    )
}

fn human_size(b: usize) -> String {
    let b = b as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.1} GiB", b / 1024f64.powi(3))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", b / 1024f64.powi(2))
    } else if b >= 1024.0 {
        format!("{:.1} KiB", b / 1024.0)
    } else {
        format!("{b} B")
    }
}

fn info(file: &Path, json: bool, verify: bool) -> CliResult {
    let bag = Bag::open(file).map_err(bag_err)?;
    // --verify: count what actually reads and decodes, per channel.
    let mut readable: std::collections::BTreeMap<u16, u64> = Default::default();
    if verify {
        bag.for_each_message(None, TimeRange::ALL, |m| *readable.entry(m.channel_id).or_default() += 1);
        bag.for_each_decoded(.., |_| {}); // notes CDR that does not decode
    }
    let readable_of = |t: &naic_bag::TopicInfo| readable.get(&t.channel_id).copied().unwrap_or(0);
    let topics = bag.topics();
    let (start, end) = bag.time_bounds().unwrap_or((0, 0));
    let duration = end.saturating_sub(start);
    // messages per second over the bag's duration (count-1 intervals)
    let rate = |n: u64| if duration > 0 && n > 1 { (n - 1) as f64 / (duration as f64 * 1e-9) } else { 0.0 };
    let damage = bag.damage();
    if json {
        let v = serde_json::json!({
            "file": file.display().to_string(),
            "size_bytes": bag.file_size(),
            "profile": bag.profile(),
            "library": bag.library(),
            "indexed": bag.is_indexed(),
            "chunks": bag.chunk_count(),
            "start_ns": start,
            "end_ns": end,
            "duration_s": duration as f64 * 1e-9,
            "message_count": bag.message_count(),
            "topics": topics.iter().map(|t| serde_json::json!({
                "topic": t.topic, "type": t.type_name, "count": t.count,
                "rate_hz": rate(t.count), "type_hash": t.type_hash,
                "readable": if verify { Some(readable_of(t)) } else { None },
            })).collect::<Vec<_>>(),
            "damage": damage.iter().map(|d| d.to_string()).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
        return Ok(());
    }
    let mut s = String::new();
    let _ = writeln!(s, "Files:             {}", file.display());
    let _ = writeln!(s, "Bag size:          {}", human_size(bag.file_size()));
    let _ = writeln!(s, "Storage id:        mcap (profile {:?}, written by {:?})", bag.profile(), bag.library());
    let _ = writeln!(s, "Duration:          {:.9}s", duration as f64 * 1e-9);
    let _ = writeln!(s, "Start:             {} ({}.{:09})", utc(start), start / 1_000_000_000, start % 1_000_000_000);
    let _ = writeln!(s, "End:               {} ({}.{:09})", utc(end), end / 1_000_000_000, end % 1_000_000_000);
    let _ = writeln!(s, "Messages:          {}", bag.message_count());
    let _ = writeln!(s, "Chunks:            {} (index {})", bag.chunk_count(), if bag.is_indexed() { "intact" } else { "missing or damaged: counted by scanning" });
    let w = topics.iter().map(|t| t.topic.len()).max().unwrap_or(0);
    let tw = topics.iter().map(|t| t.type_name.len()).max().unwrap_or(0);
    for (i, t) in topics.iter().enumerate() {
        let _ = writeln!(
            s,
            "{}Topic: {:w$} | Type: {:tw$} | Count: {} | Rate: {:.1} Hz | Serialization Format: cdr{}",
            if i == 0 { "Topic information: " } else { "                   " },
            t.topic,
            t.type_name,
            t.count,
            rate(t.count),
            if verify { format!(" | Readable: {}", readable_of(t)) } else { String::new() },
        );
    }
    if topics.is_empty() {
        s.push_str("Topic information: (none)\n");
    }
    for d in &damage {
        let _ = writeln!(s, "Damage:            {d}");
    }
    if !damage.is_empty() {
        let _ = writeln!(s, "                   `naic bag repair {} OUT.mcap` writes a clean copy.", file.display());
    }
    print!("{s}");
    Ok(())
}

/// Flattening of a message into CSV columns. Variable-length fields get as many columns as
/// the longest message has (`shape`); shorter messages leave those cells empty.
trait CsvRow: RosMessage {
    /// Grows `shape` (one entry per variable-length field) to fit this message.
    fn shape(&self, _shape: &mut Vec<usize>) {}
    fn header(&self, shape: &[usize]) -> Vec<String>;
    fn row(&self, shape: &[usize], out: &mut String);
}

fn num(out: &mut String, v: f64) {
    let _ = write!(out, ",{v}");
}

fn nums(out: &mut String, v: &[f64], width: usize) {
    for i in 0..width {
        match v.get(i) {
            Some(x) => num(out, *x),
            None => out.push(','),
        }
    }
}

fn text(out: &mut String, v: &str) {
    if v.contains([',', '"', '\n', '\r']) {
        let _ = write!(out, ",\"{}\"", v.replace('"', "\"\""));
    } else {
        let _ = write!(out, ",{v}");
    }
}

/// Exact `sec.nanosec` (an f64 would lose the nanoseconds of an epoch stamp).
fn time_col(out: &mut String, t: &Time) {
    let ns = t.to_nanos();
    let sign = if ns < 0 { "-" } else { "" };
    let _ = write!(out, ",{sign}{}.{:09}", ns.unsigned_abs() / 1_000_000_000, ns.unsigned_abs() % 1_000_000_000);
}

fn grow(shape: &mut Vec<usize>, lens: &[usize]) {
    if shape.len() < lens.len() {
        shape.resize(lens.len(), 0);
    }
    for (s, l) in shape.iter_mut().zip(lens) {
        *s = (*s).max(*l);
    }
}

impl CsvRow for JointState {
    fn shape(&self, shape: &mut Vec<usize>) {
        grow(shape, &[self.position.len(), self.velocity.len(), self.effort.len()]);
    }
    fn header(&self, shape: &[usize]) -> Vec<String> {
        let mut h = vec!["stamp_s".to_string(), "frame_id".to_string()];
        for (k, kind) in ["position", "velocity", "effort"].iter().enumerate() {
            for i in 0..shape[k] {
                let name = self.name.get(i).cloned().unwrap_or_else(|| format!("{i}"));
                h.push(format!("{kind}_{name}"));
            }
        }
        h
    }
    fn row(&self, shape: &[usize], out: &mut String) {
        time_col(out, &self.header.stamp);
        text(out, &self.header.frame_id);
        for (k, v) in [&self.position, &self.velocity, &self.effort].into_iter().enumerate() {
            nums(out, v, shape[k]);
        }
    }
}

impl CsvRow for WrenchStamped {
    fn header(&self, _: &[usize]) -> Vec<String> {
        ["stamp_s", "frame_id", "force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z"]
            .map(String::from)
            .to_vec()
    }
    fn row(&self, _: &[usize], out: &mut String) {
        time_col(out, &self.header.stamp);
        text(out, &self.header.frame_id);
        let (f, t) = (&self.wrench.force, &self.wrench.torque);
        for v in [f.x, f.y, f.z, t.x, t.y, t.z] {
            num(out, v);
        }
    }
}

impl CsvRow for Float64MultiArray {
    fn shape(&self, shape: &mut Vec<usize>) {
        grow(shape, &[self.data.len()]);
    }
    fn header(&self, shape: &[usize]) -> Vec<String> {
        (0..shape[0]).map(|i| format!("data_{i}")).collect()
    }
    fn row(&self, shape: &[usize], out: &mut String) {
        nums(out, &self.data, shape[0]);
    }
}

impl CsvRow for NaicParams {
    fn header(&self, _: &[usize]) -> Vec<String> {
        [
            "stamp_s", "frame_id", "mode", "phase", "force_axis", "desired_force", "measured_force", "e_f", "m_d", "b_d",
            "k_d", "sigma", "phi", "gamma", "gamma_bound", "gamma_clipped", "fault", "fault_count",
        ]
        .map(String::from)
        .to_vec()
    }
    fn row(&self, _: &[usize], out: &mut String) {
        time_col(out, &self.header.stamp);
        text(out, &self.header.frame_id);
        text(out, &self.mode);
        let _ = write!(out, ",{},{}", self.phase, self.force_axis);
        for v in [
            self.desired_force, self.measured_force, self.e_f, self.m_d, self.b_d, self.k_d, self.sigma, self.phi,
            self.gamma, self.gamma_bound,
        ] {
            num(out, v);
        }
        let _ = write!(out, ",{}", self.gamma_clipped as u8);
        text(out, &self.fault);
        let _ = write!(out, ",{}", self.fault_count);
    }
}

impl CsvRow for PoseStamped {
    fn header(&self, _: &[usize]) -> Vec<String> {
        ["stamp_s", "frame_id", "position_x", "position_y", "position_z", "orientation_x", "orientation_y", "orientation_z", "orientation_w"]
            .map(String::from)
            .to_vec()
    }
    fn row(&self, _: &[usize], out: &mut String) {
        time_col(out, &self.header.stamp);
        text(out, &self.header.frame_id);
        let (p, q) = (&self.pose.position, &self.pose.orientation);
        for v in [p.x, p.y, p.z, q.x, q.y, q.z, q.w] {
            num(out, v);
        }
    }
}

impl CsvRow for Clock {
    fn header(&self, _: &[usize]) -> Vec<String> {
        vec!["clock_s".into()]
    }
    fn row(&self, _: &[usize], out: &mut String) {
        time_col(out, &self.clock);
    }
}

fn export_topic<M: CsvRow>(bag: &Bag, topic: &str, path: &Path) -> Result<usize, CliError> {
    let msgs = bag.messages::<M>(topic, ..).map_err(bag_err)?;
    let mut shape = Vec::new();
    for m in &msgs {
        m.msg.shape(&mut shape);
    }
    shape.resize(3, 0);
    let mut s = String::new();
    let cols = msgs.first().map(|m| m.msg.header(&shape)).unwrap_or_default();
    s.push_str("log_time_ns,publish_time_ns");
    for c in &cols {
        s.push(',');
        s.push_str(c);
    }
    s.push('\n');
    for m in &msgs {
        let _ = write!(s, "{},{}", m.log_time, m.publish_time);
        m.msg.row(&shape, &mut s);
        s.push('\n');
    }
    std::fs::write(path, s).map_err(|e| CliError::failure(format!("could not write {}: {e}", path.display())))?;
    Ok(msgs.len())
}

fn export_csv(file: &Path, out: &Path) -> CliResult {
    let bag = Bag::open(file).map_err(bag_err)?;
    std::fs::create_dir_all(out)
        .map_err(|e| CliError::usage(format!("could not create output directory {}: {e}", out.display())))?;
    for t in bag.topics() {
        let name = t.topic.trim_start_matches('/').replace('/', "_");
        let path = out.join(format!("{name}.csv"));
        let n = match t.type_name.as_str() {
            "sensor_msgs/msg/JointState" => export_topic::<JointState>(&bag, &t.topic, &path)?,
            "geometry_msgs/msg/WrenchStamped" => export_topic::<WrenchStamped>(&bag, &t.topic, &path)?,
            "std_msgs/msg/Float64MultiArray" => export_topic::<Float64MultiArray>(&bag, &t.topic, &path)?,
            "naic_msgs/msg/NaicParams" => export_topic::<NaicParams>(&bag, &t.topic, &path)?,
            "rosgraph_msgs/msg/Clock" => export_topic::<Clock>(&bag, &t.topic, &path)?,
            "geometry_msgs/msg/PoseStamped" => export_topic::<PoseStamped>(&bag, &t.topic, &path)?,
            other => {
                eprintln!("naic bag export-csv: skipping {} ({other} has no CSV layout)", t.topic);
                continue;
            }
        };
        println!("{}: {n} rows", path.display());
    }
    for d in bag.damage() {
        eprintln!("naic bag export-csv: {}: {d}", file.display());
    }
    Ok(())
}

fn write_sample(out: &Path, seconds: f64, rate: f64, dump: Option<&Path>) -> CliResult {
    if !(seconds > 0.0 && seconds.is_finite() && rate > 0.0 && rate.is_finite()) {
        return Err(CliError::usage("--seconds and --rate must be positive numbers"));
    }
    let cycles = (seconds * rate).round() as u64;
    let mut lines = dump.map(|_| String::new());
    let n = naic_bag::sample::write_sample(out, cycles, rate, |c| {
        if let Some(s) = lines.as_mut() {
            let log = c.stamp_ns + 150_000;
            for (k, (topic, v)) in [
                ("/joint_states", serde_json::to_value(&c.joint_states)),
                ("/wrench", serde_json::to_value(&c.wrench)),
                ("/joint_effort_cmd", serde_json::to_value(&c.effort)),
                ("/naic/params", serde_json::to_value(&c.params)),
            ]
            .into_iter()
            .enumerate()
            {
                let line = serde_json::json!({"topic": topic, "log_time": log + 1000 * k as u64,
                    "publish_time": c.stamp_ns, "msg": v.unwrap()});
                s.push_str(&line.to_string());
                s.push('\n');
            }
        }
    })
    .map_err(bag_err)?;
    if let (Some(p), Some(s)) = (dump, lines) {
        std::fs::write(p, s).map_err(|e| CliError::failure(format!("could not write {}: {e}", p.display())))?;
    }
    println!("wrote {n} messages to {}", out.display());
    Ok(())
}

/// `naic bench bag`: read+decode rate of a generated 1 kHz, 4-topic, 60 s bag, against the
/// Python `mcap_ros2` reader on the same file in the same run.
pub fn bench(json: bool, seconds: f64) -> CliResult {
    let dir = std::env::temp_dir().join(format!("naic_bench_bag_{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::failure(format!("temp dir: {e}")))?;
    let path = dir.join("bench_1khz_4topics.mcap");
    let cycles = (seconds * 1000.0).round() as u64;
    let t = std::time::Instant::now();
    let written = naic_bag::sample::write_sample(&path, cycles, 1000.0, |_| {}).map_err(bag_err)?;
    let write_s = t.elapsed().as_secs_f64();

    // Rust: open + decode every message of the four topics into typed structs, streaming in
    // one pass like the Python loop (each message decoded, inspected, dropped); best of 5.
    let mut best = f64::INFINITY;
    let mut decoded = 0usize;
    let mut checksum = 0.0;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let bag = Bag::open(&path).map_err(bag_err)?;
        let mut n = 0usize;
        bag.for_each_decoded(.., |m| {
            n += 1;
            // black_box: the decoded message (strings, vectors) counts as used.
            let m = std::hint::black_box(m);
            if let naic_bag::AnyMessage::NaicParams(p) = &m.msg {
                checksum += p.m_d;
            }
        });
        best = best.min(t.elapsed().as_secs_f64());
        decoded = n;
    }
    // Typed vectors of the four topics in one pass (what plots and analysis use).
    let mut best_typed = f64::INFINITY;
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let bag = Bag::open(&path).map_err(bag_err)?;
        let run = naic_bag::RunData::load(&bag, ..);
        best_typed = best_typed.min(t.elapsed().as_secs_f64());
        let n = run.joint_states.len() + run.wrench.len() + run.effort_cmd.len() + run.params.len();
        if n as u64 != written {
            return Err(CliError::failure(format!("bench: wrote {written} messages but read {n} as typed vectors")));
        }
    }
    let _ = checksum;
    if decoded as u64 != written {
        return Err(CliError::failure(format!("bench: wrote {written} messages but decoded {decoded}")));
    }
    let rust_rate = decoded as f64 / best;
    // Zero-copy raw iteration (no decode) for reference.
    let bag = Bag::open(&path).map_err(bag_err)?;
    let t = std::time::Instant::now();
    let mut raw = 0usize;
    bag.for_each_message(None, TimeRange::ALL, |m| raw += m.data.len());
    let raw_rate = written as f64 / t.elapsed().as_secs_f64();

    let py = python_rate(&path)?;
    let file_size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let _ = std::fs::remove_dir_all(&dir);
    let ratio = py.map(|(rate, _)| rust_rate / rate);
    if json {
        let v = serde_json::json!({
            "bench": "bag_read_decode",
            "file": {"topics": 4, "rate_hz": 1000, "seconds": seconds, "messages": written, "bytes": file_size},
            "write_messages_per_s": written as f64 / write_s,
            "rust_read_decode_messages_per_s": rust_rate,
            "rust_read_raw_messages_per_s": raw_rate,
            "rust_typed_vectors_one_pass_messages_per_s": written as f64 / best_typed,
            "python_mcap_ros2_messages_per_s": py.map(|p| p.0),
            "python_messages": py.map(|p| p.1),
            "ratio_rust_over_python": ratio,
            "target": {"messages_per_s": 1.0e6, "ratio": 25.0},
        });
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
    } else {
        println!("bag: {written} messages, {:.1} MiB", file_size as f64 / 1048576.0);
        println!("rust read+decode: {:.0} msg/s (raw {:.0} msg/s, typed vectors (RunData::load) {:.0} msg/s)", rust_rate, raw_rate, written as f64 / best_typed);
        match py {
            Some((r, _)) => println!("python mcap_ros2: {r:.0} msg/s; ratio {:.1}x", rust_rate / r),
            None => println!("python mcap_ros2: not available"),
        }
    }
    let _ = std::io::stdout().flush();
    Ok(())
}

/// Messages/s of `mcap_ros2.reader.read_ros2_messages` decoding every message of `path`.
/// None (with a note on stderr) when no Python with mcap-ros2-support is found.
fn python_rate(path: &Path) -> Result<Option<(f64, u64)>, CliError> {
    let python = super::sim::python();
    const SCRIPT: &str = r#"
import sys, time
from mcap_ros2.reader import read_ros2_messages
t = time.perf_counter()
n = 0
for m in read_ros2_messages(sys.argv[1]):
    _ = m.ros_msg
    n += 1
dt = time.perf_counter() - t
print(n, dt)
"#;
    let out = std::process::Command::new(&python).arg("-c").arg(SCRIPT).arg(path).output();
    let out = match out {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            eprintln!(
                "naic bench bag: {python} could not run the mcap_ros2 reader (pip install mcap-ros2-support): {}",
                String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or("")
            );
            return Ok(None);
        }
        Err(e) => {
            eprintln!("naic bench bag: could not start {python} (set NAIC_PYTHON or NAIC_VENV): {e}");
            return Ok(None);
        }
    };
    let s = String::from_utf8_lossy(&out.stdout);
    let mut it = s.split_whitespace();
    let n: u64 = it.next().and_then(|x| x.parse().ok()).unwrap_or(0);
    let dt: f64 = it.next().and_then(|x| x.parse().ok()).unwrap_or(0.0);
    if n == 0 || dt <= 0.0 {
        return Err(CliError::failure(format!("unexpected output from the Python reader: {s}")));
    }
    Ok(Some((n as f64 / dt, n)))
}

/// Writes one simulated run as a bag with the topics the node suite publishes, so that
/// `naic plot`, `naic replay` and rosbag2 tools treat simulations and recordings alike.
/// Stamps, log and publish times are the simulation time (like a `use_sim_time` run; `/clock`
/// is included). Per control period: `/joint_states` (q, q̇, applied τ), `/wrench` (raw F/T,
/// `ft_sensor`), `/joint_effort_cmd` (applied τ), `/naic/params` (mode = `controller`,
/// measured force = the controller's estimate) and `/clock`. Fields a simulation record does
/// not carry are NaN (`k_d`, `phi`); `gamma_clipped` is derived as γ ≥ its eq-15 bound.
/// `force_axis` is the axis index 0..2 (x, y, z) of the scenario's force direction.
pub fn write_sim_run(
    path: &Path,
    controller: &str,
    records: &[naic_sim::runner::Record],
    force_axis: u8,
) -> Result<u64, CliError> {
    let mut w = naic_bag::BagWriter::create(path).map_err(bag_err)?;
    let q = naic_bag::Qos::default();
    let js = w.add_topic::<JointState>("/joint_states", q).map_err(bag_err)?;
    let wr = w.add_topic::<WrenchStamped>("/wrench", q).map_err(bag_err)?;
    let ef = w.add_topic::<Float64MultiArray>("/joint_effort_cmd", q).map_err(bag_err)?;
    let pa = w.add_topic::<NaicParams>("/naic/params", q).map_err(bag_err)?;
    let ck = w.add_topic::<Clock>("/clock", q).map_err(bag_err)?;
    let names: Vec<String> = (1..=6).map(|j| format!("joint{j}")).collect();
    let dim = vec![MultiArrayDimension { label: "joints".into(), size: 6, stride: 6 }];
    for r in records {
        let ns = (r.t * 1e9).round().max(0.0) as u64;
        let stamp = Time::from_nanos(ns as i64);
        let header = |frame: &str| Header { stamp: stamp.clone(), frame_id: frame.into() };
        let wrench = Wrench {
            force: Vector3 { x: r.wrench[0], y: r.wrench[1], z: r.wrench[2] },
            torque: Vector3 { x: r.wrench[3], y: r.wrench[4], z: r.wrench[5] },
        };
        w.write(ck, &Clock { clock: stamp.clone() }, ns, ns).map_err(bag_err)?;
        w.write(
            js,
            &JointState {
                header: header(""),
                name: names.clone(),
                position: r.q.to_vec(),
                velocity: r.dq.to_vec(),
                effort: r.tau.to_vec(),
            },
            ns,
            ns,
        )
        .map_err(bag_err)?;
        w.write(wr, &WrenchStamped { header: header("ft_sensor"), wrench }, ns, ns).map_err(bag_err)?;
        w.write(
            ef,
            &Float64MultiArray { layout: MultiArrayLayout { dim: dim.clone(), data_offset: 0 }, data: r.tau.to_vec() },
            ns,
            ns,
        )
        .map_err(bag_err)?;
        let params = NaicParams {
            header: header("base_link"),
            mode: controller.to_string(),
            phase: r.phase,
            force_axis,
            desired_force: r.f_d,
            measured_force: r.f_ext_est,
            e_f: r.f_ext_est - r.f_d,
            m_d: r.m_d,
            b_d: r.b_d,
            k_d: f64::NAN,
            sigma: r.sigma,
            phi: f64::NAN,
            gamma: r.gamma,
            gamma_bound: r.gamma_bound,
            gamma_clipped: r.gamma_bound.is_finite() && r.gamma >= r.gamma_bound,
            fault: String::new(),
            fault_count: 0,
            k_e_hat: r.k_e_hat,
            k_e_confidence: r.k_e_confidence,
            ..Default::default()
        };
        w.write(pa, &params, ns, ns).map_err(bag_err)?;
    }
    let n = w.message_count();
    w.finish().map_err(bag_err)?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim_run_bag_reads_back_every_value() {
        let recs: Vec<naic_sim::runner::Record> = (0..500)
            .map(|k| {
                let mut r = naic_sim::runner::Record { t: k as f64 * 1e-3, ..Default::default() };
                r.q = [0.1 * k as f64, 1.0, -1.0, 0.5, 0.25, 0.0];
                r.tau = [k as f64, 2.0, 3.0, 4.0, 5.0, 6.0];
                r.wrench = [1.0, 2.0, -(k as f64), 0.0, 0.1, 0.2];
                r.f_d = 10.0;
                r.f_ext_est = 9.0 + k as f64 * 1e-3;
                r.b_d = 50.0 + k as f64;
                r.gamma = 1e-3;
                r.gamma_bound = if k % 2 == 0 { f64::INFINITY } else { 5e-4 };
                r.phase = 1;
                r
            })
            .collect();
        let p = std::env::temp_dir().join(format!("naic_sim_bag_{}.mcap", std::process::id()));
        let n = write_sim_run(&p, "naic", &recs, 2).unwrap();
        assert_eq!(n, 5 * 500);
        let bag = Bag::open(&p).unwrap();
        let run = naic_bag::RunData::load(&bag, ..);
        assert_eq!(run.params.len(), 500);
        assert_eq!(run.clock.len(), 500);
        for (k, r) in recs.iter().enumerate() {
            assert_eq!(run.joint_states[k].msg.position, r.q.to_vec());
            assert_eq!(run.effort_cmd[k].msg.data, r.tau.to_vec());
            assert_eq!(run.wrench[k].msg.wrench.force.z, r.wrench[2]);
            let p = &run.params[k].msg;
            assert_eq!((p.measured_force, p.b_d, p.mode.as_str()), (r.f_ext_est, r.b_d, "naic"));
            assert_eq!(p.gamma_clipped, k % 2 == 1);
            assert_eq!(run.params[k].log_time, (r.t * 1e9).round() as u64);
        }
        let _ = std::fs::remove_file(&p);
    }
}
