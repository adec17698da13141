//! Declared parameters with ROS descriptors, validation and change tracking.
//!
//! ros2-client 0.12 keeps parameter values but has no descriptor API (its
//! `describe_parameters` answers "description missing"), so naic serves the six
//! `rcl_interfaces` parameter services itself (see [`crate::node`]) from this table.
//!
//! Rules (as rclcpp applies them, plus ranges on array elements):
//! - only declared parameters exist; setting anything else is rejected;
//! - the type is fixed (an integer given for a double parameter is converted);
//! - numeric values must lie in the declared range, strings in the declared choices,
//!   arrays have the declared length;
//! - read-only parameters are fixed after start-up;
//! - a node-specific check sees the whole proposed set and may reject it with a reason.
//!
//! The control loop polls [`ParamTable::generation`] (one atomic load) and copies the
//! values only when it changed, so an accepted value takes effect at the next cycle.

use std::sync::{
    atomic::{AtomicU64, Ordering},
    Mutex,
};

use ros2_client::{
    parameters::raw,
    ParameterValue,
};

/// Declared numeric range of a parameter (inclusive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Range {
    None,
    Float { from: f64, to: f64 },
    Int { from: i64, to: i64 },
}

/// Declaration of one parameter.
#[derive(Debug, Clone)]
pub struct ParamSpec {
    pub name: String,
    pub description: String,
    pub default: ParameterValue,
    pub range: Range,
    /// Allowed values of a string parameter (empty: any string).
    pub choices: Vec<String>,
    /// Required length of an array parameter.
    pub len: Option<usize>,
    /// A double array that also accepts one number, meaning that value for every element.
    pub scalar_fills: bool,
    pub read_only: bool,
}

impl ParamSpec {
    pub fn new(name: &str, default: ParameterValue, description: &str) -> Self {
        ParamSpec {
            name: name.into(),
            description: description.into(),
            default,
            range: Range::None,
            choices: vec![],
            len: None,
            scalar_fills: false,
            read_only: false,
        }
    }
    pub fn double(name: &str, default: f64, from: f64, to: f64, description: &str) -> Self {
        Self::new(name, ParameterValue::Double(default), description).range(Range::Float { from, to })
    }
    pub fn int(name: &str, default: i64, from: i64, to: i64, description: &str) -> Self {
        Self::new(name, ParameterValue::Integer(default), description).range(Range::Int { from, to })
    }
    pub fn boolean(name: &str, default: bool, description: &str) -> Self {
        Self::new(name, ParameterValue::Boolean(default), description)
    }
    pub fn string(name: &str, default: &str, description: &str) -> Self {
        Self::new(name, ParameterValue::String(default.into()), description)
    }
    pub fn choice(name: &str, default: &str, choices: &[&str], description: &str) -> Self {
        let mut s = Self::string(name, default, description);
        s.choices = choices.iter().map(|c| c.to_string()).collect();
        s
    }
    pub fn doubles(name: &str, default: &[f64], from: f64, to: f64, description: &str) -> Self {
        let mut s = Self::new(name, ParameterValue::DoubleArray(default.to_vec()), description)
            .range(Range::Float { from, to });
        s.len = Some(default.len());
        s
    }
    pub fn range(mut self, range: Range) -> Self {
        self.range = range;
        self
    }
    pub fn read_only(mut self) -> Self {
        self.read_only = true;
        self
    }
    /// A double array that also accepts a single number for all its elements
    /// (`x` → `[x, x, …]`, from files, `-p` and the parameter services alike).
    pub fn scalar_fills(mut self) -> Self {
        self.scalar_fills = true;
        self
    }

