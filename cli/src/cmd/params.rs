//! `naic params`: every ROS parameter of the three nodes, as the nodes themselves declare it
//! (name, type, built-in default, the value `naic launch` starts with from `params/`, range or
//! choices, whether it is read-only, and the description with its unit). `--markdown` prints
//! the tables of docs/parameters.md, which a test regenerates and compares, so the reference
//! cannot drift from the code.

use std::path::PathBuf;

use clap::Args;
use naic_ros::{
    params::{type_name, ParamSpec, ParamTable, Range},
    ParameterValue, RosArgs,
};

use super::{CliError, CliResult};

#[derive(Args, Debug)]
pub struct ParamsArgs {
    /// Print the Markdown tables of docs/parameters.md (default: one plain line per parameter).
    #[arg(long)]
    pub markdown: bool,
    /// Folder of the node parameter files whose values `naic launch` starts with.
    #[arg(long, default_value = "params")]
    pub params_dir: PathBuf,
}

/// One node's declared parameters and the launch file's values for them.
struct NodeParams {
    node: &'static str,
    specs: Vec<ParamSpec>,
    launch: Vec<(String, ParameterValue)>,
}

pub fn run(a: ParamsArgs) -> CliResult {
    let nodes = [
        load(jk5_sim_driver::setup::NODE, &a, |r| jk5_sim_driver::setup::Setup::from_args(r).map(|s| s.specs()))?,
        load(naic_controller::setup::NODE, &a, |r| naic_controller::setup::Setup::from_args(r).map(|s| s.specs()))?,
        load(friction_compensation::setup::NODE, &a, |r| friction_compensation::setup::Setup::from_args(r).map(|s| s.specs()))?,
    ];
    let mut out = String::new();
    for n in &nodes {
        if a.markdown {
            markdown(&mut out, n, &a.params_dir);
        } else {
            for s in &n.specs {
                out.push_str(&format!("{} {} = {}  # {}\n", n.node, s.name, show(&s.default), s.description));
            }
        }
    }
    print!("{out}");
    Ok(())
}

/// The node's declared parameters with its built-in defaults (no files, no overrides: what
/// `ros2 param describe` reports) and the values `params/<node>.yaml` sets.
fn load(
    node: &'static str,
    a: &ParamsArgs,
    specs: impl Fn(&RosArgs) -> Result<Vec<ParamSpec>, naic_ros::RosError>,
) -> Result<NodeParams, CliError> {
    let err = |e: naic_ros::RosError| CliError::failure(format!("{node}: {e} (run naic params from the repository root)"));
    let bare = RosArgs::parse(Vec::<String>::new()).map_err(err)?;
    // The common parameters (use_sim_time, realtime_priority, ...) are added by the table.
    let table = ParamTable::new(specs(&bare).map_err(err)?, None, &[]).map_err(|e| err(naic_ros::RosError::Param(e)))?;
    let file = a.params_dir.join(format!("{node}.yaml"));
    let launch = if file.is_file() {
        let args = RosArgs::parse(["--ros-args".to_string(), "--params-file".to_string(), file.display().to_string()]).map_err(err)?;
        args.overrides(node).map_err(err)?
    } else {
        vec![]
    };
    Ok(NodeParams { node, specs: table.specs().to_vec(), launch })
}

fn markdown(out: &mut String, n: &NodeParams, params_dir: &std::path::Path) {
    let file = params_dir.join(format!("{}.yaml", n.node));
    out.push_str(&format!("## `{}`\n\n", n.node));
    out.push_str(&format!(
        "| name | type | default | `{}` | range | description |\n| --- | --- | --- | --- | --- | --- |\n",
        file.display()
    ));
    for s in &n.specs {
        let launch = n.launch.iter().find(|(k, _)| *k == s.name).map(|(_, v)| show(v)).filter(|v| *v != show(&s.default));
        let mut range = match s.range {
            Range::None => String::new(),
            Range::Float { from, to } => format!("{from:?} … {to:?}"),
            Range::Int { from, to } => format!("{from} … {to}"),
        };
        if !s.choices.is_empty() {
            range = s.choices.join(", ");
        }
        if let Some(len) = s.len {
            range = if range.is_empty() { format!("{len} values") } else { format!("{len} values in {range}") };
        }
        let ty = if s.read_only { format!("{} (read-only)", type_name(&s.default)) } else { type_name(&s.default).to_string() };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} |\n",
            s.name,
            ty,
            cell(&show(&s.default)),
            launch.map(|v| cell(&v)).unwrap_or_default(),
            cell(&range),
            cell(&s.description)
        ));
    }
    out.push('\n');
}

/// A value as it is written in a parameter file.
pub(super) fn show(v: &ParameterValue) -> String {
    fn list<T: std::fmt::Debug>(v: &[T]) -> String {
        format!("[{}]", v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", "))
    }
    match v {
        ParameterValue::NotSet => "(not set)".into(),
        ParameterValue::Boolean(b) => b.to_string(),
        ParameterValue::Integer(i) => i.to_string(),
        ParameterValue::Double(d) => format!("{d:?}"),
        ParameterValue::String(s) => format!("{s:?}"),
        ParameterValue::ByteArray(b) => list(b),
        ParameterValue::BooleanArray(b) => list(b),
        ParameterValue::IntegerArray(i) => list(i),
        ParameterValue::DoubleArray(d) => list(d),
        ParameterValue::StringArray(s) => list(s),
    }
}

/// Text safe inside a Markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}
