//! The friction parameter file (`params/friction_*.yaml`).
//!
//! ```yaml
//! source: "where the numbers come from"
//! notes: "optional free text"
//! smoothing_v_s: 0.001            # optional: evaluate with tanh(q̇/v_s) instead of sgn (simulation)
//! joints:
//!   - joint: 1                    # 1-based, each joint 1..n exactly once
//!     model: stribeck_per_direction
//!     positive: {f_a: 41.63, f_b: 17.97, q_s: 0.2610, f_v: 30.52, rmse_dfe: 1.259}
//!     negative: {f_a: 29.95, f_b: 16.98, q_s: 0.2715, f_v: 5.811, rmse_dfe: 0.8796}
//!   - joint: 2
//!     model: stribeck             # eq. 5, same in both directions
//!     f_a: 5.0
//!     f_b: 5.5
//!     q_s: 0.03
//!     f_v: 22.0
//!   - joint: 3
//!     model: coulomb_viscous      # eq. 4
//!     f_c: 0.6
//!     f_v: 3.7
//! ```
//!
//! Optional fit statistics next to the parameters of a branch: `rmse` (√(SSR/n), N·m),
//! `rmse_dfe` (√(SSR/(n−p)), MATLAB's gof.rmse as printed in Table 1), `n_points`, and
//! `ci95: {f_a: [lo, hi], q_s: at bound, f_b: unidentifiable}`; for the symmetric models,
//! `stats_positive`/`stats_negative: {rmse:, n_points:}` give the RMSE per direction.
//!
//! Loading never panics: every problem (YAML syntax, missing or unknown field, NaN,
//! negative or zero value, duplicate or missing joint) is reported with the file, the
//! joint, the field and the fix.

use super::model::{FrictionModel, JointFriction, Smoothing, StribeckParams};
use super::FrictionError;
use serde_yaml::{Mapping, Value};
use std::path::Path;

/// A confidence interval, or why there is none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ci95 {
    Interval { lo: f64, hi: f64 },
    /// The parameter ended on a bound (constrained optimum): no interval.
    AtBound,
    /// The data does not determine the parameter (null space of the Jacobian).
    Unidentifiable,
}

impl Ci95 {
    /// Whether `v` lies in the interval (false for AtBound/Unidentifiable).
    pub fn contains(&self, v: f64) -> bool {
        matches!(*self, Ci95::Interval { lo, hi } if lo <= v && v <= hi)
    }
}

/// Fit statistics of one branch (all optional).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BranchStats {
    /// √(SSR/n), N·m.
    pub rmse: Option<f64>,
    /// √(SSR/(n − p)), N·m.
    pub rmse_dfe: Option<f64>,
    pub n_points: Option<usize>,
    /// 95 % intervals by parameter name.
    pub ci95: Vec<(String, Ci95)>,
}

impl BranchStats {
    fn is_empty(&self) -> bool {
        self.rmse.is_none() && self.rmse_dfe.is_none() && self.n_points.is_none() && self.ci95.is_empty()
    }
}

/// Fit statistics of one joint: `all` for the symmetric forms (the fitted branch),
/// `positive`/`negative` per direction (for every form).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointStats {
    pub all: BranchStats,
    pub positive: BranchStats,
    pub negative: BranchStats,
}

/// One joint of the file.
#[derive(Clone, Debug, PartialEq)]
pub struct JointParams {
    /// 1-based joint number.
    pub joint: usize,
    pub friction: JointFriction,
    pub stats: JointStats,
}

/// A whole parameter file.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionParams {
    pub source: String,
    pub notes: Option<String>,
    /// If set, [`FrictionParams::to_model`] uses [`Smoothing::Tanh`] with this v_s (rad/s).
    pub smoothing_v_s: Option<f64>,
    pub joints: Vec<JointParams>,
}

const STRIBECK_KEYS: [&str; 4] = ["f_a", "f_b", "q_s", "f_v"];
const STAT_KEYS: [&str; 4] = ["rmse", "rmse_dfe", "n_points", "ci95"];

fn perr(msg: String) -> FrictionError {
    FrictionError::Params(msg)
}

