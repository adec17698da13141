//! `naic launch --composed`: the three nodes in one process, as a ROS 2 component
//! container with intra-process communication has them.
//!
//! The same node cores and loop bodies as the three processes (each node crate's
//! `runner::Runner` over its `core`), called in one thread per cycle: driver state →
//! controller → friction_compensation → driver command, each runner reading the previous
//! one's message by reference (no copy, no DDS on the control path). Then every topic goes out on DDS for observers (rclpy, `ros2 topic`, `naic
//! record`): `/joint_states`, `/wrench`, `/clock`, `/naic/effort`, `/naic/params`,
//! `/joint_effort_cmd`. With `scenario: none` the controller follows `/naic/target_pose`
//! and `/naic/desired_wrench` from DDS, as the node process does. The three ROS nodes keep their names, parameters and parameter
//! services (three nodes in one DDS participant).
//!
//! - Real time: one cycle per period of the driver's `rate`; the command computed from a
//!   state is applied at the next deadline, so the chain latency is the compute time of
//!   the two cores (measured as in the three processes, stamp → command at the driver).
//! - Lockstep: simulated time, one step per command computed from the state just
//!   published, paced at most at `rate` steps per wall second so DDS observers (reliable,
//!   keep last 10) get every sample. The cores run on simulated stamps only, so the run is
//!   the same as the three processes in lockstep, stamp by stamp.
//! - `/joint_effort_cmd` is published, not subscribed: the driver's commands come from the
//!   chain in this process only.
//! - A crash of this process ends all three nodes at once, the driver's hold with them
//!   (docs/nodes.md: "One process or three").

use std::time::Instant;

use friction_compensation::{runner as fc, setup as fc_setup};
use jk5_sim_driver::{
    latency::Histogram,
    runner::{self as drv, monotonic_ns},
    setup as drv_setup,
};
use naic_controller::{runner as ctl, setup as ctl_setup, tf as ctl_tf};
use naic_msgs::CopyFrom;
use naic_ros::{
    context::{create_context, DdsSettings},
    handoff::Handoff,
    msgs::{self, Clock, Float64MultiArray, JointState, NaicParams, TFMessage, WrenchStamped},
    node::{apply_scheduling, data_qos, pub_qos},
    time::wall_ns,
    ParamTable, RosArgs, RosError, RosNode,
};

use super::{
    launch::{node_args, LaunchArgs},
    CliError, CliResult,
};

/// A node's start-up error as the launch's (the node named, its exit code kept).
fn node_err(node: &str) -> impl Fn(RosError) -> CliError + '_ {
    move |e| CliError::with_code(e.exit_code().max(1), format!("{node}: {e}"))
}

/// What observers get each cycle, handed to the publisher thread (`has_*`: the message
/// was produced this cycle).
#[derive(Clone, Default)]
struct Observed {
    js: JointState,
    w: WrenchStamped,
    clock: Clock,
    effort: Float64MultiArray,
    has_effort: bool,
    report: NaicParams,
    has_report: bool,
    cmd: Float64MultiArray,
    has_cmd: bool,
    tf: TFMessage,
    has_tf: bool,
}

impl CopyFrom for Observed {
    fn copy_from(&mut self, o: &Self) {
        self.js.copy_from(&o.js);
        self.w.copy_from(&o.w);
        self.clock.copy_from(&o.clock);
        self.effort.copy_from(&o.effort);
        self.report.copy_from(&o.report);
        self.cmd.copy_from(&o.cmd);
        self.tf.copy_from(&o.tf);
        (self.has_effort, self.has_report, self.has_cmd, self.has_tf) = (o.has_effort, o.has_report, o.has_cmd, o.has_tf);
    }
}

/// `src` into `dst` if there is one; whether there was.
fn copy_opt<M: CopyFrom>(dst: &mut M, src: Option<&M>) -> bool {
    if let Some(m) = src {
        dst.copy_from(m);
    }
    src.is_some()
}

/// Deadline statistics of the real-time loop (what a 1 kHz arm sees).
#[derive(Default)]
struct Deadlines {
    /// Wake-up lateness after each deadline [ns].
    wake: Histogram,
    /// Deadline → commands and topics out (the whole cycle's work) [ns].
    work: Histogram,
    /// Cycles whose work ended after the next deadline (the next step was late).
    overruns: u64,
}

