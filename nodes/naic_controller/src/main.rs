//! `naic_controller`: the fixed / AIC / NAIC force-tracking controller as a ROS 2 node.
//!
//! Subscribes `/joint_states`, `/wrench`, `/joint_effort_cmd` (what reaches the driver:
//! actuation supervision) and, with `scenario: none`, the reference topics; publishes the
//! torque on `/naic/effort`, the controller's state on `/naic/params`, and the robot model
//! (`/robot_description`, `/tf_static`, `/tf` from the measured joint states). All it does with the messages is the library's
//! (`naic_controller::runner`, over the pure `core`); this shell only moves them.

use std::time::Duration;

use naic_controller::{runner::{ReferenceSubs, Runner, Services}, setup::{Setup, NODE}, tf::ModelTopics};
use naic_ros::{
    msgs::{self, Float64MultiArray, JointState, NaicParams, WrenchStamped},
    node::{data_qos, pub_qos, QOS_SUB},
    wait::{take_newest, take_until, Waiter},
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
    let (robot, n) = naic_controller::setup::arm(&args)?;
    naic_core::with_joints!(n, N => run_arm::<N>(args, robot)).map_err(|e| RosError::param(e.to_string()))?
}

fn run_arm<const N: usize>(args: RosArgs, robot: Option<naic_core::robot_file::Robot>) -> Result<(), RosError> {
    let setup = Setup::<N>::for_arm(&args, robot)?; // files first, before any DDS participant exists
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut r = Runner::new(setup, &node.params);
    let mut js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let w_sub = node.subscription::<WrenchStamped>("wrench", msgs::WRENCH_STAMPED, QOS_SUB)?;
    // What reaches the driver: without it for actuation_timeout, the force law is held.
    let cmd_sub = node.subscription::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB)?;
    // The reference topics: the real-robot setting (scenario 'none') only.
    let refs = ReferenceSubs::new(&mut node, &r)?;
    let mut services = Services::new(&mut node)?;
    let effort_pub = node.publisher::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, node.params.with(data_qos).0)?;
    let params_pub = node.publisher::<NaicParams>("naic/params", msgs::NAIC_PARAMS, node.params.with(pub_qos))?;
    // The robot model for RViz, Foxglove and late joiners (robot_state_publisher's topics).
    let (mut model_topics, tf_pub) = ModelTopics::advertise(&mut node, naic_ros::time::wall_ns())?;
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut js_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        r.reload(&node.params);
        while let Ok(Some((w, _))) = w_sub.take() {
            r.wrench(&w);
        }
        if let Some(c) = take_newest(&cmd_sub) {
            r.actuated(&c);
        }
        if let Some(refs) = &refs {
            refs.feed(&mut r);
        }
        services.serve(&mut r, &node);
        // Newest joint state only; older samples in the queue are skipped.
        let Some(js) = take_newest(&js_sub) else { continue };
        let out = r.joint_states(&js, |until| {
            let mut w = None; // lockstep: the wrench of this state is on its way
            take_until(&w_sub, until, |m| w.replace(m).is_none());
            w
        });
        // ros2-client publishes by value: one clone of the buffer per message.
        if let Some(m) = out.effort {
            let _ = effort_pub.publish(m.clone());
        }
        if let Some(m) = out.report {
            let _ = params_pub.publish(m.clone());
        }
        if let Some(m) = model_topics.joint_states(&node.params, &js) {
            let _ = tf_pub.publish(m.clone());
        }
    }
    log::info!("stopped after {} cycles", r.s.cycles);
    Ok(())
}
