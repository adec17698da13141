//! `--ros-args` command-line parsing, the subset the naic nodes support:
//! `-p name:=value`, `--params-file FILE`, `-r __node:=NAME`, `-r __ns:=/NS`,
//! `-r old_topic:=new_topic`, and `--log-level LEVEL` (accepted, applied to stderr logging).
//!
//! Values after `-p` are parsed the way ROS 2 does it: as one YAML value
//! (`true` → bool, `3` → integer, `0.5` → double, `[1.0, 2.0]` → double array,
//! anything else → string).

use std::path::PathBuf;

use ros2_client::ParameterValue;

use crate::{params::ParamError, RosError};

/// What the command line asked for.
#[derive(Debug, Clone, Default)]
pub struct RosArgs {
    /// `-r __node:=NAME`
    pub node_name: Option<String>,
    /// `-r __ns:=/NS`
    pub namespace: Option<String>,
    /// `-p name:=value`, in command-line order (later wins).
    pub params: Vec<(String, ParameterValue)>,
    /// `--params-file FILE`, in command-line order (later wins; `-p` wins over files).
    pub params_files: Vec<PathBuf>,
    /// `-r from:=to` topic remappings (names as given, e.g. `joint_states` or `/joint_states`).
    pub remaps: Vec<(String, String)>,
    /// `--log-level LEVEL`
    pub log_level: Option<String>,
    /// `-e NAME` / `--enclave NAME`: the SROS2 enclave (DDS Security, [`crate::security`]).
    pub enclave: Option<String>,
}

const USAGE: &str = "usage: <node> [--ros-args [-p name:=value]... [--params-file FILE]... \
[-r __node:=NAME] [-r __ns:=/NAMESPACE] [-r from:=to]... [--log-level LEVEL] [--enclave /NAME] [--]]";

