//! `naic param get|set`: a node's parameters over DDS, as `ros2 param get|set` does, from a
//! RustDDS participant that honours the ROS security variables (`ROS_SECURITY_ENABLE`,
//! `ROS_SECURITY_KEYSTORE`, `ROS_SECURITY_ENCLAVE_OVERRIDE`). The PyPI rclpy and the ros2 CLI
//! built on it cannot join a secured chain (docs/deploy.md); this can, with a certificate
//! from the keystore, and cannot without one: the request is never answered.

use std::time::{Duration, Instant};

use clap::{Args, Subcommand};
use naic_ros::{params::type_name, ParameterValue, RosArgs, RosNode};
use ros2_client::{
    parameters::raw,
    qos::{History, Reliability, WhenFull},
    rcl_interfaces as rcl, Name, QosProfile, ServiceMapping, ServiceTypeName,
};

use super::{params::show, CliError, CliResult};

#[derive(Subcommand, Debug)]
pub enum ParamCmd {
    /// Print one parameter of a running node (`ros2 param get NODE NAME`).
    Get(GetArgs),
    /// Set one parameter of a running node (`ros2 param set NODE NAME VALUE`).
    Set(SetArgs),
}

#[derive(Args, Debug)]
pub struct GetArgs {
    /// The node, e.g. jk5_sim_driver or /ns/jk5_sim_driver.
    pub node: String,
    /// The parameter's name.
    pub name: String,
    /// Give up after this many seconds without an answer (exit code 3).
    #[arg(long, default_value_t = 20.0)]
    pub timeout: f64,
}

#[derive(Args, Debug)]
pub struct SetArgs {
    /// The node, e.g. jk5_sim_driver or /ns/jk5_sim_driver.
    pub node: String,
    /// NAME:=VALUE, the value written as on the command line of a node (`-p NAME:=VALUE`).
    pub assignment: String,
    /// Give up after this many seconds without an answer (exit code 3).
    #[arg(long, default_value_t = 20.0)]
    pub timeout: f64,
}

/// Exit code when the node never answered (not found, or not reachable from this participant).
pub const NO_ANSWER: i32 = 3;

pub fn run(c: ParamCmd) -> CliResult {
    match c {
        ParamCmd::Get(a) => get(a),
        ParamCmd::Set(a) => set(a),
    }
}

fn ros_err(e: naic_ros::RosError) -> CliError {
    CliError::failure(e.to_string())
}

fn node_fqn(node: &str) -> Result<String, CliError> {
    let fqn = if node.starts_with('/') { node.to_string() } else { format!("/{node}") };
    let ok = fqn.len() > 1 && fqn[1..].split('/').all(|c| !c.is_empty() && c.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_'));
    if ok {
        Ok(fqn)
    } else {
        Err(CliError::usage(format!("node '{node}': a node name is letters, digits and _ (optionally /namespace/name), e.g. jk5_sim_driver")))
    }
}

fn check_timeout(t: f64) -> CliResult {
    if t > 0.0 && t.is_finite() {
        Ok(())
    } else {
        Err(CliError::usage(format!("--timeout must be a positive number of seconds, got {t}")))
    }
}

/// Call `srv` of node `fqn` with `req` until it answers or `timeout` [s] passed. The request
/// is sent again every second: the server may discover this participant's reply reader
/// after the first one arrived.
fn call<Req, Resp>(fqn: &str, srv: &str, ty: &str, req: Req, timeout: f64) -> Result<Resp, CliError>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let args = RosArgs::parse(std::iter::empty::<String>()).map_err(ros_err)?;
    let mut node = RosNode::new(args, "naic_param", Vec::new(), None).map_err(ros_err)?;
    let qos = QosProfile::default()
        .reliability(Reliability::Reliable { when_full: WhenFull::Fail })
        .history(History::KeepLast { depth: 10 });
    let name = Name::new(fqn, srv).map_err(|e| CliError::usage(format!("service {fqn}/{srv}: {e:?}")))?;
    let client = node
        .node
        .create_client::<Req, Resp>(ServiceMapping::Enhanced, &name, &ServiceTypeName::new("rcl_interfaces", ty), qos.clone(), qos)
        .map_err(|e| CliError::failure(format!("cannot create a client of {fqn}/{srv}: {e:?}")))?;
    let start = Instant::now();
    let mut sent = None::<Instant>;
    while start.elapsed().as_secs_f64() < timeout {
        if sent.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
            // A write that fails (no reader matched yet is not a failure) is tried again.
            let _ = client.send_request(req.clone());
            sent = Some(Instant::now());
        }
        match client.receive_response() {
            Ok(Some((_, resp))) => return Ok(resp),
            Ok(None) => std::thread::sleep(Duration::from_millis(10)),
            Err(e) => return Err(CliError::failure(format!("{fqn}/{srv}: unreadable answer: {e:?}"))),
        }
    }
    Err(CliError::with_code(
        NO_ANSWER,
        format!(
            "{fqn}/{srv}: no answer in {timeout} s: is the node running on this ROS_DOMAIN_ID, and, on a secured chain, does this process have a certificate and permissions from the chain's keystore (ROS_SECURITY_ENABLE=true ROS_SECURITY_KEYSTORE=KEYSTORE ROS_SECURITY_ENCLAVE_OVERRIDE=/naic/observer)?"
        ),
    ))
}

