//! The driver's loop body, whatever carries the messages: the DDS shell (`main.rs`) and
//! `naic launch --composed` call it and publish the state messages it leaves in
//! [`Runner::msgs`].
//!
//! [`Runner`] owns the plant, the core's parameters and state, the state messages (filled
//! in place) and the period clock. Per cycle the shell calls [`Runner::reload`] (accepted
//! parameter values), waits ([`Runner::pace`] in real time, [`SharedCommands::wait_ready`]
//! or [`core::Commands::take_ready`] in lockstep, [`Runner::pause`] while paused), calls
//! [`Runner::step`] and [`Runner::announce`] and publishes. Commands go through
//! [`receive`] (or [`SharedCommands::receive`] from a receive thread). The core's events
//! are logged here.

use naic_core::N_JOINTS;
use std::{
    sync::{Condvar, Mutex, MutexGuard},
    time::Duration,
};

use naic_ros::{
    alloc_check,
    msgs::{self, Clock, Float64MultiArray, Header, JointState, WrenchStamped},
    time::{time_from_ns, wall_ns},
    ParamTable, ParamView,
};

use crate::{
    config,
    core::{self, Commands, Hold},
    latency::Histogram,
    plant::Plant,
    setup::NODE,
};

/// A failing sensor, played by the driver (`sensor_fault`): what the controller's sense
/// stage must catch (`naic_core::pipeline::sense`) whichever way the messages travel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SensorFault {
    #[default]
    None,
    /// `/wrench` force z is NaN.
    NanWrench,
    /// `/wrench` force z is 5 kN, beyond any plausible reading of the ATI mini45.
    AbsurdWrench,
    /// `/wrench` keeps its last value and stamp (a sensor that stopped updating).
    StaleWrench,
    /// `/joint_states` position of joint 2 is NaN.
    NanJoint,
}

impl SensorFault {
    pub const NAMES: &'static [&'static str] = &["none", "nan_wrench", "absurd_wrench", "stale_wrench", "nan_joint"];

    /// The value of the `sensor_fault` parameter (checked against [`SensorFault::NAMES`]
    /// when it was set).
    pub fn from_param(v: &str) -> SensorFault {
        match v {
            "nan_wrench" => SensorFault::NanWrench,
            "absurd_wrench" => SensorFault::AbsurdWrench,
            "stale_wrench" => SensorFault::StaleWrench,
            "nan_joint" => SensorFault::NanJoint,
            _ => SensorFault::None,
        }
    }
}

/// `/joint_states`, `/wrench` and `/clock`, preallocated and rewritten in place each cycle.
pub struct StateMsgs<const N: usize = N_JOINTS> {
    pub js: JointState,
    pub w: WrenchStamped,
    pub clock: Clock,
    /// `js`'s slot `i` carries joint `order[i]` of the arm ([`config::joint_order`]).
    order: [usize; N],
}

impl Default for StateMsgs {
    fn default() -> Self {
        StateMsgs::in_order([0, 1, 2, 3, 4, 5], &msgs::JOINT_NAMES.map(String::from))
    }
}

impl<const N: usize> StateMsgs<N> {
    /// The messages with the arm's joints `joints` in `/joint_states` in `order` (slot `i`:
    /// joint `joints[order[i]]`).
    pub fn in_order(order: [usize; N], joints: &[String; N]) -> Self {
        StateMsgs {
            js: JointState { name: order.iter().map(|&j| joints[j].clone()).collect(), position: vec![0.0; N], velocity: vec![0.0; N], effort: vec![0.0; N], ..Default::default() },
            w: WrenchStamped { header: Header { frame_id: "ft_sensor".into(), ..Default::default() }, ..Default::default() },
            clock: Clock::default(),
            order,
        }
    }

