//! Reading measured data: the three kinds of input `naic explain` accepts.
//!
//! * **bag**: an MCAP file (rosbag2 profile) with `/joint_states` (position, velocity,
//!   effort = measured joint torque), optionally `/joint_effort_cmd` (used as the torque
//!   when `/joint_states` carries no effort) and `/wrench`.
//! * **timeseries**: CSV with header `t,q1..qN,dq1..dqN,tau1..tauN` (s, rad, rad/s, N·m;
//!   N = the number of `qK` columns, checked against the URDF's joints), optional
//!   `fx,fy,fz,mx,my,mz`; extra columns are ignored. Timestamps need not be uniform
//!   ([`crate::resample`] puts them on a uniform grid); they must increase.
//! * **friction_points**: CSV `joint,velocity_rad_s,torque_nm` (steady-state segment
//!   means), read by [`naic_ident::FrictionData`].
//!
//! The kind is detected from the MCAP magic bytes / `.mcap` extension, else from the CSV
//! header. Every problem names the column or row and the fix.

use crate::ExplainError;
use naic_ident::FrictionData;
use std::path::Path;

/// Rows of equal width stored flat, row-major: `rows[i]` is sample i's slice (one
/// allocation for a whole recording instead of one per sample).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rows {
    width: usize,
    data: Vec<f64>,
}

impl Rows {
    /// Empty rows of `width` values, with room for `n` rows.
    pub fn with_capacity(width: usize, n: usize) -> Self {
        Self { width, data: Vec::with_capacity(width * n) }
    }
    /// `n` rows of zeros.
    pub fn zeros(width: usize, n: usize) -> Self {
        Self { width, data: vec![0.0; width * n] }
    }
    pub fn width(&self) -> usize {
        self.width
    }
    pub fn len(&self) -> usize {
        self.data.len().checked_div(self.width).unwrap_or(0)
    }
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// Appends a row; the first row of an empty `Rows::default()` sets the width.
    /// Panics (a programming error) when a row has another width.
    pub fn push(&mut self, row: impl AsRef<[f64]>) {
        let r = row.as_ref();
        if self.data.is_empty() && self.width == 0 {
            self.width = r.len();
        }
        assert_eq!(r.len(), self.width, "Rows::push: row of {} values into rows of {}", r.len(), self.width);
        self.data.extend_from_slice(r);
    }
    /// Appends every row of `other` (same width).
    pub fn extend(&mut self, other: &Rows) {
        for r in other.iter() {
            self.push(r);
        }
    }
    pub fn iter(&self) -> std::slice::ChunksExact<'_, f64> {
        self.data.chunks_exact(self.width.max(1))
    }
    pub fn iter_mut(&mut self) -> std::slice::ChunksExactMut<'_, f64> {
        self.data.chunks_exact_mut(self.width.max(1))
    }
    /// Column `j` as a vector.
    pub fn column(&self, j: usize) -> Vec<f64> {
        self.iter().map(|r| r[j]).collect()
    }
}

impl std::ops::Index<usize> for Rows {
    type Output = [f64];
    fn index(&self, i: usize) -> &[f64] {
        &self.data[i * self.width..(i + 1) * self.width]
    }
}

impl std::ops::IndexMut<usize> for Rows {
    fn index_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.data[i * self.width..(i + 1) * self.width]
    }
}

/// Which kind of input was read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Bag,
    TimeSeries,
    FrictionPoints,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Bag => "bag",
            Kind::TimeSeries => "timeseries",
            Kind::FrictionPoints => "friction_points",
        }
    }
}

/// A time series of an N-joint arm (N = `q.width()`).
#[derive(Clone, Debug, Default)]
pub struct TimeSeries {
    /// Time [s], strictly increasing.
    pub t: Vec<f64>,
    /// Joint positions [rad], one row per sample.
    pub q: Rows,
    /// Measured joint velocities [rad/s] (kept for reference; the analysis differentiates `q`).
    pub dq: Rows,
    /// Measured joint torques [N·m].
    pub tau: Rows,
    /// Wrench in the sensor frame when present (force then torque).
    pub wrench: Option<Vec<[f64; 6]>>,
    /// Column names that were present but not used.
    pub ignored_columns: Vec<String>,
}