fn get(a: GetArgs) -> CliResult {
    check_timeout(a.timeout)?;
    let fqn = node_fqn(&a.node)?;
    let resp: rcl::GetParametersResponse =
        call(&fqn, "get_parameters", "GetParameters", rcl::GetParametersRequest { names: vec![a.name.clone()] }, a.timeout)?;
    let v: ParameterValue = resp
        .values
        .into_iter()
        .next()
        .map(ParameterValue::from)
        .ok_or_else(|| CliError::failure(format!("{fqn}: empty answer for {}", a.name)))?;
    if matches!(v, ParameterValue::NotSet) {
        return Err(CliError::usage(format!("{fqn} has no parameter '{}' (`naic params` lists them)", a.name)));
    }
    println!("{} ({}) = {}", a.name, type_name(&v), show(&v));
    Ok(())
}

fn set(a: SetArgs) -> CliResult {
    check_timeout(a.timeout)?;
    let fqn = node_fqn(&a.node)?;
    let parsed = RosArgs::with_params([a.assignment.as_str()])
        .and_then(|r| r.overrides("naic_param"))
        .map_err(|e| CliError::usage(format!("'{}': {e}; write NAME:=VALUE, e.g. command_timeout:=0.05", a.assignment)))?;
    let Some((name, value)) = parsed.into_iter().next() else {
        return Err(CliError::usage(format!("'{}': write NAME:=VALUE, e.g. command_timeout:=0.05", a.assignment)));
    };
    let req = rcl::SetParametersRequest { parameter: vec![raw::Parameter { name: name.clone(), value: value.clone().into() }] };
    let resp: rcl::SetParametersResponse = call(&fqn, "set_parameters", "SetParameters", req, a.timeout)?;
    let r = resp.results.into_iter().next().ok_or_else(|| CliError::failure(format!("{fqn}: empty answer for {name}")))?;
    if r.successful {
        println!("{fqn}: set {name} = {}", show(&value));
        Ok(())
    } else {
        Err(CliError::failure(format!("{fqn} refused {name} = {}: {}", show(&value), r.reason)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_names_are_checked() {
        assert_eq!(node_fqn("jk5_sim_driver").unwrap(), "/jk5_sim_driver");
        assert_eq!(node_fqn("/ns/a").unwrap(), "/ns/a");
        for bad in ["", "/", "a b", "a//b", "a-b"] {
            let e = node_fqn(bad).unwrap_err();
            assert_eq!(e.code, 2, "{bad}");
            assert!(e.message.contains("node name"), "{}", e.message);
        }
        assert_eq!(check_timeout(0.0).unwrap_err().code, 2);
        assert_eq!(check_timeout(f64::NAN).unwrap_err().code, 2);
    }
}
