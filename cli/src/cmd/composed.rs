//! `naic launch --composed`: the three nodes in one process, as a ROS 2 component
//! container with intra-process communication has them.
//!
//! The same node cores as the three processes (`jk5_sim_driver::core`,
//! `naic_controller::core`, `friction_compensation::core`), called in one thread per
//! cycle: driver state → controller → friction_compensation → driver command, each core
//! reading the previous one's message by reference (no copy, no DDS on the control
//! path). Then every topic goes out on DDS for observers (rclpy, `ros2 topic`, `naic
//! record`): `/joint_states`, `/wrench`, `/clock`, `/naic/effort`, `/naic/params`,
//! `/joint_effort_cmd`. The three ROS nodes keep their names, parameters and parameter
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
//!   (README: "One process or three").

use std::time::{Duration, Instant};

use friction_compensation::{core as fc, shell as fc_shell};
use jk5_sim_driver::{
    config as drv_config,
    core::{self as drv, Commands},
    latency::Histogram,
    shell::{self as drv_shell, monotonic_ns, sim_stamp_ns, sim_stamps, sleep_until, StateMsgs},
};
use naic_controller::{core as ctl, shell as ctl_shell};
use naic_ros::{
    context::{create_context, DdsSettings},
    msgs::{self, Clock, Float64MultiArray, NaicParams},
    node::{apply_scheduling, QOS_PUB},
    time::{time_from_ns, wall_ns},
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

/// The messages of one cycle, preallocated and rewritten in place.
struct Wire {
    state: StateMsgs,
    effort: Float64MultiArray,
    report: NaicParams,
    cmd: Float64MultiArray,
    /// This cycle produced a `/naic/effort`, a `/naic/params`, a `/joint_effort_cmd`.
    has: (bool, bool, bool),
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
    if a.respawn {
        return Err(CliError::usage(
            "--respawn with --composed: the three nodes share one process, so a crash ends them all \
             (README: One process or three); use the three processes (without --composed) to respawn",
        ));
    }
    let parse = |node: &str| -> Result<RosArgs, CliError> { RosArgs::parse(node_args(node, a)?).map_err(node_err(node)) };
    let (d_args, c_args, f_args) = (parse(drv_shell::NODE)?, parse(ctl_shell::NODE)?, parse(fc_shell::NODE)?);
    // Every file and start-up value checked before any DDS participant exists.
    let d = drv_shell::Setup::from_args(&d_args).map_err(node_err(drv_shell::NODE))?;
    let c = ctl_shell::Setup::from_args(&c_args).map_err(node_err(ctl_shell::NODE))?;
    let f = fc_shell::Setup::from_args(&f_args).map_err(node_err(fc_shell::NODE))?;
    naic_ros::log::init("naic_composed", d_args.log_level.as_deref());
    // The process's scheduling is the driver's (the 1 kHz loop), set before any thread.
    ParamTable::new(d.specs(), None, &d_args.overrides(drv_shell::NODE).map_err(node_err(drv_shell::NODE))?)
        .map_err(|e| CliError::usage(format!("{}: {e}", drv_shell::NODE)))?
        .with(apply_scheduling);
    naic_ros::install_signal_handlers();
    let context = DdsSettings::from_env().and_then(|s| create_context(&s)).map_err(node_err("naic launch --composed"))?;
    let (d_specs, d_check, mut plant) = (d.specs(), d.check(), d.plant);
    let mut dn = RosNode::in_context(d_args, drv_shell::NODE, d_specs, Some(d_check), &context).map_err(node_err(drv_shell::NODE))?;
    let mut cn = RosNode::in_context(c_args, ctl_shell::NODE, c.specs(), Some(c.check()), &context).map_err(node_err(ctl_shell::NODE))?;
    let mut fnode = RosNode::in_context(f_args, fc_shell::NODE, f.specs(), Some(f.check()), &context).map_err(node_err(fc_shell::NODE))?;
    let dds = |e: RosError| CliError::failure(format!("naic launch --composed: {e}"));
    let js_pub = dn.publisher("joint_states", msgs::JOINT_STATE, QOS_PUB).map_err(dds)?;
    let w_pub = dn.publisher("wrench", msgs::WRENCH_STAMPED, QOS_PUB).map_err(dds)?;
    let clock_pub = dn.publisher("/clock", msgs::CLOCK, QOS_PUB).map_err(dds)?;
    let effort_pub = cn.publisher::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB).map_err(dds)?;
    let params_pub = cn.publisher::<NaicParams>("naic/params", msgs::NAIC_PARAMS, QOS_PUB).map_err(dds)?;
    let cmd_pub = fnode.publisher::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB).map_err(dds)?;
    eprintln!("naic launch: composed {}, {}, {} in one process (pid {})", drv_shell::NODE, fc_shell::NODE, ctl_shell::NODE, std::process::id());

    // The three cores' parameters and states.
    let (mut d_gen, mut c_gen, mut f_gen) = (dn.params.generation(), cn.params.generation(), fnode.params.generation());
    let read_driver = |dn: &RosNode| dn.params.with(|v| (drv_config::core_params(v), v.bool("paused"), sim_stamps(v)));
    let (mut dp, mut paused, mut sim) = read_driver(&dn);
    let warmup_ns = dn.params.with(|p| (p.f64("latency_warmup") * 1e9) as i64);
    let mut cmds = Commands::new(wall_ns() + warmup_ns, sim);
    let mut ds = drv::State::default();
    let (base, mut cp) = (c.base, c.params);
    let mut cs = ctl::State::new(&cp);
    let mut ws = cp.controller.workspace();
    let sense = f.sense;
    let mut fp = fnode.params.with(|v| friction_compensation::config::core_params(v, &sense)).map_err(|e| CliError::usage(format!("{}: {e}", fc_shell::NODE)))?;
    let mut fs = fc::State::default();
    let mut wire = Wire { state: StateMsgs::default(), effort: Float64MultiArray::default(), report: NaicParams::default(), cmd: Float64MultiArray::default(), has: (false, false, false) };
    let mut dl = Deadlines::default();

    let t0 = Instant::now();
    let mut next = monotonic_ns();
    let mut reload = |dn: &RosNode, dp: &mut drv::Params, paused: &mut bool, sim: &mut bool, cmds: &mut Commands| {
        if dn.params.generation() != d_gen {
            d_gen = dn.params.generation();
            (*dp, *paused, *sim) = read_driver(dn);
            cmds.sim_stamps = *sim;
        }
    };
    while !naic_ros::shutdown_requested() && !a.duration.is_some_and(|s| t0.elapsed().as_secs_f64() >= s) {
        reload(&dn, &mut dp, &mut paused, &mut sim, &mut cmds);
        ctl_shell::reload(&cn, &mut c_gen, &base, &mut cp, &mut cs);
        fc_shell::reload(&fnode, &mut f_gen, &sense, &mut fp);
        // The state, then the chain on it, in this thread.
        let stamp = wire.state.fill(&plant, dp.lockstep || sim);
        cmds.expect(dp.lockstep.then(|| sim_stamp_ns(&plant)));
        ds.last_published_stamp = Some(stamp);
        chain(&cp, &mut cs, &mut ws, &fp, &mut fs, &mut wire);
        if wire.has.2 {
            if let Some(e) = drv::receive(&mut cmds, &wire.cmd, wall_ns()) {
                log::warn!("ignoring /joint_effort_cmd: {e} (rejected so far: {})", cmds.rejected);
            }
        }
        // Then everything on DDS for observers (by value: one clone each).
        let _ = w_pub.publish(wire.state.w.clone());
        let _ = js_pub.publish(wire.state.js.clone());
        let _ = clock_pub.publish(Clock { clock: time_from_ns(sim_stamp_ns(&plant)) });
        if wire.has.0 {
            let _ = effort_pub.publish(wire.effort.clone());
        }
        if wire.has.1 {
            let _ = params_pub.publish(wire.report.clone());
        }
        if wire.has.2 {
            let _ = cmd_pub.publish(wire.cmd.clone());
        }
        let period_ns = (1e9 / dp.rate) as i64;
        let end = monotonic_ns();
        if !paused && !dp.lockstep && !sim && wall_ns() >= cmds.record_after_ns {
            dl.work.record(end - next);
            if end > next + period_ns {
                dl.overruns += 1;
            }
        }
        if paused {
            // Time stands still; the same state goes out again so late subscribers get it.
            std::thread::sleep(Duration::from_nanos(dp.command_timeout_ns as u64));
            next = monotonic_ns();
            continue;
        }
        next += period_ns;
        let now = monotonic_ns();
        if now > next + 10 * period_ns {
            next = now; // fell far behind (suspended?): resynchronise
        }
        sleep_until(next);
        let woke = monotonic_ns();
        if wall_ns() >= cmds.record_after_ns && !dp.lockstep && !sim {
            dl.wake.record(woke - next);
        }
        // A value accepted while waiting applies to this step.
        reload(&dn, &mut dp, &mut paused, &mut sim, &mut cmds);
        if dp.lockstep {
            if !cmds.ready {
                // No command for this state (the chain held it back): simulated time
                // stands still, the same state goes out again.
                continue;
            }
            cmds.ready = false;
        }
        let (n, o) = drv::step(&dp, &ds, &cmds.view(), wall_ns(), &mut plant);
        ds = n;
        drv_shell::log_events(&o, &dp, &ds);
    }

    log::info!("stopping: controller {} cycles, friction_compensation {} commands", cs.cycles, fs.published);
    let q = |h: &Histogram, f: f64| h.quantile_ns(f).map_or(f64::NAN, |ns| ns / 1e3);
    let extra = serde_json::json!({
        "mode": "composed",
        "deadline_overruns": dl.overruns,
        "wake_late_p99_us": q(&dl.wake, 0.99),
        "wake_late_max_us": dl.wake.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
        "cycle_work_median_us": q(&dl.work, 0.5),
        "cycle_work_p99_us": q(&dl.work, 0.99),
        "cycle_work_max_us": dl.work.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
    });
    let path = dn.params.with(|p| p.str("latency_report").to_string());
    drv_shell::write_report(&cmds, &ds, &path, extra);
    drop((fnode, cn, dn));
    Ok(())
}