    /// Human-readable constraints, also sent as the descriptor's `additional_constraints`.
    pub fn constraints(&self) -> String {
        let mut parts = vec![];
        if !self.choices.is_empty() {
            parts.push(format!("one of: {}", self.choices.join(", ")));
        }
        if let Some(n) = self.len {
            parts.push(format!("exactly {n} elements"));
        }
        if self.scalar_fills {
            parts.push("or one number for all elements".into());
        }
        if matches!(self.default, ParameterValue::DoubleArray(_)) {
            if let Range::Float { from, to } = self.range {
                parts.push(format!("each element in [{from}, {to}]"));
            }
        }
        if matches!(self.default, ParameterValue::Double(_) | ParameterValue::DoubleArray(_)) {
            parts.push("finite".into());
        }
        parts.join("; ")
    }

    /// The `rcl_interfaces/ParameterDescriptor` rclpy's `describe_parameters` returns.
    pub fn descriptor(&self) -> raw::ParameterDescriptor {
        let scalar = !matches!(
            self.default,
            ParameterValue::DoubleArray(_) | ParameterValue::IntegerArray(_)
        );
        let (integer_range, floating_point_range) = match self.range {
            Range::Int { from, to } if scalar => {
                (vec![raw::IntegerRange { from_value: from, to_value: to, step: 0 }], vec![])
            }
            Range::Float { from, to } if scalar => (
                vec![],
                vec![raw::FloatingPointRange { from_value: from, to_value: to, step: 0.0 }],
            ),
            _ => (vec![], vec![]),
        };
        raw::ParameterDescriptor {
            name: self.name.clone(),
            r#type: self.default.to_parameter_type() as u8,
            description: self.description.clone(),
            additional_constraints: self.constraints(),
            read_only: self.read_only,
            dynamic_typing: false,
            integer_range,
            floating_point_range,
        }
    }

    /// Check `value` against this declaration; returns the value to store (ints → doubles).
    pub fn validate(&self, value: ParameterValue) -> Result<ParameterValue, ParamError> {
        use ParameterValue as V;
        let name = &self.name;
        let fill = |x: f64| V::DoubleArray(vec![x; self.len.unwrap_or(1)]);
        let value = match (&self.default, value) {
            (V::Double(_), V::Integer(i)) => V::Double(i as f64),
            (V::DoubleArray(_), V::IntegerArray(a)) => V::DoubleArray(a.iter().map(|&i| i as f64).collect()),
            (V::DoubleArray(_), V::Double(x)) if self.scalar_fills => fill(x),
            (V::DoubleArray(_), V::Integer(i)) if self.scalar_fills => fill(i as f64),
            (_, v) => v,
        };
        if value.to_parameter_type() != self.default.to_parameter_type() {
            return Err(ParamError::WrongType {
                name: name.clone(),
                expected: type_name(&self.default),
                got: type_name(&value),
            });
        }
        let out_of_range = |value: String, from: String, to: String| ParamError::OutOfRange { name: name.clone(), value, from, to };
        let in_float = |x: f64| -> Result<(), ParamError> {
            if !x.is_finite() {
                return Err(ParamError::NotFinite { name: name.clone(), value: x });
            }
            if let Range::Float { from, to } = self.range {
                if !(from..=to).contains(&x) {
                    return Err(out_of_range(x.to_string(), from.to_string(), to.to_string()));
                }
            }
            Ok(())
        };
        match &value {
            V::Double(x) => in_float(*x)?,
            V::DoubleArray(a) => {
                for x in a {
                    in_float(*x)?
                }
            }
            V::Integer(i) => {
                if let Range::Int { from, to } = self.range {
                    if !(from..=to).contains(i) {
                        return Err(out_of_range(i.to_string(), from.to_string(), to.to_string()));
                    }
                }
            }
            V::String(s) => {
                if !self.choices.is_empty() && !self.choices.iter().any(|c| c == s) {
                    return Err(ParamError::NotAChoice { name: name.clone(), value: s.clone(), choices: self.choices.join(", ") });
                }
            }
            _ => {}
        }
        if let Some(n) = self.len {
            let got = match &value {
                V::DoubleArray(a) => a.len(),
                V::IntegerArray(a) => a.len(),
                V::StringArray(a) => a.len(),
                V::BooleanArray(a) => a.len(),
                _ => n,
            };
            if got != n {
                return Err(ParamError::WrongLength { name: name.clone(), expected: n, got });
            }
        }
        Ok(value)
    }
}

