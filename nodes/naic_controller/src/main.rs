//! `naic_controller`: the fixed / AIC / NAIC force-tracking controller as a ROS 2 node.
//!
//! Subscribes `/joint_states` and `/wrench`; on every `/joint_states` sample runs one
//! cycle of the node's core (`naic_controller::core`: `naic_core::pipeline::controller`
//! plus pairing, replay, time base, reference and the parameter-change policy) and
//! publishes the torque on `/naic/effort` and its state on `/naic/params`. Faults make the
//! core hold the arm; above `force_limit` it backs off and stays off (latched) until any
//! parameter is set. This shell only moves messages.

use std::time::Duration;

use naic_controller::{core, shell::{self, fill_report, log_events, log_reference_events, Setup, NODE}};
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState, NaicParams, PoseStamped, WrenchStamped},
    node::{QOS_PUB, QOS_SUB},
    time::wall_ns,
    wait::{take_newest, take_until, Waiter},
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
    // Everything that reads a file or can reject the model is checked before the DDS
    // participant exists.
    let setup = Setup::from_args(&args)?;
    let (specs, check, base, mut p) = (setup.specs(), Some(setup.check()), setup.base, setup.params);
    let mut node = RosNode::new(args, NODE, specs, check)?;
    let mut js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let w_sub = node.subscription::<WrenchStamped>("wrench", msgs::WRENCH_STAMPED, QOS_SUB)?;
    // The reference topics: the real-robot setting (scenario 'none') only.
    let (tp_sub, dw_sub) = if p.reference.is_none() {
        (
            Some(node.subscription::<PoseStamped>("naic/target_pose", msgs::POSE_STAMPED, QOS_SUB)?),
            Some(node.subscription::<WrenchStamped>("naic/desired_wrench", msgs::WRENCH_STAMPED, QOS_SUB)?),
        )
    } else {
        log::info!("following the scenario's reference: /naic/target_pose and /naic/desired_wrench are not subscribed (scenario:=none follows them)");
        (None, None)
    };
    let effort_pub = node.publisher::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB)?;
    let params_pub = node.publisher::<NaicParams>("naic/params", msgs::NAIC_PARAMS, QOS_PUB)?;
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut js_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    let mut gen = node.params.generation();
    let mut s = core::State::new(&p);
    let mut ws = p.controller.workspace();
    let (mut effort_msg, mut report_msg, mut warned) = (Float64MultiArray::default(), NaicParams::default(), false);
    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        shell::reload(&node, &mut gen, &base, &mut p, &mut s);
        let mut step = |s: &mut core::State, inbox: core::Inbox| {
            let (next, out) = alloc_check::check(NODE, &mut warned, || core::step(&p, s, &inbox, wall_ns(), &mut ws));
            *s = next;
            out
        };
        while let Ok(Some((w, _))) = w_sub.take() {
            step(&mut s, core::Inbox { wrench: Some(&w), ..Default::default() });
        }
        // Reference samples, newest of each topic (the stage keeps only the last target).
        let (tp, dw) = (tp_sub.as_ref().and_then(take_newest), dw_sub.as_ref().and_then(take_newest));
        if tp.is_some() || dw.is_some() {
            let out = step(&mut s, core::Inbox { target_pose: tp.as_ref(), desired_wrench: dw.as_ref(), ..Default::default() });
            log_reference_events(&out.events, tp.as_ref(), dw.as_ref(), &p.reference_params.base_frame);
        }
        // Newest joint state only; older samples in the queue are skipped.
        let Some(js) = take_newest(&js_sub) else { continue };
        let mut out = step(&mut s, core::Inbox { joint_states: Some(&js), ..Default::default() });
        while let Some(until) = out.wait_until_ns {
            // Lockstep: the wrench of this state is on its way.
            let mut w = None;
            take_until(&w_sub, until, |m| w.replace(m).is_none());
            out = step(&mut s, core::Inbox { wrench: w.as_ref(), ..Default::default() });
        }
        log_events(&out.events, p.settings.force_limit);
        if let Some((tau, stamp)) = out.effort {
            msgs::set_effort_msg(&mut effort_msg, &tau, Some(stamp));
            // ros2-client publishes by value: one clone of the buffer per message.
            let _ = effort_pub.publish(effort_msg.clone());
        }
        if let Some(r) = out.report {
            fill_report(&mut report_msg, &r);
            let _ = params_pub.publish(report_msg.clone());
        }
    }
    log::info!("stopped after {} cycles", s.cycles);
    Ok(())
}
