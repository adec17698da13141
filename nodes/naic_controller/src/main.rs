//! `naic_controller`: the fixed / AIC / NAIC force-tracking controller as a ROS 2 node.
//!
//! Subscribes `/joint_states` and `/wrench`; on every `/joint_states` sample runs one
//! `naic_core::pipeline::controller::step` (sense → estimate → control → inverse dynamics)
//! and publishes the torque on `/naic/effort` (std_msgs/Float64MultiArray, before friction
//! feedforward) and its state on `/naic/params` (naic_msgs/NaicParams).
//!
//! Chain: driver → `/joint_states`, `/wrench` → naic_controller → `/naic/effort` →
//! friction_compensation → `/joint_effort_cmd` → driver.
//!
//! Parameters (see `config.rs`) take effect at the next cycle after they are accepted.
//! Faults (NaN/Inf/implausible/stale data) make the core hold the arm (gravity compensation
//! + joint damping); the fault is logged (rate-limited) and published in `/naic/params`.
//! Above `force_limit` the core's force limit (`pipeline::control::ForceLimit`, latched)
//! stops pushing and backs off; the node only reports it, and resumes it on any accepted
//! parameter change (`ControlState::resume`).

mod config;
mod reference;

use std::time::Duration;

use naic_core::{
    dynamics,
    model::{Data6, Model},
    pipeline::{
        control::Phase,
        control::force_law::{self, Mode},
        controller::{self, Controller, ControllerParams, ControllerState, Reference, Workspace},
        sense::RawMeasurements,
    },
};
use naic_ros::{
    msgs::{self, Header, JointState, NaicParams, WrenchStamped},
    node::{QOS_PUB, QOS_SUB},
    time::{time_from_ns, wall_ns},
    wait::{take_until, Waiter},
    ParamTable, RosArgs, RosError, RosNode,
};
use nalgebra::{UnitQuaternion, Vector3, Vector6};


fn main() {
    naic_ros::run_main("naic_controller", run)
}

/// Joint-name → index map of the incoming `/joint_states` (built once per name layout).
struct JointMap {
    names: Vec<String>,
    idx: [usize; 6],
    ok: bool,
}

impl JointMap {
    fn update(&mut self, names: &[String]) {
        if names == self.names.as_slice() {
            return;
        }
        self.names = names.to_vec();
        self.ok = true;
        for (j, want) in msgs::JOINT_NAMES.iter().enumerate() {
            match names.iter().position(|n| n == want) {
                Some(i) => self.idx[j] = i,
                None if names.is_empty() => self.idx[j] = j,
                None => {
                    self.ok = false;
                    log::error!("/joint_states has no '{want}' (names: {names:?}); holding");
                }
            }
        }
    }
    fn get(&self, v: &[f64], out: &mut [f64; 6]) -> bool {
        if !self.ok {
            return false;
        }
        for j in 0..6 {
            match v.get(self.idx[j]) {
                Some(x) => out[j] = *x,
                None => return false,
            }
        }
        true
    }
}

