//! The driver's core: what it does with each command and each simulator step, without
//! I/O, threads or clocks (the shell passes the wall time).
//!
//! - [`receive`] (the receive thread, per `/joint_effort_cmd`): six finite numbers or
//!   refused (and then the driver holds at once, never keeping the previous command); in
//!   lockstep only a command computed from the state just published (its stamp) may
//!   advance the simulation, others are dropped and counted; the chain latency of
//!   wall-clock stamps goes into the histogram after the warm-up.
//! - [`step`] (the main loop, per simulator step): the newest command if it is fresh,
//!   else the hold (`Plant::hold_torque`, the core's hold law); saturation at
//!   `effort_limit` whatever is applied; missed-cycle accounting; one plant step.
//!
//! [`Commands`] holds the latency histogram (18 KiB), so [`receive`] takes it `&mut`
//! rather than copying it every command; [`State`] is `Copy` and [`step`] pure.

use naic_core::pipeline::actuate;
use naic_core::{JointVec, N_JOINTS};
use naic_ros::{
    msgs::{self, EffortError, Float64MultiArray},
    throttle::Throttle,
};

use crate::{latency::Histogram, plant::Plant};

/// The driver's parameters as the core reads them (an arm of `N` joints).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params<const N: usize = N_JOINTS> {
    /// One step per command computed from the state just published.
    pub lockstep: bool,
    /// Simulation and publishing rate [Hz].
    pub rate: f64,
    /// Lockstep: simulated time runs at most this many times wall time (0: as fast as the
    /// chain allows). Pacing is the shell's ([`crate::runner::Runner::pace`]); the step
    /// does not read it.
    pub real_time_factor: f64,
    /// Hold when no valid command arrived for this long [ns] (real time).
    pub command_timeout_ns: i64,
    /// Joint damping of the hold [N m s/rad].
    pub hold_damping: f64,
    /// Per-joint saturation of everything applied [N m].
    pub effort_limit: JointVec<N>,
}

/// The newest command, written by the receive thread, read by the main loop.
#[derive(Clone)]
pub struct Commands<const N: usize = N_JOINTS> {
    pub tau: JointVec<N>,
    /// The newest command was valid (else: hold until a valid one arrives).
    pub valid: bool,
    /// Wall-clock arrival of the newest command [ns].
    pub arrival_ns: i64,
    /// Commands received (valid or not).
    pub seq: u64,
    /// `/joint_states` stamp the newest command was computed from (if traced).
    pub source_stamp_ns: Option<i64>,
    /// Latencies (arrival − source stamp) of traced commands, wall-clock stamps only.
    pub latency: Histogram,
    /// Latencies are recorded from this wall time on (after the warm-up) [ns].
    pub record_after_ns: i64,
    /// Stamps are simulated time (lockstep / use_sim_time): no latency statistics.
    pub sim_stamps: bool,
    pub rejected: u64,
    /// Lockstep: only commands for this stamp (or without a stamp) may advance the
    /// simulation. `None` in real time.
    pub expect_stamp_ns: Option<i64>,
    /// Lockstep: a command for `expect_stamp_ns` waits to be applied.
    pub ready: bool,
    /// Lockstep: commands dropped because they were computed from another state.
    pub stale_dropped: u64,
    warn: Throttle,
}

impl<const N: usize> Commands<N> {
    pub fn new(record_after_ns: i64, sim_stamps: bool) -> Self {
        Commands {
            tau: [0.0; N],
            valid: false,
            arrival_ns: 0,
            seq: 0,
            source_stamp_ns: None,
            latency: Histogram::default(),
            record_after_ns,
            sim_stamps,
            rejected: 0,
            expect_stamp_ns: None,
            ready: false,
            stale_dropped: 0,
            warn: Throttle::default(),
        }
    }

    /// Lockstep: from now on only commands computed from `stamp` advance the simulation
    /// (`None`: real time, every valid command is taken).
    pub fn expect(&mut self, stamp: Option<i64>) {
        if self.expect_stamp_ns != stamp {
            self.expect_stamp_ns = stamp;
            self.ready = false;
        }
    }