pub fn type_name(v: &ParameterValue) -> &'static str {
    use ParameterValue as V;
    match v {
        V::NotSet => "not set",
        V::Boolean(_) => "bool",
        V::Integer(_) => "integer",
        V::Double(_) => "double",
        V::String(_) => "string",
        V::ByteArray(_) => "byte array",
        V::BooleanArray(_) => "bool array",
        V::IntegerArray(_) => "integer array",
        V::DoubleArray(_) => "double array",
        V::StringArray(_) => "string array",
    }
}

/// Read access to a complete set of parameter values (current or proposed).
pub struct ParamView<'a> {
    specs: &'a [ParamSpec],
    values: &'a [ParameterValue],
}

impl<'a> ParamView<'a> {
    pub fn get(&self, name: &str) -> Option<&'a ParameterValue> {
        self.specs.iter().position(|s| s.name == name).map(|i| &self.values[i])
    }
    /// A declared double (0.0 if the name is not a declared double: a programming error
    /// caught by the node's unit tests).
    pub fn f64(&self, name: &str) -> f64 {
        match self.get(name) {
            Some(ParameterValue::Double(x)) => *x,
            Some(ParameterValue::Integer(i)) => *i as f64,
            _ => {
                debug_assert!(false, "parameter {name} is not a declared double");
                0.0
            }
        }
    }
    pub fn i64(&self, name: &str) -> i64 {
        match self.get(name) {
            Some(ParameterValue::Integer(i)) => *i,
            _ => {
                debug_assert!(false, "parameter {name} is not a declared integer");
                0
            }
        }
    }
    pub fn bool(&self, name: &str) -> bool {
        matches!(self.get(name), Some(ParameterValue::Boolean(true)))
    }
    pub fn str(&self, name: &str) -> &'a str {
        match self.get(name) {
            Some(ParameterValue::String(s)) => s,
            _ => {
                debug_assert!(false, "parameter {name} is not a declared string");
                ""
            }
        }
    }
    pub fn f64s(&self, name: &str) -> &'a [f64] {
        match self.get(name) {
            Some(ParameterValue::DoubleArray(a)) => a,
            _ => {
                debug_assert!(false, "parameter {name} is not a declared double array");
                &[]
            }
        }
    }
}

/// Why a parameter value, declaration or set request was refused. The text (`Display`) is
/// what a ROS client gets as `SetParametersResult.reason` and what a node prints at start-up:
/// it names the parameter, the value and the rule.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("parameter '{name}' is not declared by this node")]
    Undeclared { name: String },
    #[error("unknown parameter '{name}'; this node declares: {declared}")]
    Unknown { name: String, declared: String },
    #[error("parameter '{name}' declared twice")]
    DeclaredTwice { name: String },
    #[error("default of {0}")]
    BadDefault(Box<ParamError>),
    #[error("parameter '{name}' cannot be undeclared")]
    Unset { name: String },
    #[error("parameter '{name}' is read-only")]
    ReadOnly { name: String },
    #[error("parameter '{name}' has type {expected}, got {got}")]
    WrongType { name: String, expected: &'static str, got: &'static str },
    #[error("parameter '{name}' must be finite, got {value}")]
    NotFinite { name: String, value: f64 },
    #[error("parameter '{name}' = {value} is outside its range [{from}, {to}]")]
    OutOfRange { name: String, value: String, from: String, to: String },
    #[error("parameter '{name}' = '{value}' is not one of: {choices}")]
    NotAChoice { name: String, value: String, choices: String },
    #[error("parameter '{name}' needs exactly {expected} elements, got {got}")]
    WrongLength { name: String, expected: usize, got: usize },
    #[error("parameter '{name}' must be a file path, got {got}")]
    NotAPath { name: String, got: String },
    /// The core refused the parameter set (its field, value and rule).
    #[error("{0}")]
    Core(#[from] naic_core::pipeline::ConfigError),
    /// A node's rule across its parameters ([`SetCheck`]), in the node's words.
    #[error("{0}")]
    Rule(String),
    /// The file parameter `param` names (`path`: a URDF, a friction YAML) cannot be used:
    /// `problem` says why (naming the file), `fix` what to set instead.
    #[error("{problem} ({fix})")]
    File { param: &'static str, path: String, problem: String, fix: &'static str },
}

