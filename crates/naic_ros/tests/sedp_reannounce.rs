//! The vendored rustdds patch (crates/vendor/rustdds/PATCHED.md; docs/notes/2026-12-dds-test-forensics.md, "The 10 s
//! failure, traced"): when a participant discovers a new remote participant, it announces
//! its user endpoints again, as new DCPSSubscription / DCPSPublication samples.
//!
//! Three loopback-only participants on one domain: `a` has a user reader and writer, `c`
//! watches `a`'s endpoints through its own built-in discovery (each received SEDP sample of
//! an endpoint gives one `ReaderDetected` / `WriterDetected` status event; so does a
//! DCPSTopic sample of its topic, which `a` sends only when the topic is created), and `b`
//! joins later. Without the patch `a` publishes each endpoint once, when it is created, so
//! `c` sees no sample of them after `b` joins; with it, two (0.1 s and 1 s after `a`
//! discovered `b`).

use std::time::{Duration, Instant};

mod common;

use common::{claim_domain, participant};
use ros2_client::dds::rustdds::{
    policy, DomainParticipant, DomainParticipantStatusEvent, QosPolicyBuilder, RTPSEntity, StatusEvented,
    TopicKind, GUID,
};
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize)]
struct Probe {
    x: u32,
}

/// How many SEDP samples of `reader` and of `writer` a participant has received.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Seen {
    reader: usize,
    writer: usize,
}

/// Drains `c`'s status events for `timeout`, counting the samples of `a`'s two endpoints
/// into `seen`.
fn watch(c: &DomainParticipant, reader: GUID, writer: GUID, seen: &mut Seen, timeout: Duration) {
    let events = c.status_listener();
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        while let Some(e) = events.try_recv_status() {
            match e {
                DomainParticipantStatusEvent::ReaderDetected { reader: d } if d.guid == reader => seen.reader += 1,
                DomainParticipantStatusEvent::WriterDetected { writer: d } if d.guid == writer => seen.writer += 1,
                _ => {}
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Waits until `p` has discovered the participant `remote`; false after `timeout`.
fn discovers(p: &DomainParticipant, remote: GUID, timeout: Duration) -> bool {
    let events = p.status_listener();
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        while let Some(e) = events.try_recv_status() {
            if let DomainParticipantStatusEvent::ParticipantDiscovered { dpd } = e {
                if dpd.guid.prefix == remote.prefix {
                    return true;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    false
}

#[test]
fn a_new_remote_participant_makes_local_endpoints_announced_again() {
    let (domain, _claim) = claim_domain();
    let qos = QosPolicyBuilder::new()
        .reliability(policy::Reliability::Reliable { max_blocking_time: ros2_client::dds::rustdds::Duration::ZERO })
        .build();

    let a = participant(domain);
    let topic = a
        .create_topic("naic_sedp_probe".into(), "naic::Probe".into(), &qos, TopicKind::NoKey)
        .expect("create topic");
    let reader = a
        .create_subscriber(&qos)
        .expect("create subscriber")
        .create_datareader_no_key_cdr::<Probe>(&topic, None)
        .expect("create reader");
    let writer = a
        .create_publisher(&qos)
        .expect("create publisher")
        .create_datawriter_no_key_cdr::<Probe>(&topic, None)
        .expect("create writer");
    let (reader, writer) = (reader.guid(), writer.guid());

    // `c` learns `a`'s endpoints. Then wait out what `a` does on discovering `c` (with the
    // patch: two more samples each, 0.1 s and 1 s after), so that the count below is
    // settled before `b` exists.
    let c = participant(domain);
    let mut seen = Seen::default();
    watch(&c, reader, writer, &mut seen, Duration::from_secs(3));
    assert!(
        seen.reader >= 1 && seen.writer >= 1,
        "precondition: participant c never received a's reader and writer announcements in 3 s: {seen:?}"
    );
    let before_b = seen;

    let b = participant(domain);
    let b_guid = b.guid();
    assert!(
        discovers(&a, b_guid, Duration::from_secs(5)),
        "precondition: participant a did not discover the new participant b within 5 s"
    );
    watch(&c, reader, writer, &mut seen, Duration::from_secs(4));
    assert!(
        seen.reader >= before_b.reader + 2 && seen.writer >= before_b.writer + 2,
        "after a discovered b, c did not receive the two re-announcements (0.1 s and 1 s later) of a's \
         reader and writer: before b {before_b:?}, 4 s after {seen:?}"
    );
    drop((b, c, a));
}
