//! `naic bag export-csv`: one CSV per topic, a row per message, flattened per type.
use super::{bag_err, flat};
use crate::cmd::{CliError, CliResult};
use naic_bag::Bag;
use naic_msgs::*;
use std::fmt::Write as _;
use std::path::Path;

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

/// Every field of every message, columns derived from the message's fields
/// ([`super::flat`]): `/naic/params` (a field added to `NaicParams.msg` is a column at once).
fn export_topic_flat<M: RosMessage + serde::Serialize>(bag: &Bag, topic: &str, path: &Path) -> Result<usize, CliError> {
    let msgs = bag.messages::<M>(topic, ..).map_err(bag_err)?;
    let rows: Vec<flat::Cells> = msgs.iter().map(|m| flat::cells(&m.msg)).collect();
    let cols = flat::columns(&rows);
    let mut s = String::from("log_time_ns,publish_time_ns");
    for c in &cols {
        s.push(',');
        s.push_str(c);
    }
    s.push('\n');
    for (m, row) in msgs.iter().zip(&rows) {
        let _ = write!(s, "{},{}", m.log_time, m.publish_time);
        // A row's cells are in the order of `cols` (flat::columns keeps it); the columns it
        // lacks stay empty.
        let mut cells = row.iter().peekable();
        for c in &cols {
            s.push(',');
            if let Some((_, v)) = cells.next_if(|(rc, _)| rc == c) {
                s.push_str(v);
            }
        }
        s.push('\n');
    }
    std::fs::write(path, s).map_err(|e| CliError::failure(format!("could not write {}: {e}", path.display())))?;
    Ok(msgs.len())
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

pub(super) fn export_csv(file: &Path, out: &Path) -> CliResult {
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
            "naic_msgs/msg/NaicParams" => export_topic_flat::<NaicParams>(&bag, &t.topic, &path)?,
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
