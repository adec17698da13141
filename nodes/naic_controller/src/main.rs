//! `naic_controller`: the fixed / AIC / NAIC force-tracking controller as a ROS 2 node.
//!
//! Subscribes `/joint_states` and `/wrench`; on every `/joint_states` sample runs one
//! cycle of the node's core (`naic_controller::core`: `naic_core::pipeline::controller`
//! plus pairing, replay, time base, reference and the parameter-change policy) and
//! publishes the torque on `/naic/effort` and its state on `/naic/params`. Faults make the
//! core hold the arm; above `force_limit` it backs off and stays off (latched) until any
//! parameter is set. This shell only moves messages.

use std::{fmt::Write, time::Duration};

use naic_controller::{config, core, reference::ScenarioReference};
use naic_core::{
    model::Model,
    pipeline::{control::force_law::{self, Mode}, controller::{Controller, ControllerParams}},
};
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState, NaicParams, WrenchStamped},
    node::{QOS_PUB, QOS_SUB},
    time::{time_from_ns, wall_ns},
    wait::{take_until, Waiter},
    ParamTable, RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;

const NODE: &str = "naic_controller";

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
    let model = Model::from_urdf_file(&urdf)
        .map_err(|e| RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
    // Defaults: the core's paper settings on this model (learning rate: not in the paper).
    let base = ControllerParams::paper_defaults(&model, Mode::Naic, force_law::DEFAULT_GAMMA);
    // Everything that reads a file or can reject the model is checked before the DDS
    // participant exists: the start-up parameters, the model (6 joints, 'tip' and
    // 'ft_sensor' frames) and the scenario.
    let table = ParamTable::new(config::specs(&base), Some(config::check(base)), &args.overrides(NODE)?).map_err(RosError::Param)?;
    let bad_model = |e: String| RosError::Param(format!("robot model '{urdf}': {e} (set -p urdf:=PATH)"));
    let cp = table.with(|p| config::controller_params(p, &base)).map_err(RosError::Param)?;
    let ctl = Controller::new(model.clone(), cp).map_err(bad_model)?;
    let reference = ScenarioReference::new(&table.with(|p| p.str("scenario").to_string()), &model).map_err(RosError::Param)?;
    let mut p = core::Params::new(ctl, table.with(config::settings), reference).map_err(bad_model)?;
    let mut node = RosNode::new(args, NODE, config::specs(&base), Some(config::check(base)))?;
    let mut js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let w_sub = node.subscription::<WrenchStamped>("wrench", msgs::WRENCH_STAMPED, QOS_SUB)?;
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
        if node.params.generation() != gen {
            gen = node.params.generation();
            let (cp, settings) = node.params.with(|v| (config::controller_params(v, &base), config::settings(v)));
            match cp.and_then(|cp| core::set_params(&mut p, &mut s, cp, settings)) {
                Ok(o) if o.resumed => log::info!("parameters changed: resuming force control"),
                Ok(_) => {}
                Err(e) => log::error!("parameters not applied: {e}"),
            }
        }
        let mut step = |s: &mut core::State, inbox: core::Inbox| {
            let (next, out) = alloc_check::check(NODE, &mut warned, || core::step(&p, s, &inbox, wall_ns(), &mut ws));
            *s = next;
            out
        };
        while let Ok(Some((w, _))) = w_sub.take() {
            step(&mut s, core::Inbox { wrench: Some(&w), ..Default::default() });
        }
        // Newest joint state only; older samples in the queue are skipped.
        let mut newest = None;
        while let Ok(Some((js, _))) = js_sub.take() {
            newest = Some(js);
        }
        let Some(js) = newest else { continue };
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

fn log_events(e: &core::Events, force_limit: f64) {
    if let Some(j) = e.missing_joint {
        log::error!("/joint_states has no '{j}'; holding");
    }
    if let Some(p) = e.start_tip {
        log::info!("start tip position {p:?}");
    }
    if let Some(f) = e.force_limited {
        log::warn!("measured force {f:.1} N above force_limit {force_limit} N: retracting (set any parameter to resume)");
    }
    if let Some((f, n)) = e.fault {
        log::warn!("holding: {f} (faults so far: {n})");
    }
    if e.non_finite_torque {
        log::error!("controller produced a non-finite torque; not published");
    }
}

/// `/naic/params` from the core's report, in place (the strings keep their capacity).
fn fill_report(m: &mut NaicParams, r: &core::Report) {
    let st = &r.status;
    m.header.stamp = time_from_ns(r.stamp_ns);
    m.mode.clear();
    m.mode.push_str(st.mode.as_str());
    m.phase = st.phase as u8;
    m.force_axis = st.force_axis as u8;
    (m.desired_force, m.measured_force, m.e_f) = (st.f_d, st.f_ext, st.e_f);
    (m.m_d, m.b_d, m.k_d, m.sigma, m.phi) = (st.m_d, st.b_d, st.k_d, st.sigma, st.phi);
    (m.gamma, m.gamma_bound, m.gamma_clipped) = (st.gamma, st.gamma_bound, st.gamma_clipped);
    m.fault.clear();
    if let Some(f) = &r.fault {
        let _ = write!(m.fault, "{f}");
    }
    m.fault_count = st.fault_count;
}
