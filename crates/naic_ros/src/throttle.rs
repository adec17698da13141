//! Rate-limited reporting: a warning repeated every cycle would flood the log at 1 kHz.

/// Lets one report through per `period_ns` (and always the first). `Copy`, lives in the
/// node core's state, so the decision is part of the pure step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Throttle {
    last_ns: Option<i64>,
    period_ns: i64,
}

/// One report per second, the nodes' default.
pub const LOG_PERIOD_NS: i64 = 1_000_000_000;

impl Default for Throttle {
    fn default() -> Self {
        Self::new(LOG_PERIOD_NS)
    }
}

impl Throttle {
    pub const fn new(period_ns: i64) -> Self {
        Self { last_ns: None, period_ns }
    }

    /// True (and the period restarts) when a report at wall time `now_ns` may go out.
    pub fn ready(&mut self, now_ns: i64) -> bool {
        match self.last_ns {
            Some(t) if now_ns - t <= self.period_ns => false,
            _ => {
                self.last_ns = Some(now_ns);
                true
            }
        }
    }

    /// Let the next report through regardless of the period (a new kind of event).
    pub fn reset(&mut self) {
        self.last_ns = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_report_per_period() {
        let mut t = Throttle::new(1000);
        assert!(t.ready(0));
        assert!(!t.ready(500));
        assert!(!t.ready(1000));
        assert!(t.ready(1001));
        t.reset();
        assert!(t.ready(1002));
    }
}