fn meaning(field: &str) -> &'static str {
    match field {
        "f_a" => "Coulomb level at high speed in N·m (≥ 0)",
        "f_b" => "breakaway (static) level in N·m (≥ 0)",
        "q_s" => "Stribeck velocity in rad/s (> 0)",
        "f_v" => "viscous coefficient in N·m·s/rad (≥ 0)",
        "f_c" => "Coulomb level in N·m (≥ 0)",
        "rmse" | "rmse_dfe" => "fit RMSE in N·m (≥ 0)",
        _ => "a number",
    }
}

fn check_keys(map: &Mapping, allowed: &[&str], ctx: &str) -> Result<(), FrictionError> {
    for k in map.keys() {
        let ks = k.as_str().unwrap_or("");
        if !allowed.contains(&ks) {
            return Err(perr(format!(
                "{ctx}: unknown field `{}`; allowed fields here are {}",
                serde_yaml::to_string(k).unwrap_or_default().trim(),
                allowed.iter().map(|a| format!("`{a}`")).collect::<Vec<_>>().join(", ")
            )));
        }
    }
    Ok(())
}

fn get_f64(map: &Mapping, key: &str, ctx: &str) -> Result<Option<f64>, FrictionError> {
    match map.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => {
            let v = n.as_f64().unwrap_or(f64::NAN);
            if v.is_nan() {
                Err(perr(format!("{ctx}: {key} is NaN; give the {}", meaning(key))))
            } else {
                Ok(Some(v))
            }
        }
        Some(other) => Err(perr(format!(
            "{ctx}: {key} = {} is not a number; give the {}",
            serde_yaml::to_string(other).unwrap_or_default().trim(),
            meaning(key)
        ))),
    }
}

fn req_f64(map: &Mapping, key: &str, ctx: &str) -> Result<f64, FrictionError> {
    get_f64(map, key, ctx)?
        .ok_or_else(|| perr(format!("{ctx}: missing field `{key}`; add `{key}: <{}>`", meaning(key))))
}

fn get_usize(map: &Mapping, key: &str, ctx: &str) -> Result<Option<usize>, FrictionError> {
    match map.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) if n.as_u64().is_some() => Ok(Some(n.as_u64().unwrap_or(0) as usize)),
        Some(other) => Err(perr(format!(
            "{ctx}: {key} = {} is not a whole number ≥ 0; fix it",
            serde_yaml::to_string(other).unwrap_or_default().trim()
        ))),
    }
}

fn read_stats(map: &Mapping, ctx: &str) -> Result<BranchStats, FrictionError> {
    let mut s = BranchStats {
        rmse: get_f64(map, "rmse", ctx)?,
        rmse_dfe: get_f64(map, "rmse_dfe", ctx)?,
        n_points: get_usize(map, "n_points", ctx)?,
        ci95: Vec::new(),
    };
    for (k, v) in [("rmse", s.rmse), ("rmse_dfe", s.rmse_dfe)] {
        if let Some(v) = v {
            if !v.is_finite() || v < 0.0 {
                return Err(perr(format!("{ctx}: {k} = {v} is invalid; give the {}", meaning(k))));
            }
        }
    }
    match map.get("ci95") {
        None | Some(Value::Null) => {}
        Some(Value::Mapping(m)) => {
            for (k, v) in m {
                let name = k.as_str().unwrap_or("?").to_string();
                let bad = || {
                    perr(format!(
                        "{ctx}: ci95.{name} must be `[lo, hi]` (two finite numbers, lo ≤ hi), `at bound` or `unidentifiable`"
                    ))
                };
                let ci = match v {
                    Value::String(t) if t == "at bound" => Ci95::AtBound,
                    Value::String(t) if t == "unidentifiable" => Ci95::Unidentifiable,
                    Value::Sequence(seq) if seq.len() == 2 => {
                        let lo = seq[0].as_f64().ok_or_else(bad)?;
                        let hi = seq[1].as_f64().ok_or_else(bad)?;
                        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                            return Err(bad());
                        }
                        Ci95::Interval { lo, hi }
                    }
                    _ => return Err(bad()),
                };
                s.ci95.push((name, ci));
            }
        }
        Some(_) => return Err(perr(format!("{ctx}: ci95 must be a map like `{{f_a: [lo, hi], q_s: at bound}}`"))),
    }
    Ok(s)
}

fn read_stribeck(map: &Mapping, ctx: &str) -> Result<StribeckParams, FrictionError> {
    let p = StribeckParams {
        f_a: req_f64(map, "f_a", ctx)?,
        f_b: req_f64(map, "f_b", ctx)?,
        q_s: req_f64(map, "q_s", ctx)?,
        f_v: req_f64(map, "f_v", ctx)?,
    };
    p.validate(ctx)?;
    Ok(p)
}

