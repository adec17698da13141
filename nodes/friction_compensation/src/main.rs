//! `friction_compensation`: the last two pipeline stages as a ROS 2 node.
//!
//! Subscribes `/naic/effort` (the controller's torque) and `/joint_states`; on every
//! command adds the friction feedforward of `friction_file` at the filtered joint velocity
//! and applies the actuation guard (rate limit, effort limits, never NaN); publishes
//! `/joint_effort_cmd`. On start and after a gap longer than `takeover_gap` the rate limit
//! starts from the measured joint torque. All of that is the pure core
//! (`friction_compensation::core`, unit-tested); this shell only moves messages.

use std::time::Duration;

use friction_compensation::{config, core, shell::{self, Setup, NODE}};
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState},
    node::{QOS_PUB, QOS_SUB},
    time::wall_ns,
    wait::{take_until, Waiter},
    RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let setup = Setup::from_args(&args)?;
    let sense = setup.sense;
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut cmd_sub = node.subscription::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB)?;
    let js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let cmd_pub = node.publisher::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB)?;
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    let mut gen = node.params.generation();
    let mut p = node.params.with(|v| config::core_params(v, &sense)).map_err(RosError::Param)?;
    let mut s = core::State::default();
    let (mut out_msg, mut warned) = (Float64MultiArray::default(), false);
    let mut step = |p: &core::Params, s: &mut core::State, inbox: core::Inbox| -> core::Outbox {
        let (next, out) = alloc_check::check(NODE, &mut warned, || core::step(p, s, &inbox, wall_ns()));
        *s = next;
        shell::log_event(&out.event);
        out
    };

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        shell::reload(&node, &mut gen, &sense, &mut p);
        while let Ok(Some((js, _))) = js_sub.take() {
            step(&p, &mut s, core::Inbox { joint_states: Some(&js), ..Default::default() });
        }
        let mut newest = None;
        while let Ok(Some((m, _))) = cmd_sub.take() {
            newest = Some(m);
        }
        let Some(m) = newest else { continue };
        let mut out = step(&p, &mut s, core::Inbox { command: Some(&m), ..Default::default() });
        while let Some(until) = out.wait_until_ns {
            // Lockstep: the joint state of the command's stamp is on its way.
            let mut js = None;
            take_until(&js_sub, until, |m| js.replace(m).is_none());
            out = step(&p, &mut s, core::Inbox { joint_states: js.as_ref(), ..Default::default() });
        }
        if let Some((tau, src)) = out.command {
            msgs::set_effort_msg(&mut out_msg, &tau, src);
            // By value: ros2-client's publish consumes the message (one clone per command).
            let _ = cmd_pub.publish(out_msg.clone());
        }
    }
    log::info!("stopped after {} commands", s.published);
    Ok(())
}
