//! Messages of the types naic knows, decoded in one pass.

use super::{message, Bag, TimeRange};
use std::ops::RangeBounds;

/// A message of any type naic knows, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyMessage {
    JointState(naic_msgs::JointState),
    WrenchStamped(naic_msgs::WrenchStamped),
    Float64MultiArray(naic_msgs::Float64MultiArray),
    NaicParams(naic_msgs::NaicParams),
    Clock(naic_msgs::Clock),
    /// `/naic/target_pose`, the controller's position reference.
    PoseStamped(naic_msgs::PoseStamped),
}

#[derive(Clone, Copy)]
enum Kind {
    Js,
    Ws,
    Fa,
    Np,
    Ck,
    Ps,
    Unknown,
}

impl Kind {
    fn of(type_name: &str) -> Kind {
        use naic_msgs::*;
        match type_name {
            t if t == JointState::type_name() => Kind::Js,
            t if t == WrenchStamped::type_name() => Kind::Ws,
            t if t == Float64MultiArray::type_name() => Kind::Fa,
            t if t == NaicParams::type_name() => Kind::Np,
            t if t == Clock::type_name() => Kind::Ck,
            t if t == PoseStamped::type_name() => Kind::Ps,
            _ => Kind::Unknown,
        }
    }
    #[inline]
    fn decode(self, data: &[u8]) -> Option<Result<AnyMessage, naic_msgs::CdrError>> {
        use naic_msgs::*;
        Some(match self {
            Kind::Js => JointState::from_cdr(data).map(AnyMessage::JointState),
            Kind::Ws => WrenchStamped::from_cdr(data).map(AnyMessage::WrenchStamped),
            Kind::Fa => Float64MultiArray::from_cdr(data).map(AnyMessage::Float64MultiArray),
            Kind::Np => NaicParams::from_cdr(data).map(AnyMessage::NaicParams),
            Kind::Ck => Clock::from_cdr(data).map(AnyMessage::Clock),
            Kind::Ps => PoseStamped::from_cdr(data).map(AnyMessage::PoseStamped),
            Kind::Unknown => return None,
        })
    }
}

/// A decoded message with its channel and bag times.
#[derive(Debug, Clone, PartialEq)]
pub struct AnyStamped {
    pub channel_id: u16,
    pub log_time: u64,
    pub publish_time: u64,
    pub sequence: u32,
    pub msg: AnyMessage,
}

impl Bag {
    /// Streams, in one pass over the file, every message of a known type (JointState,
    /// WrenchStamped, Float64MultiArray, NaicParams, Clock, PoseStamped) with log time in `range`, decoded,
    /// in file order. Messages of other types are left out (read them raw with
    /// [`Bag::for_each_message`]); undecodable ones are skipped and reported in [`Bag::damage`].
    pub fn for_each_decoded(&self, range: impl RangeBounds<u64>, mut f: impl FnMut(AnyStamped)) {
        let range = TimeRange::from_bounds(range);
        let mut kinds = vec![Kind::Unknown; 65536];
        for c in self.channels.values() {
            kinds[c.id as usize] = Kind::of(self.type_name(c.id));
        }
        let mut bad = 0usize;
        for s in 0..self.sources.len() {
            self.with_records(s, range, &mut |opc, body| {
                let Some((h, data)) = message(opc, body) else { return };
                if !range.contains(h.log_time) {
                    return;
                }
                match kinds[h.channel_id as usize].decode(data) {
                    Some(Ok(msg)) => f(AnyStamped {
                        channel_id: h.channel_id,
                        log_time: h.log_time,
                        publish_time: h.publish_time,
                        sequence: h.sequence,
                        msg,
                    }),
                    Some(Err(_)) => bad += 1,
                    None => {}
                }
            });
        }
        if bad > 0 {
            self.note(0, format!("{bad} message(s) do not decode as their channel's type; skipped"));
        }
    }

    /// [`Bag::for_each_decoded`] collected into a vector.
    pub fn decode_all(&self, range: impl RangeBounds<u64>) -> Vec<AnyStamped> {
        let mut out = Vec::with_capacity(self.capacity_hint(self.message_count()));
        self.for_each_decoded(range, |m| out.push(m));
        out
    }
}