impl RosArgs {
    /// The arguments `--ros-args -p a₁ -p a₂ …` for the assignments `name:=value` (tests and
    /// in-process runs of a node).
    pub fn with_params<I, S>(assignments: I) -> Result<RosArgs, RosError>
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        let mut args = vec!["--ros-args".to_string()];
        for a in assignments {
            args.extend(["-p".to_string(), a.into()]);
        }
        RosArgs::parse(args)
    }

    /// Parse the process arguments (without the program name).
    ///
    /// Everything outside `--ros-args … [--]` is rejected: the naic nodes take no other
    /// arguments. `--help`/`-h` outside returns `RosError::Help`.
    pub fn parse<I, S>(args: I) -> Result<RosArgs, RosError>
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        let args: Vec<String> = args.into_iter().map(Into::into).collect();
        let mut out = RosArgs::default();
        let mut i = 0;
        let mut in_ros = false;
        while i < args.len() {
            let a = args[i].as_str();
            if !in_ros {
                match a {
                    "--ros-args" => in_ros = true,
                    "-h" | "--help" => return Err(RosError::Help(USAGE.to_string())),
                    _ => {
                        return Err(RosError::Args(format!(
                            "unexpected argument '{a}'; node options go after --ros-args\n{USAGE}"
                        )))
                    }
                }
                i += 1;
                continue;
            }
            let take_value = |i: usize, what: &str| -> Result<&str, RosError> {
                args.get(i + 1).map(|s| s.as_str()).ok_or_else(|| {
                    RosError::Args(format!("'{a}' needs {what} after it\n{USAGE}"))
                })
            };
            match a {
                "--" => in_ros = false,
                "--ros-args" => {}
                "-p" | "--param" => {
                    let v = take_value(i, "name:=value")?;
                    out.params.push(parse_param_assignment(v)?);
                    i += 1;
                }
                "-e" | "--enclave" => {
                    let v = take_value(i, "an enclave name, e.g. /naic/chain")?;
                    out.enclave = Some(v.to_string());
                    i += 1;
                }
                "--params-file" => {
                    let v = take_value(i, "a YAML file")?;
                    out.params_files.push(PathBuf::from(v));
                    i += 1;
                }
                "-r" | "--remap" => {
                    let v = take_value(i, "from:=to")?;
                    let (from, to) = split_assign(v).ok_or_else(|| {
                        RosError::Args(format!("bad remapping '{v}': expected from:=to"))
                    })?;
                    match from {
                        "__node" | "__name" => {
                            validate_base_name(to).map_err(|e| {
                                RosError::Args(format!("bad node name in '-r {v}': {e}"))
                            })?;
                            out.node_name = Some(to.to_string())
                        }
                        "__ns" => {
                            out.namespace = Some(normalize_namespace(to).map_err(|e| {
                                RosError::Args(format!("bad namespace in '-r {v}': {e}"))
                            })?)
                        }
                        _ => {
                            if from.is_empty() || to.is_empty() {
                                return Err(RosError::Args(format!(
                                    "bad remapping '{v}': both sides must be topic names"
                                )));
                            }
                            out.remaps.push((from.to_string(), to.to_string()))
                        }
                    }
                    i += 1;
                }
                "--log-level" => {
                    let v = take_value(i, "a level (debug, info, warn, error)")?;
                    // `--log-level name:=level` (per logger) is accepted; the level is used.
                    let level = split_assign(v).map(|(_, l)| l).unwrap_or(v).to_ascii_lowercase();
                    if !["debug", "info", "warn", "error", "fatal"].contains(&level.as_str()) {
                        return Err(RosError::Args(format!(
                            "bad log level '{v}': use debug, info, warn, error or fatal"
                        )));
                    }
                    out.log_level = Some(level);
                    i += 1;
                }
                "--enable-rosout-logs" | "--disable-rosout-logs" | "--enable-stdout-logs"
                | "--disable-stdout-logs" => {}
                _ => {
                    return Err(RosError::Args(format!(
                        "unknown --ros-args option '{a}'\n{USAGE}"
                    )))
                }
            }
            i += 1;
        }
        Ok(out)
    }

    /// Fully qualified node name these arguments give a node whose default name is
    /// `default_name`.
    pub fn fqn(&self, default_name: &str) -> String {
        let name = self.node_name.as_deref().unwrap_or(default_name);
        match self.namespace.as_deref() {
            None | Some("/") => format!("/{name}"),
            Some(ns) => format!("{ns}/{name}"),
        }
    }

    /// Start-up overrides in the order they apply: `--params-file`s, then `-p`.
    pub fn overrides(&self, default_name: &str) -> Result<Vec<(String, ParameterValue)>, RosError> {
        let fqn = self.fqn(default_name);
        let mut out = Vec::new();
        for f in &self.params_files {
            out.extend(crate::params_file::load_for_node(f, &fqn)?);
        }
        out.extend(self.params.iter().cloned());
        Ok(out)
    }

    /// The value a parameter gets at start-up from files and `-p` (None: its default).
    /// For parameters a node needs before it can declare the rest (e.g. its model file).
    pub fn peek(&self, default_name: &str, name: &str) -> Result<Option<ParameterValue>, RosError> {
        Ok(self.overrides(default_name)?.into_iter().rev().find(|(n, _)| n == name).map(|(_, v)| v))
    }

    /// [`peek`](Self::peek) for a string parameter such as a file path: its start-up value,
    /// `default` when none is given, an error naming the parameter when it is not a string.
    pub fn peek_string(&self, default_name: &str, name: &str, default: &str) -> Result<String, RosError> {
        match self.peek(default_name, name)? {
            None => Ok(default.to_string()),
            Some(ParameterValue::String(s)) => Ok(s),
            Some(v) => Err(RosError::Param(ParamError::NotAPath { name: name.to_string(), got: format!("{v:?}") })),
        }
    }

    /// Apply topic remappings to a topic name as the node spells it.
    pub fn remap_topic<'a>(&'a self, topic: &'a str) -> &'a str {
        let bare = topic.trim_start_matches('/');
        for (from, to) in self.remaps.iter().rev() {
            if from == topic || from.trim_start_matches('/') == bare {
                return to;
            }
        }
        topic
    }
}

fn split_assign(s: &str) -> Option<(&str, &str)> {
    s.split_once(":=")
}

/// `name:=value` → (name, value parsed as a YAML scalar/sequence).
pub fn parse_param_assignment(s: &str) -> Result<(String, ParameterValue), RosError> {
    let (name, value) = split_assign(s).ok_or_else(|| {
        RosError::Args(format!("bad parameter '-p {s}': expected name:=value, e.g. -p desired_force:=10.0"))
    })?;
    if name.is_empty() {
        return Err(RosError::Args(format!("bad parameter '-p {s}': empty name")));
    }
    let yaml: serde_yaml::Value = serde_yaml::from_str(value).unwrap_or(serde_yaml::Value::String(value.to_string()));
    let v = crate::params_file::yaml_to_value(&yaml).map_err(|e| {
        RosError::Args(format!("bad value for parameter '{name}' in '-p {s}': {e}"))
    })?;
    Ok((name.to_string(), v))
}

/// A ROS name token (a node name, one part of a namespace) that ROS refuses: each variant
/// names the token and the rule it breaks.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    #[error("empty name: give letters, digits and _, e.g. naic_controller")]
    Empty,
    #[error("'{name}' starts with a digit (a name starts with a letter or _)")]
    LeadingDigit { name: String },
    #[error("'{name}' contains '{found}' (only letters, digits and _ are allowed)")]
    BadCharacter { name: String, found: char },
    #[error("'{name}' contains a double underscore (__ is reserved by ROS; use a single _)")]
    DoubleUnderscore { name: String },
}

