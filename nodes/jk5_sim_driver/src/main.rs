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

mod latency;
mod plant;
mod sim_plant;

use std::{
    sync::{Arc, Condvar, Mutex},
    time::Duration,
};

use naic_core::{model::Model, pipeline::actuate};
use naic_ros::{
    msgs::{self, Clock, Header, JointState, Vector3, Wrench, WrenchStamped},
    node::{QOS_PUB, QOS_SUB_RELIABLE},
    params::{effort_limit_within, SetCheck, EFFORT_CAP},
    time::{time_from_ns, wall_ns},
    wait::Waiter,
    ParamSpec, ParamTable, ParamView, RosArgs, RosError, RosNode,
};
use plant::Plant;
use sim_plant::{make_plant, PLANT_NAME};

const NODE: &str = "jk5_sim_driver";

fn specs(urdf_effort: &[f64; 6]) -> Vec<ParamSpec> {
    vec![
        ParamSpec::doubles(
            "effort_limit",
            urdf_effort,
            0.0,
            EFFORT_CAP,
            "Per-joint saturation of every torque the driver applies (commands and its own hold) [N m]; at most the URDF effort limit (default: the URDF's)",
        ),
        ParamSpec::double("rate", 1000.0, 1.0, 5000.0, "Simulation and publishing rate [Hz]; the simulator's control period is 1/rate").read_only(),
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model of the simulator").read_only(),
        ParamSpec::string("friction_file", "params/friction_jk5.yaml", "Joint friction acting in the simulator (naic_core::friction YAML)").read_only(),
        ParamSpec::double("friction_smoothing", naic_core::friction::DEFAULT_V_S, 1.0e-5, 1.0, "v_s [rad/s] of the simulator's tanh-smoothed friction").read_only(),
        ParamSpec::boolean(
            "lockstep",
            false,
            "Advance one simulator step per /joint_effort_cmd received (deterministic, faster than real time); stamps become simulated time",
        ),
        ParamSpec::boolean(
            "paused",
            false,
            "Simulation paused: no steps, the current state is published again every command_timeout (set false to run)",
        ),
        ParamSpec::double(
            "command_timeout",
            0.02,
            0.001,
            1.0,
            "Hold the arm (gravity compensation + damping) when no command arrived for this long [s]",
        ),
        ParamSpec::double("hold_damping", 5.0, 0.0, 200.0, "Joint damping of the driver's own hold [N m s/rad]"),
        ParamSpec::choice(
            "scenario",
            "flat",
            &["flat", "stiffness-step", "slope", "foam", "two-material"],
            "Paper scenario of naic_sim: environment and start pose",
        )
        .read_only(),
        ParamSpec::string("plant", PLANT_NAME, "Simulator behind the driver (informational)").read_only(),
        ParamSpec::double("latency_warmup", 2.0, 0.0, 3600.0, "Chain-latency statistics ignore the first seconds after start").read_only(),
        ParamSpec::string("latency_report", "", "If set, write chain-latency statistics (JSON) to this file at exit").read_only(),
    ]
}

/// Effort limits `<limit effort>` of the six joints of `urdf` [N m].
fn urdf_effort_limits(urdf: &str) -> Result<[f64; 6], String> {
    let model = Model::from_urdf_file(urdf).map_err(|e| format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)"))?;
    let l = model.effort_limits();
    if l.len() != 6 {
        return Err(format!("robot model '{urdf}' has {} joints; the JK5 driver needs 6 (set -p urdf:=PATH)", l.len()));
    }
    if let Some(i) = (0..6).find(|&i| !(l[i].is_finite() && l[i] > 0.0)) {
        return Err(format!(
            "robot model '{urdf}': joint {} has effort limit {}; set <limit effort=\"...\"> > 0 in the URDF",
            i + 1,
            l[i]
        ));
    }
    Ok(std::array::from_fn(|i| l[i].min(EFFORT_CAP)))
}

/// Live `effort_limit` changes may tighten the URDF limits, never loosen them.
fn check(urdf_effort: [f64; 6]) -> SetCheck {
    Box::new(move |p: &ParamView| effort_limit_within(p, &urdf_effort))
}