fn as_map<'a>(v: &'a Value, ctx: &str, what: &str) -> Result<&'a Mapping, FrictionError> {
    v.as_mapping().ok_or_else(|| perr(format!("{ctx}: {what} must be a map of fields (`name: value`)")))
}

fn read_joint(v: &Value, idx: usize, file: &str) -> Result<JointParams, FrictionError> {
    let ctx0 = format!("{file}: joints[{idx}]");
    let map = as_map(v, &ctx0, "each entry of `joints`")?;
    let joint = match map.get("joint") {
        Some(Value::Number(n)) if n.as_u64().is_some_and(|j| j >= 1) => n.as_u64().unwrap_or(1) as usize,
        Some(other) => {
            return Err(perr(format!(
                "{ctx0}: joint = {} is not a joint number; use an integer ≥ 1 (joint 1 is the base joint)",
                serde_yaml::to_string(other).unwrap_or_default().trim()
            )))
        }
        None => return Err(perr(format!("{ctx0}: missing field `joint`; add `joint: <number from 1>`"))),
    };
    let ctx = format!("{file}: joint {joint}");
    let model = match map.get("model") {
        Some(Value::String(s)) => s.as_str(),
        Some(_) | None => {
            return Err(perr(format!(
                "{ctx}: missing or non-text field `model`; add `model: stribeck_per_direction` (Table 1), \
                 `stribeck` (eq. 5) or `coulomb_viscous` (eq. 4)"
            )))
        }
    };
    let sub = |key: &str| -> Result<Option<&Mapping>, FrictionError> {
        match map.get(key) {
            None => Ok(None),
            Some(v) => as_map(v, &format!("{ctx}, {key}"), key).map(Some),
        }
    };
    let mut stats = JointStats::default();
    let sym_stats = |stats: &mut JointStats| -> Result<(), FrictionError> {
        stats.all = read_stats(map, &ctx)?;
        for (key, slot) in [("stats_positive", &mut stats.positive), ("stats_negative", &mut stats.negative)] {
            if let Some(m) = sub(key)? {
                let c = format!("{ctx}, {key}");
                check_keys(m, &STAT_KEYS, &c)?;
                *slot = read_stats(m, &c)?;
            }
        }
        Ok(())
    };
    let friction = match model {
        "stribeck_per_direction" => {
            check_keys(map, &["joint", "model", "positive", "negative"], &ctx)?;
            let branch = |dir: &str| -> Result<(StribeckParams, BranchStats), FrictionError> {
                let c = format!("{ctx}, {dir} direction");
                let m = sub(dir)?.ok_or_else(|| {
                    perr(format!(
                        "{ctx}: missing field `{dir}`; a stribeck_per_direction joint needs `positive:` and `negative:` maps \
                         with f_a, f_b, q_s, f_v (positive magnitudes)"
                    ))
                })?;
                let allowed: Vec<&str> = STRIBECK_KEYS.iter().chain(&STAT_KEYS).copied().collect();
                check_keys(m, &allowed, &c)?;
                Ok((read_stribeck(m, &c)?, read_stats(m, &c)?))
            };
            let (positive, sp) = branch("positive")?;
            let (negative, sn) = branch("negative")?;
            stats.positive = sp;
            stats.negative = sn;
            JointFriction::StribeckPerDirection { positive, negative }
        }
        "stribeck" => {
            let allowed: Vec<&str> = ["joint", "model", "stats_positive", "stats_negative"]
                .iter()
                .chain(&STRIBECK_KEYS)
                .chain(&STAT_KEYS)
                .copied()
                .collect();
            check_keys(map, &allowed, &ctx)?;
            sym_stats(&mut stats)?;
            JointFriction::Stribeck(read_stribeck(map, &ctx)?)
        }
        "coulomb_viscous" => {
            let allowed: Vec<&str> = ["joint", "model", "stats_positive", "stats_negative", "f_c", "f_v"]
                .iter()
                .chain(&STAT_KEYS)
                .copied()
                .collect();
            check_keys(map, &allowed, &ctx)?;
            sym_stats(&mut stats)?;
            let jf = JointFriction::CoulombViscous { f_c: req_f64(map, "f_c", &ctx)?, f_v: req_f64(map, "f_v", &ctx)? };
            jf.validate(&ctx)?;
            jf
        }
        other => {
            return Err(perr(format!(
                "{ctx}: unknown model `{other}`; use `stribeck_per_direction` (Table 1), `stribeck` (eq. 5) or \
                 `coulomb_viscous` (eq. 4)"
            )))
        }
    };
    Ok(JointParams { joint, friction, stats })
}

