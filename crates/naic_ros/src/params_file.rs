//! ROS 2 parameter YAML files (`--params-file`), as rcl reads them:
//!
//! ```yaml
//! /**:                      # every node
//!   ros__parameters:
//!     use_sim_time: false
//! naic_controller:          # a node by name (or /ns/name, or nested ns: name:)
//!   ros__parameters:
//!     desired_force: 10.0
//!     impedance:            # nested keys become dotted names: impedance.m_d
//!       m_d: [1.0, 1.0, 1.0]
//! ```
//!
//! `*` matches one name token, `**` any number. Entries apply in file order, later wins.

use std::path::Path;

use ros2_client::ParameterValue;
use serde_yaml::Value;

use crate::RosError;

/// A parameter YAML file rcl would not read: each variant names the key or node and the
/// rule of the format (see the module docs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamsFileError {
    #[error("invalid YAML: {problem}")]
    Yaml { problem: String },
    #[error("the top level must be a mapping of node names to 'ros__parameters:' blocks")]
    TopLevel,
    #[error("'{node}' must be a mapping containing 'ros__parameters:'")]
    NodeNotAMapping { node: String },
    #[error("'ros__parameters' must be under a node name (or '/**')")]
    ParametersWithoutNode,
    #[error("unsupported key {key}: keys must be names")]
    Key { key: String },
    #[error("'ros__parameters' of '{node}' must be a mapping name: value")]
    ParametersNotAMapping { node: String },
    #[error("parameter '{name}' of '{node}': {source}")]
    Value { name: String, node: String, source: ValueError },
}

/// A YAML value that is no ROS parameter value; each variant names the value and the rule.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ValueError {
    #[error("number {number} out of range (a parameter is a 64-bit integer or a double)")]
    NumberOutOfRange { number: String },
    #[error("empty arrays have no type; give at least one element")]
    EmptyArray,
    #[error("arrays must hold one type (all numbers, all strings or all booleans)")]
    MixedArray,
    #[error("no value given (null)")]
    Null,
    #[error("a mapping is not a parameter value")]
    Mapping,
}

/// Parameters from `path` that apply to the node with fully qualified name `fqn` (`/ns/name`).
pub fn load_for_node(path: &Path, fqn: &str) -> Result<Vec<(String, ParameterValue)>, RosError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        RosError::ParamsFile(format!("cannot read parameter file {}: {e}", path.display()))
    })?;
    parse_for_node(&text, fqn)
        .map_err(|e| RosError::ParamsFile(format!("parameter file {}: {e}", path.display())))
}

/// Same as [`load_for_node`] on YAML text; errors name the offending key.
pub fn parse_for_node(text: &str, fqn: &str) -> Result<Vec<(String, ParameterValue)>, ParamsFileError> {
    let doc: Value = serde_yaml::from_str(text).map_err(|e| ParamsFileError::Yaml { problem: e.to_string() })?;
    let mut out = Vec::new();
    match &doc {
        Value::Mapping(_) => walk_nodes(&doc, &mut Vec::new(), fqn, &mut out)?,
        Value::Null => {}
        _ => return Err(ParamsFileError::TopLevel),
    }
    Ok(out)
}

fn walk_nodes(
    v: &Value,
    path: &mut Vec<String>,
    fqn: &str,
    out: &mut Vec<(String, ParameterValue)>,
) -> Result<(), ParamsFileError> {
    let Value::Mapping(m) = v else {
        return Err(ParamsFileError::NodeNotAMapping { node: path.join("/") });
    };
    for (k, child) in m {
        let key = key_str(k)?;
        if key == "ros__parameters" {
            if path.is_empty() {
                return Err(ParamsFileError::ParametersWithoutNode);
            }
            let pattern = path.join("/");
            if node_matches(&pattern, fqn) {
                flatten_params(child, "", &pattern, out)?;
            }
        } else {
            path.push(key.trim_matches('/').to_string());
            walk_nodes(child, path, fqn, out)?;
            path.pop();
        }
    }
    Ok(())
}