pub fn run(a: &LaunchArgs) -> CliResult {
    let started = std::time::Instant::now();
    if a.respawn {
        return Err(CliError::usage(
            "--respawn with --composed: the three nodes share one process, so a crash ends them all \
             (docs/nodes.md: One process or three); use the three processes (without --composed) to respawn",
        ));
    }
    let (dname, cname, fname) = (drv_setup::NODE, ctl_setup::NODE, fc_setup::NODE);
    let parse = |node: &str| -> Result<RosArgs, CliError> { RosArgs::parse(node_args(node, a)?).map_err(node_err(node)) };
    let (d_args, c_args, f_args) = (parse(dname)?, parse(cname)?, parse(fname)?);
    // The arms of the three nodes (`-p robot:=FILE`; naic launch --robot gives each the same)
    // pick the compiled shell: one joint count for the chain.
    let (d_robot, n) = drv_setup::arm(&d_args).map_err(node_err(dname))?;
    let (c_robot, nc) = ctl_setup::arm(&c_args).map_err(node_err(cname))?;
    let (f_robot, nf) = fc_setup::arm(&f_args).map_err(node_err(fname))?;
    if nc != n || nf != n {
        return Err(CliError::usage(format!("{dname} runs {n} joints, {cname} {nc} and {fname} {nf}: give the three nodes the same robot (naic launch --robot FILE)")));
    }
    naic_core::with_joints!(n, N => run_arm::<N>(a, started, (d_args, d_robot), (c_args, c_robot), (f_args, f_robot)))
        .map_err(|e| CliError::usage(e.to_string()))?
}

type Arm = (RosArgs, Option<naic_core::robot_file::Robot>);