    /// Lockstep: the command for the announced state is in; takes it (`ready` is cleared).
    pub fn take_ready(&mut self) -> bool {
        std::mem::take(&mut self.ready)
    }

    /// What [`step`] needs of the newest command.
    pub fn view(&self) -> Command<N> {
        Command {
            tau: self.tau,
            valid: self.valid,
            arrival_ns: self.arrival_ns,
            seq: self.seq,
            source_stamp_ns: self.source_stamp_ns,
            record_after_ns: self.record_after_ns,
        }
    }
}

/// Take one `/joint_effort_cmd` at wall time `now_ns`. Returns the reason of a refusal
/// when a report is due (one per second).
pub fn receive<const N: usize>(c: &mut Commands<N>, m: &Float64MultiArray, now_ns: i64) -> Option<EffortError> {
    let mut tau = [0.0; N];
    match msgs::effort_values(m, &mut tau) {
        Ok(()) => {
            let src = msgs::effort_source_stamp(m);
            if let (Some(want), Some(got)) = (c.expect_stamp_ns, src) {
                if got != want {
                    // Lockstep: computed from another state; never applied.
                    c.stale_dropped += 1;
                    return None;
                }
            }
            c.ready = c.expect_stamp_ns.is_some();
            (c.tau, c.valid, c.arrival_ns, c.source_stamp_ns) = (tau, true, now_ns, src);
            c.seq += 1;
            if let (Some(st), false) = (src, c.sim_stamps) {
                if now_ns >= c.record_after_ns {
                    c.latency.record(now_ns - st);
                }
            }
            None
        }
        Err(e) => {
            // Not applied, and the previous command is not kept either: in real time the
            // driver holds from the next cycle on (in lockstep a refused command never
            // advances the simulation).
            (c.valid, c.arrival_ns) = (false, now_ns);
            c.seq += 1;
            c.rejected += 1;
            c.warn.ready(now_ns).then_some(e)
        }
    }
}

/// The newest command as [`step`] sees it (a copy taken under the lock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Command<const N: usize = N_JOINTS> {
    pub tau: JointVec<N>,
    pub valid: bool,
    pub arrival_ns: i64,
    pub seq: u64,
    pub source_stamp_ns: Option<i64>,
    pub record_after_ns: i64,
}

/// What the main loop remembers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct State {
    /// Holding the arm itself (no fresh valid command).
    pub holding: bool,
    /// Real time: cycles whose command did not answer the previous state.
    pub missed: u64,
    /// A traced command has arrived (missed cycles count from then on).
    chain_started: bool,
    pub saturated_cycles: u64,
    sat_warn: Throttle,
    pub cycles: u64,
    /// The stamp of the state published last [ns] (the shell sets it when publishing).
    pub last_published_stamp: Option<i64>,
}

/// Why the driver started to hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// No command for `command_timeout`.
    Timeout,
    /// The last command was refused.
    Rejected,
}

/// Things for the shell to log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Events<const N: usize = N_JOINTS> {
    pub hold: Option<Hold>,
    /// Commands resumed: the hold is released.
    pub released: bool,
    /// The torque was saturated on these joints (one report per second).
    pub saturated: Option<[bool; N]>,
}

/// What one step applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outbox<const N: usize = N_JOINTS> {
    /// The torque applied to the plant [N m].
    pub tau: JointVec<N>,
    pub events: Events<N>,
}

