//! Time stamps: wall clock or simulated, as `builtin_interfaces/Time`.

use crate::msgs::Time;

/// Nanoseconds since the Unix epoch, from the system clock.
pub fn wall_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// Nanoseconds → `Time` (negative times clamp to zero).
pub fn time_from_ns(ns: i64) -> Time {
    let ns = ns.max(0);
    Time { sec: (ns / 1_000_000_000) as i32, nanosec: (ns % 1_000_000_000) as u32 }
}

/// `Time` → nanoseconds.
pub fn ns_from_time(t: &Time) -> i64 {
    t.sec as i64 * 1_000_000_000 + t.nanosec as i64
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn round_trip() {
        let t = time_from_ns(1_700_000_000_123_456_789);
        assert_eq!(t.sec, 1_700_000_000);
        assert_eq!(t.nanosec, 123_456_789);
        assert_eq!(ns_from_time(&t), 1_700_000_000_123_456_789);
    }
}