/// The newest command and the latency samples, shared with the receive thread.
struct CmdSlot {
    tau: [f64; 6],
    /// The newest command was valid (else the driver holds until a valid one arrives).
    valid: bool,
    /// Wall-clock arrival of the newest valid command [ns]; 0: none yet.
    arrival_ns: i64,
    /// Counts valid commands received.
    seq: u64,
    /// `/joint_states` stamp the newest command was computed from (if traced).
    source_stamp_ns: Option<i64>,
    /// Latencies (arrival − source stamp) [ns] of traced commands (wall-clock stamps only),
    /// as a fixed-size histogram: constant memory however long the driver runs.
    latency: latency::Histogram,
    /// Latencies are recorded from this wall time on (after the warm-up).
    record_after_ns: i64,
    /// Stamps are simulated time (lockstep / use_sim_time): no latency statistics.
    sim_stamps: bool,
    rejected: u64,
    /// Lockstep: the stamp of the state just published; only commands computed from it
    /// (or carrying no stamp) may advance the simulation. `None` in real time.
    expect_stamp_ns: Option<i64>,
    /// Lockstep: a command for `expect_stamp_ns` is waiting to be applied.
    ready: bool,
    /// Lockstep: commands dropped because they were computed from another state.
    stale_dropped: u64,
}

struct Shared {
    slot: Mutex<CmdSlot>,
    cv: Condvar,
}