impl TimeSeries {
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Number of joints.
    pub fn nj(&self) -> usize {
        self.q.width()
    }
    /// Median sample period [s].
    pub fn dt(&self) -> f64 {
        if self.t.len() < 2 {
            return f64::NAN;
        }
        let mut d: Vec<f64> = self.t.windows(2).map(|w| w[1] - w[0]).collect();
        let mid = d.len() / 2;
        *d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
    }

    /// Checks length agreement and strictly increasing time (uniformity is not needed:
    /// [`crate::resample`] handles jitter and gaps).
    pub fn validate(&self, name: &str) -> Result<(), ExplainError> {
        let n = self.t.len();
        if n < 200 {
            return Err(ExplainError::input(format!(
                "{name}: only {n} samples; the analysis needs at least 200 (seconds of data at ≥ 100 Hz)"
            )));
        }
        if self.q.len() != n || self.tau.len() != n || self.dq.len() != n || self.dq.width() != self.nj() || self.tau.width() != self.nj() {
            return Err(ExplainError::input(format!("{name}: t, q, dq and tau have different lengths")));
        }
        let dt = self.dt();
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(ExplainError::input(format!("{name}: time column `t` does not increase; give time in seconds")));
        }
        for i in 1..n {
            let d = self.t[i] - self.t[i - 1];
            if !(d > 0.0) {
                return Err(ExplainError::input(format!(
                    "{name}: sample {} (t = {}): time does not increase (previous t = {}); sort the rows by time and remove duplicates",
                    i + 1,
                    self.t[i],
                    self.t[i - 1]
                )));
            }
        }
        Ok(())
    }
}

/// What was read.
#[derive(Clone, Debug)]
pub enum Measured {
    Series(TimeSeries),
    Points(FrictionData),
}

/// Reads `path`, detecting its kind.
pub fn load(path: &Path) -> Result<(Kind, Measured), ExplainError> {
    let bytes = std::fs::read(path).map_err(|e| ExplainError::input(format!("{}: cannot read ({e})", path.display())))?;
    let name = path.display().to_string();
    let is_mcap = bytes.starts_with(naic_bag::MAGIC) || path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    if is_mcap {
        return Ok((Kind::Bag, Measured::Series(load_bag(path, bytes)?)));
    }
    let text = String::from_utf8(bytes).map_err(|_| {
        ExplainError::input(format!("{name}: not UTF-8 text and not an MCAP file; give a CSV (time series or friction points) or an .mcap bag"))
    })?;
    let header = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .ok_or_else(|| ExplainError::input(format!("{name}: the file is empty")))?;
    let cols: Vec<String> = header.split(',').map(|c| c.trim().to_ascii_lowercase()).collect();
    if cols.iter().any(|c| c == "velocity_rad_s") && cols.iter().any(|c| c == "joint") {
        let d = FrictionData::from_csv_str(&name, &text).map_err(|e| ExplainError::input(e.to_string()))?;
        return Ok((Kind::FrictionPoints, Measured::Points(d)));
    }
    if cols.iter().any(|c| c == "t") || cols.iter().any(|c| c == "q1") {
        return Ok((Kind::TimeSeries, Measured::Series(parse_timeseries_csv(&name, &text)?)));
    }
    Err(ExplainError::input(format!(
        "{name}: cannot tell the kind of data from the header `{header}`; expected a time series \
         `t,q1..qN,dq1..dqN,tau1..tauN` or friction points `joint,velocity_rad_s,torque_nm`, or an .mcap bag"
    )))
}