/// A `/wrench` sample as (F, τ) in the sensor frame, its stamp, and its arrival time [ns].
fn wrench_sample(w: &WrenchStamped) -> ([f64; 6], Option<i64>, i64) {
    let (f, t) = (&w.wrench.force, &w.wrench.torque);
    ([f.x, f.y, f.z, t.x, t.y, t.z], Some(w.header.stamp.to_nanos()), wall_ns())
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let urdf = args.peek_string("naic_controller", "urdf", "urdf/jk5.urdf")?;
    let model = Model::from_urdf_file(&urdf).map_err(|e| {
        RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)"))
    })?;
    // Defaults: the core's paper settings on this model (learning rate: not in the paper).
    let base = ControllerParams::paper_defaults(&model, Mode::Naic, force_law::DEFAULT_GAMMA);
    // Everything that reads a file or can reject the model is checked before the DDS
    // participant exists: the start-up parameters (params files, -p), the model against the
    // controller's needs (6 joints, 'tip' and 'ft_sensor' frames) and the scenario.
    let (mut ctl, scenario_ref) = {
        let table = ParamTable::new(config::specs(&base), Some(config::check(base)), &args.overrides("naic_controller")?)
            .map_err(RosError::Param)?;
        let cp = table.with(|p| config::controller_params(p, &base)).map_err(RosError::Param)?;
        let ctl = Controller::new(model.clone(), cp)
            .map_err(|e| RosError::Param(format!("robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
        let name = table.with(|p| p.str("scenario").to_string());
        (ctl, reference::ScenarioReference::new(&name, &model).map_err(RosError::Param)?)
    };
    let mut node = RosNode::new(args, "naic_controller", config::specs(&base), Some(config::check(base)))?;
    let mut state: ControllerState = ctl.initial_state();
    let mut ws: Workspace = ctl.workspace();
    let mut fk = Data6::try_new(&model).map_err(|e| RosError::Param(format!("{urdf}: {e}")))?;
    let tip = model.frame_id(controller::TIP_FRAME).ok_or_else(|| RosError::Node("URDF has no 'tip' frame".into()))?;

    let mut js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let w_sub = node.subscription::<WrenchStamped>("wrench", msgs::WRENCH_STAMPED, QOS_SUB)?;
    let effort_pub = node.publisher::<msgs::Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB)?;
    let params_pub = node.publisher::<NaicParams>("naic/params", msgs::NAIC_PARAMS, QOS_PUB)?;
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut js_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    let mut gen = node.params.generation();
    let (mut f_d, mut force_limit, mut approach, mut use_sim_time, mut mode) =
        (0.0, 0.0, 0.0, false, String::new());
    let mut was_force_limited = false;
    let mut reload = true;
    let mut jmap = JointMap { names: vec![], idx: [0; 6], ok: false };
    let mut wrench = [f64::NAN; 6];
    let mut wrench_stamp_ns: Option<i64> = None;
    let mut wrench_rx_ns: i64 = 0;
    let mut t0_ns: Option<i64> = None;
    let mut p_start: Option<(Vector3<f64>, UnitQuaternion<f64>)> = None;
    let mut last_fault_log = 0i64;
    let mut prev_fault_count = 0u32;
    let mut cycles = 0u64;
    let (mut q, mut dq) = ([0.0; 6], [0.0; 6]);
    // The last command and the `/joint_states` stamp it answers: a repeated stamp (the
    // lockstep driver publishing the same state again) gets the same command, and the
    // controller state advances once per state.
    let mut last_cmd: Option<(i64, [f64; 6])> = None;
    let mut last_params: Option<NaicParams> = None;

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        if node.params.generation() != gen || reload {
            gen = node.params.generation();
            reload = false;
            let r = node.params.with(|p| {
                f_d = p.f64("desired_force");
                force_limit = p.f64("force_limit");
                approach = p.f64("approach_depth");
                use_sim_time = p.bool("use_sim_time");
                mode = p.str("mode").to_string();
                config::controller_params(p, &base)
            });
            match r.and_then(|cp| ctl.with_params(cp)) {
                Ok(c) => {
                    if c.params().control != ctl.params().control {
                        // New force law settings: the NAIC weights restart from the parameters.
                        state.control = c.initial_state().control;
                    }
                    ctl = c;
                }
                Err(e) => log::error!("parameters not applied: {e}"),
            }
            if state.control.retracting() {
                log::info!("parameters changed: resuming force control");
                state.control = state.control.resume();
            }
        }

        while let Ok(Some((w, _))) = w_sub.take() {
            (wrench, wrench_stamp_ns, wrench_rx_ns) = wrench_sample(&w);
        }
        // Newest joint state only; older samples in the queue are skipped.
        let mut newest: Option<JointState> = None;
        while let Ok(Some((js, _))) = js_sub.take() {
            newest = Some(js);
        }
        let Some(js) = newest else { continue };
        let js_stamp_ns = js.header.stamp.to_nanos();
        if let Some((st, tau)) = last_cmd.filter(|(st, _)| *st == js_stamp_ns) {
            let _ = effort_pub.publish(msgs::effort_msg(&tau, Some(st)));
            // The state report of that cycle again (a paused or waiting driver keeps
            // /naic/params alive for late subscribers).
            if let Some(p) = last_params.as_ref().filter(|p| p.header.stamp.to_nanos() == st) {
                let _ = params_pub.publish(p.clone());
            }
            continue;
        }
        if use_sim_time && wrench_stamp_ns.is_none_or(|w| w < js_stamp_ns) {
            // Simulated time: the driver publishes the wrench of a state just before its
            // joint states; take that one (not the previous one) so the loop is deterministic.
            take_until(&w_sub, wall_ns() + 5_000_000, |w| {
                (wrench, wrench_stamp_ns, wrench_rx_ns) = wrench_sample(&w);
                wrench_stamp_ns.is_some_and(|w| w >= js_stamp_ns)
            });
        }
        jmap.update(&js.name);
        let valid = jmap.get(&js.position, &mut q) & jmap.get(&js.velocity, &mut dq);
        if !valid {
            q = [f64::NAN; 6];
            dq = [f64::NAN; 6];
        }

        // Time base: simulated stamps with use_sim_time, else the wall clock.
        let t0 = *t0_ns.get_or_insert(js_stamp_ns);
        let sec = |ns: i64| (ns - t0) as f64 * 1e-9;
        let now_ns = if use_sim_time { js_stamp_ns } else { wall_ns() };
        // Without sim time, staleness is judged by receive time (clocks of other hosts
        // may differ); with sim time by the stamps.
        let w_stamp = match wrench_stamp_ns {
            None => f64::NEG_INFINITY,
            Some(ns) if use_sim_time => sec(ns),
            Some(_) => sec(wrench_rx_ns),
        };
        let m = RawMeasurements {
            t: sec(now_ns),
            q,
            dq,
            joints_stamp: if use_sim_time { sec(js_stamp_ns) } else { sec(now_ns) },
            wrench,
            wrench_stamp: w_stamp,
        };

        // Reference: hold the start orientation; the free-space target is the start
        // position moved `approach_depth` along n (above force_limit the core backs off
        // from it and stays off until resumed).
        if p_start.is_none() && valid && q.iter().all(|x| x.is_finite()) {
            dynamics::forward_kinematics(&model, &mut fk, &Vector6::from(q));
            let pose = fk.frame_se3(tip);
            let r = UnitQuaternion::from_matrix(&pose.rot);
            p_start = Some((pose.trans, r));
            log::info!("start tip position {:?}", pose.trans.as_slice());
        }
        let (p0, r0) = p_start.unwrap_or((Vector3::zeros(), UnitQuaternion::identity()));
        let axis = ctl.params().control.force_axis;
        let mut n = Vector3::zeros();
        n[axis.axis] = axis.sign;
        let reference = match &scenario_ref {
            // The scenario's trajectory; the force set point is the parameter.
            Some(sr) => Reference { f_d, ..sr.at(m.t) },
            None => Reference { p_d: p0 + n * approach, r_d: r0, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d },
        };
        let (next, out) = controller::step(&ctl, &state, &m, &reference, &mut ws);
        state = next;
        cycles += 1;
        let st = &out.status;
        if st.force_limited && !was_force_limited {
            log::warn!("measured force {:.1} N above force_limit {force_limit} N: retracting (set any parameter to resume)", st.f_ext);
        }
        was_force_limited = st.force_limited;
        if let Some(f) = st.fault {
            let now = wall_ns();
            if st.fault_count != prev_fault_count || now - last_fault_log > 1_000_000_000 {
                last_fault_log = now;
                log::warn!("holding: {f} (faults so far: {})", st.fault_count);
            }
        }
        prev_fault_count = st.fault_count;

        // Never publish a non-finite torque: skip the cycle (the driver holds after 20 ms).
        if out.tau.iter().all(|t| t.is_finite()) {
            let _ = effort_pub.publish(msgs::effort_msg(&out.tau, Some(js_stamp_ns)));
            last_cmd = Some((js_stamp_ns, out.tau));
        } else {
            log::error!("controller produced a non-finite torque; not published");
        }
        let fault = match (st.fault, st.force_limited) {
            (Some(f), _) => f.to_string(),
            (None, true) => format!("force above force_limit ({force_limit} N): retracting, then holding off the surface until a parameter is set"),
            (None, false) => String::new(),
        };
        let report = NaicParams {
            header: Header { stamp: time_from_ns(js_stamp_ns), frame_id: String::new() },
            mode: mode.clone(),
            phase: match st.phase {
                Phase::Free => NaicParams::PHASE_FREE,
                Phase::Contact => NaicParams::PHASE_CONTACT,
                Phase::Hold => NaicParams::PHASE_HOLD,
            },
            force_axis: st.force_axis as u8,
            desired_force: st.f_d,
            measured_force: st.f_ext,
            e_f: st.e_f,
            m_d: st.m_d,
            b_d: st.b_d,
            k_d: st.k_d,
            sigma: st.sigma,
            phi: st.phi,
            gamma: st.gamma,
            gamma_bound: st.gamma_bound,
            gamma_clipped: st.gamma_clipped,
            fault,
            fault_count: st.fault_count,
        };
        // Kept for a repeated stamp only (lockstep); in real time stamps never repeat.
        if use_sim_time {
            last_params = Some(report.clone());
        }
        let _ = params_pub.publish(report);
    }
    log::info!("stopped after {cycles} cycles");
    Ok(())
}
