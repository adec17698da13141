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
    core::{self, Commands},
    plant::Plant,
    shell::{self, monotonic_ns, sim_stamp_ns, sim_stamps, sleep_until, Setup, StateMsgs, NODE},
};
use naic_ros::{
    alloc_check,
    msgs::{self, Clock, Float64MultiArray, JointState, WrenchStamped},
    node::{Pub, QOS_PUB, QOS_SUB_RELIABLE},
    time::{time_from_ns, wall_ns},
    wait::Waiter,
    RosArgs, RosError, RosNode,
};

#[cfg(debug_assertions)]
#[global_allocator]
static COUNTING: alloc_check::CountingAlloc = alloc_check::CountingAlloc;

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
    m: StateMsgs,
    js_pub: Pub<JointState>,
    w_pub: Pub<WrenchStamped>,
    clock_pub: Pub<Clock>,
}

impl StatePub {
    /// Publish joint states, wrench and clock; returns the stamp used [ns].
    fn publish(&mut self, plant: &impl Plant, sim_stamps: bool) -> i64 {
        let stamp_ns = self.m.fill(plant, sim_stamps);
        // Wrench first: the controller cycles on /joint_states and uses the newest wrench.
        let _ = self.w_pub.publish(self.m.w.clone());
        let _ = self.js_pub.publish(self.m.js.clone());
        let _ = self.clock_pub.publish(Clock { clock: time_from_ns(sim_stamp_ns(plant)) });
        stamp_ns
    }
}

fn main() {
    naic_ros::run_main(NODE, run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    // Files first, before any DDS participant exists.
    let setup = Setup::from_args(&args)?;
    let mut node = RosNode::new(args, NODE, setup.specs(), Some(setup.check()))?;
    let mut plant = setup.plant;
    let mut out = StatePub {
        m: StateMsgs::default(),
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
        shell::log_events(&o, &p, &s);
        // Lockstep: announce the state before publishing it, so its command is never early.
        shared.lock().expect(p.lockstep.then(|| sim_stamp_ns(&plant)));
        s.last_published_stamp = Some(out.publish(&plant, p.lockstep || sim));
    }

    // Report the chain latency.
    let path = node.params.with(|p| p.str("latency_report").to_string());
    shell::write_report(&shared.lock(), &s, &path, serde_json::json!({}));
    Ok(())
}