fn num(v: f64) -> Value {
    Value::Number(v.into())
}

fn stats_into(m: &mut Mapping, s: &BranchStats) {
    if let Some(v) = s.rmse {
        m.insert("rmse".into(), num(v));
    }
    if let Some(v) = s.rmse_dfe {
        m.insert("rmse_dfe".into(), num(v));
    }
    if let Some(n) = s.n_points {
        m.insert("n_points".into(), Value::Number((n as u64).into()));
    }
    if !s.ci95.is_empty() {
        let mut c = Mapping::new();
        for (name, ci) in &s.ci95 {
            let v = match ci {
                Ci95::Interval { lo, hi } => Value::Sequence(vec![num(*lo), num(*hi)]),
                Ci95::AtBound => "at bound".into(),
                Ci95::Unidentifiable => "unidentifiable".into(),
            };
            c.insert(name.as_str().into(), v);
        }
        m.insert("ci95".into(), Value::Mapping(c));
    }
}

fn stribeck_into(m: &mut Mapping, p: &StribeckParams) {
    m.insert("f_a".into(), num(p.f_a));
    m.insert("f_b".into(), num(p.f_b));
    m.insert("q_s".into(), num(p.q_s));
    m.insert("f_v".into(), num(p.f_v));
}

impl FrictionParams {
    /// Parses and validates YAML text; `name` (the file name) is used in messages.
    pub fn from_yaml_str(name: &str, text: &str) -> Result<Self, FrictionError> {
        let root: Value = serde_yaml::from_str(text)
            .map_err(|e| perr(format!("{name}: not valid YAML ({e}); fix the syntax at the place shown")))?;
        let map = root
            .as_mapping()
            .ok_or_else(|| perr(format!("{name}: the file must be a YAML map with `source:` and `joints:`")))?;
        check_keys(map, &["source", "notes", "smoothing_v_s", "joints"], name)?;
        let source = match map.get("source") {
            Some(Value::String(s)) if !s.trim().is_empty() => s.clone(),
            _ => {
                return Err(perr(format!(
                    "{name}: missing field `source`; say where the parameters come from, e.g. \
                     `source: \"Table 1 of the NAIC paper\"` or the fit command and data file"
                )))
            }
        };
        let notes = match map.get("notes") {
            None | Some(Value::Null) => None,
            Some(Value::String(s)) => Some(s.clone()),
            Some(_) => return Err(perr(format!("{name}: notes must be text"))),
        };
        let smoothing_v_s = get_f64(map, "smoothing_v_s", name)?;
        if let Some(v) = smoothing_v_s {
            if !(v.is_finite() && v > 0.0) {
                return Err(perr(format!(
                    "{name}: smoothing_v_s = {v} is invalid; give the tanh smoothing velocity in rad/s (> 0, e.g. 0.001) \
                     or remove the field for the exact sgn law"
                )));
            }
        }
        let seq = match map.get("joints") {
            Some(Value::Sequence(s)) if !s.is_empty() => s,
            _ => {
                return Err(perr(format!(
                    "{name}: missing or empty `joints:` list; add one entry per joint (`- joint: 1`, `model: ...`, parameters)"
                )))
            }
        };
        let mut joints = Vec::with_capacity(seq.len());
        for (i, v) in seq.iter().enumerate() {
            let jp = read_joint(v, i, name)?;
            if joints.iter().any(|o: &JointParams| o.joint == jp.joint) {
                return Err(perr(format!("{name}: joint {} appears twice in `joints`; keep one entry per joint", jp.joint)));
            }
            joints.push(jp);
        }
        Ok(Self { source, notes, smoothing_v_s, joints })
    }