fn main() {
    naic_ros::run_main("jk5_sim_driver", run)
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    // Files first, before any DDS participant exists: the robot model (effort limits), then
    // the whole plant (model, scenario, friction file) from the start-up parameters.
    let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
    let urdf_effort = urdf_effort_limits(&urdf).map_err(RosError::Param)?;
    let mut plant = ParamTable::new(specs(&urdf_effort), Some(check(urdf_effort)), &args.overrides(NODE)?)
        .map_err(RosError::Param)?
        .with(make_plant)
        .map_err(RosError::Param)?;
    let mut node = RosNode::new(args, NODE, specs(&urdf_effort), Some(check(urdf_effort)))?;
    let js_pub = node.publisher::<JointState>("joint_states", msgs::JOINT_STATE, QOS_PUB)?;
    let w_pub = node.publisher::<WrenchStamped>("wrench", msgs::WRENCH_STAMPED, QOS_PUB)?;
    let clock_pub = node.publisher::<Clock>("/clock", msgs::CLOCK, QOS_PUB)?;
    let mut cmd_sub =
        node.subscription::<msgs::Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB_RELIABLE)?;

    let shared = Arc::new(Shared {
        slot: Mutex::new(CmdSlot {
            tau: [0.0; 6],
            valid: false,
            arrival_ns: 0,
            seq: 0,
            source_stamp_ns: None,
            latency: latency::Histogram::default(),
            record_after_ns: wall_ns() + node.params.with(|p| (p.f64("latency_warmup") * 1e9) as i64),
            sim_stamps: node.params.with(|p| p.bool("lockstep") || p.bool("use_sim_time")),
            rejected: 0,
            expect_stamp_ns: None,
            ready: false,
            stale_dropped: 0,
        }),
        cv: Condvar::new(),
    });

    // Receive thread: wakes on each command, validates it, stamps its arrival.
    {
        let shared = Arc::clone(&shared);
        let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
        waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll register: {e}")))?;
        std::thread::Builder::new()
            .name("cmd-rx".into())
            .spawn(move || {
                let mut tau = [0.0; 6];
                let mut last_warn = 0i64;
                while !naic_ros::shutdown_requested() {
                    waiter.wait(Some(Duration::from_millis(50)));
                    while let Ok(Some((m, _info))) = cmd_sub.take() {
                        let now = wall_ns();
                        let mut s = shared.slot.lock().unwrap_or_else(|p| p.into_inner());
                        match msgs::effort_values(&m, &mut tau) {
                            Ok(()) => {
                                let src = msgs::effort_source_stamp(&m);
                                if let (Some(want), Some(got)) = (s.expect_stamp_ns, src) {
                                    if got != want {
                                        // Lockstep: computed from another state; never applied.
                                        s.stale_dropped += 1;
                                        continue;
                                    }
                                }
                                s.ready = s.expect_stamp_ns.is_some();
                                s.tau = tau;
                                s.valid = true;
                                s.arrival_ns = now;
                                s.seq += 1;
                                s.source_stamp_ns = src;
                                // Latency only when stamps are wall-clock time.
                                if let (Some(st), false) = (s.source_stamp_ns, s.sim_stamps) {
                                    if now >= s.record_after_ns {
                                        s.latency.record(now - st);
                                    }
                                }
                            }
                            Err(e) => {
                                // Not applied, and the previous command is not kept either:
                                // in real time the driver holds from the next cycle on (in
                                // lockstep a rejected command never advances the simulation).
                                s.valid = false;
                                s.arrival_ns = now;
                                s.seq += 1;
                                s.rejected += 1;
                                if now - last_warn > 1_000_000_000 {
                                    last_warn = now;
                                    log::warn!("ignoring /joint_effort_cmd: {e} (rejected so far: {})", s.rejected);
                                }
                            }
                        }
                        drop(s);
                        shared.cv.notify_all();
                    }
                }
            })
            .map_err(|e| RosError::Node(format!("cannot start receive thread: {e}")))?;
    }

    let mut gen = 0;
    let (mut rate, mut lockstep, mut timeout_ns, mut damping, mut use_sim_time) = (1000.0, false, 20_000_000i64, 5.0, false);
    let mut paused = false;
    let mut effort_limit = urdf_effort;
    let (mut saturated_cycles, mut last_sat_warn) = (0u64, 0i64);
    let mut js = JointState {
        header: Header { stamp: Default::default(), frame_id: String::new() },
        name: msgs::JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        position: vec![0.0; 6],
        velocity: vec![0.0; 6],
        effort: vec![0.0; 6],
    };
    let mut cycles: u64 = 0;
    let mut missed: u64 = 0;
    let mut holding = false;
    let mut last_published_stamp: Option<i64> = None;
    let mut chain_started = false;
    let mut next = monotonic_ns();

    // Take accepted parameter values (at the top of a cycle, and again just before the
    // step, so a limit accepted while waiting applies to that step).
    macro_rules! reload_params {
        () => {
            if node.params.generation() != gen {
                gen = node.params.generation();
                node.params.with(|p| {
                    rate = p.f64("rate");
                    lockstep = p.bool("lockstep");
                    paused = p.bool("paused");
                    timeout_ns = (p.f64("command_timeout") * 1e9) as i64;
                    damping = p.f64("hold_damping");
                    use_sim_time = p.bool("use_sim_time");
                    effort_limit = std::array::from_fn(|i| p.f64s("effort_limit")[i]);
                });
                shared.slot.lock().unwrap_or_else(|p| p.into_inner()).sim_stamps = lockstep || use_sim_time;
            }
        };
    }

    while !naic_ros::shutdown_requested() {
        reload_params!();
        let dt = 1.0 / rate;
        let period_ns = (1e9 / rate) as i64;

        if paused {
            // Time stands still; the same state goes out again so late subscribers get it.
            std::thread::sleep(Duration::from_nanos(timeout_ns as u64));
            expect(&shared, lockstep.then(|| sim_stamp_ns(&plant)));
            let st = publish_state(&plant, &mut js, &js_pub, &w_pub, &clock_pub, lockstep || use_sim_time)?;
            last_published_stamp = Some(st);
            next = monotonic_ns();
            continue;
        }
        // Wait for the next step: a deadline (real time) or the command for the state just
        // published (lockstep).
        if lockstep {
            let stamp = match last_published_stamp {
                Some(st) if shared.slot.lock().unwrap_or_else(|p| p.into_inner()).expect_stamp_ns == Some(st) => st,
                // First cycle, or just switched to lockstep: publish the state to answer.
                _ => {
                    expect(&shared, Some(sim_stamp_ns(&plant)));
                    let st = publish_state(&plant, &mut js, &js_pub, &w_pub, &clock_pub, true)?;
                    last_published_stamp = Some(st);
                    st
                }
            };
            let s = shared.slot.lock().unwrap_or_else(|p| p.into_inner());
            let (mut s, _) = shared
                .cv
                .wait_timeout_while(s, Duration::from_nanos(timeout_ns as u64), |s| !s.ready)
                .unwrap_or_else(|p| p.into_inner());
            if !s.ready {
                // No command for this state: simulated time stands still; publish the same
                // state again so a late or restarted controller gets it.
                drop(s);
                let again = publish_state(&plant, &mut js, &js_pub, &w_pub, &clock_pub, true)?;
                debug_assert_eq!(again, stamp);
                continue;
            }
            s.ready = false;
        } else {
            next += period_ns;
            let now = monotonic_ns();
            if now > next + 10 * period_ns {
                next = now; // fell far behind (suspended?): resynchronise
            }
            sleep_until(next);
        }

        reload_params!();
        // Take the newest command, or hold if it is stale.
        let (tau, fresh, valid, seq, src, recording) = {
            let s = shared.slot.lock().unwrap_or_else(|p| p.into_inner());
            let now = wall_ns();
            // Lockstep: the wait above returned with the command for this state (unless a
            // rejected one came after it: then hold).
            let fresh = s.valid && s.seq > 0 && (lockstep || now - s.arrival_ns <= timeout_ns);
            (s.tau, fresh, s.valid, s.seq, s.source_stamp_ns, now >= s.record_after_ns)
        };
        if !lockstep && chain_started && recording {
            // A cycle is missed when the command for the previous state did not arrive in time.
            if let (Some(p), true) = (last_published_stamp, src.is_some()) {
                if src != Some(p) {
                    missed += 1;
                }
            }
        }
        if src.is_some() {
            chain_started = true;
        }
        let tau = if fresh {
            if holding {
                log::info!("commands resumed; releasing the hold");
                holding = false;
            }
            tau
        } else {
            if !holding && seq > 0 {
                if valid {
                    log::warn!("no /joint_effort_cmd for {} ms: holding the arm", timeout_ns / 1_000_000);
                } else {
                    log::warn!("last /joint_effort_cmd rejected: holding the arm");
                }
            }
            holding = seq > 0 || holding;
            Plant::hold_torque(&mut plant, damping)
        };
        // Whatever is applied, command or hold, stays within the effort limits.
        let (tau, clipped) = actuate::saturate(&effort_limit, &tau);
        if clipped.iter().any(|&c| c) {
            saturated_cycles += 1;
            let now = wall_ns();
            if now - last_sat_warn > 1_000_000_000 {
                last_sat_warn = now;
                log::warn!("torque saturated at effort_limit {effort_limit:?} N m (joints {clipped:?}; {saturated_cycles} cycles so far)");
            }
        }
        Plant::step(&mut plant, &tau, dt);
        cycles += 1;
        // Lockstep: announce the state before publishing it, so its command is never early.
        expect(&shared, lockstep.then(|| sim_stamp_ns(&plant)));
        let stamp = publish_state(&plant, &mut js, &js_pub, &w_pub, &clock_pub, lockstep || use_sim_time)?;
        last_published_stamp = Some(stamp);
    }

    // Report the chain latency.
    let s = shared.slot.lock().unwrap_or_else(|p| p.into_inner());
    let recorded_ns = (wall_ns() - s.record_after_ns).max(0);
    if s.stale_dropped > 0 {
        log::info!("lockstep: {} commands computed from an earlier state were dropped", s.stale_dropped);
    }
    let mut report = latency_report(&s.latency, missed, cycles, recorded_ns, s.rejected);
    report["saturated_cycles"] = saturated_cycles.into();
    let path = node.params.with(|p| p.str("latency_report").to_string());
    if !path.is_empty() {
        if let Err(e) = std::fs::write(&path, report.to_string()) {
            log::error!("cannot write latency report {path}: {e}");
        }
    }
    log::info!("stopped after {cycles} cycles; chain latency {report}");
    Ok(())
}