fn key_str(k: &Value) -> Result<String, ParamsFileError> {
    match k {
        Value::String(s) => Ok(s.clone()),
        Value::Number(n) => Ok(n.to_string()),
        Value::Bool(b) => Ok(b.to_string()),
        other => Err(ParamsFileError::Key { key: format!("{other:?}") }),
    }
}

fn flatten_params(
    v: &Value,
    prefix: &str,
    node: &str,
    out: &mut Vec<(String, ParameterValue)>,
) -> Result<(), ParamsFileError> {
    let Value::Mapping(m) = v else {
        return Err(ParamsFileError::ParametersNotAMapping { node: node.to_string() });
    };
    for (k, child) in m {
        let key = key_str(k)?;
        let name = if prefix.is_empty() { key } else { format!("{prefix}.{key}") };
        match child {
            Value::Mapping(_) => flatten_params(child, &name, node, out)?,
            _ => {
                let pv = yaml_to_value(child).map_err(|source| ParamsFileError::Value {
                    name: name.clone(),
                    node: node.to_string(),
                    source,
                })?;
                out.push((name, pv));
            }
        }
    }
    Ok(())
}

/// One YAML value → a ROS parameter value (arrays must be homogeneous; ints in a float
/// array are promoted to float, as rcl does not but users expect).
pub fn yaml_to_value(v: &Value) -> Result<ParameterValue, ValueError> {
    Ok(match v {
        Value::Bool(b) => ParameterValue::Boolean(*b),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                ParameterValue::Integer(i)
            } else if let Some(f) = n.as_f64() {
                ParameterValue::Double(f)
            } else {
                return Err(ValueError::NumberOutOfRange { number: n.to_string() });
            }
        }
        Value::String(s) => ParameterValue::String(s.clone()),
        Value::Sequence(seq) => {
            if seq.is_empty() {
                return Err(ValueError::EmptyArray);
            }
            let items: Vec<ParameterValue> =
                seq.iter().map(yaml_to_value).collect::<Result<_, _>>()?;
            let all = |f: fn(&ParameterValue) -> bool| items.iter().all(f);
            if all(|x| matches!(x, ParameterValue::Boolean(_))) {
                ParameterValue::BooleanArray(
                    items.iter().map(|x| matches!(x, ParameterValue::Boolean(true))).collect(),
                )
            } else if all(|x| matches!(x, ParameterValue::Integer(_))) {
                ParameterValue::IntegerArray(
                    items.iter().map(|x| if let ParameterValue::Integer(i) = x { *i } else { 0 }).collect(),
                )
            } else if all(|x| matches!(x, ParameterValue::Integer(_) | ParameterValue::Double(_))) {
                ParameterValue::DoubleArray(
                    items
                        .iter()
                        .map(|x| match x {
                            ParameterValue::Integer(i) => *i as f64,
                            ParameterValue::Double(d) => *d,
                            _ => 0.0,
                        })
                        .collect(),
                )
            } else if all(|x| matches!(x, ParameterValue::String(_))) {
                ParameterValue::StringArray(
                    items
                        .into_iter()
                        .map(|x| if let ParameterValue::String(s) = x { s } else { String::new() })
                        .collect(),
                )
            } else {
                return Err(ValueError::MixedArray);
            }
        }
        Value::Null => return Err(ValueError::Null),
        Value::Mapping(_) => return Err(ValueError::Mapping),
        Value::Tagged(t) => return yaml_to_value(&t.value),
    })
}

/// Does the node pattern (`/**`, `name`, `/ns/name`, `ns/*`) match the node `fqn`?
pub fn node_matches(pattern: &str, fqn: &str) -> bool {
    let pat: Vec<&str> = pattern.trim_matches('/').split('/').filter(|s| !s.is_empty()).collect();
    let name: Vec<&str> = fqn.trim_matches('/').split('/').filter(|s| !s.is_empty()).collect();
    // A bare node name (no namespace in the pattern) matches that name in the root namespace
    // only, as in rcl; `/**` and `**/name` reach into namespaces.
    glob(&pat, &name)
}