    /// The plant's state into the messages, as a sensor with `fault` would report it;
    /// returns the stamp used [ns] (simulated time if `sim_stamps`, else the wall clock).
    /// `/clock` is always simulated time.
    pub fn fill(&mut self, plant: &impl Plant<N>, sim_stamps: bool, fault: SensorFault) -> i64 {
        let stamp_ns = if sim_stamps { sim_stamp_ns(plant) } else { wall_ns() };
        let (q, v, t) = plant.joints();
        self.js.header.stamp = time_from_ns(stamp_ns);
        for (i, &j) in self.order.iter().enumerate() {
            (self.js.position[i], self.js.velocity[i], self.js.effort[i]) = (q[j], v[j], t[j]);
            if fault == SensorFault::NanJoint && j == 1 {
                self.js.position[i] = f64::NAN;
            }
        }
        if fault != SensorFault::StaleWrench {
            let w = plant.wrench();
            self.w.header.stamp = time_from_ns(stamp_ns);
            (self.w.wrench.force.x, self.w.wrench.force.y, self.w.wrench.force.z) = (w[0], w[1], w[2]);
            (self.w.wrench.torque.x, self.w.wrench.torque.y, self.w.wrench.torque.z) = (w[3], w[4], w[5]);
            match fault {
                SensorFault::NanWrench => self.w.wrench.force.z = f64::NAN,
                SensorFault::AbsurdWrench => self.w.wrench.force.z = 5000.0,
                _ => {}
            }
        }
        self.clock.clock = time_from_ns(sim_stamp_ns(plant));
        stamp_ns
    }
}

/// Stamps are simulated time.
pub fn sim_stamps(p: &ParamView) -> bool {
    p.bool("lockstep") || p.bool("use_sim_time")
}

/// The simulated-time stamp of the plant's current state [ns].
pub fn sim_stamp_ns<const N: usize>(plant: &impl Plant<N>) -> i64 {
    (plant.time() * 1e9).round() as i64
}

/// The driver between two cycles (an arm of `N` joints).
pub struct Runner<P: Plant<N>, const N: usize = N_JOINTS> {
    pub plant: P,
    pub p: core::Params<N>,
    /// The `paused` parameter: simulated time stands still.
    pub paused: bool,
    /// Stamps are simulated time ([`sim_stamps`]).
    pub sim: bool,
    /// The `sensor_fault` parameter.
    pub fault: SensorFault,
    pub s: core::State,
    /// The state messages, as of the last [`Runner::announce`].
    pub msgs: StateMsgs<N>,
    /// Generation of the parameter table last applied.
    gen: u64,
    /// The current period's deadline [ns, CLOCK_MONOTONIC] (real time).
    next_ns: i64,
    warned: bool,
}

impl<P: Plant<N>, const N: usize> Runner<P, N> {
    /// `params` is the node's parameter table as it starts; `joints`: the arm's joint names
    /// (the `/joint_states` names, in the plant's and the commands' order).
    pub fn new(plant: P, params: &ParamTable, joints: &[String; N]) -> Runner<P, N> {
        let (p, paused, sim, fault) = params.with(read);
        // Checked when the table was built (config::check); read-only.
        let order = params.with(|v| config::joint_order(v, joints)).unwrap_or(std::array::from_fn(|i| i));
        Runner { plant, p, paused, sim, fault, s: core::State::default(), msgs: StateMsgs::in_order(order, joints), gen: params.generation(), next_ns: monotonic_ns(), warned: false }
    }

    /// The command slot, latency statistics from the end of `latency_warmup` on.
    pub fn commands(&self, params: &ParamTable) -> Commands<N> {
        Commands::new(wall_ns() + params.with(|v| (v.f64("latency_warmup") * 1e9) as i64), self.sim)
    }

    /// Take the node's parameters when a set was accepted since the last call (at the top
    /// of a cycle, and again just before the step, so a limit accepted while waiting
    /// applies to that step).
    pub fn reload(&mut self, params: &ParamTable, cmds: &mut Commands<N>) {
        if params.generation() != self.gen {
            self.gen = params.generation();
            let fault;
            (self.p, self.paused, self.sim, fault) = params.with(read);
            if fault != self.fault {
                log::warn!("sensor_fault: {fault:?} (test hook: the published measurements are corrupted as a failing sensor would)");
                self.fault = fault;
            }
            cmds.sim_stamps = self.sim;
        }
    }