/// Lockstep: from now on only commands computed from `stamp` advance the simulation
/// (`None`: real time, every valid command is taken).
fn expect(shared: &Shared, stamp: Option<i64>) {
    let mut s = shared.slot.lock().unwrap_or_else(|p| p.into_inner());
    if s.expect_stamp_ns != stamp {
        s.expect_stamp_ns = stamp;
        s.ready = false;
    }
}

/// The simulated-time stamp of the plant's current state [ns].
fn sim_stamp_ns(plant: &impl Plant) -> i64 {
    (plant.time() * 1e9).round() as i64
}

/// Publish joint states, wrench and clock; returns the stamp used [ns].
fn publish_state(
    plant: &impl Plant,
    js: &mut JointState,
    js_pub: &naic_ros::node::Pub<JointState>,
    w_pub: &naic_ros::node::Pub<WrenchStamped>,
    clock_pub: &naic_ros::node::Pub<Clock>,
    sim_stamps: bool,
) -> Result<i64, RosError> {
    let sim_ns = sim_stamp_ns(plant);
    let stamp_ns = if sim_stamps { sim_ns } else { wall_ns() };
    let stamp = time_from_ns(stamp_ns);
    let (q, v, t) = plant.joints();
    js.header.stamp = stamp.clone();
    js.position.copy_from_slice(&q);
    js.velocity.copy_from_slice(&v);
    js.effort.copy_from_slice(&t);
    let w = plant.wrench();
    let ws = WrenchStamped {
        header: Header { stamp, frame_id: "ft_sensor".into() },
        wrench: Wrench {
            force: Vector3 { x: w[0], y: w[1], z: w[2] },
            torque: Vector3 { x: w[3], y: w[4], z: w[5] },
        },
    };
    // Wrench first: the controller cycles on /joint_states and uses the newest wrench.
    let _ = w_pub.publish(ws);
    let _ = js_pub.publish(js.clone());
    let _ = clock_pub.publish(Clock { clock: time_from_ns(sim_ns) });
    Ok(stamp_ns)
}

fn latency_report(lat: &latency::Histogram, missed: u64, cycles: u64, wall_ns: i64, rejected: u64) -> serde_json::Value {
    let q = |f: f64| -> f64 { lat.quantile_ns(f).map_or(f64::NAN, |ns| ns / 1e3) };
    let minutes = wall_ns as f64 / 60e9;
    serde_json::json!({
        "samples": lat.len(),
        "cycles": cycles,
        "median_us": q(0.5),
        "p99_us": q(0.99),
        "max_us": lat.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
        "missed_cycles": missed,
        "missed_per_min": if minutes > 0.0 { missed as f64 / minutes } else { 0.0 },
        "rejected_commands": rejected,
        "duration_s": wall_ns as f64 / 1e9,
    })
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
