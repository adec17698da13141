//! Time stamps: wall clock or simulated, as `builtin_interfaces/Time`.

use crate::msgs::Time;

/// Nanoseconds since the Unix epoch, from the system clock.
pub fn wall_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// Nanoseconds → `Time`.
pub fn time_from_ns(ns: i64) -> Time {
    Time::from_nanos(ns)
}

/// `Time` → nanoseconds.
pub fn ns_from_time(t: &Time) -> i64 {
    t.to_nanos()
}