    /// Lockstep: the state to answer has not been announced yet (the first cycle, or just
    /// switched to lockstep).
    pub fn needs_announce(&self, cmds: &Commands<N>) -> bool {
        self.s.last_published_stamp.is_none() || cmds.expect_stamp_ns != self.s.last_published_stamp
    }

    /// The plant's state into [`Runner::msgs`], announced to `cmds` (lockstep: only a
    /// command for it may advance the simulation) before the shell publishes it, so its
    /// command is never early. Returns the stamp [ns].
    pub fn announce(&mut self, cmds: &mut Commands<N>) -> i64 {
        let stamp = self.msgs.fill(&self.plant, self.sim, self.fault);
        cmds.expect(self.p.lockstep.then(|| sim_stamp_ns(&self.plant)));
        self.s.last_published_stamp = Some(stamp);
        stamp
    }

    /// One simulator step with the newest command (or the hold), its events logged.
    pub fn step(&mut self, cmd: &core::Command<N>) {
        let (p, s, plant) = (&self.p, &self.s, &mut self.plant);
        let (n, o) = alloc_check::check(NODE, &mut self.warned, || core::step(p, s, cmd, wall_ns(), plant));
        self.s = n;
        log_events(&o, &self.p, &self.s);
    }

    /// Paused: wait one `command_timeout` (the shell then publishes the same state again,
    /// so late subscribers get it); the period clock restarts afterwards.
    pub fn pause(&mut self) {
        std::thread::sleep(self.command_timeout());
        self.next_ns = monotonic_ns();
    }

    pub fn command_timeout(&self) -> Duration {
        Duration::from_nanos(self.p.command_timeout_ns.max(0) as u64)
    }

    pub fn period_ns(&self) -> i64 {
        (1e9 / self.p.rate) as i64
    }

    /// The wall time one step takes at least when paced [ns]: the period, divided by
    /// `real_time_factor` in lockstep.
    pub fn wall_period_ns(&self) -> i64 {
        if self.paced_lockstep() {
            (self.period_ns() as f64 / self.p.real_time_factor).round().max(1.0) as i64
        } else {
            self.period_ns()
        }
    }

    /// The current period's deadline [ns, CLOCK_MONOTONIC].
    pub fn deadline_ns(&self) -> i64 {
        self.next_ns
    }

    /// Lockstep with a `real_time_factor`: the chain would run faster than it allows.
    pub fn paced_lockstep(&self) -> bool {
        self.p.lockstep && self.p.real_time_factor > 0.0
    }

    /// Real time: sleep until the next period's deadline (absolute, so the rate does not
    /// drift); returns it [ns, CLOCK_MONOTONIC]. In lockstep with a `real_time_factor` the
    /// period is the simulated one divided by it.
    pub fn pace(&mut self) -> i64 {
        let period_ns = self.wall_period_ns();
        self.next_ns += period_ns;
        let now = monotonic_ns();
        if now > self.next_ns + 10 * period_ns {
            self.next_ns = now; // fell far behind (suspended?): resynchronise
        }
        sleep_until(self.next_ns);
        self.next_ns
    }

    /// At exit: the latency report (JSON to `latency_report`, if set, with `extra`'s
    /// fields) and the last log line.
    pub fn finish(&self, cmds: &Commands<N>, params: &ParamTable, extra: serde_json::Value) {
        let path = params.with(|p| p.str("latency_report").to_string());
        write_report(cmds, &self.s, &path, extra);
    }
}

fn read<const N: usize>(v: &ParamView) -> (core::Params<N>, bool, bool, SensorFault) {
    (config::core_params(v), v.bool("paused"), sim_stamps(v), SensorFault::from_param(v.str("sensor_fault")))
}

/// Take one `/joint_effort_cmd` (the core's [`core::receive`]), logging a refusal.
pub fn receive<const N: usize>(cmds: &mut Commands<N>, m: &Float64MultiArray) {
    if let Some(e) = core::receive(cmds, m, wall_ns()) {
        log::warn!("ignoring /joint_effort_cmd: {e} (rejected so far: {})", cmds.rejected);
    }
}

/// The command slot shared between a receive thread and the main loop; a command wakes
/// the lockstep wait.
pub struct SharedCommands<const N: usize = N_JOINTS> {
    slot: Mutex<Commands<N>>,
    cv: Condvar,
}

