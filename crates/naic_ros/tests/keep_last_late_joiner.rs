//! The vendored rustdds patch "Late joiners of a KeepLast writer"
//! (crates/vendor/rustdds/PATCHED.md; docs/notes/2026-12-dds-test-forensics.md, "The graph that went back"): a reader
//! that joins a transient-local, KeepLast(1) writer without key late gets the newest sample
//! only, not the writer's older samples that its history still holds.
//!
//! A writer's history keeps a sample until every matched reader has acknowledged it, so a
//! writer that wrote before any reader existed keeps all it wrote (ros2-client's
//! `ros_discovery_info` writer: one sample per endpoint a node creates at start-up).
//! Unpatched rustdds 0.15.1 sent a late reader all of them, oldest first; rclpy's graph,
//! which takes the newest sample it received as a participant's node list, then went back
//! through the start-up lists for tens of ms.

use std::time::{Duration, Instant};

mod common;

use common::{claim_domain, participant};
use ros2_client::dds::rustdds::{policy, QosPolicyBuilder, TopicKind};
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize, Debug)]
struct Probe {
    x: u32,
}

#[test]
fn a_late_reader_of_a_keep_last_writer_gets_only_the_newest_sample() {
    let (domain, _claim) = claim_domain();
    // rmw's ros_discovery_info QoS on both sides: reliable, transient local; the writer
    // keeps the last sample, the reader would take up to 10.
    let qos = |depth| {
        QosPolicyBuilder::new()
            .reliability(policy::Reliability::Reliable { max_blocking_time: ros2_client::dds::rustdds::Duration::ZERO })
            .durability(policy::Durability::TransientLocal)
            .history(policy::History::KeepLast { depth })
            .build()
    };
    let a = participant(domain);
    let topic = a
        .create_topic("naic_keep_last_probe".into(), "naic::Probe".into(), &qos(1), TopicKind::NoKey)
        .expect("create topic");
    let writer = a
        .create_publisher(&qos(1))
        .expect("create publisher")
        .create_datawriter_no_key_cdr::<Probe>(&topic, None)
        .expect("create writer");
    const WRITTEN: u32 = 5;
    for x in 1..=WRITTEN {
        writer.write(Probe { x }, None).expect("write a sample");
    }

    let b = participant(domain);
    let topic_b = b
        .create_topic("naic_keep_last_probe".into(), "naic::Probe".into(), &qos(10), TopicKind::NoKey)
        .expect("create topic in b");
    let mut reader = b
        .create_subscriber(&qos(10))
        .expect("create subscriber")
        .create_datareader_no_key_cdr::<Probe>(&topic_b, None)
        .expect("create reader");
    // Until the newest sample is in, then 1 s more for anything older to arrive.
    let mut got = Vec::new();
    let t0 = Instant::now();
    let mut newest_at = None;
    while t0.elapsed() < Duration::from_secs(10) && newest_at.is_none_or(|t: Instant| t.elapsed() < Duration::from_secs(1)) {
        while let Ok(Some(s)) = reader.take_next_sample() {
            let x = s.value().x;
            got.push(x);
            if x == WRITTEN {
                newest_at.get_or_insert_with(Instant::now);
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        got.contains(&WRITTEN),
        "precondition: the late reader never received the newest sample ({WRITTEN}) in 10 s; it got {got:?}"
    );
    assert_eq!(
        got,
        vec![WRITTEN],
        "a late reader of a KeepLast(1) transient-local writer got superseded samples (oldest first)"
    );
    drop((reader, writer, b, a));
}
