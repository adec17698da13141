//! Steady-state friction data: one `(joint, velocity, torque)` point per
//! constant-velocity segment, read from CSV with the header
//! `joint,velocity_rad_s,torque_nm` (columns in any order; extra columns are ignored;
//! blank lines and lines starting with `#` are skipped), parsed with the `csv` crate.

use naic_core::friction::FrictionError;
use std::path::Path;

/// The header the CSV reader expects.
pub const CSV_HEADER: &str = "joint,velocity_rad_s,torque_nm";

/// One steady-state point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionSample {
    /// Joint number, 1-based (the paper's i).
    pub joint: usize,
    /// Mean joint velocity of the segment, rad/s.
    pub qdot: f64,
    /// Mean joint torque of the segment, N·m.
    pub tau: f64,
    /// 1-based line in the source file (0 when the sample did not come from a file).
    pub line: usize,
}

/// A set of steady-state points, validated (finite values, joint ≥ 1, at least one row).
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionData {
    /// Where the data came from (file name), for messages.
    pub name: String,
    pub samples: Vec<FrictionSample>,
}

impl FrictionData {
    /// Reads and validates a CSV file.
    pub fn from_csv_file(path: impl AsRef<Path>) -> Result<Self, FrictionError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| FrictionError::Io {
            path: path.display().to_string(),
            source: e,
        })?;
        Self::from_csv_str(&path.display().to_string(), &text)
    }

    /// Parses and validates CSV text (the `csv` crate: quoting, `#` comments, trimmed
    /// fields); `name` is used in error messages, which name the line and the column.
    pub fn from_csv_str(name: &str, text: &str) -> Result<Self, FrictionError> {
        let err = |msg: String| FrictionError::Data(format!("{name}: {msg}"));
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        // Line by line, so that messages give the file's own line numbers (the csv crate's
        // positions do not count comment lines); each line's fields are read by the csv
        // crate (quoting, trimming).
        let fields_of = |line: &str| -> Result<Vec<String>, csv::Error> {
            let mut r = csv::ReaderBuilder::new().has_headers(false).trim(csv::Trim::All).flexible(true).from_reader(line.as_bytes());
            Ok(r.records().next().transpose()?.map(|rec| rec.iter().map(String::from).collect()).unwrap_or_default())
        };
        let mut rows = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
            .map(|(line, l)| fields_of(l).map(|f| (line, f)).map_err(|e| (line, e)));
        let csv_err = |(line, e): (usize, csv::Error)| {
            err(format!("line {line}: {e}; the file must be plain CSV (UTF-8, comma-separated)"))
        };
        let Some(first) = rows.next() else {
            return Err(err(format!(
                "the file is empty; it needs the header `{CSV_HEADER}` and one row per constant-velocity segment"
            )));
        };
        let (header_line, header) = first.map_err(csv_err)?;
        let cols: Vec<String> = header.iter().map(|c| c.to_ascii_lowercase()).collect();
        if cols.iter().all(|c| c.parse::<f64>().is_ok()) {
            return Err(err(format!(
                "line {header_line} is data, not a header; add the header line `{CSV_HEADER}` as the first line"
            )));
        }
        let find = |want: &str| -> Result<usize, FrictionError> {
            let hits: Vec<usize> = cols.iter().enumerate().filter(|(_, c)| *c == want).map(|(i, _)| i).collect();
            match hits.len() {
                1 => Ok(hits[0]),
                0 => Err(err(format!(
                    "line {header_line}: missing column `{want}` (header has {}); the expected header is `{CSV_HEADER}` \
                     (joint number from 1, velocity in rad/s, torque in N·m)",
                    cols.iter().map(|c| format!("`{c}`")).collect::<Vec<_>>().join(", ")
                ))),
                _ => Err(err(format!("line {header_line}: column `{want}` appears {} times; keep one", hits.len()))),
            }
        };
        let (cj, cv, ct) = (find("joint")?, find("velocity_rad_s")?, find("torque_nm")?);
        let mut samples = Vec::new();
        for row in rows {
            let (line, fields) = row.map_err(csv_err)?;
            if fields.len() != cols.len() {
                return Err(err(format!(
                    "line {line}: expected {} fields like the header, found {}; fix the row `{}`",
                    cols.len(),
                    fields.len(),
                    fields.join(",")
                )));
            }
            let joint = parse_joint(&fields[cj]).ok_or_else(|| {
                err(format!(
                    "line {line}, column `joint`: `{}` is not a joint number; use an integer ≥ 1 (joint 1 is the base joint)",
                    &fields[cj]
                ))
            })?;
            let num = |col: usize, cname: &str, unit: &str| -> Result<f64, FrictionError> {
                let s = &fields[col];
                let v: f64 = s.parse().map_err(|_| {
                    err(format!("line {line}, column `{cname}`: `{s}` is not a number; give the value in {unit}"))
                })?;
                if !v.is_finite() {
                    return Err(err(format!(
                        "line {line}, column `{cname}`: value `{s}` is not finite; remove the row or repair the value ({unit})"
                    )));
                }
                Ok(v)
            };
            let qdot = num(cv, "velocity_rad_s", "rad/s")?;
            let tau = num(ct, "torque_nm", "N·m")?;
            samples.push(FrictionSample { joint, qdot, tau, line });
        }
        if samples.is_empty() {
            return Err(err(format!(
                "no data rows after the header (line {header_line}); add rows `{CSV_HEADER}`, one per segment"
            )));
        }
        Ok(Self { name: name.to_string(), samples })
    }

    /// Builds a data set from `(joint, qdot, tau)` triples (joint 1-based), with the same checks as the CSV reader.
    pub fn from_points(name: &str, points: &[(usize, f64, f64)]) -> Result<Self, FrictionError> {
        if points.is_empty() {
            return Err(FrictionError::Data(format!("{name}: no data points; give at least one (joint, velocity, torque)")));
        }
        let mut samples = Vec::with_capacity(points.len());
        for (i, &(joint, qdot, tau)) in points.iter().enumerate() {
            if joint == 0 {
                return Err(FrictionError::Data(format!("{name}: point {i}: joint 0 does not exist; joints count from 1")));
            }
            for (v, what) in [(qdot, "velocity"), (tau, "torque")] {
                if !v.is_finite() {
                    return Err(FrictionError::Data(format!(
                        "{name}: point {i} (joint {joint}): {what} {v} is not finite; remove or repair the point"
                    )));
                }
            }
            samples.push(FrictionSample { joint, qdot, tau, line: 0 });
        }
        Ok(Self { name: name.to_string(), samples })
    }

    /// The joint numbers present, sorted.
    pub fn joints(&self) -> Vec<usize> {
        let mut j: Vec<usize> = self.samples.iter().map(|s| s.joint).collect();
        j.sort_unstable();
        j.dedup();
        j
    }

    /// The samples of one joint (1-based).
    pub fn joint_samples(&self, joint: usize) -> impl Iterator<Item = &FrictionSample> {
        self.samples.iter().filter(move |s| s.joint == joint)
    }
}

fn parse_joint(s: &str) -> Option<usize> {
    if let Ok(j) = s.parse::<usize>() {
        return (j >= 1).then_some(j);
    }
    // MATLAB exports write 1.0; accept integral floats.
    let f: f64 = s.parse().ok()?;
    (f.is_finite() && f >= 1.0 && f.fract() == 0.0 && f < 1e6).then_some(f as usize)
}