fn run_arm<const N: usize>(a: &LaunchArgs, started: Instant, (d_args, d_robot): Arm, (c_args, c_robot): Arm, (f_args, f_robot): Arm) -> CliResult {
    let (dname, cname, fname) = (drv_setup::NODE, ctl_setup::NODE, fc_setup::NODE);
    // Every file and start-up value checked before any DDS participant exists.
    let d = drv_setup::Setup::<N>::for_arm(&d_args, d_robot).map_err(node_err(dname))?;
    let c = ctl_setup::Setup::<N>::for_arm(&c_args, c_robot).map_err(node_err(cname))?;
    let f = fc_setup::Setup::<N>::for_arm(&f_args, f_robot).map_err(node_err(fname))?;
    naic_ros::log::init("naic_composed", d_args.log_level.as_deref());
    // The loop thread's scheduling is the driver's (`realtime_priority`, `cpu_affinity`).
    // It is set on this thread only, after the DDS threads and the publisher thread exist:
    // in one process nothing on DDS is on the control path, so they run with normal
    // scheduling and never delay the loop.
    let scheduling = ParamTable::new(d.specs(), None, &d_args.overrides(dname).map_err(node_err(dname))?)
        .map_err(|e| CliError::usage(format!("{dname}: {e}")))?;
    naic_ros::install_signal_handlers();
    let context = DdsSettings::from_env().and_then(|s| create_context(&s)).map_err(node_err("naic launch --composed"))?;
    let mut dn = RosNode::in_context(d_args, dname, d.specs(), Some(d.check()), &context).map_err(node_err(dname))?;
    let mut cn = RosNode::in_context(c_args, cname, c.specs(), Some(c.check()), &context).map_err(node_err(cname))?;
    let mut fnode = RosNode::in_context(f_args, fname, f.specs(), Some(f.check()), &context).map_err(node_err(fname))?;
    let dds = |e: RosError| CliError::failure(format!("naic launch --composed: {e}"));
    // The data topics with each node's `data_qos`, as the node processes publish them.
    let (d_qos, c_qos, f_qos) = (dn.params.with(data_qos).0, cn.params.with(data_qos).0, fnode.params.with(data_qos).0);
    let js_pub = dn.publisher("joint_states", msgs::JOINT_STATE, d_qos.clone()).map_err(dds)?;
    let w_pub = dn.publisher("wrench", msgs::WRENCH_STAMPED, d_qos).map_err(dds)?;
    let clock_pub = dn.publisher("/clock", msgs::CLOCK, dn.params.with(pub_qos)).map_err(dds)?;
    let effort_pub = cn.publisher::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, c_qos).map_err(dds)?;
    let params_pub = cn.publisher::<NaicParams>("naic/params", msgs::NAIC_PARAMS, cn.params.with(pub_qos)).map_err(dds)?;
    let cmd_pub = fnode.publisher::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, f_qos).map_err(dds)?;
    // The robot model for RViz and Foxglove, as the controller process advertises it.
    let (mut model_topics, tf_pub) = ctl_tf::ModelTopics::advertise(&mut cn, wall_ns()).map_err(dds)?;
    eprintln!("naic launch: composed {dname}, {fname}, {cname} in one process (pid {})", std::process::id());

    // The three nodes' loop bodies.
    let mut dr = drv::Runner::new(d.plant, &dn.params, &d.joints);
    // Everything observers see goes out from a publisher thread (publish order: wrench,
    // joint states, clock, effort, report, command, as the node processes publish them).
    let mut seen = Observed { js: dr.msgs.js.clone(), ..Default::default() };
    let observers = Handoff::spawn("naic-publish", seen.clone(), move |o: &Observed| {
        let _ = w_pub.publish(o.w.clone());
        let _ = js_pub.publish(o.js.clone());
        let _ = clock_pub.publish(o.clock.clone());
        if o.has_effort {
            let _ = effort_pub.publish(o.effort.clone());
        }
        if o.has_report {
            let _ = params_pub.publish(o.report.clone());
        }
        if o.has_cmd {
            let _ = cmd_pub.publish(o.cmd.clone());
        }
        if o.has_tf {
            let _ = tf_pub.publish(o.tf.clone());
        }
    })
    .map_err(|e| CliError::failure(format!("naic launch --composed: cannot start the publisher thread: {e}")))?;
    scheduling.with(apply_scheduling);
    let mut cmds = dr.commands(&dn.params);
    let fr = fc::Runner::new(&f, &fnode.params).map_err(|e| CliError::usage(format!("{fname}: {e}")));
    let (mut cr, mut fr) = (ctl::Runner::new(c, &cn.params), fr?);
    // scenario:=none: the reference topics, as the node process subscribes them.
    let refs = ctl::ReferenceSubs::new(&mut cn, &cr).map_err(dds)?;
    let mut services = ctl::Services::new(&mut cn).map_err(dds)?;
    let mut dl = Deadlines::default();
    let t0 = Instant::now();
    while !naic_ros::shutdown_requested() && !a.duration.is_some_and(|s| t0.elapsed().as_secs_f64() >= s) {
        dr.reload(&dn.params, &mut cmds);
        cr.reload(&cn.params);
        fr.reload(&fnode.params);
        // The state, then the chain on it, in this thread. The wrench of this state is
        // already in, so the controller's pairing does not wait (if it did, nothing more
        // can come: it is given up at once), nor does friction_compensation's.
        dr.announce(&mut cmds);
        let (js, w) = (&dr.msgs.js, &dr.msgs.w);
        cr.wrench(w);
        if let Some(refs) = &refs {
            refs.feed(&mut cr);
        }
        services.serve(&mut cr, &cn);
        let out = cr.joint_states(js, |_| None);
        let cmd = match out.effort {
            Some(e) => {
                fr.joint_states(js);
                fr.command(e, |_| None)
            }
            None => None,
        };
        if let Some(m) = cmd {
            drv::receive(&mut cmds, m);
        }
        // Then everything to the publisher thread for observers: in real time without
        // waiting (newest wins, losses counted), in lockstep every state.
        seen.js.copy_from(js);
        seen.w.copy_from(w);
        seen.clock.copy_from(&dr.msgs.clock);
        seen.has_effort = copy_opt(&mut seen.effort, out.effort);
        seen.has_report = copy_opt(&mut seen.report, out.report);
        seen.has_cmd = copy_opt(&mut seen.cmd, cmd);
        seen.has_tf = copy_opt(&mut seen.tf, model_topics.joint_states(&cn.params, js));
        // What reaches the driver (the controller's actuation supervision, as over DDS).
        if let Some(m) = cmd {
            cr.actuated(m);
        }
        if dr.p.lockstep {
            observers.offer_every(&seen);
        } else {
            observers.offer(&seen);
        }
        let timed = !dr.p.lockstep && !dr.sim && wall_ns() >= cmds.record_after_ns;
        let end = monotonic_ns();
        if timed && !dr.paused {
            dl.work.record(end - dr.deadline_ns());
            if end > dr.deadline_ns() + dr.period_ns() {
                dl.overruns += 1;
            }
        }
        if dr.paused {
            // Time stands still; the same state goes out again so late subscribers get it.
            dr.pause();
            continue;
        }
        let deadline = dr.pace();
        if timed {
            dl.wake.record(monotonic_ns() - deadline);
        }
        // A value accepted while waiting applies to this step.
        dr.reload(&dn.params, &mut cmds);
        if dr.p.lockstep && !cmds.take_ready() {
            // No command for this state (the chain held it back): simulated time stands
            // still, the same state goes out again.
            continue;
        }
        dr.step(&cmds.view());
    }

    let dropped = observers.dropped();
    drop(observers); // what is still in the slot goes out
    if dropped > 0 {
        log::warn!("{dropped} cycles' messages were not published to observers (the publisher thread was behind; the control path was not affected)");
    }
    log::info!("stopping: controller {} cycles, friction_compensation {} commands", cr.s.cycles, fr.s.published);
    let q = |h: &Histogram, f: f64| h.quantile_ns(f).map_or(f64::NAN, |ns| ns / 1e3);
    let extra = serde_json::json!({
        "mode": "composed",
        "observer_cycles_dropped": dropped,
        "deadline_overruns": dl.overruns,
        "wake_late_p99_us": q(&dl.wake, 0.99),
        "wake_late_max_us": dl.wake.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
        "cycle_work_median_us": q(&dl.work, 0.5),
        "cycle_work_p99_us": q(&dl.work, 0.99),
        "cycle_work_max_us": dl.work.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
    });
    dr.finish(&cmds, &dn.params, extra);
    drop((fnode, cn, dn));
    naic_ros::threads::warn_busy_threads("naic launch --composed", started.elapsed());
    Ok(())
}
