//! "A repeated stamp gets the same answer": the one rule every lockstep node follows.
//!
//! The lockstep driver publishes the same state again (same stamp) when no command for it
//! arrived in time. A node that has already answered that stamp must answer it with the
//! same output and must not advance its own state a second time; otherwise its state
//! would advance once per *publication* rather than once per *state*, and two runs would
//! differ with the machine's load.

/// The last answer and the stamp it answers [ns]. `Copy`, no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Replay<T: Copy> {
    last: Option<(i64, T)>,
}

impl<T: Copy> Default for Replay<T> {
    fn default() -> Self {
        Self { last: None }
    }
}

impl<T: Copy> Replay<T> {
    /// The answer already given for `stamp_ns`, if it was the last one answered.
    pub fn get(&self, stamp_ns: i64) -> Option<T> {
        self.last.filter(|(st, _)| *st == stamp_ns).map(|(_, v)| v)
    }

    /// Remember `v` as the answer to `stamp_ns` (replaces the previous one).
    pub fn store(&mut self, stamp_ns: i64, v: T) {
        self.last = Some((stamp_ns, v));
    }

    /// Forget the last answer.
    pub fn clear(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_last_stamp_is_replayed() {
        let mut r = Replay::default();
        assert_eq!(r.get(5), None);
        r.store(5, [1.0; 6]);
        assert_eq!(r.get(5), Some([1.0; 6]));
        assert_eq!(r.get(6), None);
        r.store(6, [2.0; 6]);
        assert_eq!(r.get(5), None, "an older stamp is not answered again");
        assert_eq!(r.get(6), Some([2.0; 6]));
        r.clear();
        assert_eq!(r.get(6), None);
    }
}