/// Parses the time-series CSV (see module docs).
pub fn parse_timeseries_csv(name: &str, text: &str) -> Result<TimeSeries, ExplainError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().filter(|(_, l)| {
        let l = l.trim();
        !l.is_empty() && !l.starts_with('#')
    });
    let (hl, header) = lines.next().ok_or_else(|| ExplainError::input(format!("{name}: the file is empty")))?;
    let cols: Vec<String> = header.split(',').map(|c| c.trim().to_ascii_lowercase()).collect();
    let find = |want: &str| -> Result<Option<usize>, ExplainError> {
        let hits: Vec<usize> = cols.iter().enumerate().filter(|(_, c)| *c == want).map(|(i, _)| i).collect();
        match hits.len() {
            0 => Ok(None),
            1 => Ok(Some(hits[0])),
            _ => Err(ExplainError::input(format!("{name}: line {}: column `{want}` appears {} times; keep one", hl + 1, hits.len()))),
        }
    };
    let need = |want: &str| -> Result<usize, ExplainError> {
        find(want)?.ok_or_else(|| {
            ExplainError::input(format!(
                "{name}: line {}: missing column `{want}`; a time series needs `t,q1..qN,dq1..dqN,tau1..tauN` \
                 for the N joints of the URDF, e.g. `t,q1..q6,dq1..dq6,tau1..tau6` for the JK5 \
                 (s, rad, rad/s, N·m; tau = measured joint torque)",
                hl + 1
            ))
        })
    };
    let ct = need("t")?;
    // the joint count is the number of consecutive position columns q1, q2, …
    let mut nj = 0;
    while find(&format!("q{}", nj + 1))?.is_some() {
        nj += 1;
    }
    if nj == 0 {
        need("q1")?;
    }
    let mut cq = vec![0; nj];
    let mut cdq = vec![0; nj];
    let mut ctau = vec![0; nj];
    for j in 0..nj {
        cq[j] = need(&format!("q{}", j + 1))?;
        cdq[j] = need(&format!("dq{}", j + 1))?;
        ctau[j] = need(&format!("tau{}", j + 1))?;
    }
    let wnames = ["fx", "fy", "fz", "mx", "my", "mz"];
    let cw: Vec<Option<usize>> = wnames.iter().map(|w| find(w)).collect::<Result<_, _>>()?;
    let n_w = cw.iter().filter(|c| c.is_some()).count();
    if n_w != 0 && n_w != 6 {
        return Err(ExplainError::input(format!(
            "{name}: line {}: wrench columns must be all of `fx,fy,fz,mx,my,mz` or none (found {n_w} of them)",
            hl + 1
        )));
    }
    let mut used: Vec<usize> = vec![ct];
    used.extend(cq.iter().chain(&cdq).chain(&ctau));
    used.extend(cw.iter().flatten());
    let ignored: Vec<String> = cols.iter().enumerate().filter(|(i, _)| !used.contains(i)).map(|(_, c)| c.clone()).collect();
    let mut ts = TimeSeries {
        q: Rows::with_capacity(nj, 0),
        dq: Rows::with_capacity(nj, 0),
        tau: Rows::with_capacity(nj, 0),
        ignored_columns: ignored,
        ..Default::default()
    };
    let (mut q, mut dq, mut tau) = (vec![0.0; nj], vec![0.0; nj], vec![0.0; nj]);
    let mut wrench = Vec::new();
    let mut fields: Vec<&str> = Vec::with_capacity(cols.len());
    for (ln, line) in lines {
        fields.clear();
        fields.extend(line.split(',').map(str::trim));
        if fields.len() != cols.len() {
            return Err(ExplainError::input(format!(
                "{name}: line {}: expected {} fields like the header, found {}",
                ln + 1,
                cols.len(),
                fields.len()
            )));
        }
        let num = |c: usize| -> Result<f64, ExplainError> {
            let s = fields[c];
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(ExplainError::input(format!(
                    "{name}: line {}, column `{}`: `{s}` is not a finite number; repair or remove the row",
                    ln + 1,
                    cols[c]
                ))),
            }
        };
        ts.t.push(num(ct)?);
        for j in 0..nj {
            q[j] = num(cq[j])?;
            dq[j] = num(cdq[j])?;
            tau[j] = num(ctau[j])?;
        }
        ts.q.push(&q);
        ts.dq.push(&dq);
        ts.tau.push(&tau);
        if n_w == 6 {
            let mut w = [0.0; 6];
            for k in 0..6 {
                w[k] = num(cw[k].unwrap_or(0))?;
            }
            wrench.push(w);
        }
    }
    if n_w == 6 {
        ts.wrench = Some(wrench);
    }
    ts.validate(name)?;
    Ok(ts)
}

/// Writes a time series as CSV (the format [`parse_timeseries_csv`] reads).
pub fn write_timeseries_csv(ts: &TimeSeries) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(ts.len() * 200);
    s.push_str("t");
    for p in ["q", "dq", "tau"] {
        for j in 1..=ts.nj() {
            let _ = write!(s, ",{p}{j}");
        }
    }
    if ts.wrench.is_some() {
        s.push_str(",fx,fy,fz,mx,my,mz");
    }
    s.push('\n');
    for i in 0..ts.len() {
        let _ = write!(s, "{}", ts.t[i]);
        for arr in [&ts.q[i], &ts.dq[i], &ts.tau[i]] {
            for v in arr {
                let _ = write!(s, ",{v}");
            }
        }
        if let Some(w) = &ts.wrench {
            for v in &w[i] {
                let _ = write!(s, ",{v}");
            }
        }
        s.push('\n');
    }
    s
}

