//! The nodes' time base: the wall clock, or simulated time (`use_sim_time`, the lockstep
//! loop), in one place.
//!
//! With the wall clock a sample is as old as its *arrival* says (the clocks of other hosts
//! may differ from ours); with simulated time its *stamp* is the time, and nothing depends
//! on when it arrived, so machine load cannot change the result.

/// Simulated time: how long [ns, wall clock] a sample waits for its partner of the same
/// stamp (the controller's joint state for the wrench, friction_compensation's command for
/// the joint state) before the *first* partner has ever arrived. Discovery may match one of
/// the driver's writers seconds before the other (seen across hosts, under load); giving
/// up then changes the first cycle, and with it the whole lockstep run.
pub const FIRST_PAIR_TIMEOUT_NS: i64 = 10_000_000_000;

/// Which clock the node's logic runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TimeBase {
    /// System clock; samples are timed by their arrival.
    #[default]
    Wall,
    /// Simulated time; samples are timed by their stamps.
    Sim,
}

impl TimeBase {
    /// `use_sim_time` → time base.
    pub fn from_use_sim_time(use_sim_time: bool) -> Self {
        if use_sim_time {
            TimeBase::Sim
        } else {
            TimeBase::Wall
        }
    }

    pub fn is_sim(self) -> bool {
        self == TimeBase::Sim
    }

    /// The time [ns] of a sample stamped `stamp_ns` that arrived at wall time `rx_ns`.
    pub fn at(self, stamp_ns: i64, rx_ns: i64) -> i64 {
        match self {
            TimeBase::Wall => rx_ns,
            TimeBase::Sim => stamp_ns,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim_time_is_the_stamp_wall_time_the_arrival() {
        assert_eq!(TimeBase::from_use_sim_time(true).at(5, 900), 5);
        assert_eq!(TimeBase::from_use_sim_time(false).at(5, 900), 900);
        assert_eq!(TimeBase::default(), TimeBase::Wall);
    }
}
