//! What every shell of the driver needs besides the core: the start-up checks (robot
//! model, effort limits, the whole plant), the state messages filled in place from the
//! plant, the core's events logged, and the period clock. Used by the DDS shell
//! (`main.rs`) and by `naic launch --composed`.

use naic_ros::{
    msgs::{self, Header, JointState, WrenchStamped},
    time::{time_from_ns, wall_ns},
    ParamSpec, ParamTable, ParamView, RosArgs, RosError,
};

use crate::{
    config,
    core::{self, Hold},
    plant::Plant,
    sim_plant::{make_plant, SimPlant},
};

pub const NODE: &str = "jk5_sim_driver";

/// What the node is built from, read before any DDS participant exists.
pub struct Setup {
    /// The URDF's `<limit effort>`: the highest `effort_limit` a parameter may set.
    pub urdf_effort: [f64; 6],
    pub plant: SimPlant,
}

impl Setup {
    /// Files first: the robot model (effort limits), then the whole plant (model,
    /// scenario, friction file) from the start-up parameters.
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
        let urdf_effort = config::urdf_effort_limits(&urdf).map_err(RosError::Param)?;
        let plant = ParamTable::new(config::specs(&urdf_effort), Some(config::check(urdf_effort)), &args.overrides(NODE)?)
            .map_err(RosError::Param)?
            .with(make_plant)
            .map_err(RosError::Param)?;
        Ok(Setup { urdf_effort, plant })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        config::specs(&self.urdf_effort)
    }

    pub fn check(&self) -> naic_ros::params::SetCheck {
        config::check(self.urdf_effort)
    }
}

/// `/joint_states` and `/wrench`, preallocated and rewritten in place each cycle.
pub struct StateMsgs {
    pub js: JointState,
    pub w: WrenchStamped,
}

impl Default for StateMsgs {
    fn default() -> Self {
        StateMsgs {
            js: JointState { name: msgs::JOINT_NAMES.iter().map(|s| s.to_string()).collect(), position: vec![0.0; 6], velocity: vec![0.0; 6], effort: vec![0.0; 6], ..Default::default() },
            w: WrenchStamped { header: Header { frame_id: "ft_sensor".into(), ..Default::default() }, ..Default::default() },
        }
    }
}

impl StateMsgs {
    /// The plant's state into the messages; returns the stamp used [ns] (simulated time
    /// if `sim_stamps`, else the wall clock).
    pub fn fill(&mut self, plant: &impl Plant, sim_stamps: bool) -> i64 {
        let stamp_ns = if sim_stamps { sim_stamp_ns(plant) } else { wall_ns() };
        let (q, v, t) = plant.joints();
        self.js.header.stamp = time_from_ns(stamp_ns);
        self.js.position.copy_from_slice(&q);
        self.js.velocity.copy_from_slice(&v);
        self.js.effort.copy_from_slice(&t);
        let w = plant.wrench();
        self.w.header.stamp = time_from_ns(stamp_ns);
        (self.w.wrench.force.x, self.w.wrench.force.y, self.w.wrench.force.z) = (w[0], w[1], w[2]);
        (self.w.wrench.torque.x, self.w.wrench.torque.y, self.w.wrench.torque.z) = (w[3], w[4], w[5]);
        stamp_ns
    }
}

/// Stamps are simulated time.
pub fn sim_stamps(p: &ParamView) -> bool {
    p.bool("lockstep") || p.bool("use_sim_time")
}

/// The simulated-time stamp of the plant's current state [ns].
pub fn sim_stamp_ns(plant: &impl Plant) -> i64 {
    (plant.time() * 1e9).round() as i64
}

/// Log what one step reports.
pub fn log_events(o: &core::Outbox, p: &core::Params, s: &core::State) {
    match o.events.hold {
        Some(Hold::Timeout) => log::warn!("no /joint_effort_cmd for {} ms: holding the arm", p.command_timeout_ns / 1_000_000),
        Some(Hold::Rejected) => log::warn!("last /joint_effort_cmd rejected: holding the arm"),
        None if o.events.released => log::info!("commands resumed; releasing the hold"),
        None => {}
    }
    if let Some(c) = o.events.saturated {
        log::warn!("torque saturated at effort_limit {:?} N m (joints {c:?}; {} cycles so far)", p.effort_limit, s.saturated_cycles);
    }
}

/// The latency report at exit (JSON to `latency_report`, if set) and the last log line.
pub fn write_report(c: &core::Commands, s: &core::State, path: &str, extra: serde_json::Value) {
    let recorded_ns = (wall_ns() - c.record_after_ns).max(0);
    if c.stale_dropped > 0 {
        log::info!("lockstep: {} commands computed from an earlier state were dropped", c.stale_dropped);
    }
    let mut report = config::latency_report(&c.latency, s.missed, s.cycles, recorded_ns, c.rejected);
    report["saturated_cycles"] = s.saturated_cycles.into();
    if let (Some(r), serde_json::Value::Object(x)) = (report.as_object_mut(), extra) {
        r.extend(x);
    }
    if !path.is_empty() {
        if let Err(e) = std::fs::write(path, report.to_string()) {
            log::error!("cannot write latency report {path}: {e}");
        }
    }
    log::info!("stopped after {} cycles; chain latency {report}", s.cycles);
}

pub fn monotonic_ns() -> i64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: valid pointer to a timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as i64 * 1_000_000_000 + ts.tv_nsec as i64
}

pub fn sleep_until(deadline_ns: i64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    // SAFETY: absolute sleep on CLOCK_MONOTONIC with a valid timespec; EINTR just returns early.
    unsafe {
        libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut());
    }
}