/// A node base name: letters, digits, underscores, not starting with a digit.
pub fn validate_base_name(s: &str) -> Result<(), NameError> {
    if s.is_empty() {
        return Err(NameError::Empty);
    }
    if s.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(NameError::LeadingDigit { name: s.to_string() });
    }
    if let Some(c) = s.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_')) {
        return Err(NameError::BadCharacter { name: s.to_string(), found: c });
    }
    if s.contains("__") {
        return Err(NameError::DoubleUnderscore { name: s.to_string() });
    }
    Ok(())
}

/// `/a/b`, `a/b`, `/a/b/` → `/a/b`; `/` stays `/`.
pub fn normalize_namespace(s: &str) -> Result<String, NameError> {
    let trimmed = s.trim_matches('/');
    if trimmed.is_empty() {
        return Ok("/".into());
    }
    for tok in trimmed.split('/') {
        validate_base_name(tok)?;
    }
    Ok(format!("/{trimmed}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_full_ros_args() {
        let a = RosArgs::parse([
            "--ros-args", "-p", "desired_force:=12.5", "-p", "mode:=aic", "-p", "k:=3",
            "-p", "flag:=true", "-p", "v:=[1.0, 2.0]", "--params-file", "x.yaml",
            "-r", "__node:=ctl", "-r", "__ns:=/robot1/", "-r", "wrench:=/ft", "--log-level", "warn",
        ])
        .unwrap();
        assert_eq!(a.node_name.as_deref(), Some("ctl"));
        assert_eq!(a.namespace.as_deref(), Some("/robot1"));
        assert_eq!(a.params[0], ("desired_force".into(), ParameterValue::Double(12.5)));
        assert_eq!(a.params[1], ("mode".into(), ParameterValue::String("aic".into())));
        assert_eq!(a.params[2], ("k".into(), ParameterValue::Integer(3)));
        assert_eq!(a.params[3], ("flag".into(), ParameterValue::Boolean(true)));
        assert_eq!(a.params[4], ("v".into(), ParameterValue::DoubleArray(vec![1.0, 2.0])));
        assert_eq!(a.params_files, vec![PathBuf::from("x.yaml")]);
        assert_eq!(a.remap_topic("wrench"), "/ft");
        assert_eq!(a.remap_topic("/wrench"), "/ft");
        assert_eq!(a.remap_topic("joint_states"), "joint_states");
        assert_eq!(a.log_level.as_deref(), Some("warn"));
    }

    #[test]
    fn rejects_bad_args_with_reasons() {
        let e = |v: &[&str]| RosArgs::parse(v.iter().copied()).unwrap_err().to_string();
        assert!(e(&["--foo"]).contains("unexpected argument '--foo'"));
        assert!(e(&["--ros-args", "-p"]).contains("needs name:=value"));
        assert!(e(&["--ros-args", "-p", "novalue"]).contains("expected name:=value"));
        assert!(e(&["--ros-args", "-r", "__node:=9bad"]).contains("starts with a digit"));
        assert!(e(&["--ros-args", "-r", "__ns:=/a b"]).contains("contains ' '"));
        assert!(e(&["--ros-args", "--bogus"]).contains("unknown --ros-args option"));
        assert!(e(&["--ros-args", "--log-level", "loud"]).contains("bad log level"));
        assert!(matches!(RosArgs::parse(["--help"]), Err(RosError::Help(_))));
    }

    #[test]
    fn name_errors_name_the_token_and_the_rule() {
        let e = validate_base_name("9bad").unwrap_err();
        assert_eq!(e, NameError::LeadingDigit { name: "9bad".into() });
        assert!(e.to_string().contains("'9bad'") && e.to_string().contains("starts with a letter or _"), "{e}");
        let e = validate_base_name("a-b").unwrap_err().to_string();
        assert!(e.contains("'a-b'") && e.contains("'-'") && e.contains("only letters, digits and _"), "{e}");
        let e = validate_base_name("a__b").unwrap_err().to_string();
        assert!(e.contains("'a__b'") && e.contains("use a single _"), "{e}");
        let e = normalize_namespace("/robot1//x").unwrap_err();
        assert_eq!(e, NameError::Empty);
        assert!(e.to_string().contains("give letters, digits and _"), "{e}");
        assert_eq!(normalize_namespace("robot1/arm/").as_deref(), Ok("/robot1/arm"));
    }

    #[test]
    fn args_after_double_dash_are_rejected() {
        let e = RosArgs::parse(["--ros-args", "-p", "a:=1", "--", "extra"]).unwrap_err();
        assert!(e.to_string().contains("'extra'"));
    }
}