impl ParamError {
    /// The file `path` named by parameter `param` cannot be used: `problem`, fixed by `fix`.
    pub fn file(param: &'static str, path: &str, problem: impl Into<String>, fix: &'static str) -> Self {
        ParamError::File { param, path: path.to_string(), problem: problem.into(), fix }
    }
}

impl From<String> for ParamError {
    /// A node check's reason (the core's validation messages name the field and the rule).
    fn from(reason: String) -> Self {
        ParamError::Rule(reason)
    }
}

/// A whole-set check run on every proposed change (cross-parameter rules).
pub type SetCheck = Box<dyn Fn(&ParamView) -> Result<(), ParamError> + Send + Sync>;

/// Largest per-joint effort limit an `effort_limit` parameter may declare [N m] (the range
/// of the parameter; a larger URDF limit is capped to it).
pub const EFFORT_CAP: f64 = 10_000.0;

/// The `<limit effort>` of the arm's joints in `urdf` [N m], capped at [`EFFORT_CAP`]: the
/// default and the ceiling of the nodes' `effort_limit`. A model that does not load, has
/// another joint count, or gives a joint no positive limit is refused (no torque limit is
/// guessed), naming the file and the fix.
pub fn urdf_effort_limits(urdf: &str) -> Result<naic_core::JointVec, ParamError> {
    use naic_core::N_JOINTS;
    const FIX: &str = "set -p urdf:=PATH";
    let model = naic_core::model::Model::from_urdf_file(urdf)
        .map_err(|e| ParamError::file("urdf", urdf, format!("cannot load the robot model '{urdf}': {e}"), FIX))?;
    if model.nv() != N_JOINTS {
        return Err(ParamError::file("urdf", urdf, format!("robot model '{urdf}' has {} joints; the JK5 needs {N_JOINTS}", model.nv()), FIX));
    }
    model_effort_limits(&model, "urdf", urdf)
}

/// [`urdf_effort_limits`] of a loaded model of `N` joints (a robot file's, whose `limits`
/// may replace the URDF's): `name`/`source` say where it came from in the error.
pub fn model_effort_limits<const N: usize>(model: &naic_core::model::Model, name: &'static str, source: &str) -> Result<naic_core::JointVec<N>, ParamError> {
    let l = model.effort_limits();
    if l.len() != N {
        return Err(ParamError::file(name, source, format!("robot model '{source}' has {} joints; expected {N}", l.len()), "give an arm of that many joints"));
    }
    if let Some(i) = (0..N).find(|&i| !(l[i].is_finite() && l[i] > 0.0)) {
        let problem = format!("robot model '{source}': joint {} has effort limit {}", i + 1, l[i]);
        return Err(ParamError::file(name, source, problem, "set <limit effort=\"...\"> > 0 in the URDF (or `limits: effort` in the robot file)"));
    }
    Ok(std::array::from_fn(|i| l[i].min(EFFORT_CAP)))
}

/// The nodes' per-joint `effort_limit` may tighten the URDF's `<limit effort>`, never
/// loosen it: the message names the joint and both values.
pub fn effort_limit_within<const N: usize>(p: &ParamView, urdf_effort: &naic_core::JointVec<N>) -> Result<(), ParamError> {
    let e = p.f64s("effort_limit");
    match (0..N).find(|&i| e[i] > urdf_effort[i]) {
        Some(i) => Err(ParamError::Rule(format!("effort_limit[{i}] = {} is above the URDF effort limit {} of joint{}", e[i], urdf_effort[i], i + 1))),
        None => Ok(()),
    }
}