    /// Reads and validates a YAML file.
    pub fn from_yaml_file(path: impl AsRef<Path>) -> Result<Self, FrictionError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| FrictionError::Io { path: path.display().to_string(), source: e })?;
        Self::from_yaml_str(&path.display().to_string(), &text)
    }

    /// The YAML text (with a comment header) that [`FrictionParams::from_yaml_str`] reads back unchanged.
    pub fn to_yaml_string(&self) -> String {
        let mut root = Mapping::new();
        root.insert("source".into(), self.source.as_str().into());
        if let Some(n) = &self.notes {
            root.insert("notes".into(), n.as_str().into());
        }
        if let Some(v) = self.smoothing_v_s {
            root.insert("smoothing_v_s".into(), num(v));
        }
        let mut seq = Vec::new();
        for j in &self.joints {
            let mut m = Mapping::new();
            m.insert("joint".into(), Value::Number((j.joint as u64).into()));
            m.insert("model".into(), j.friction.model_name().into());
            match &j.friction {
                JointFriction::StribeckPerDirection { positive, negative } => {
                    for (key, p, s) in [("positive", positive, &j.stats.positive), ("negative", negative, &j.stats.negative)] {
                        let mut b = Mapping::new();
                        stribeck_into(&mut b, p);
                        stats_into(&mut b, s);
                        m.insert(key.into(), Value::Mapping(b));
                    }
                }
                JointFriction::Stribeck(p) => stribeck_into(&mut m, p),
                JointFriction::CoulombViscous { f_c, f_v } => {
                    m.insert("f_c".into(), num(*f_c));
                    m.insert("f_v".into(), num(*f_v));
                }
            }
            if !matches!(j.friction, JointFriction::StribeckPerDirection { .. }) {
                stats_into(&mut m, &j.stats.all);
                for (key, s) in [("stats_positive", &j.stats.positive), ("stats_negative", &j.stats.negative)] {
                    if !s.is_empty() {
                        let mut b = Mapping::new();
                        stats_into(&mut b, s);
                        m.insert(key.into(), Value::Mapping(b));
                    }
                }
            }
            seq.push(Value::Mapping(m));
        }
        root.insert("joints".into(), Value::Sequence(seq));
        let body = serde_yaml::to_string(&Value::Mapping(root)).unwrap_or_default();
        format!(
            "# Joint friction parameters for naic (read by naic_core::friction::FrictionParams).\n\
             # Units: f_a, f_b, f_c in N·m; q_s in rad/s; f_v in N·m·s/rad; joints numbered from 1.\n{body}"
        )
    }

    /// Writes [`FrictionParams::to_yaml_string`] to `path`, creating its directory.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), FrictionError> {
        let path = path.as_ref();
        let io = |e| FrictionError::Io { path: path.display().to_string(), source: e };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        std::fs::write(path, self.to_yaml_string()).map_err(io)
    }

    /// The model of a friction file as the feedforward evaluates it: smooth (tanh,
    /// [`super::DEFAULT_V_S`]), whatever smoothing the file names. One place for `naic sim`
    /// and the controller node, whose scheduled law takes its Stribeck drops from it
    /// (`pipeline::feedforward::FastVelocity::for_model`), so both find the same ones.
    pub fn load_feedforward_model(path: impl AsRef<Path>) -> Result<FrictionModel, FrictionError> {
        Self::from_yaml_file(path)?.to_model()?.with_smoothing(Smoothing::Tanh { v_s: super::DEFAULT_V_S })
    }

    /// The evaluable model: joints must be exactly 1..n (any order in the file).
    pub fn to_model(&self) -> Result<FrictionModel, FrictionError> {
        let n = self.joints.len();
        let mut laws: Vec<Option<JointFriction>> = vec![None; n];
        for j in &self.joints {
            if j.joint > n {
                let have: Vec<String> = self.joints.iter().map(|j| j.joint.to_string()).collect();
                return Err(perr(format!(
                    "joint {} given but the file has only {n} joints ({}); a model needs joints 1..{n} without gaps",
                    j.joint,
                    have.join(", ")
                )));
            }
            laws[j.joint - 1] = Some(j.friction);
        }
        let laws: Vec<JointFriction> = laws.into_iter().flatten().collect();
        let model = FrictionModel::new(laws)?;
        match self.smoothing_v_s {
            Some(v_s) => model.with_smoothing(Smoothing::Tanh { v_s }),
            None => Ok(model),
        }
    }
}

impl FrictionModel {
    /// Loads a parameter file and builds the model (see [`FrictionParams`]).
    pub fn from_yaml_file(path: impl AsRef<Path>) -> Result<Self, FrictionError> {
        FrictionParams::from_yaml_file(path)?.to_model()
    }
}
