//! The naic topics of a recorded run, as typed vectors, read in one pass (for plots and
//! analysis).

use crate::reader::{AnyMessage, Bag, Stamped};
use naic_msgs::{Clock, Float64MultiArray, JointState, NaicParams, WrenchStamped};
use std::ops::RangeBounds;

/// Topic names of the naic node suite.
pub mod topics {
    pub const JOINT_STATES: &str = "/joint_states";
    pub const WRENCH: &str = "/wrench";
    pub const JOINT_EFFORT_CMD: &str = "/joint_effort_cmd";
    pub const NAIC_EFFORT: &str = "/naic/effort";
    pub const NAIC_PARAMS: &str = "/naic/params";
    pub const CLOCK: &str = "/clock";
}

/// Every message of the naic topics in a bag (a topic that is absent gives an empty vector).
#[derive(Debug, Clone, Default)]
pub struct RunData {
    pub joint_states: Vec<Stamped<JointState>>,
    pub wrench: Vec<Stamped<WrenchStamped>>,
    /// `/joint_effort_cmd`: the torque sent to the drives.
    pub effort_cmd: Vec<Stamped<Float64MultiArray>>,
    /// `/naic/effort`: the controller's torque before friction compensation.
    pub naic_effort: Vec<Stamped<Float64MultiArray>>,
    pub params: Vec<Stamped<NaicParams>>,
    pub clock: Vec<Stamped<Clock>>,
}

impl RunData {
    /// Reads the naic topics with log time in `range` in one pass over the bag. A topic
    /// whose type is not the expected one is left empty and noted in [`Bag::damage`]'s
    /// sense: check `bag.topics()` if a vector is unexpectedly empty.
    pub fn load(bag: &Bag, range: impl RangeBounds<u64>) -> RunData {
        use topics::*;
        let slot = |t: &str| bag.channel_by_topic(t).ok().map(|c| c as i32).unwrap_or(-1);
        let (js, wr, ec, ne, pa, ck) =
            (slot(JOINT_STATES), slot(WRENCH), slot(JOINT_EFFORT_CMD), slot(NAIC_EFFORT), slot(NAIC_PARAMS), slot(CLOCK));
        let mut r = RunData::default();
        bag.for_each_decoded(range, |m| {
            let ch = m.channel_id as i32;
            let (log_time, publish_time, sequence) = (m.log_time, m.publish_time, m.sequence);
            macro_rules! st {
                ($x:expr) => {
                    Stamped { log_time, publish_time, sequence, msg: $x }
                };
            }
            match m.msg {
                AnyMessage::JointState(x) if ch == js => r.joint_states.push(st!(x)),
                AnyMessage::WrenchStamped(x) if ch == wr => r.wrench.push(st!(x)),
                AnyMessage::Float64MultiArray(x) if ch == ec => r.effort_cmd.push(st!(x)),
                AnyMessage::Float64MultiArray(x) if ch == ne => r.naic_effort.push(st!(x)),
                AnyMessage::NaicParams(x) if ch == pa => r.params.push(st!(x)),
                AnyMessage::Clock(x) if ch == ck => r.clock.push(st!(x)),
                _ => {}
            }
        });
        r
    }
}