impl<const N: usize> SharedCommands<N> {
    pub fn new(c: Commands<N>) -> SharedCommands<N> {
        SharedCommands { slot: Mutex::new(c), cv: Condvar::new() }
    }

    pub fn lock(&self) -> MutexGuard<'_, Commands<N>> {
        self.slot.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// [`receive`], then wake the main loop.
    pub fn receive(&self, m: &Float64MultiArray) {
        receive(&mut self.lock(), m);
        self.cv.notify_all();
    }

    /// Lockstep: wait up to `timeout` for the command of the announced state; takes it.
    pub fn wait_ready(&self, timeout: Duration) -> bool {
        let (mut c, _) = self.cv.wait_timeout_while(self.lock(), timeout, |c| !c.ready).unwrap_or_else(|e| e.into_inner());
        c.take_ready()
    }
}

/// Real time, the three-process shell: when the driver woke after each deadline, and
/// whether each missed cycle came with a late wake-up of the driver itself.
///
/// The driver's loop thread is a cyclictest thread inside the chain: a wake-up more than half
/// a period late means the CPU was not available to its priority then (the kernel or the
/// hypervisor ran something else, or the loop is catching up overdue periods back to back
/// after such a stall, as [`Runner::pace`] does). A missed cycle whose own wake-up or the
/// previous one was that late is counted in `missed_driver_late`; one where the driver woke on
/// time both times in `missed_driver_on_time` (the chain took longer than the period while
/// the driver's thread ran when due). Episodes are runs of consecutive missed cycles: one
/// stall of n ms costs about n missed cycles. Allocation-free after construction.
pub struct WakeStats {
    /// Wake-up lateness after each deadline [ns].
    pub wake: Histogram,
    late: bool,
    late_before: bool,
    pub missed_driver_late: u64,
    pub missed_driver_on_time: u64,
    pub episodes: u64,
    pub longest_episode: u64,
    run: u64,
}

impl Default for WakeStats {
    fn default() -> Self {
        WakeStats { wake: Histogram::default(), late: false, late_before: false, missed_driver_late: 0, missed_driver_on_time: 0, episodes: 0, longest_episode: 0, run: 0 }
    }
}

impl WakeStats {
    /// The loop woke at `now_ns` for the deadline `deadline_ns` [ns, CLOCK_MONOTONIC] of a
    /// period of `period_ns`; `timed`: after the warm-up (recorded).
    pub fn woke(&mut self, deadline_ns: i64, now_ns: i64, period_ns: i64, timed: bool) {
        self.late_before = self.late;
        self.late = now_ns - deadline_ns > period_ns / 2;
        if timed {
            self.wake.record(now_ns - deadline_ns);
        }
    }

    /// After the step: `missed` whether it counted a missed cycle (the core's count grew).
    pub fn stepped(&mut self, missed: bool) {
        if missed {
            if self.late || self.late_before {
                self.missed_driver_late += 1;
            } else {
                self.missed_driver_on_time += 1;
            }
            if self.run == 0 {
                self.episodes += 1;
            }
            self.run += 1;
            self.longest_episode = self.longest_episode.max(self.run);
        } else {
            self.run = 0;
        }
    }

    /// The report's fields.
    pub fn report(&self) -> serde_json::Value {
        let q = |f: f64| self.wake.quantile_ns(f).map_or(f64::NAN, |ns| ns / 1e3);
        serde_json::json!({
            "wake_late_median_us": q(0.5),
            "wake_late_p99_us": q(0.99),
            "wake_late_p9999_us": q(0.9999),
            "wake_late_max_us": self.wake.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
            "wakes_late_over_500us": self.wake.count_over(500_000),
            "wakes_late_over_1ms": self.wake.count_over(1_000_000),
            "missed_driver_late": self.missed_driver_late,
            "missed_driver_on_time": self.missed_driver_on_time,
            "miss_episodes": self.episodes,
            "longest_miss_episode": self.longest_episode,
        })
    }
}

