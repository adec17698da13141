//! `jk5_sim_driver`: the simulated JK5 + ATI mini45 as a ROS 2 node.
//!
//! Publishes `/joint_states`, `/wrench` and `/clock`; subscribes `/joint_effort_cmd`. What
//! the driver does (real time or lockstep, the hold, the last guard before the plant, the
//! chain latency) is the library's: see the crate documentation (`lib.rs`) and
//! `jk5_sim_driver::runner`. This shell only moves the messages; a separate receive thread
//! wakes on each command and stamps its arrival.

use std::sync::Arc;

use jk5_sim_driver::{
    runner::{monotonic_ns, MissMarker, Runner, SharedCommands, WakeStats},
    setup::{Setup, NODE},
    sim_plant::SimPlant,
};
use naic_ros::{
    msgs::{self, Clock, Float64MultiArray, JointState, WrenchStamped},
    node::{data_qos, pub_qos, Pub, QOS_SUB},
    source::SourceGate,
    wait::spawn_receiver,
    RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;

/// The state publishers; the messages are the runner's, published by value (ros2-client),
/// one clone each.
struct StatePub(Pub<WrenchStamped>, Pub<JointState>, Pub<Clock>);

impl StatePub {
    /// The runner's state, announced to the command slot first (so its command is never
    /// early), then published; wrench first: the controller cycles on /joint_states.
    fn announce<const N: usize>(&self, d: &mut Runner<SimPlant<N>, N>, shared: &SharedCommands<N>) {
        d.announce(&mut shared.lock());
        let _ = self.0.publish(d.msgs.w.clone());
        let _ = self.1.publish(d.msgs.js.clone());
        let _ = self.2.publish(d.msgs.clock.clone());
    }
}

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    // The arm's joint count picks the compiled shell (the one dispatch point).
    let (robot, n) = jk5_sim_driver::setup::arm(&args)?;
    naic_core::with_joints!(n, N => run_arm::<N>(args, robot)).map_err(|e| RosError::param(e.to_string()))?
}

fn run_arm<const N: usize>(args: RosArgs, robot: Option<naic_core::robot_file::Robot>) -> Result<(), RosError> {
    let marker = MissMarker::from_env();
    let setup = Setup::<N>::for_arm(&args, robot)?; // files first, before any DDS participant exists
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut d = Runner::new(setup.plant, &node.params, &setup.joints);
    let (data_pub, data_sub) = node.params.with(data_qos);
    let out = StatePub(
        node.publisher("wrench", msgs::WRENCH_STAMPED, data_pub.clone())?,
        node.publisher("joint_states", msgs::JOINT_STATE, data_pub)?,
        node.publisher("/clock", msgs::CLOCK, node.params.with(pub_qos))?,
    );
    // The command subscription is reliable only in lockstep (every command counts there).
    // In real time a late command is worthless, and a reliable reader would cost the chain:
    // friction_compensation's writer would keep every command until the driver acknowledged
    // it and drop them in one go every 6 s (RustDDS's cache cleaning: a 0.7-1.1 ms stall of
    // its event loop, a missed cycle each time), the driver would acknowledge every command,
    // and one lost packet would hold the newer commands back until it was repaired.
    let cmd_qos = if d.p.lockstep { data_sub } else { QOS_SUB };
    let cmd_sub = node.subscription::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, cmd_qos)?;
    let shared = Arc::new(SharedCommands::new(d.commands(&node.params)));
    // One owner of the command (`command_source`): other writers' commands are ignored,
    // counted and logged; a restarted owner takes over after command_timeout.
    let source = node.params.with(|p| p.str("command_source").to_string());
    let mut gate = SourceGate::in_context(&node.context, "/joint_effort_cmd", "command_source", &source, d.p.command_timeout_ns)?;
    let (ignored, foreign) = (gate.ignored(), gate.foreign());
    // Receive thread: wakes on each command, checks its writer and the command, stamps its
    // arrival.
    let rx = Arc::clone(&shared);
    spawn_receiver("cmd-rx", cmd_sub, move |m, info| {
        if gate.admit(info.publisher_gid(), naic_ros::time::wall_ns()) {
            rx.receive(&m)
        }
    })
    .map_err(|e| RosError::Node(format!("cannot start the receive thread: {e}")))?;

    let mut wake = WakeStats::default();
    let record_after_ns = shared.lock().record_after_ns;
    while !naic_ros::shutdown_requested() {
        d.reload(&node.params, &mut shared.lock());
        if d.paused {
            d.pause(); // time stands still; the same state goes out again for late subscribers
            out.announce(&mut d, &shared);
            continue;
        }
        // Wait for the command for the state just published (lockstep) or the deadline.
        if d.p.lockstep {
            if d.needs_announce(&shared.lock()) {
                out.announce(&mut d, &shared);
            }
            if !shared.wait_ready(d.command_timeout()) {
                // No command for this state: simulated time stands still; the same state
                // goes out again so a late or restarted controller gets it.
                out.announce(&mut d, &shared);
                continue;
            }
            if d.paced_lockstep() {
                d.pace(); // no faster than real_time_factor × wall time
            }
        } else {
            let deadline = d.pace();
            let timed = !d.sim && naic_ros::time::wall_ns() >= record_after_ns;
            wake.woke(deadline, monotonic_ns(), d.period_ns(), timed);
        }
        d.reload(&node.params, &mut shared.lock());
        let cmd = shared.lock().view();
        let missed = d.s.missed;
        d.step(&cmd);
        if !d.p.lockstep {
            wake.stepped(d.s.missed > missed);
            if d.s.missed > missed {
                marker.miss(d.s.missed);
            }
        }
        out.announce(&mut d, &shared);
    }
    let mut extra = if d.p.lockstep { serde_json::json!({}) } else { wake.report() };
    extra["foreign_commands"] = foreign.load(std::sync::atomic::Ordering::Relaxed).into();
    extra["ignored_commands"] = ignored.load(std::sync::atomic::Ordering::Relaxed).into();
    d.finish(&shared.lock(), &node.params, extra);
    Ok(())
}
