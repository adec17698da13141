//! `jk5_sim_driver`: the simulated JK5 + ATI mini45 as a ROS 2 node.
//!
//! Publishes `/joint_states` (sensor_msgs/JointState, joint1..joint6: position, velocity,
//! effort = measured joint torque), `/wrench` (geometry_msgs/WrenchStamped, frame_id
//! `ft_sensor`, the raw sensor reading) and `/clock` (rosgraph_msgs/Clock, simulated time);
//! subscribes `/joint_effort_cmd` (std_msgs/Float64MultiArray, six torques in N m).
//!
//! Real-time mode: one simulator step per period (`rate`, default 1 kHz, absolute-deadline
//! sleeps). In real time, if no valid command arrived for `command_timeout` (20 ms), the
//! driver holds the arm itself (gravity compensation + joint damping) and never keeps
//! applying an old torque.
//!
//! Lockstep mode (`lockstep: true`): one step per command *computed from the state just
//! published*, so a closed loop over DDS is deterministic and runs as fast as the chain
//! allows; stamps are then simulated time. A command carries the `/joint_states` stamp it
//! was computed from (`naic_ros::msgs::effort_msg`); commands for any other stamp (a late
//! duplicate, a restarted node's first command) are dropped and counted. When no matching
//! command arrives within `command_timeout`, simulated time stands still and the same state
//! is published again (same stamp), so a late or restarted controller gets it; the nodes
//! answer a repeated stamp with the command they already computed for it. Commands without
//! a stamp (for example from rclpy) are taken as they come.
//!
//! Last guard before the plant, whoever sends the command (friction_compensation, or
//! anyone publishing `/joint_effort_cmd` directly): a command that is not six finite
//! numbers is rejected (rate-limited log) and the driver holds instead of keeping the
//! previous one; whatever is applied, command or the driver's own hold, is saturated per
//! joint at `effort_limit` (default: the URDF `<limit effort>`, values above it refused).
//! The robot model and the friction file are loaded and checked before the DDS
//! participant exists: a bad file exits with code 2 and a message naming it.
//!
//! A separate receive thread wakes on each command and stamps its arrival, so the chain
//! latency (`/joint_states` stamp → command arrival) is measured exactly; it is written as
//! JSON to `latency_report` at exit (see `naic bench chain`).

use std::sync::Arc;

use jk5_sim_driver::{
    runner::{Runner, SharedCommands, StateMsgs},
    setup::{Setup, NODE},
};
use naic_ros::{
    msgs::{self, Clock, Float64MultiArray, JointState, WrenchStamped},
    node::{Pub, QOS_PUB, QOS_SUB_RELIABLE},
    wait::Waiter,
    RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;

/// The state publishers; the messages are the runner's, published by value (ros2-client),
/// one clone each. Wrench first: the controller cycles on /joint_states.
struct StatePub(Pub<WrenchStamped>, Pub<JointState>, Pub<Clock>);

impl StatePub {
    fn publish(&self, m: &StateMsgs) {
        let _ = self.0.publish(m.w.clone());
        let _ = self.1.publish(m.js.clone());
        let _ = self.2.publish(m.clock.clone());
    }
}

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let setup = Setup::from_args(&args)?; // files first, before any DDS participant exists
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut d = Runner::new(setup.plant, &node.params);
    let out = StatePub(
        node.publisher("wrench", msgs::WRENCH_STAMPED, QOS_PUB)?,
        node.publisher("joint_states", msgs::JOINT_STATE, QOS_PUB)?,
        node.publisher("/clock", msgs::CLOCK, QOS_PUB)?,
    );
    let mut cmd_sub = node.subscription::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB_RELIABLE)?;
    let shared = Arc::new(SharedCommands::new(d.commands(&node.params)));

    // Receive thread: wakes on each command, checks it, stamps its arrival.
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll register: {e}")))?;
    let rx = Arc::clone(&shared);
    let receive = move || {
        while !naic_ros::shutdown_requested() {
            waiter.wait(Some(std::time::Duration::from_millis(50)));
            while let Ok(Some((m, _))) = cmd_sub.take() {
                rx.receive(&m);
            }
        }
    };
    std::thread::Builder::new().name("cmd-rx".into()).spawn(receive).map_err(|e| RosError::Node(format!("cannot start receive thread: {e}")))?;

    while !naic_ros::shutdown_requested() {
        d.reload(&node.params, &mut shared.lock());
        if d.paused {
            // Time stands still; the same state goes out again so late subscribers get it.
            d.pause();
            d.announce(&mut shared.lock());
            out.publish(&d.msgs);
            continue;
        }
        // Wait for the next step: the command for the state just published (lockstep) or
        // the deadline (real time).
        if d.p.lockstep {
            if d.needs_announce(&shared.lock()) {
                d.announce(&mut shared.lock());
                out.publish(&d.msgs);
            }
            if !shared.wait_ready(d.command_timeout()) {
                // No command for this state: simulated time stands still; the same state
                // goes out again so a late or restarted controller gets it.
                d.announce(&mut shared.lock());
                out.publish(&d.msgs);
                continue;
            }
        } else {
            d.pace();
        }
        d.reload(&node.params, &mut shared.lock());
        let cmd = shared.lock().view();
        d.step(&cmd);
        d.announce(&mut shared.lock());
        out.publish(&d.msgs);
    }
    d.finish(&shared.lock(), &node.params, serde_json::json!({}));
    Ok(())
}
