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

use std::{
    sync::{Arc, Condvar, Mutex, MutexGuard},
    time::Duration,
};

use jk5_sim_driver::{
    config,
    core::{self, Commands, Hold},
    plant::Plant,
    sim_plant::make_plant,
};
use naic_ros::{
    alloc_check,
    msgs::{self, Clock, Float64MultiArray, Header, JointState, WrenchStamped},
    node::{Pub, QOS_PUB, QOS_SUB_RELIABLE},
    time::{time_from_ns, wall_ns},
    wait::Waiter,
    ParamTable, ParamView, RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;

const NODE: &str = "jk5_sim_driver";

/// The newest command, shared with the receive thread (which wakes the lockstep wait).
struct Shared {
    slot: Mutex<Commands>,
    cv: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Commands> {
        self.slot.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The state messages, preallocated; published by value (ros2-client), one clone each.
struct StatePub {
    js: JointState,
    w: WrenchStamped,
    js_pub: Pub<JointState>,
    w_pub: Pub<WrenchStamped>,
    clock_pub: Pub<Clock>,
}

impl StatePub {
    /// Publish joint states, wrench and clock; returns the stamp used [ns].
    fn publish(&mut self, plant: &impl Plant, sim_stamps: bool) -> i64 {
        let sim_ns = sim_stamp_ns(plant);
        let stamp_ns = if sim_stamps { sim_ns } else { wall_ns() };
        let (q, v, t) = plant.joints();
        self.js.header.stamp = time_from_ns(stamp_ns);
        self.js.position.copy_from_slice(&q);
        self.js.velocity.copy_from_slice(&v);
        self.js.effort.copy_from_slice(&t);
        let w = plant.wrench();
        self.w.header.stamp = time_from_ns(stamp_ns);
        (self.w.wrench.force.x, self.w.wrench.force.y, self.w.wrench.force.z) = (w[0], w[1], w[2]);
        (self.w.wrench.torque.x, self.w.wrench.torque.y, self.w.wrench.torque.z) = (w[3], w[4], w[5]);
        // Wrench first: the controller cycles on /joint_states and uses the newest wrench.
        let _ = self.w_pub.publish(self.w.clone());
        let _ = self.js_pub.publish(self.js.clone());
        let _ = self.clock_pub.publish(Clock { clock: time_from_ns(sim_ns) });
        stamp_ns
    }
}

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    // Files first, before any DDS participant exists: the robot model (effort limits), then
    // the whole plant (model, scenario, friction file) from the start-up parameters.
    let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
    let urdf_effort = config::urdf_effort_limits(&urdf).map_err(RosError::Param)?;
    let mut plant = ParamTable::new(config::specs(&urdf_effort), Some(config::check(urdf_effort)), &args.overrides(NODE)?)
        .map_err(RosError::Param)?
        .with(make_plant)
        .map_err(RosError::Param)?;
    let mut node = RosNode::new(args, NODE, config::specs(&urdf_effort), Some(config::check(urdf_effort)))?;
    let mut out = StatePub {
        js: JointState { name: msgs::JOINT_NAMES.iter().map(|s| s.to_string()).collect(), position: vec![0.0; 6], velocity: vec![0.0; 6], effort: vec![0.0; 6], ..Default::default() },
        w: WrenchStamped { header: Header { frame_id: "ft_sensor".into(), ..Default::default() }, ..Default::default() },
        js_pub: node.publisher("joint_states", msgs::JOINT_STATE, QOS_PUB)?,
        w_pub: node.publisher("wrench", msgs::WRENCH_STAMPED, QOS_PUB)?,
        clock_pub: node.publisher("/clock", msgs::CLOCK, QOS_PUB)?,
    };
    let mut cmd_sub = node.subscription::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB_RELIABLE)?;
    let warmup_ns = node.params.with(|p| (p.f64("latency_warmup") * 1e9) as i64);
    let shared = Arc::new(Shared { slot: Mutex::new(Commands::new(wall_ns() + warmup_ns, node.params.with(sim_stamps))), cv: Condvar::new() });

    // Receive thread: wakes on each command, checks it, stamps its arrival.
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll register: {e}")))?;
    let rx = Arc::clone(&shared);
    let receive = move || {
        while !naic_ros::shutdown_requested() {
            waiter.wait(Some(Duration::from_millis(50)));
            while let Ok(Some((m, _))) = cmd_sub.take() {
                let mut c = rx.lock();
                if let Some(e) = core::receive(&mut c, &m, wall_ns()) {
                    log::warn!("ignoring /joint_effort_cmd: {e} (rejected so far: {})", c.rejected);
                }
                drop(c);
                rx.cv.notify_all();
            }
        }
    };
    std::thread::Builder::new().name("cmd-rx".into()).spawn(receive).map_err(|e| RosError::Node(format!("cannot start receive thread: {e}")))?;

    let (mut gen, mut paused, mut sim) = (0, false, false);
    let mut p = node.params.with(config::core_params);
    let (mut s, mut warned) = (core::State::default(), false);
    let mut next = monotonic_ns();
    // Take accepted parameter values (at the top of a cycle, and again just before the
    // step, so a limit accepted while waiting applies to that step).
    let mut reload = |p: &mut core::Params, paused: &mut bool, sim: &mut bool| {
        if node.params.generation() != gen {
            gen = node.params.generation();
            (*p, *paused, *sim) = node.params.with(|v| (config::core_params(v), v.bool("paused"), sim_stamps(v)));
            shared.lock().sim_stamps = *sim;
        }
    };
    while !naic_ros::shutdown_requested() {
        reload(&mut p, &mut paused, &mut sim);
        if paused {
            // Time stands still; the same state goes out again so late subscribers get it.
            std::thread::sleep(Duration::from_nanos(p.command_timeout_ns as u64));
            shared.lock().expect(p.lockstep.then(|| sim_stamp_ns(&plant)));
            s.last_published_stamp = Some(out.publish(&plant, sim));
            next = monotonic_ns();
            continue;
        }
        // Wait for the next step: a deadline (real time) or the command for the state just
        // published (lockstep).
        if p.lockstep {
            if s.last_published_stamp.is_none() || shared.lock().expect_stamp_ns != s.last_published_stamp {
                // First cycle, or just switched to lockstep: publish the state to answer.
                shared.lock().expect(Some(sim_stamp_ns(&plant)));
                s.last_published_stamp = Some(out.publish(&plant, true));
            }
            let timeout = Duration::from_nanos(p.command_timeout_ns as u64);
            let (mut c, _) = shared.cv.wait_timeout_while(shared.lock(), timeout, |c| !c.ready).unwrap_or_else(|e| e.into_inner());
            if !c.ready {
                // No command for this state: simulated time stands still; publish the same
                // state again so a late or restarted controller gets it.
                drop(c);
                out.publish(&plant, true);
                continue;
            }
            c.ready = false;
        } else {
            let period_ns = (1e9 / p.rate) as i64;
            next += period_ns;
            let now = monotonic_ns();
            if now > next + 10 * period_ns {
                next = now; // fell far behind (suspended?): resynchronise
            }
            sleep_until(next);
        }
        reload(&mut p, &mut paused, &mut sim);
        let cmd = shared.lock().view();
        let (n, o) = alloc_check::check(NODE, &mut warned, || core::step(&p, &s, &cmd, wall_ns(), &mut plant));
        s = n;
        match o.events.hold {
            Some(Hold::Timeout) => log::warn!("no /joint_effort_cmd for {} ms: holding the arm", p.command_timeout_ns / 1_000_000),
            Some(Hold::Rejected) => log::warn!("last /joint_effort_cmd rejected: holding the arm"),
            None if o.events.released => log::info!("commands resumed; releasing the hold"),
            None => {}
        }
        if let Some(c) = o.events.saturated {
            log::warn!("torque saturated at effort_limit {:?} N m (joints {c:?}; {} cycles so far)", p.effort_limit, s.saturated_cycles);
        }
        // Lockstep: announce the state before publishing it, so its command is never early.
        shared.lock().expect(p.lockstep.then(|| sim_stamp_ns(&plant)));
        s.last_published_stamp = Some(out.publish(&plant, p.lockstep || sim));
    }

    // Report the chain latency.
    let c = shared.lock();
    let recorded_ns = (wall_ns() - c.record_after_ns).max(0);
    if c.stale_dropped > 0 {
        log::info!("lockstep: {} commands computed from an earlier state were dropped", c.stale_dropped);
    }
    let mut report = config::latency_report(&c.latency, s.missed, s.cycles, recorded_ns, c.rejected);
    report["saturated_cycles"] = s.saturated_cycles.into();
    let path = node.params.with(|p| p.str("latency_report").to_string());
    if !path.is_empty() {
        if let Err(e) = std::fs::write(&path, report.to_string()) {
            log::error!("cannot write latency report {path}: {e}");
        }
    }
    log::info!("stopped after {} cycles; chain latency {report}", s.cycles);
    Ok(())
}

/// Stamps are simulated time.
fn sim_stamps(p: &ParamView) -> bool {
    p.bool("lockstep") || p.bool("use_sim_time")
}

/// The simulated-time stamp of the plant's current state [ns].
fn sim_stamp_ns(plant: &impl Plant) -> i64 {
    (plant.time() * 1e9).round() as i64
}

fn monotonic_ns() -> i64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: valid pointer to a timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as i64 * 1_000_000_000 + ts.tv_nsec as i64
}

fn sleep_until(deadline_ns: i64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    // SAFETY: absolute sleep on CLOCK_MONOTONIC with a valid timespec; EINTR just returns early.
    unsafe {
        libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut());
    }
}