fn load_bag(path: &Path, bytes: Vec<u8>) -> Result<TimeSeries, ExplainError> {
    use naic_msgs::{Float64MultiArray, JointState, WrenchStamped};
    let name = path.display().to_string();
    let bag = naic_bag::Bag::from_bytes(path, bytes).map_err(|e| ExplainError::input(format!("{name}: {e}")))?;
    let js = bag
        .messages::<JointState>("/joint_states", ..)
        .map_err(|e| ExplainError::input(format!("{name}: {e}; the analysis needs /joint_states (sensor_msgs/msg/JointState)")))?;
    if js.is_empty() {
        return Err(ExplainError::input(format!("{name}: /joint_states has no messages")));
    }
    // the joint count is the first message's number of positions (checked against the URDF later)
    let nj = js[0].msg.position.len();
    if nj == 0 {
        return Err(ExplainError::input(format!("{name}: the first /joint_states message has no positions")));
    }
    let has_effort = js.iter().all(|m| m.msg.effort.len() >= nj);
    let cmd = if has_effort {
        None
    } else {
        let c = bag.messages::<Float64MultiArray>("/joint_effort_cmd", ..).map_err(|e| {
            ExplainError::input(format!(
                "{name}: /joint_states carries no effort and {e}; the analysis needs the joint torque \
                 (JointState.effort or /joint_effort_cmd)"
            ))
        })?;
        Some(c)
    };
    let wrench = bag.messages::<WrenchStamped>("/wrench", ..).ok();
    let mut ts = TimeSeries::default();
    let (mut q, mut dq, mut tau) = (vec![0.0; nj], vec![0.0; nj], vec![0.0; nj]);
    let mut ci = 0usize;
    let mut wi = 0usize;
    let mut wv = Vec::new();
    let mut t_first: Option<u64> = None;
    for (k, m) in js.iter().enumerate() {
        let s = &m.msg;
        if s.position.len() != nj {
            return Err(ExplainError::input(format!(
                "{name}: /joint_states message {} has {} positions, the first one {nj}; every message needs all joints",
                k + 1,
                s.position.len()
            )));
        }
        let stamp = s.header.stamp.to_nanos();
        let t_ns = if stamp > 0 { stamp as u64 } else { m.log_time };
        // time from the first message, subtracted in integer ns: epoch stamps (~1.7e18 ns)
        // as f64 seconds would keep only ~0.2 µs resolution
        let t0_ns = *t_first.get_or_insert(t_ns);
        let t = (t_ns as i128 - t0_ns as i128) as f64 * 1e-9;
        for j in 0..nj {
            q[j] = s.position[j];
            dq[j] = s.velocity.get(j).copied().unwrap_or(0.0);
        }
        if has_effort {
            tau.copy_from_slice(&s.effort[..nj]);
        } else if let Some(c) = &cmd {
            while ci + 1 < c.len() && c[ci + 1].log_time <= m.log_time {
                ci += 1;
            }
            let d = &c.get(ci).ok_or_else(|| ExplainError::input(format!("{name}: /joint_effort_cmd has no messages")))?.msg.data;
            if d.len() < nj {
                return Err(ExplainError::input(format!("{name}: /joint_effort_cmd message has {} values; {nj} are needed", d.len())));
            }
            tau.copy_from_slice(&d[..nj]);
        }
        for (what, arr) in [("position", &q), ("velocity", &dq), ("effort", &tau)] {
            if arr.iter().any(|v| !v.is_finite()) {
                return Err(ExplainError::input(format!("{name}: /joint_states message {} has a non-finite {what}", k + 1)));
            }
        }
        if let Some(w) = &wrench {
            if !w.is_empty() {
                while wi + 1 < w.len() && w[wi + 1].log_time <= m.log_time {
                    wi += 1;
                }
                let ww = &w[wi].msg.wrench;
                wv.push([ww.force.x, ww.force.y, ww.force.z, ww.torque.x, ww.torque.y, ww.torque.z]);
            }
        }
        ts.t.push(t);
        ts.q.push(&q);
        ts.dq.push(&dq);
        ts.tau.push(&tau);
    }
    if wv.len() == ts.t.len() {
        ts.wrench = Some(wv);
    }
    ts.validate(&name)?;
    Ok(ts)
}