/// Diagnostics: with `NAIC_TRACE_MARKER=FILE` (a kernel trace's `trace_marker`, e.g.
/// `/sys/kernel/tracing/trace_marker`), each missed cycle writes `naic missed N` there, so a
/// scheduler trace shows what ran around it (docs/notes/2026-12-benchmark-history.md, "Where the
/// three-process misses come from"). Unset: nothing (one branch per missed cycle).
pub struct MissMarker(Option<std::fs::File>);

impl MissMarker {
    pub fn from_env() -> MissMarker {
        MissMarker(std::env::var_os("NAIC_TRACE_MARKER").and_then(|p| std::fs::OpenOptions::new().write(true).open(p).ok()))
    }

    /// Missed cycle number `n` (writes only when the marker file is open).
    pub fn miss(&self, n: u64) {
        if let Some(mut f) = self.0.as_ref() {
            use std::io::Write;
            let mut buf = [0u8; 40];
            let mut w = &mut buf[..];
            let _ = write!(w, "naic missed {n}");
            let len = 40 - w.len();
            let _ = f.write_all(&buf[..len]);
        }
    }
}

/// Log what one step reports.
pub fn log_events<const N: usize>(o: &core::Outbox<N>, p: &core::Params<N>, s: &core::State) {
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

/// The latency report (JSON to `path`, if not empty, with `extra`'s fields) and the last
/// log line.
pub fn write_report<const N: usize>(c: &Commands<N>, s: &core::State, path: &str, extra: serde_json::Value) {
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

#[cfg(test)]
mod tests {
    use naic_ros::{msgs::effort_msg, ParameterValue, RosArgs};

    use super::*;
    use crate::{setup::Setup, sim_plant::SimPlant};

    /// The runner on the repository's JK5 files, with `-p` overrides `extra`, and the node's
    /// parameter table as `RosNode` would build it.
    fn runner(extra: &[&str]) -> (Runner<SimPlant>, ParamTable) {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let files = [format!("urdf:={root}/urdf/jk5.urdf"), format!("friction_file:={root}/params/friction_jk5.yaml")];
        let args = RosArgs::with_params(files.into_iter().chain(extra.iter().map(|e| e.to_string()))).unwrap();
        let setup = Setup::from_args(&args).unwrap();
        let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
        (Runner::new(setup.plant, &table, &setup.joints), table)
    }

    #[test]
    fn wake_stats_tell_a_late_driver_from_a_late_chain() {
        const MS: i64 = 1_000_000;
        let mut w = WakeStats::default();
        // (deadline, woke) in ms, missed: on time and answered; on time but the chain was
        // late; a 3 ms stall, the two overdue periods caught up back to back, and the first
        // cycle after them (its state went out late); on time again.
        let cycles = [(1, 1, false), (2, 2, true), (3, 6, true), (4, 6, true), (5, 6, true), (6, 6, true), (7, 7, false)];
        for (deadline, woke, missed) in cycles {
            w.woke(deadline * MS, woke * MS + 20_000, MS, true);
            w.stepped(missed);
        }
        assert_eq!((w.missed_driver_on_time, w.missed_driver_late), (1, 4));
        assert_eq!((w.episodes, w.longest_episode), (1, 5));
        assert_eq!(w.wake.count_over(MS as u64), 3, "woke 3.02, 2.02 and 1.02 ms late");
        let r = w.report();
        assert!((r["wake_late_max_us"].as_f64().unwrap() - 3020.0).abs() < 30.0, "{r}");
    }

    #[test]
    fn real_time_factor_paces_lockstep_only() {
        // Lockstep at 1 kHz, no factor: not paced (as fast as the chain allows).
        let (d, _) = runner(&["lockstep:=true"]);
        assert!(!d.paced_lockstep());
        // Factor 2: each step takes at least 0.5 ms of wall time; 0.5: 2 ms.
        let (d, _) = runner(&["lockstep:=true", "real_time_factor:=2.0"]);
        assert!(d.paced_lockstep());
        assert_eq!(d.wall_period_ns(), 500_000);
        let (d, _) = runner(&["lockstep:=true", "real_time_factor:=0.5"]);
        assert_eq!(d.wall_period_ns(), 2_000_000);
        // Real time ignores it: one period per step.
        let (d, _) = runner(&["real_time_factor:=2.0"]);
        assert!(!d.paced_lockstep());
        assert_eq!(d.wall_period_ns(), 1_000_000);
    }

    #[test]
    fn lockstep_steps_once_per_command_for_the_state_just_announced() {
        let (mut d, table) = runner(&["lockstep:=true"]);
        let mut cmds = d.commands(&table);
        assert!(d.needs_announce(&cmds), "nothing announced yet");
        assert_eq!(d.announce(&mut cmds), 0);
        assert!(!d.needs_announce(&cmds));
        assert_eq!((d.msgs.js.header.stamp.to_nanos(), d.msgs.w.header.stamp.to_nanos(), d.msgs.clock.clock.to_nanos()), (0, 0, 0));
        // A command for another state is dropped; the one for stamp 0 is taken, once.
        receive(&mut cmds, &effort_msg(&[0.0; 6], Some(7)));
        assert!(!cmds.take_ready());
        receive(&mut cmds, &effort_msg(&[0.0; 6], Some(0)));
        assert!(cmds.take_ready());
        assert!(!cmds.take_ready(), "taken");
        d.step(&cmds.view());
        assert_eq!(d.announce(&mut cmds), 1_000_000, "one 1 ms step, simulated stamps");
        assert_eq!((d.s.cycles, d.s.holding, cmds.stale_dropped), (1, false, 1));
        assert_eq!(cmds.expect_stamp_ns, Some(1_000_000));
    }

    #[test]
    fn joint_order_publishes_the_joints_by_name_in_that_order() {
        let (mut a, ta) = runner(&[]);
        let (mut b, tb) = runner(&["joint_order:=[joint3, joint6, joint1, joint5, joint2, joint4]"]);
        let tau = [1.5, -2.0, 2.5, 0.5, -0.25, 0.125];
        for (d, t) in [(&mut a, &ta), (&mut b, &tb)] {
            let mut cmds = d.commands(t);
            receive(&mut cmds, &effort_msg(&tau, None));
            for _ in 0..20 {
                d.step(&cmds.view());
            }
            d.announce(&mut cmds);
        }
        let js = &b.msgs.js;
        assert_eq!(js.name, ["joint3", "joint6", "joint1", "joint5", "joint2", "joint4"]);
        for (i, n) in js.name.iter().enumerate() {
            let j = msgs::JOINT_NAMES.iter().position(|x| x == n).unwrap();
            // The same plant state, slot by name; the applied torque is the command's joint j.
            assert_eq!((js.position[i], js.velocity[i], js.effort[i]), (a.msgs.js.position[j], a.msgs.js.velocity[j], a.msgs.js.effort[j]), "{n}");
            assert_eq!(js.effort[i], tau[j], "{n}");
        }
        assert!(a.msgs.js.velocity.iter().any(|v| v.abs() > 1e-4), "the arm did not move");
    }

    #[test]
    fn a_joint_order_that_is_not_each_joint_once_is_refused() {
        let setup = |v: &str| {
            let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
            let args = RosArgs::with_params([format!("urdf:={root}/urdf/jk5.urdf"), format!("friction_file:={root}/params/friction_jk5.yaml"), format!("joint_order:={v}")]).unwrap();
            Setup::from_args(&args).err().map(|e| e.to_string()).unwrap_or_default()
        };
        let e = setup("[joint1, joint2, joint3, joint4, joint5, wrist]");
        assert!(e.contains("joint_order[5] = 'wrist'") && e.contains("joint1, joint2"), "{e}");
        let e = setup("[joint1, joint2, joint3, joint4, joint5, joint1]");
        assert!(e.contains("names 'joint1' twice (elements 0 and 5)"), "{e}");
        let e = setup("[joint1, joint2]");
        assert!(e.contains("joint_order") && e.contains("6 elements"), "{e}");
    }

    #[test]
    fn sensor_fault_corrupts_what_is_published_until_it_is_cleared() {
        let (mut d, table) = runner(&["lockstep:=true"]);
        let mut cmds = d.commands(&table);
        let set = |v: &str| table.set_atomically(&[("sensor_fault".to_string(), ParameterValue::String(v.into()))]).unwrap();
        let step = |d: &mut Runner<SimPlant>, cmds: &mut Commands| {
            d.reload(&table, cmds);
            let stamp = d.announce(cmds);
            receive(cmds, &effort_msg(&[0.0; 6], Some(stamp)));
            assert!(cmds.take_ready());
            d.step(&cmds.view());
            stamp
        };
        step(&mut d, &mut cmds);
        let fz = |d: &Runner<SimPlant>| d.msgs.w.wrench.force.z;
        assert!(fz(&d).is_finite() && d.msgs.js.position.iter().all(|q| q.is_finite()));
        set("nan_wrench");
        step(&mut d, &mut cmds);
        assert!(fz(&d).is_nan() && d.msgs.w.wrench.force.x.is_finite());
        set("absurd_wrench");
        step(&mut d, &mut cmds);
        assert_eq!(fz(&d), 5000.0);
        set("nan_joint");
        step(&mut d, &mut cmds);
        assert!(d.msgs.js.position[1].is_nan() && fz(&d).is_finite());
        assert_eq!(d.msgs.js.position.iter().filter(|q| q.is_nan()).count(), 1);
        set("stale_wrench");
        let frozen = step(&mut d, &mut cmds);
        let w = d.msgs.w.clone();
        let later = step(&mut d, &mut cmds);
        assert!(later > frozen, "the joint states go on");
        assert_eq!(d.msgs.w, w, "the wrench keeps its value and stamp");
        assert!(d.msgs.w.header.stamp.to_nanos() < frozen);
        set("none");
        let now = step(&mut d, &mut cmds);
        assert_eq!(d.msgs.w.header.stamp.to_nanos(), now);
        assert!(fz(&d).is_finite() && d.msgs.js.position.iter().all(|q| q.is_finite()));
        // A value that is not a fault is refused when it is set, naming the choices.
        let e = table.set_atomically(&[("sensor_fault".to_string(), ParameterValue::String("smoke".into()))]).unwrap_err();
        assert!(e.to_string().contains("nan_wrench"), "{e}");
    }

    #[test]
    fn accepted_parameters_apply_at_the_next_reload() {
        let (mut d, table) = runner(&[]);
        let mut cmds = d.commands(&table);
        assert!(!d.paused && !d.sim && !cmds.sim_stamps);
        let set = |name: &str, v| table.set_atomically(&[(name.to_string(), v)]).unwrap();
        set("paused", ParameterValue::Boolean(true));
        set("use_sim_time", ParameterValue::Boolean(true));
        set("command_timeout", ParameterValue::Double(0.005));
        assert!(!d.paused, "not before the reload");
        d.reload(&table, &mut cmds);
        assert!(d.paused && d.sim && cmds.sim_stamps, "simulated stamps reach the command slot too");
        assert_eq!(d.command_timeout(), Duration::from_millis(5));
        // Paused: the period clock restarts after one command_timeout.
        let before = monotonic_ns();
        d.pause();
        assert!(d.deadline_ns() - before >= 5_000_000);
    }

    #[test]
    fn the_report_has_the_counts_and_the_callers_fields() {
        let path = std::env::temp_dir().join(format!("naic-driver-report-{}.json", std::process::id()));
        let (mut d, table) = runner(&["effort_limit:=[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]", &format!("latency_report:={}", path.display())]);
        let mut cmds = d.commands(&table);
        receive(&mut cmds, &effort_msg(&[50.0; 6], None));
        receive(&mut cmds, &effort_msg(&[f64::NAN; 6], None));
        d.step(&cmds.view());
        d.finish(&cmds, &table, serde_json::json!({ "mode": "test" }));
        let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!((r["cycles"].as_u64(), r["rejected_commands"].as_u64(), r["mode"].as_str()), (Some(1), Some(1), Some("test")), "{r}");
        // The refused command made the driver hold; the hold (gravity of the JK5) is
        // saturated at 1 N m.
        assert_eq!(r["saturated_cycles"].as_u64(), Some(1), "{r}");
    }
}
