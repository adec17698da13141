//! `/joint_states` read by joint *name*, in every consumer.
//!
//! `sensor_msgs/JointState` does not fix the joint order: ros2_control's
//! `joint_state_broadcaster`, for one, may publish the joints in another order than the
//! URDF's. Each consumer maps its arm's joint names (the JK5's `joint1..joint6`,
//! [`crate::msgs::JOINT_NAMES`], through [`JointMap::sample`]; any N-joint arm's list, from
//! its URDF or a `joints` parameter, through [`JointMap::sample_named`]) to the message's
//! indices through a [`JointMap`]; a message without names is taken in joint order (rclpy
//! tools often leave them out), and a message that lacks one of the names gives no usable
//! values (the consumer holds / leaves the feedforward out). Names the message carries
//! beyond the arm's (a gripper's fingers on ros2_control's joint_state_broadcaster) are
//! not read.

use crate::msgs::{JointState, JOINT_NAMES};
use naic_core::{JointVec, N_JOINTS};

/// One `/joint_states` sample in the arm's joint order. Values the message does not carry
/// are NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointSample<const N: usize = N_JOINTS> {
    pub stamp_ns: i64,
    pub q: JointVec<N>,
    pub dq: JointVec<N>,
    pub effort: JointVec<N>,
}

/// How the names were mapped, for the caller to report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Same layout as the previous message.
    Same,
    /// A new layout with all the arm's names (or none: joint order).
    New,
    /// A new layout lacking the arm's joint `i` (its name: the list given, `JOINT_NAMES[i]`).
    Missing(usize),
}

/// Joint-name → message-index map, rebuilt only when the names change. `Copy`, no
/// allocation: the current map is checked against the message's names (N string
/// compares) instead of keeping a copy of them. The arm's names are the caller's (fixed
/// when the robot is loaded), passed with each message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JointMap<const N: usize = N_JOINTS> {
    idx: [usize; N],
    /// `None`: no message yet; `Some(false)`: the last layout lacked a name.
    ok: Option<bool>,
    /// The message carried no names (joint order).
    unnamed: bool,
}

impl<const N: usize> Default for JointMap<N> {
    fn default() -> Self {
        Self { idx: std::array::from_fn(|j| j), ok: None, unnamed: false }
    }
}

impl JointMap<N_JOINTS> {
    /// Map `names` to the JK5's [`JOINT_NAMES`] ([`JointMap::update_named`]).
    pub fn update(&mut self, names: &[String]) -> Layout {
        self.update_named(names, &JOINT_NAMES)
    }

    /// `js` in the JK5's joint order ([`JointMap::sample_named`] with [`JOINT_NAMES`]).
    pub fn sample(&mut self, js: &JointState) -> (JointSample, Layout) {
        self.sample_named(js, &JOINT_NAMES)
    }
}

impl<const N: usize> JointMap<N> {
    fn matches<S: AsRef<str>>(&self, names: &[String], want: &[S; N]) -> bool {
        if names.is_empty() {
            return self.unnamed;
        }
        !self.unnamed && (0..N).all(|j| names.get(self.idx[j]).is_some_and(|n| n == want[j].as_ref()))
    }

    /// Map `names` to the arm's joints `want` (rebuilt only when the layout changed).
    pub fn update_named<S: AsRef<str>>(&mut self, names: &[String], want: &[S; N]) -> Layout {
        if self.ok == Some(true) && self.matches(names, want) {
            return Layout::Same;
        }
        let was = self.ok;
        self.unnamed = names.is_empty();
        self.ok = Some(true);
        let mut missing = None;
        for (j, want) in want.iter().enumerate() {
            match names.iter().position(|n| n == want.as_ref()) {
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

    /// `js` in the order of the arm's joints `want` (NaN where a value is missing or the
    /// layout lacks a name).
    pub fn sample_named<S: AsRef<str>>(&mut self, js: &JointState, want: &[S; N]) -> (JointSample<N>, Layout) {
        let layout = self.update_named(&js.name, want);
        let ok = self.ok == Some(true);
        let pick = |v: &[f64]| -> JointVec<N> {
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

/// The N values, if all are finite.
pub fn finite<const N: usize>(v: &JointVec<N>) -> Option<JointVec<N>> {
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

    #[test]
    fn a_seven_joint_arm_is_read_by_its_own_names_and_a_gripper_is_ignored() {
        let want = ["panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4", "panda_joint5", "panda_joint6", "panda_joint7"];
        let mut js = shuffled(&[0, 1, 2, 3, 4, 5]);
        // ros2_control's broadcaster: the arm's joints in another order, and the fingers.
        let order = [6usize, 2, 0, 5, 1, 3, 4];
        js.name = order.iter().map(|&j| want[j].to_string()).chain(["panda_finger_joint1".to_string()]).collect();
        js.position = order.iter().map(|&j| j as f64 + 0.5).chain([0.04]).collect();
        js.velocity = vec![0.0; 8];
        js.effort = vec![0.0; 8];
        let mut m = JointMap::<7>::default();
        let (s, l) = m.sample_named(&js, &want);
        assert_eq!(l, Layout::New);
        assert_eq!(s.q, std::array::from_fn(|j| j as f64 + 0.5));
        assert_eq!(m.sample_named(&js, &want).1, Layout::Same);
        // A missing joint: named by its index in the arm's list, NaN values (the consumer holds).
        js.name[3] = "wrist".into();
        let (s, l) = m.sample_named(&js, &want);
        assert_eq!(l, Layout::Missing(5));
        assert!(s.q.iter().all(|x| x.is_nan()));
    }
}
