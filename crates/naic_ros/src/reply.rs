//! Service replies held until the client can receive them.
//!
//! A service reply goes out on a volatile, reliable writer, and RustDDS marks every sample
//! written before a reader matched as irrelevant to that reader (a GAP: `matched_reader_update`
//! in its `rtps/writer.rs`). A reply to a client whose reply reader this participant has not
//! discovered yet is therefore lost, and the client waits forever. rclpy's
//! `service_is_ready` only says that the *client's* participant knows our endpoints; ours can
//! learn the client's reply reader seconds later on a loaded machine, after its first request
//! arrived. rmw_fastrtps holds such a reply until the client's reader has matched; this does
//! the same: a reply waits until a reader on the reply topic with the requester's GUID prefix
//! (the client's participant) has been known for [`GRACE`] (the time RustDDS's event loop
//! takes to give the writer its reader proxy), and is dropped with a warning after
//! [`GIVE_UP`].

use std::{
    collections::{HashMap, HashSet},
    time::{Duration, Instant},
};

use ros2_client::{gid::Gid, service::request_id::RmwRequestId, Context};

/// How long a client's reply reader must have been discovered before a reply is sent to it.
pub const GRACE: Duration = Duration::from_millis(100);
/// How long a reply waits for its client's reply reader before it is dropped (with a warning).
pub const GIVE_UP: Duration = Duration::from_secs(30);

/// A participant, by the 12-byte GUID prefix all its endpoints share.
pub type Participant = [u8; 12];

/// The participant of a requester (the client's request writer).
pub fn participant_of(id: &RmwRequestId) -> Participant {
    prefix(&id.writer_gid)
}

fn prefix(g: &Gid) -> Participant {
    let mut p = [0; 12];
    p.copy_from_slice(&g.as_bytes()[..12]);
    p
}

/// What to do with a held reply now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Send,
    Hold,
    GiveUp,
}

/// When each (reply topic, client participant) reader was first seen: the only state.
#[derive(Default)]
pub struct Sightings {
    first_seen: HashMap<(String, Participant), Instant>,
}

impl Sightings {
    /// The verdict for a reply on `topic` to `client`, requested at `requested`, given whether
    /// the client's reader on `topic` is discovered now.
    pub fn verdict(&mut self, topic: &str, client: Participant, known: bool, requested: Instant, now: Instant) -> Verdict {
        let key = (topic.to_string(), client);
        if !known {
            self.first_seen.remove(&key);
            return if now.duration_since(requested) >= GIVE_UP { Verdict::GiveUp } else { Verdict::Hold };
        }
        let seen = *self.first_seen.entry(key).or_insert(now);
        if now.duration_since(seen) >= GRACE {
            Verdict::Send
        } else if now.duration_since(requested) >= GIVE_UP {
            Verdict::GiveUp
        } else {
            Verdict::Hold
        }
    }

    /// Forget the readers that are gone (clients that left), so the table stays as small as
    /// the set of live clients.
    pub fn forget_gone(&mut self, readers: &HashSet<(String, Participant)>) {
        self.first_seen.retain(|k, _| readers.contains(k));
    }
}

/// The readers this participant has discovered, as (DDS topic, participant) pairs.
pub fn discovered_readers(context: &Context) -> HashSet<(String, Participant)> {
    context
        .domain_participant()
        .discovered_readers()
        .into_iter()
        .map(|r| {
            let p = prefix(&Gid::from(r.reader_proxy.remote_reader_guid));
            (r.subscription_topic_data.topic_name().to_string(), p)
        })
        .collect()
}

/// The DDS topic a service's replies go out on (`rr/<node>/<service>Reply`, as ros2-client
/// and rmw name it) for a fully qualified node name `fqn` (`/ns/name`).
pub fn reply_topic(fqn: &str, service: &str) -> String {
    format!("rr{fqn}/{service}Reply")
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: &str = "rr/n/get_parametersReply";
    const C: Participant = [7; 12];

    #[test]
    fn a_reply_waits_for_the_reader_then_for_the_grace() {
        let mut s = Sightings::default();
        let t0 = Instant::now();
        assert_eq!(s.verdict(T, C, false, t0, t0), Verdict::Hold);
        let t1 = t0 + Duration::from_secs(2);
        assert_eq!(s.verdict(T, C, true, t0, t1), Verdict::Hold, "just discovered: the writer may not have matched yet");
        assert_eq!(s.verdict(T, C, true, t0, t1 + GRACE / 2), Verdict::Hold);
        assert_eq!(s.verdict(T, C, true, t0, t1 + GRACE), Verdict::Send);
        // A later request from the same client is sent at once.
        let t2 = t1 + Duration::from_secs(1);
        assert_eq!(s.verdict(T, C, true, t2, t2), Verdict::Send);
        // Another client (or another service's topic) has its own sighting.
        assert_eq!(s.verdict(T, [8; 12], true, t2, t2), Verdict::Hold);
        assert_eq!(s.verdict("rr/n/set_parametersReply", C, true, t2, t2), Verdict::Hold);
    }

    #[test]
    fn a_reader_that_went_away_must_be_seen_again_and_an_unknown_one_is_given_up() {
        let mut s = Sightings::default();
        let t0 = Instant::now();
        assert_eq!(s.verdict(T, C, true, t0, t0), Verdict::Hold);
        assert_eq!(s.verdict(T, C, false, t0, t0 + GRACE), Verdict::Hold);
        let t1 = t0 + 2 * GRACE;
        assert_eq!(s.verdict(T, C, true, t0, t1), Verdict::Hold, "the sighting restarts");
        assert_eq!(s.verdict(T, C, false, t0, t0 + GIVE_UP), Verdict::GiveUp);
        assert_eq!(s.verdict(T, C, true, t0, t1), Verdict::Hold);
        s.forget_gone(&HashSet::new());
        assert!(s.first_seen.is_empty());
    }

    #[test]
    fn reply_topic_matches_the_ros2_names() {
        assert_eq!(reply_topic("/friction_compensation", "get_parameters"), "rr/friction_compensation/get_parametersReply");
        assert_eq!(reply_topic("/arm/naic_controller", "set_parameters"), "rr/arm/naic_controller/set_parametersReply");
        let mut g = [0u8; 16];
        g[..12].copy_from_slice(&[3; 12]);
        g[12..].copy_from_slice(&[0, 0, 1, 3]);
        let id = RmwRequestId { writer_gid: Gid::from(g), sequence_number: 1 };
        assert_eq!(participant_of(&id), [3; 12]);
    }
}
