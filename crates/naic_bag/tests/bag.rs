//! Round trip, damage tolerance (seeded random cuts and flipped bytes) and repair.

use naic_bag::sample::{cycle, write_sample, T0_NS};
use naic_bag::*;
use naic_core::rng::Rng;
use naic_msgs::*;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("naic_bag_test_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

const RATE: f64 = 1000.0;

/// Small chunks so that damage tests see many chunks.
fn write_small_chunks(path: &std::path::Path, cycles: u64) -> Vec<u64> {
    // returns the file offset after which each chunk is complete is not known here;
    // instead we rely on flush to close a chunk every `per` cycles.
    let mut w = BagWriter::create(path).unwrap();
    w.set_flush_interval(std::time::Duration::from_secs(3600));
    let js = w.add_topic::<JointState>("/joint_states", Qos::default()).unwrap();
    let pa = w.add_topic::<NaicParams>("/naic/params", Qos::default()).unwrap();
    let mut sizes = Vec::new();
    for i in 0..cycles {
        let c = cycle(i, RATE);
        w.write(js, &c.joint_states, c.stamp_ns + 100, c.stamp_ns).unwrap();
        w.write(pa, &c.params, c.stamp_ns + 200, c.stamp_ns).unwrap();
        if i % 50 == 49 {
            w.flush().unwrap();
            sizes.push(std::fs::metadata(path).unwrap().len());
        }
    }
    w.finish().unwrap();
    sizes
}

#[test]
fn round_trip_every_value_and_time() {
    let p = tmp("round_trip.mcap");
    let n = write_sample(&p, 2000, RATE, |_| {}).unwrap();
    assert_eq!(n, 8000);
    let bag = Bag::open(&p).unwrap();
    assert!(bag.is_indexed());
    assert!(bag.damage().is_empty(), "{:?}", bag.damage());
    assert_eq!(bag.profile(), "ros2");
    assert_eq!(bag.message_count(), 8000);
    let topics = bag.topics();
    assert_eq!(topics.len(), 4);
    assert!(topics.iter().all(|t| t.count == 2000));
    assert_eq!(
        topics.iter().find(|t| t.topic == "/naic/params").unwrap().type_hash,
        type_hash(NaicParams::type_info())
    );
    let js = bag.messages::<JointState>("/joint_states", ..).unwrap();
    let wr = bag.messages::<WrenchStamped>("/wrench", ..).unwrap();
    let ef = bag.messages::<Float64MultiArray>("/joint_effort_cmd", ..).unwrap();
    let pa = bag.messages::<NaicParams>("/naic/params", ..).unwrap();
    assert_eq!((js.len(), wr.len(), ef.len(), pa.len()), (2000, 2000, 2000, 2000));
    for i in 0..2000u64 {
        let c = cycle(i, RATE);
        let k = i as usize;
        assert_eq!(js[k].msg, c.joint_states);
        assert_eq!(wr[k].msg, c.wrench);
        assert_eq!(ef[k].msg, c.effort);
        assert_eq!(pa[k].msg, c.params);
        assert_eq!(js[k].publish_time, c.stamp_ns);
        assert_eq!(js[k].log_time, c.stamp_ns + 150_000);
        assert_eq!(js[k].sequence, i as u32 + 1);
    }
    // The same in one pass as typed vectors.
    let run = RunData::load(&bag, ..);
    assert_eq!(run.joint_states, js);
    assert_eq!(run.wrench, wr);
    assert_eq!(run.effort_cmd, ef);
    assert_eq!(run.params, pa);
    assert!(run.naic_effort.is_empty() && run.clock.is_empty());
    // Time range: cycles 100..=199 by log time.
    let lo = T0_NS + 100_000_000;
    let hi = T0_NS + 199_000_000 + 150_000;
    let part = bag.messages::<JointState>("/joint_states", lo..=hi).unwrap();
    assert_eq!(part.len(), 100);
    assert_eq!(part[0].msg, cycle(100, RATE).joint_states);
    // Clear errors for a wrong topic or type.
    let e = bag.messages::<JointState>("/nope", ..).unwrap_err().to_string();
    assert!(e.contains("/nope") && e.contains("/joint_states"), "{e}");
    let e = bag.messages::<JointState>("/wrench", ..).unwrap_err().to_string();
    assert!(e.contains("geometry_msgs/msg/WrenchStamped"), "{e}");
    // The rosbag2 metadata record is there.
    let md = bag.metadata().iter().find(|(n, _)| n == "rosbag2").expect("rosbag2 metadata");
    let y = &md.1["serialized_metadata"];
    assert!(y.contains("message_count: 8000"), "{y}");
}

#[test]
fn not_mcap_is_a_clear_error() {
    let p = tmp("not.mcap");
    std::fs::write(&p, b"joint,velocity\n1,2\n").unwrap();
    let e = Bag::open(&p).err().unwrap().to_string();
    assert!(e.contains("not an MCAP"), "{e}");
    let e = Bag::open(tmp("missing.mcap")).err().unwrap().to_string();
    assert!(e.contains("could not read"), "{e}");
}

#[test]
fn truncation_at_random_points_recovers_every_complete_chunk() {
    let p = tmp("cut_src.mcap");
    let cycles = 1000;
    let sizes = write_small_chunks(&p, cycles);
    let full = std::fs::read(&p).unwrap();
    let mut rng = Rng::seed(0x5eed_1234);
    let mut cuts: Vec<usize> = (0..150).map(|_| (rng.next_u64() as usize) % full.len()).collect();
    cuts.extend([0, 1, 7, 8, 9, 20, full.len() - 1, full.len() - 8, full.len() - 9]);
    for cut in cuts {
        let r = Bag::from_bytes("cut.mcap", full[..cut].to_vec());
        if cut < 8 {
            assert!(r.is_err(), "cut {cut}: should be not-MCAP");
            continue;
        }
        let bag = r.unwrap_or_else(|e| panic!("cut {cut}: {e}"));
        let js = bag.messages::<JointState>("/joint_states", ..);
        // Every message in a chunk that was completely on disk before the cut is recovered
        // (each flush ended a chunk at a known file size), in order, with exact values.
        let complete_chunks = sizes.iter().filter(|&&s| (s as usize) <= cut).count();
        let must = complete_chunks as u64 * 50;
        let got = match js {
            Ok(v) => v,
            Err(e) => {
                assert_eq!(must, 0, "cut {cut}: {e}");
                continue;
            }
        };
        assert!(got.len() as u64 >= must, "cut {cut}: got {} < {must}", got.len());
        for (k, m) in got.iter().enumerate() {
            assert_eq!(m.msg, cycle(k as u64, RATE).joint_states, "cut {cut} msg {k}");
        }
        if cut < full.len() {
            assert!(!bag.damage().is_empty(), "cut {cut}: damage not reported");
        }
    }
}

#[test]
fn flipped_bytes_never_panic_and_keep_intact_chunks() {
    let p = tmp("flip_src.mcap");
    let cycles = 1000;
    let sizes = write_small_chunks(&p, cycles);
    let full = std::fs::read(&p).unwrap();
    let mut rng = Rng::seed(0xF11b_0042);
    for trial in 0..200 {
        let mut d = full.clone();
        let nflip = 1 + (rng.next_u64() % 4) as usize;
        let mut first = usize::MAX;
        for _ in 0..nflip {
            let at = 8 + (rng.next_u64() as usize) % (d.len() - 8);
            d[at] ^= 1 << (rng.next_u64() % 8);
            first = first.min(at);
        }
        let bag = match Bag::from_bytes("flip.mcap", d) {
            Ok(b) => b,
            Err(e) => panic!("trial {trial}: open failed: {e}"),
        };
        let got = match bag.messages::<JointState>("/joint_states", ..) {
            Ok(v) => v,
            Err(e) => {
                // Only acceptable if the damage hit the channel definitions in the first chunk.
                assert!(first < sizes[0] as usize, "trial {trial}: {e}");
                continue;
            }
        };
        // Messages decode to exactly what was written, or are dropped; never wrong values.
        for m in &got {
            let i = (m.publish_time - T0_NS) / 1_000_000;
            assert_eq!(m.msg, cycle(i, RATE).joint_states, "trial {trial}");
        }
        // All chunks that end before the first flipped byte are recovered.
        let before = sizes.iter().filter(|&&s| (s as usize) <= first).count() as u64 * 50;
        assert!(got.len() as u64 >= before, "trial {trial}: {} < {before}", got.len());
    }
}

#[test]
fn repair_writes_a_clean_indexed_copy() {
    let p = tmp("repair_src.mcap");
    write_small_chunks(&p, 600);
    let full = std::fs::read(&p).unwrap();
    let cut = full.len() * 2 / 3;
    let damaged = tmp("repair_cut.mcap");
    std::fs::write(&damaged, &full[..cut]).unwrap();
    let before = Bag::open(&damaged).unwrap();
    assert!(!before.is_indexed());
    let n_before = before.messages::<JointState>("/joint_states", ..).unwrap().len();
    assert!(n_before >= 300);
    let out = tmp("repair_out.mcap");
    let rep = repair(&damaged, &out).unwrap();
    assert!(!rep.damage.is_empty());
    let fixed = Bag::open(&out).unwrap();
    assert!(fixed.is_indexed());
    assert!(fixed.damage().is_empty(), "{:?}", fixed.damage());
    let js = fixed.messages::<JointState>("/joint_states", ..).unwrap();
    assert_eq!(js.len(), n_before);
    for (k, m) in js.iter().enumerate() {
        assert_eq!(m.msg, cycle(k as u64, RATE).joint_states);
    }
    let src = Bag::open(&p).unwrap();
    assert_eq!(fixed.topics().iter().map(|t| (&t.topic, &t.type_name, &t.type_hash)).collect::<Vec<_>>(),
               src.topics().iter().map(|t| (&t.topic, &t.type_name, &t.type_hash)).collect::<Vec<_>>());
    // Refuses to overwrite its input.
    assert!(repair(&damaged, &damaged).is_err());
}

#[test]
fn periodic_flush_limits_loss_on_crash() {
    // Simulate a crash: copy the file while the writer is still open.
    let p = tmp("crash.mcap");
    let mut w = BagWriter::create(&p).unwrap();
    w.set_flush_interval(std::time::Duration::from_millis(0)); // flush on every write
    let js = w.add_topic::<JointState>("/joint_states", Qos::default()).unwrap();
    for i in 0..300 {
        let c = cycle(i, RATE);
        w.write(js, &c.joint_states, c.stamp_ns, c.stamp_ns).unwrap();
    }
    let snapshot = std::fs::read(&p).unwrap();
    drop(w);
    let bag = Bag::from_bytes("crash.mcap", snapshot).unwrap();
    assert!(!bag.is_indexed());
    assert_eq!(bag.messages::<JointState>("/joint_states", ..).unwrap().len(), 300);
}

#[test]
fn garbage_and_hostile_headers_never_panic() {
    let mut rng = Rng::seed(0xBAD_5EED);
    // Random bytes after the magic.
    for len in [8usize, 9, 17, 100, 1000, 20000] {
        for _ in 0..20 {
            let mut d = MAGIC.to_vec();
            d.extend((0..len).map(|_| rng.next_u64() as u8));
            if let Ok(bag) = Bag::from_bytes("garbage.mcap", d) {
                let _ = bag.messages::<JointState>("/joint_states", ..);
                let _ = bag.decode_all(..);
                let _ = bag.topics();
            }
        }
    }
    // A real file whose first chunk claims 2^40 or 2^31 uncompressed bytes: reported, not
    // allocated; the other chunks still read.
    let p = tmp("hostile.mcap");
    write_small_chunks(&p, 100);
    let clean = std::fs::read(&p).unwrap();
    // the header record (opcode 0x01) comes first; the first chunk record follows it
    let hlen = u64::from_le_bytes(clean[9..17].try_into().unwrap()) as usize;
    let pos = 8 + 9 + hlen;
    assert_eq!(clean[pos], 0x06);
    for claim in [1u64 << 40, 1u64 << 31] {
        let mut d = clean.clone();
        // chunk body: start u64, end u64, uncompressed_size u64
        d[pos + 9 + 16..pos + 9 + 24].copy_from_slice(&claim.to_le_bytes());
        let bag = Bag::from_bytes("hostile.mcap", d).unwrap();
        let js = bag.messages::<JointState>("/joint_states", ..).unwrap();
        assert_eq!(js.len(), 50, "claim {claim}");
        assert_eq!(js[0].msg, cycle(50, RATE).joint_states);
        assert!(bag.damage().iter().any(|x| x.message.contains("claims")), "{:?}", bag.damage());
    }
}

/// Offset of the first record with `opcode` after the header record and the first chunk.
fn first_after_first_chunk(d: &[u8], opcode: u8) -> usize {
    let le = |p: usize| u64::from_le_bytes(d[p + 1..p + 9].try_into().unwrap()) as usize;
    let mut p = 8 + 9 + le(8); // past the header record
    assert_eq!(d[p], 0x06, "first chunk");
    p += 9 + le(p);
    while d[p] != opcode {
        p += 9 + le(p);
    }
    p
}

#[test]
fn intact_files_are_read_through_their_index() {
    // With an intact summary the chunks are reached through the chunk index (the mcap
    // crate's reader): garbage between chunks in the data section is never visited, so it
    // is neither reported nor in the way. (The record walk used for damaged files would
    // stop at it and report it.)
    let p = tmp("indexed.mcap");
    write_small_chunks(&p, 200);
    let mut d = std::fs::read(&p).unwrap();
    let at = first_after_first_chunk(&d, 0x07); // a message index record
    d[at] = 0x55; // an opcode MCAP does not have
    let bag = Bag::from_bytes("indexed.mcap", d.clone()).unwrap();
    assert!(bag.is_indexed());
    assert!(bag.damage().is_empty(), "{:?}", bag.damage());
    assert_eq!(bag.messages::<JointState>("/joint_states", ..).unwrap().len(), 200);
    // The same bytes without the summary go through the record walk, which reports it and
    // still finds every message.
    let footer_cut = d.len() - 8;
    d.truncate(footer_cut);
    let walked = Bag::from_bytes("walked.mcap", d).unwrap();
    assert!(!walked.is_indexed());
    assert!(walked.damage().iter().any(|x| x.message.contains("invalid record opcode 0x55")), "{:?}", walked.damage());
    let js = walked.messages::<JointState>("/joint_states", ..).unwrap();
    assert_eq!(js.len(), 200);
    assert_eq!(js[199].msg, cycle(199, RATE).joint_states);
}

#[test]
fn a_summary_without_chunk_indexes_is_read_by_walking_the_records() {
    // Another writer's choice (the mcap crate, chunk indexes off): the summary still gives
    // topics and counts, the chunks are found by walking the data section, no damage.
    let p = tmp("no_chunk_index.mcap");
    let f = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").emit_chunk_indexes(false).chunk_size(Some(4096)).create(f).unwrap();
    let info = JointState::type_info();
    let schema = w.add_schema(info.name, "ros2msg", schema_text(info).as_bytes()).unwrap();
    let ch = w.add_channel(schema, "/joint_states", "cdr", &Default::default()).unwrap();
    for i in 0..300u64 {
        let c = cycle(i, RATE);
        let header = mcap::records::MessageHeader { channel_id: ch, sequence: i as u32, log_time: c.stamp_ns, publish_time: c.stamp_ns };
        w.write_to_known_channel(&header, &c.joint_states.to_cdr()).unwrap();
    }
    w.finish().unwrap();
    drop(w);
    let bag = Bag::open(&p).unwrap();
    assert!(bag.is_indexed());
    assert!(bag.damage().is_empty(), "{:?}", bag.damage());
    assert!(bag.chunk_count() > 1, "{} chunks", bag.chunk_count());
    assert_eq!(bag.message_count(), 300);
    let js = bag.messages::<JointState>("/joint_states", ..).unwrap();
    assert_eq!(js.len(), 300);
    for (k, m) in js.iter().enumerate() {
        assert_eq!(m.msg, cycle(k as u64, RATE).joint_states);
    }
}

#[test]
fn pose_stamped_targets_are_decoded_with_the_other_types() {
    let p = tmp("pose.mcap");
    let mut w = BagWriter::create(&p).unwrap();
    let tp = w.add_topic::<PoseStamped>("/naic/target_pose", Qos::default()).unwrap();
    let ck = w.add_topic::<Clock>("/clock", Qos::default()).unwrap();
    let target = |k: u32| PoseStamped {
        header: Header { stamp: Time { sec: 100, nanosec: k * 20_000_000 }, frame_id: "base_link".into() },
        pose: Pose {
            position: Point { x: -0.3 + 1e-4 * k as f64, y: -0.11, z: 0.075 },
            orientation: Quaternion { x: 0.0, y: 1.0, z: 0.0, w: 1e-3 * k as f64 },
        },
    };
    for k in 0..20u32 {
        w.write(tp, &target(k), 1_000 + 2 * k as u64, 1_000 + 2 * k as u64).unwrap();
        w.write(ck, &Clock { clock: Time { sec: k as i32, nanosec: 0 } }, 1_001 + 2 * k as u64, 0).unwrap();
    }
    w.finish().unwrap();
    let bag = Bag::open(&p).unwrap();
    let all = bag.decode_all(..);
    let poses: Vec<_> = all.iter().filter_map(|m| if let AnyMessage::PoseStamped(x) = &m.msg { Some(x.clone()) } else { None }).collect();
    assert_eq!(poses, (0..20).map(target).collect::<Vec<_>>());
    assert_eq!(all.len(), 40, "the clock is decoded beside them");
    assert!(bag.damage().is_empty(), "{:?}", bag.damage());
    let typed: Vec<_> = bag.messages::<PoseStamped>("/naic/target_pose", ..).unwrap().into_iter().map(|m| m.msg).collect();
    assert_eq!(typed, poses);
}
