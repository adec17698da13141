//! `friction_compensation`: the last two pipeline stages as a ROS 2 node.
//!
//! Subscribes `/naic/effort` (the controller's torque) and `/joint_states`; publishes
//! `/joint_effort_cmd`: the friction feedforward of `friction_file` at the filtered joint
//! velocity plus the actuation guard (rate limit, effort limits, never NaN), taking over
//! from the measured torque on start and after a gap. All it does with the messages is the
//! library's (`friction_compensation::runner`, over the pure `core`); this shell only moves
//! them.

use std::time::Duration;

use friction_compensation::{runner::Runner, setup::{Setup, NODE}};
use naic_ros::{
    msgs::{self, Float64MultiArray, JointState},
    node::{data_qos, QOS_SUB},
    source::SourceGate,
    wait::{take_newest_admitted, take_until, Waiter},
    RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    // The arm's joint count picks the compiled shell (the one dispatch point).
    let (robot, n) = friction_compensation::setup::arm(&args)?;
    naic_core::with_joints!(n, N => run_arm::<N>(args, robot)).map_err(|e| RosError::param(e.to_string()))?
}

fn run_arm<const N: usize>(args: RosArgs, robot: Option<naic_core::robot_file::Robot>) -> Result<(), RosError> {
    let setup = Setup::<N>::for_arm(&args, robot)?; // files first, before any DDS participant exists
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut r = Runner::new(&setup, &node.params)?;
    let mut cmd_sub = node.subscription::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB)?;
    let js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let cmd_pub = node.publisher::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, node.params.with(data_qos).0)?;
    // One owner of /naic/effort (`command_source`); a restarted owner takes over after
    // takeover_gap, when the rate limit restarts from the measured torque anyway.
    let source = node.params.with(|p| p.str("command_source").to_string());
    let mut gate = SourceGate::in_context(&node.context, "/naic/effort", "command_source", &source, r.p.takeover_gap_ns)?;
    let (ignored, foreign) = (gate.ignored(), gate.foreign());
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        r.reload(&node.params);
        while let Ok(Some((js, _))) = js_sub.take() {
            r.joint_states(&js);
        }
        let Some(m) = take_newest_admitted(&cmd_sub, |i| gate.admit(i.publisher_gid(), naic_ros::time::wall_ns())) else { continue };
        let out = r.command(&m, |until| {
            let mut js = None; // lockstep: the joint state of the command's stamp is on its way
            take_until(&js_sub, until, |m| js.replace(m).is_none());
            js
        });
        if let Some(m) = out {
            // By value: ros2-client's publish consumes the message (one clone per command).
            let _ = cmd_pub.publish(m.clone());
        }
    }
    log::info!(
        "stopped after {} commands and {} take-overs; {} samples ignored, {} of them from other nodes than command_source",
        r.s.published,
        r.s.takeovers,
        ignored.load(std::sync::atomic::Ordering::Relaxed),
        foreign.load(std::sync::atomic::Ordering::Relaxed)
    );
    Ok(())
}
