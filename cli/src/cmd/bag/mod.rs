//! `naic bag …`: inspect, repair and export MCAP bags (this file: the subcommands, `info`
//! and the hidden sample writer); `csv.rs` the per-type CSV export, `bench.rs` `naic bench
//! bag`, `sim_run.rs` a simulated run written as a bag (`naic sim --bag`).
mod bench;
mod csv;
mod flat;
mod sim_run;

pub use bench::bench;
pub use sim_run::write_sim_run;

use super::{CliError, CliResult};
use naic_bag::{Bag, BagError, TimeRange};
use std::fmt::Write as _;
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

pub(super) fn bag_err(e: BagError) -> CliError {
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
        BagCmd::ExportCsv { file, out } => csv::export_csv(&file, &out),
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
