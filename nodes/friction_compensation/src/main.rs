//! `friction_compensation`: the last two pipeline stages as a ROS 2 node.
//!
//! Subscribes `/naic/effort` (the controller's torque) and `/joint_states`; on every
//! command adds the friction feedforward of `friction_file` at the filtered joint velocity
//! and applies the actuation guard (rate limit, effort limits, never NaN); publishes
//! `/joint_effort_cmd`. On start and after a gap longer than `takeover_gap` the rate limit
//! starts from the measured joint torque. All of that is the pure core
//! (`friction_compensation::core`, unit-tested); this shell only moves messages.

use std::time::Duration;

use friction_compensation::{config, core};
use naic_core::{model::Model, pipeline::sense::SenseParams};
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState},
    node::{QOS_PUB, QOS_SUB},
    params::{effort_limit_within, EFFORT_CAP},
    time::wall_ns,
    wait::{take_until, Waiter},
    ParamView, RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;

const NODE: &str = "friction_compensation";

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
    let robot = Model::from_urdf_file(&urdf)
        .map_err(|e| RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
    let l = robot.effort_limits();
    if l.len() != 6 {
        return Err(RosError::Param(format!("'{urdf}' has {} joints; the JK5 needs 6", l.len())));
    }
    let effort_limit: [f64; 6] = std::array::from_fn(|i| if l[i].is_finite() && l[i] > 0.0 { l[i].min(EFFORT_CAP) } else { EFFORT_CAP });
    // The velocity filter: the controller's sense stage (joint limits of the model).
    let sense = SenseParams { wrench_max: [f64::INFINITY; 6], joint_timeout: 1.0, wrench_timeout: 1.0, ..SenseParams::for_model(&robot) };
    // A friction file that does not load, or a saturation above the URDF's, is rejected like any bad value.
    let check: naic_ros::params::SetCheck = Box::new(move |p: &ParamView| {
        effort_limit_within(p, &effort_limit)?;
        config::load_model(p).map(|_| ())
    });
    let mut node = RosNode::new(args, NODE, config::specs(&effort_limit), Some(check))?;
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
        match out.event {
            Some(core::Event::BadCommand(e)) => log::warn!("ignoring /naic/effort: {e}"),
            Some(core::Event::MissingJoint(j)) => log::error!("/joint_states has no '{j}': no friction feedforward"),
            None => {}
        }
        out
    };

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        if node.params.generation() != gen {
            gen = node.params.generation();
            match node.params.with(|v| config::core_params(v, &sense)) {
                Ok(np) => p = np,
                Err(e) => log::error!("{e}"),
            }
        }
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