/// The node's declared parameters and their current values.
pub struct ParamTable {
    specs: Vec<ParamSpec>,
    values: Mutex<Vec<ParameterValue>>,
    generation: AtomicU64,
    check: Option<SetCheck>,
}

/// Outcome of one set request: the changed (name, value) pairs, for `/parameter_events`.
pub type Changes = Vec<(String, ParameterValue)>;

impl ParamTable {
    /// Declare `specs` (the standard `use_sim_time` is added when missing) and apply the
    /// start-up overrides in order (files, then `-p`). Unknown names and bad values in the
    /// overrides are errors naming the parameter.
    pub fn new(
        mut specs: Vec<ParamSpec>,
        check: Option<SetCheck>,
        overrides: &[(String, ParameterValue)],
    ) -> Result<ParamTable, ParamError> {
        if !specs.iter().any(|s| s.name == "use_sim_time") {
            specs.push(ParamSpec::boolean(
                "use_sim_time",
                false,
                "Stamp and time with /clock (rosgraph_msgs/Clock) instead of the system clock",
            ));
        }
        if !specs.iter().any(|s| s.name == "realtime_priority") {
            specs.push(
                ParamSpec::int(
                    "realtime_priority",
                    0,
                    0,
                    98,
                    "SCHED_RR priority of all the node's threads (0: normal scheduling); needs CAP_SYS_NICE",
                )
                .read_only(),
            );
        }
        if !specs.iter().any(|s| s.name == "cpu_affinity") {
            specs.push(
                ParamSpec::int(
                    "cpu_affinity",
                    -1,
                    -1,
                    1023,
                    "Pin all the node's threads to this CPU (-1: no pinning). The chain nodes on one CPU avoid cross-CPU wake-ups (BENCHMARKS.md)",
                )
                .read_only(),
            );
        }
        if !specs.iter().any(|s| s.name == "data_qos") {
            specs.push(
                ParamSpec::choice(
                    "data_qos",
                    "reliable",
                    &["reliable", "sensor_data"],
                    "QoS of the chain's data topics (/joint_states, /wrench, /naic/effort, /joint_effort_cmd): reliable (what default rclpy subscribers and naic record match), or ROS's sensor-data profile (best effort, keep last 5: a late sample is dropped, not re-sent; observers need a best-effort subscription, and lockstep waits command_timeout for a lost command); the same value on every node of a chain",
                )
                .read_only(),
            );
        }
        for (i, s) in specs.iter().enumerate() {
            if specs[..i].iter().any(|o| o.name == s.name) {
                return Err(ParamError::DeclaredTwice { name: s.name.clone() });
            }
            s.validate(s.default.clone()).map_err(|e| ParamError::BadDefault(Box::new(e)))?;
        }
        let mut values: Vec<ParameterValue> = specs.iter().map(|s| s.default.clone()).collect();
        for (name, v) in overrides {
            let Some(i) = specs.iter().position(|s| &s.name == name) else {
                return Err(ParamError::Unknown {
                    name: name.clone(),
                    declared: specs.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", "),
                });
            };
            values[i] = specs[i].validate(v.clone())?;
        }
        if let Some(c) = &check {
            c(&ParamView { specs: &specs, values: &values })?;
        }
        Ok(ParamTable { specs, values: Mutex::new(values), generation: AtomicU64::new(1), check })
    }

    pub fn specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    /// Changes every time a set is accepted (start: 1).
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }

    /// Run `f` on a consistent view of the current values.
    pub fn with<R>(&self, f: impl FnOnce(&ParamView) -> R) -> R {
        let values = self.values.lock().unwrap_or_else(|p| p.into_inner());
        f(&ParamView { specs: &self.specs, values: &values })
    }

    pub fn get(&self, name: &str) -> Option<ParameterValue> {
        self.with(|v| v.get(name).cloned())
    }

    pub fn all(&self) -> Vec<(String, ParameterValue)> {
        self.with(|v| self.specs.iter().map(|s| (s.name.clone(), v.get(&s.name).cloned().unwrap_or(ParameterValue::NotSet))).collect())
    }

    /// Set several parameters all-or-nothing. Errors carry the reason for the caller.
    pub fn set_atomically(&self, params: &[(String, ParameterValue)]) -> Result<Changes, ParamError> {
        let mut values = self.values.lock().unwrap_or_else(|p| p.into_inner());
        let mut proposed = values.clone();
        let mut changes = Changes::new();
        for (name, v) in params {
            let Some(i) = self.specs.iter().position(|s| &s.name == name) else {
                return Err(ParamError::Undeclared { name: name.clone() });
            };
            let spec = &self.specs[i];
            if matches!(v, ParameterValue::NotSet) {
                return Err(ParamError::Unset { name: name.clone() });
            }
            if spec.read_only {
                return Err(ParamError::ReadOnly { name: name.clone() });
            }
            let v = spec.validate(v.clone())?;
            proposed[i] = v.clone();
            changes.push((name.clone(), v));
        }
        if let Some(c) = &self.check {
            c(&ParamView { specs: &self.specs, values: &proposed })?;
        }
        *values = proposed;
        self.generation.fetch_add(1, Ordering::AcqRel);
        Ok(changes)
    }

    /// `list_parameters` the rclcpp way: names under any of `prefixes` (all when empty),
    /// at most `depth` dotted levels (0: unlimited); returns (names, prefixes).
    pub fn list(&self, prefixes: &[String], depth: u64) -> (Vec<String>, Vec<String>) {
        let mut names = vec![];
        let mut pfx: Vec<String> = vec![];
        for s in &self.specs {
            let n = &s.name;
            let dots = n.matches('.').count() as u64;
            let depth_ok = depth == 0 || dots < depth;
            let prefix_ok = prefixes.is_empty()
                || prefixes.iter().any(|p| n == p || n.starts_with(&format!("{p}.")));
            if depth_ok && prefix_ok {
                names.push(n.clone());
                if let Some((p, _)) = n.rsplit_once('.') {
                    if !pfx.iter().any(|x| x == p) {
                        pfx.push(p.to_string());
                    }
                }
            }
        }
        (names, pfx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParameterValue as V;

    fn table() -> ParamTable {
        ParamTable::new(
            vec![
                ParamSpec::double("learning_rate", 0.01, 0.0, 1.0, "gamma"),
                ParamSpec::choice("mode", "naic", &["naic", "aic", "fixed"], "controller"),
                ParamSpec::doubles("m_d", &[1.0, 1.0, 1.0], 0.01, 100.0, "mass"),
                ParamSpec::double("contact_threshold", 2.0, 0.0, 100.0, "N"),
                ParamSpec::double("force_limit", 50.0, 0.0, 500.0, "N"),
                ParamSpec::int("rate", 1000, 1, 10000, "Hz").read_only(),
            ],
            Some(Box::new(|v: &ParamView| {
                if v.f64("contact_threshold") >= v.f64("force_limit") {
                    return Err(ParamError::Rule("contact_threshold must be below force_limit".into()));
                }
                Ok(())
            })),
            &[("learning_rate".into(), V::Double(0.5))],
        )
        .unwrap()
    }

    #[test]
    fn accepts_valid_and_bumps_generation() {
        let t = table();
        assert_eq!(t.get("learning_rate"), Some(V::Double(0.5)));
        let g = t.generation();
        let ch = t.set_atomically(&[("learning_rate".into(), V::Integer(1))]).unwrap();
        assert_eq!(ch, vec![("learning_rate".to_string(), V::Double(1.0))]);
        assert!(t.generation() > g);
        assert_eq!(t.get("use_sim_time"), Some(V::Boolean(false)));
    }

    #[test]
    fn rejects_with_reasons_and_keeps_old_values() {
        let t = table();
        let g = t.generation();
        let e = |p: (&str, V)| t.set_atomically(&[(p.0.to_string(), p.1)]).unwrap_err().to_string();
        assert!(e(("learning_rate", V::Double(-1.0))).contains("outside its range [0, 1]"));
        assert!(e(("learning_rate", V::Double(f64::NAN))).contains("finite"));
        assert!(e(("learning_rate", V::String("x".into()))).contains("type double, got string"));
        assert!(e(("mode", V::String("pid".into()))).contains("not one of: naic, aic, fixed"));
        assert!(e(("m_d", V::DoubleArray(vec![1.0]))).contains("exactly 3 elements"));
        assert!(e(("m_d", V::DoubleArray(vec![1.0, 0.0, 1.0]))).contains("outside"));
        assert!(e(("nope", V::Double(1.0))).contains("not declared"));
        assert!(e(("rate", V::Integer(10))).contains("read-only"));
        assert!(e(("contact_threshold", V::Double(60.0))).contains("below force_limit"));
        assert_eq!(t.generation(), g);
        assert_eq!(t.get("learning_rate"), Some(V::Double(0.5)));
    }

    #[test]
    fn a_scalar_fills_an_array_only_where_declared() {
        let t = ParamTable::new(
            vec![
                ParamSpec::doubles("per_joint", &[1.0; 3], 0.0, 10.0, "fills").scalar_fills(),
                ParamSpec::doubles("strict", &[1.0; 3], 0.0, 10.0, "does not"),
            ],
            None,
            &[("per_joint".into(), V::Double(2.5))],
        )
        .unwrap();
        assert_eq!(t.get("per_joint"), Some(V::DoubleArray(vec![2.5; 3])));
        t.set_atomically(&[("per_joint".into(), V::Integer(4))]).unwrap();
        assert_eq!(t.get("per_joint"), Some(V::DoubleArray(vec![4.0; 3])));
        // Still range-checked and finite.
        assert!(t.set_atomically(&[("per_joint".into(), V::Double(11.0))]).unwrap_err().to_string().contains("outside"));
        assert!(t.set_atomically(&[("per_joint".into(), V::Double(f64::NAN))]).unwrap_err().to_string().contains("finite"));
        assert!(t.set_atomically(&[("strict".into(), V::Double(2.0))]).unwrap_err().to_string().contains("type double array, got double"));
        assert!(t.specs()[0].constraints().contains("one number for all"));
    }

    #[test]
    fn atomic_set_is_all_or_nothing() {
        let t = table();
        let r = t.set_atomically(&[
            ("learning_rate".into(), V::Double(0.2)),
            ("mode".into(), V::String("bad".into())),
        ]);
        assert!(r.is_err());
        assert_eq!(t.get("learning_rate"), Some(V::Double(0.5)));
    }

    #[test]
    fn bad_overrides_fail_at_start() {
        let specs = || vec![ParamSpec::double("a", 1.0, 0.0, 2.0, "a")];
        let e = ParamTable::new(specs(), None, &[("b".into(), V::Double(1.0))]).err().unwrap();
        assert!(matches!(&e, ParamError::Unknown { name, .. } if name == "b"), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("unknown parameter 'b'") && e.contains("declares: a"), "{e}");
        let e = ParamTable::new(specs(), None, &[("a".into(), V::Double(3.0))]).err().unwrap();
        assert!(matches!(&e, ParamError::OutOfRange { name, value, .. } if name == "a" && value == "3"), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("outside"), "{e}");
    }

    #[test]
    fn descriptor_carries_range_and_text() {
        let t = table();
        let d = t.specs()[0].descriptor();
        assert_eq!(d.description, "gamma");
        assert_eq!(d.r#type, 3);
        assert_eq!(d.floating_point_range.len(), 1);
        assert_eq!(d.floating_point_range[0].to_value, 1.0);
        let d = t.specs()[1].descriptor();
        assert!(d.additional_constraints.contains("naic, aic, fixed"));
        let (names, _) = t.list(&[], 0);
        assert_eq!(names.len(), 10); // 6 declared + use_sim_time, realtime_priority, cpu_affinity, data_qos
    }
}
