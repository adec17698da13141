//! `naic bench bag`: read + decode rate against Python `mcap_ros2`, same file, same run.
use super::bag_err;
use crate::cmd::{CliError, CliResult};
use naic_bag::{Bag, TimeRange};
use std::io::Write as _;
use std::path::Path;

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
    let python = crate::cmd::sim::python();
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
