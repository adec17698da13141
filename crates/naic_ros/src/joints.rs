//! `/joint_states` read by joint *name*, in every consumer.
//!
//! `sensor_msgs/JointState` does not fix the joint order: ros2_control's
//! `joint_state_broadcaster`, for one, may publish the joints in another order than the
//! URDF's. Each consumer maps `joint1..joint6` ([`crate::msgs::JOINT_NAMES`]) to the
//! message's indices through a [`JointMap`]; a message without names is taken in joint
//! order (rclpy tools often leave them out), and a message that lacks one of the names
//! gives no usable values (the consumer holds / leaves the feedforward out).

use crate::msgs::{JointState, JOINT_NAMES};
use naic_core::{JointVec, N_JOINTS};

/// One `/joint_states` sample in joint order (joint1..joint6). Values the message does
/// not carry are NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointSample {
    pub stamp_ns: i64,
    pub q: JointVec,
    pub dq: JointVec,
    pub effort: JointVec,
}

/// How the names were mapped, for the caller to report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Same layout as the previous message.
    Same,
    /// A new layout with all six names (or none: joint order).
    New,
    /// A new layout lacking `JOINT_NAMES[i]`.
    Missing(usize),
}

/// Joint-name → message-index map, rebuilt only when the names change. `Copy`, no
/// allocation: the current map is checked against the message's names (six string
/// compares) instead of keeping a copy of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointMap {
    idx: [usize; N_JOINTS],
    /// `None`: no message yet; `Some(false)`: the last layout lacked a name.
    ok: Option<bool>,
    /// The message carried no names (joint order).
    unnamed: bool,
}

impl Default for JointMap {
    fn default() -> Self {
        Self { idx: [0, 1, 2, 3, 4, 5], ok: None, unnamed: false }
    }
}

impl JointMap {
    fn matches(&self, names: &[String]) -> bool {
        if names.is_empty() {
            return self.unnamed;
        }
        !self.unnamed && (0..N_JOINTS).all(|j| names.get(self.idx[j]).is_some_and(|n| n == JOINT_NAMES[j]))
    }

    /// Map `names` (rebuilt only when the layout changed).
    pub fn update(&mut self, names: &[String]) -> Layout {
        if self.ok == Some(true) && self.matches(names) {
            return Layout::Same;
        }
        let was = self.ok;
        self.unnamed = names.is_empty();
        self.ok = Some(true);
        let mut missing = None;
        for (j, want) in JOINT_NAMES.iter().enumerate() {
            match names.iter().position(|n| n == want) {
                Some(i) => self.idx[j] = i,
                None if names.is_empty() => self.idx[j] = j,
                None => {
                    self.ok = Some(false);
                    missing.get_or_insert(j);
                }
            }
        }
        match missing {
            // The same incomplete layout again: reported once.
            Some(_) if was == Some(false) => Layout::Same,
            Some(j) => Layout::Missing(j),
            None => Layout::New,
        }
    }

    /// `js` in joint order (NaN where a value is missing or the layout lacks a name).
    pub fn sample(&mut self, js: &JointState) -> (JointSample, Layout) {
        let layout = self.update(&js.name);
        let ok = self.ok == Some(true);
        let pick = |v: &[f64]| -> JointVec {
            std::array::from_fn(|j| if ok { v.get(self.idx[j]).copied().unwrap_or(f64::NAN) } else { f64::NAN })
        };
        let s = JointSample {
            stamp_ns: js.header.stamp.to_nanos(),
            q: pick(&js.position),
            dq: pick(&js.velocity),
            effort: pick(&js.effort),
        };
        (s, layout)
    }
}

/// Six values, if all are finite.
pub fn finite(v: &JointVec) -> Option<JointVec> {
    v.iter().all(|x| x.is_finite()).then_some(*v)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::msgs::{Header, Time};

    /// A `/joint_states` message with the joints in the order `order` (indices into
    /// joint1..joint6), values `10 j + {1, 2, 3}` for joint j+1.
    pub fn shuffled(order: &[usize]) -> JointState {
        JointState {
            header: Header { stamp: Time::from_nanos(7), frame_id: String::new() },
            name: order.iter().map(|&j| JOINT_NAMES[j].to_string()).collect(),
            position: order.iter().map(|&j| 10.0 * j as f64 + 1.0).collect(),
            velocity: order.iter().map(|&j| 10.0 * j as f64 + 2.0).collect(),
            effort: order.iter().map(|&j| 10.0 * j as f64 + 3.0).collect(),
        }
    }

    #[test]
    fn joints_are_read_by_name_in_any_order() {
        let mut m = JointMap::default();
        let expect: JointVec = std::array::from_fn(|j| 10.0 * j as f64 + 1.0);
        let (s, l) = m.sample(&shuffled(&[0, 1, 2, 3, 4, 5]));
        assert_eq!((s.q, l), (expect, Layout::New));
        let (s, l) = m.sample(&shuffled(&[0, 1, 2, 3, 4, 5]));
        assert_eq!((s.q, l), (expect, Layout::Same));
        let (s, l) = m.sample(&shuffled(&[5, 3, 1, 0, 2, 4]));
        assert_eq!(l, Layout::New);
        assert_eq!(s.q, expect);
        assert_eq!(s.dq, std::array::from_fn(|j| 10.0 * j as f64 + 2.0));
        assert_eq!(s.effort, std::array::from_fn(|j| 10.0 * j as f64 + 3.0));
        assert_eq!(s.stamp_ns, 7);
    }

    #[test]
    fn a_missing_name_gives_nan_and_is_reported_once() {
        let mut m = JointMap::default();
        let mut js = shuffled(&[0, 1, 2, 3, 4, 5]);
        js.name[3] = "wrist".into();
        let (s, l) = m.sample(&js);
        assert_eq!(l, Layout::Missing(3));
        assert!(s.q.iter().all(|x| x.is_nan()));
        assert_eq!(m.sample(&js).1, Layout::Same);
        assert_eq!(m.sample(&shuffled(&[0, 1, 2, 3, 4, 5])).1, Layout::New);
    }

    #[test]
    fn no_names_means_joint_order_and_short_arrays_give_nan() {
        let mut m = JointMap::default();
        let mut js = shuffled(&[0, 1, 2, 3, 4, 5]);
        js.name.clear();
        js.effort.truncate(2);
        let (s, l) = m.sample(&js);
        assert_eq!(l, Layout::New);
        assert_eq!(s.q[5], 51.0);
        assert!(s.effort[2].is_nan() && s.effort[1] == 13.0);
        assert_eq!(finite(&s.effort), None);
        assert_eq!(finite(&s.q), Some(s.q));
    }
}
