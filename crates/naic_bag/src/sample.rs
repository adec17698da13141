//! A deterministic recording of the four naic topics, for tests and benchmarks
//! (`/joint_states`, `/wrench`, `/joint_effort_cmd`, `/naic/params`, one message each per cycle).

use crate::{BagError, BagWriter, Qos};
use naic_msgs::*;
use std::path::Path;

/// Stamp of cycle 0 [ns] (2023-11-14T22:13:20Z).
pub const T0_NS: u64 = 1_700_000_000_000_000_000;

/// The topics and types of a sample bag.
pub const TOPICS: [(&str, &str); 4] = [
    ("/joint_states", "sensor_msgs/msg/JointState"),
    ("/wrench", "geometry_msgs/msg/WrenchStamped"),
    ("/joint_effort_cmd", "std_msgs/msg/Float64MultiArray"),
    ("/naic/params", "naic_msgs/msg/NaicParams"),
];

/// One control cycle's messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    pub stamp_ns: u64,
    pub joint_states: JointState,
    pub wrench: WrenchStamped,
    pub effort: Float64MultiArray,
    pub params: NaicParams,
}

/// Deterministic pseudo-random number in [-1, 1) from (cycle, slot).
fn val(i: u64, k: u64) -> f64 {
    let mut x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 31;
    x = x.wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The messages of cycle `i` at `rate_hz`.
pub fn cycle(i: u64, rate_hz: f64) -> Cycle {
    let stamp_ns = T0_NS + (i as f64 * 1e9 / rate_hz).round() as u64;
    let header = |frame: &str| Header { stamp: Time::from_nanos(stamp_ns as i64), frame_id: frame.into() };
    let six = |k: u64| (0..6).map(|j| val(i, k * 8 + j)).collect::<Vec<f64>>();
    let joint_states = JointState {
        header: header(""),
        name: (1..=6).map(|j| format!("joint{j}")).collect(),
        position: six(1),
        velocity: six(2),
        effort: six(3),
    };
    let v3 = |k: u64| Vector3 { x: 20.0 * val(i, k), y: 20.0 * val(i, k + 1), z: 20.0 * val(i, k + 2) };
    let wrench = WrenchStamped { header: header("ft_sensor"), wrench: Wrench { force: v3(40), torque: v3(43) } };
    let effort = Float64MultiArray {
        layout: MultiArrayLayout { dim: vec![], data_offset: 0 },
        data: six(6).iter().map(|x| 30.0 * x).collect(),
    };
    let contact = i % 3000 > 500;
    let params = NaicParams {
        header: header("base_link"),
        mode: "naic".into(),
        phase: if contact { NaicParams::PHASE_CONTACT } else { NaicParams::PHASE_FREE },
        force_axis: 2,
        desired_force: 10.0,
        measured_force: 10.0 + val(i, 60),
        e_f: val(i, 60),
        m_d: 1.0 + 0.1 * val(i, 61),
        b_d: 50.0 + val(i, 62),
        k_d: if contact { 0.0 } else { 500.0 },
        sigma: 0.01 * (1.0 + val(i, 63)),
        phi: 1e-3 * val(i, 64),
        gamma: 1e-4,
        gamma_bound: 1.0 + val(i, 65).abs(),
        gamma_clipped: i % 7 == 0,
        fault: if i % 1000 == 999 { "wrench stale".into() } else { String::new() },
        fault_count: (i / 1000) as u32,
        ..Default::default()
    };
    Cycle { stamp_ns, joint_states, wrench, effort, params }
}

/// Writes `cycles` cycles at `rate_hz` to `path`; log time = stamp + 150 µs (the receive
/// time), publish time = stamp. Returns the number of messages written.
pub fn write_sample(path: &Path, cycles: u64, rate_hz: f64, mut each: impl FnMut(&Cycle)) -> Result<u64, BagError> {
    let mut w = BagWriter::create(path)?;
    let js = w.add_topic::<JointState>("/joint_states", Qos::default())?;
    let wr = w.add_topic::<WrenchStamped>("/wrench", Qos::sensor_data())?;
    let ef = w.add_topic::<Float64MultiArray>("/joint_effort_cmd", Qos::default())?;
    let pa = w.add_topic::<NaicParams>("/naic/params", Qos::default())?;
    for i in 0..cycles {
        let c = cycle(i, rate_hz);
        let log = c.stamp_ns + 150_000;
        w.write(js, &c.joint_states, log, c.stamp_ns)?;
        w.write(wr, &c.wrench, log + 1_000, c.stamp_ns)?;
        w.write(ef, &c.effort, log + 2_000, c.stamp_ns)?;
        w.write(pa, &c.params, log + 3_000, c.stamp_ns)?;
        each(&c);
    }
    let n = w.message_count();
    w.finish()?;
    Ok(n)
}