/// One pass of the control path on the state in `wire`: controller (wrench, then joint
/// states), friction_compensation (joint states, then the controller's torque); each core
/// reads the message before it by reference.
fn chain(cp: &ctl::Params, cs: &mut ctl::State, ws: &mut naic_core::pipeline::controller::Workspace, fp: &fc::Params, fs: &mut fc::State, wire: &mut Wire) {
    let (js, w) = (&wire.state.js, &wire.state.w);
    let mut c_step = |s: &mut ctl::State, inbox: ctl::Inbox, now: i64| {
        let (next, out) = ctl::step(cp, s, &inbox, now, ws);
        *s = next;
        out
    };
    c_step(cs, ctl::Inbox { wrench: Some(w), ..Default::default() }, wall_ns());
    let mut out = c_step(cs, ctl::Inbox { joint_states: Some(js), ..Default::default() }, wall_ns());
    // The wrench of this state is already in, so the pairing does not wait; if it did,
    // nothing more can come: give the wait up at once.
    while let Some(until) = out.wait_until_ns {
        out = c_step(cs, ctl::Inbox::default(), until);
    }
    ctl_shell::log_events(&out.events, cp.settings.force_limit);
    wire.has = (out.effort.is_some(), out.report.is_some(), false);
    if let Some(r) = out.report {
        ctl_shell::fill_report(&mut wire.report, &r);
    }
    let Some((tau, stamp)) = out.effort else { return };
    msgs::set_effort_msg(&mut wire.effort, &tau, Some(stamp));
    let f_step = |s: &mut fc::State, inbox: fc::Inbox, now: i64| {
        let (next, out) = fc::step(fp, s, &inbox, now);
        *s = next;
        fc_shell::log_event(&out.event);
        out
    };
    f_step(fs, fc::Inbox { joint_states: Some(js), ..Default::default() }, wall_ns());
    let mut out = f_step(fs, fc::Inbox { command: Some(&wire.effort), ..Default::default() }, wall_ns());
    while let Some(until) = out.wait_until_ns {
        out = f_step(fs, fc::Inbox::default(), until);
    }
    if let Some((tau, src)) = out.command {
        msgs::set_effort_msg(&mut wire.cmd, &tau, src);
        wire.has.2 = true;
    }
}