/// One simulator step at wall time `now_ns` with the newest command `c`.
pub fn step<const N: usize, P: Plant<N>>(p: &Params<N>, s: &State, c: &Command<N>, now_ns: i64, plant: &mut P) -> (State, Outbox<N>) {
    let mut s = *s;
    let mut out = Outbox { tau: [0.0; N], events: Events { hold: None, released: false, saturated: None } };
    // Lockstep: the shell's wait returned with the command for this state (unless a
    // refused one came after it: then hold).
    let fresh = c.valid && c.seq > 0 && (p.lockstep || now_ns - c.arrival_ns <= p.command_timeout_ns);
    if !p.lockstep && s.chain_started && now_ns >= c.record_after_ns {
        // A cycle is missed when the command for the previous state did not arrive in time.
        if let (Some(last), Some(src)) = (s.last_published_stamp, c.source_stamp_ns) {
            if src != last {
                s.missed += 1;
            }
        }
    }
    s.chain_started |= c.source_stamp_ns.is_some();
    let tau = if fresh {
        out.events.released = s.holding;
        s.holding = false;
        c.tau
    } else {
        if !s.holding && c.seq > 0 {
            out.events.hold = Some(if c.valid { Hold::Timeout } else { Hold::Rejected });
        }
        s.holding |= c.seq > 0;
        plant.hold_torque(p.hold_damping)
    };
    // Whatever is applied, command or hold, stays within the effort limits.
    let (tau, clipped) = actuate::saturate(&p.effort_limit, &tau);
    if clipped.iter().any(|&x| x) {
        s.saturated_cycles += 1;
        if s.sat_warn.ready(now_ns) {
            out.events.saturated = Some(clipped);
        }
    }
    plant.step(&tau, 1.0 / p.rate);
    s.cycles += 1;
    out.tau = tau;
    (s, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_ros::{alloc_check::counted, msgs::effort_msg};

    const MS: i64 = 1_000_000;

    /// A plant that records what it is given; its hold torque is 7 N m per joint.
    #[derive(Default)]
    struct Probe {
        applied: Vec<JointVec>,
    }

    impl Plant for Probe {
        fn step(&mut self, tau: &JointVec, _dt: f64) {
            if self.applied.len() < self.applied.capacity() {
                self.applied.push(*tau);
            }
        }
        fn hold_torque(&mut self, _damping: f64) -> JointVec {
            [7.0; 6]
        }
        fn joints(&self) -> (JointVec, JointVec, JointVec) {
            ([0.0; 6], [0.0; 6], [0.0; 6])
        }
        fn wrench(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn time(&self) -> f64 {
            0.0
        }
    }

    fn params(lockstep: bool) -> Params {
        Params { lockstep, rate: 1000.0, real_time_factor: 0.0, command_timeout_ns: 20 * MS, hold_damping: 5.0, effort_limit: [100.0; 6] }
    }

    fn run(p: &Params, s: &State, c: &Command, now: i64, plant: &mut Probe) -> (State, Outbox) {
        let (r, n) = counted(|| step(p, s, c, now, plant));
        assert_eq!(n, 0, "the step allocated");
        r
    }

    fn rx(c: &mut Commands, m: &Float64MultiArray, now: i64) -> Option<EffortError> {
        let (r, n) = counted(|| receive(c, m, now));
        assert_eq!(n, 0, "receive allocated");
        r
    }

    #[test]
    fn lockstep_takes_only_the_command_for_the_state_just_published() {
        let mut c = Commands::new(0, true);
        c.expect(Some(2000));
        rx(&mut c, &effort_msg(&[1.0; 6], Some(1000)), 0);
        assert_eq!((c.ready, c.stale_dropped, c.seq), (false, 1, 0), "a late answer to an earlier state is dropped");
        rx(&mut c, &effort_msg(&[2.0; 6], Some(2000)), 0);
        assert!(c.ready && c.tau == [2.0; 6] && c.source_stamp_ns == Some(2000));
        // A new expectation clears `ready`; the same one keeps it.
        c.expect(Some(2000));
        assert!(c.ready);
        c.expect(Some(3000));
        assert!(!c.ready);
        assert_eq!(c.latency.len(), 0, "simulated stamps: no latency statistics");
    }

    #[test]
    fn refused_commands_are_counted_reported_once_per_second_and_held_at_once() {
        let p = params(false);
        let mut c = Commands::new(0, false);
        rx(&mut c, &effort_msg(&[1.0; 6], None), 0);
        let mut plant = Probe { applied: Vec::with_capacity(8) };
        let (s, o) = run(&p, &State::default(), &c.view(), MS, &mut plant);
        assert_eq!(o.tau, [1.0; 6]);
        let mut bad = effort_msg(&[1.0; 6], None);
        bad.data.truncate(3);
        assert_eq!(rx(&mut c, &bad, 2 * MS), Some(EffortError::TooFew { need: 6, got: 3 }));
        assert_eq!(rx(&mut c, &bad, 3 * MS), None, "rate-limited");
        assert_eq!(c.rejected, 2);
        // The next cycle holds (well before command_timeout).
        let (s, o) = run(&p, &s, &c.view(), 4 * MS, &mut plant);
        assert_eq!((o.tau, o.events.hold, s.holding), ([7.0; 6], Some(Hold::Rejected), true));
        rx(&mut c, &effort_msg(&[2.0; 6], None), 5 * MS);
        let (s, o) = run(&p, &s, &c.view(), 6 * MS, &mut plant);
        assert_eq!((o.tau, o.events.released, s.holding), ([2.0; 6], true, false));
        assert_eq!(plant.applied, vec![[1.0; 6], [7.0; 6], [2.0; 6]]);
    }

    #[test]
    fn a_stale_command_gives_the_hold_and_nothing_before_the_first_command() {
        let p = params(false);
        let mut c = Commands::new(0, false);
        let mut plant = Probe { applied: Vec::with_capacity(8) };
        // No command yet: the hold, without a hold report (nothing was lost).
        let (s, o) = run(&p, &State::default(), &c.view(), 0, &mut plant);
        assert_eq!((o.tau, o.events.hold, s.holding), ([7.0; 6], None, false));
        rx(&mut c, &effort_msg(&[1.0; 6], None), MS);
        let (s, o) = run(&p, &s, &c.view(), 21 * MS, &mut plant);
        assert_eq!(o.tau, [1.0; 6], "20 ms old: still fresh");
        let (s, o) = run(&p, &s, &c.view(), 22 * MS, &mut plant);
        assert_eq!((o.tau, o.events.hold), ([7.0; 6], Some(Hold::Timeout)));
        let (_, o) = run(&p, &s, &c.view(), 23 * MS, &mut plant);
        assert_eq!((o.tau, o.events.hold), ([7.0; 6], None), "reported once");
        // Lockstep: the age of a command does not matter (simulated time stands still).
        let (_, o) = run(&params(true), &State::default(), &c.view(), 10_000 * MS, &mut plant);
        assert_eq!(o.tau, [1.0; 6]);
    }

    #[test]
    fn everything_applied_is_saturated_and_counted() {
        let mut p = params(false);
        p.effort_limit = [100.0, 100.0, 100.0, 10.0, 10.0, 10.0];
        let mut c = Commands::new(0, false);
        rx(&mut c, &effort_msg(&[1000.0, -1000.0, 5.0, 5.0, -50.0, 0.0], None), 0);
        let mut plant = Probe { applied: Vec::with_capacity(8) };
        let (s, o) = run(&p, &State::default(), &c.view(), 0, &mut plant);
        assert_eq!(o.tau, [100.0, -100.0, 5.0, 5.0, -10.0, 0.0]);
        assert_eq!(o.events.saturated, Some([true, true, false, false, true, false]));
        let (s, o) = run(&p, &s, &c.view(), MS, &mut plant);
        assert_eq!((o.events.saturated, s.saturated_cycles), (None, 2), "one report per second, every cycle counted");
        // The hold is saturated too.
        p.effort_limit = [5.0; 6];
        let (_, o) = run(&p, &s, &c.view(), 100 * MS, &mut plant);
        assert_eq!(o.tau, [5.0; 6]);
    }

    #[test]
    fn missed_cycles_count_commands_that_did_not_answer_the_previous_state() {
        let p = params(false);
        let mut c = Commands::new(0, false);
        let mut plant = Probe::default();
        let mut s = State::default();
        let mut stamp = 0;
        // Answers to states 0, 1, 2 in time; then state 3's answer is late (the command
        // in the slot still answers 2) for two cycles; then on time again.
        for (k, answers) in [(1, 0), (2, 1), (3, 2), (4, 2), (5, 2), (6, 5)] {
            rx(&mut c, &effort_msg(&[0.0; 6], Some(answers)), k * MS);
            s = run(&p, &s, &c.view(), k * MS, &mut plant).0;
            s.last_published_stamp = Some(k);
            stamp = k;
        }
        assert_eq!(stamp, 6);
        assert_eq!(s.missed, 2, "{s:?}");
        assert_eq!(c.latency.len(), 6, "wall-clock stamps: the latency of each command");
    }
}