fn glob(p: &[&str], n: &[&str]) -> bool {
    match p.first() {
        None => n.is_empty(),
        Some(&"**") => (0..=n.len()).any(|k| glob(&p[1..], &n[k..])),
        Some(&"*") => !n.is_empty() && glob(&p[1..], &n[1..]),
        Some(tok) => !n.is_empty() && n[0] == *tok && glob(&p[1..], &n[1..]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"
/**:
  ros__parameters:
    use_sim_time: false
    desired_force: 5.0
naic_controller:
  ros__parameters:
    desired_force: 10.0
    mode: naic
    m_d: [1, 2.5, 3]
    nested:
      gain: 2
other_node:
  ros__parameters:
    desired_force: 99.0
robot1:
  naic_controller:
    ros__parameters:
      desired_force: 7.0
"#;

    #[test]
    fn picks_wildcard_then_named_node() {
        let p = parse_for_node(FILE, "/naic_controller").unwrap();
        let get = |n: &str| p.iter().rev().find(|(k, _)| k == n).map(|(_, v)| v.clone());
        assert_eq!(get("use_sim_time"), Some(ParameterValue::Boolean(false)));
        assert_eq!(get("desired_force"), Some(ParameterValue::Double(10.0)));
        assert_eq!(get("m_d"), Some(ParameterValue::DoubleArray(vec![1.0, 2.5, 3.0])));
        assert_eq!(get("nested.gain"), Some(ParameterValue::Integer(2)));
        assert_eq!(get("mode"), Some(ParameterValue::String("naic".into())));
    }

    #[test]
    fn namespaced_node() {
        let p = parse_for_node(FILE, "/robot1/naic_controller").unwrap();
        let last = p.iter().rev().find(|(k, _)| k == "desired_force").unwrap();
        assert_eq!(last.1, ParameterValue::Double(7.0));
        assert!(node_matches("/**", "/a/b"));
        assert!(node_matches("robot1/*", "/robot1/x"));
        assert!(!node_matches("naic_controller", "/robot1/naic_controller"));
    }

    #[test]
    fn errors_name_the_problem() {
        assert!(parse_for_node("a: [", "/a").unwrap_err().to_string().contains("invalid YAML"));
        assert!(parse_for_node("- 1\n- 2", "/a").unwrap_err().to_string().contains("top level"));
        let e = parse_for_node("a:\n  ros__parameters:\n    x: [1, foo]\n", "/a").unwrap_err().to_string();
        assert!(e.contains("parameter 'x'") && e.contains("one type"), "{e}");
        let e = parse_for_node("a:\n  ros__parameters:\n    x:\n", "/a").unwrap_err().to_string();
        assert!(e.contains("'x'") && e.contains("null"), "{e}");
        let e = parse_for_node("ros__parameters:\n  x: 1\n", "/a").unwrap_err().to_string();
        assert!(e.contains("under a node name"), "{e}");
    }

    #[test]
    fn file_errors_name_the_node_the_parameter_and_the_rule() {
        let e = parse_for_node("robot1:\n  ctl:\n    ros__parameters:\n      m_d: []\n", "/robot1/ctl").unwrap_err();
        assert_eq!(
            e,
            ParamsFileError::Value { name: "m_d".into(), node: "robot1/ctl".into(), source: ValueError::EmptyArray }
        );
        let m = e.to_string();
        assert!(m.contains("parameter 'm_d' of 'robot1/ctl'") && m.contains("give at least one element"), "{m}");
        let e = parse_for_node("ctl:\n  ros__parameters: 3\n", "/ctl").unwrap_err();
        assert_eq!(e, ParamsFileError::ParametersNotAMapping { node: "ctl".into() });
        assert!(e.to_string().contains("'ctl'") && e.to_string().contains("mapping name: value"), "{e}");
        let e = parse_for_node("ctl: 3\n", "/ctl").unwrap_err();
        assert!(e.to_string().contains("'ctl' must be a mapping containing 'ros__parameters:'"), "{e}");
        let e = yaml_to_value(&serde_yaml::from_str("{a: 1}").unwrap()).unwrap_err();
        assert_eq!(e, ValueError::Mapping);
    }
}
