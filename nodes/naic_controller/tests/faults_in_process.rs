//! The sensor-fault sequence of the DDS test (`tests/ros/sensor_fault_probe.py`), in
//! process: the chain holds 10 N on `flat` with NAIC (the launch default), then the
//! driver plays a failing sensor for 1 s and a healthy one for 2 s, for each of a NaN
//! force, a 5 kN force, a frozen wrench and a NaN joint position, and the whole sequence
//! twice. Deterministic, so what the resume after a hold does is the same every run.
//!
//! Before a hold restarted the force law (`ControlState::hold`), the second resume
//! limit-cycled at 25 Hz with NAIC's weights at m_d = 0.05 kg, σ = 0.22, and joint 4
//! reached −6.8 rad/s, past its 6.28 rad/s limit, in the third fault's hold (docs/safety.md).

mod common;

use common::Chain;
use jk5_sim_driver::{plant::Plant, runner::SensorFault};
use naic_core::pipeline::control::Phase;

/// One answered cycle.
#[derive(Clone, Copy, Debug)]
struct Sample {
    phase: Phase,
    f: f64,
    fault: bool,
    tau_finite: bool,
    /// Largest |q̇| of the plant after the step [rad/s].
    dq_max: f64,
}

fn run_for(c: &mut Chain, seconds: f64) -> Vec<Sample> {
    let end = c.now_ns() + (seconds * 1e9) as i64;
    let mut out = Vec::new();
    while c.now_ns() < end {
        let r = c.step(None, None).expect("a report for every state in lockstep");
        let (_, dq, _) = c.plant.joints();
        out.push(Sample {
            phase: r.status.phase,
            f: r.status.f_ext,
            fault: r.fault.is_some(),
            tau_finite: c.last_command().iter().all(|t| t.is_finite()),
            dq_max: dq.iter().fold(0.0f64, |m, x| m.max(x.abs())),
        });
    }
    out
}

#[test]
fn every_sensor_fault_holds_and_force_control_resumes_without_a_spin() {
    let mut c = Chain::new(&["scenario:=flat"]);
    let before = run_for(&mut c, 3.0);
    assert!(before[2000..].iter().all(|s| s.phase == Phase::Contact && !s.fault), "no steady contact before the faults");
    for round in 0..2 {
        for fault in [SensorFault::NanWrench, SensorFault::AbsurdWrench, SensorFault::StaleWrench, SensorFault::NanJoint] {
            c.fault = fault;
            let held = run_for(&mut c, 1.0);
            c.fault = SensorFault::None;
            let rec = run_for(&mut c, 2.0);
            let what = format!("round {round}, {fault:?}");
            // Held from the first cycle (a frozen wrench: once wrench_timeout, 10 ms, has
            // passed), with finite commands throughout.
            let first_hold = held.iter().position(|s| s.phase == Phase::Hold).unwrap_or(usize::MAX);
            let allowed = if fault == SensorFault::StaleWrench { 11 } else { 0 };
            assert!(first_hold <= allowed, "{what}: first hold at cycle {first_hold}");
            assert!(held[first_hold..].iter().all(|s| s.phase == Phase::Hold && s.fault), "{what}: left the hold during the fault");
            assert!(held.iter().chain(&rec).all(|s| s.tau_finite), "{what}: a non-finite command");
            // Resumed: in contact and fault-free over the last second, the force within
            // 1 N of 10 N over the last half second, and no joint near a spin (the limit
            // is 6.28 rad/s; measured here: at most 1.0 rad/s).
            let worst = rec.iter().fold(0.0f64, |m, s| m.max(s.dq_max));
            let dev = rec[1500..].iter().fold(0.0f64, |m, s| m.max((s.f - 10.0).abs()));
            eprintln!("{what}: held from cycle {first_hold}; resumed with max |q̇| {worst:.2} rad/s, last 0.5 s |f - 10 N| <= {dev:.2} N");
            assert!(rec[1000..].iter().all(|s| s.phase == Phase::Contact && !s.fault), "{what}: not back in steady contact");
            // Measured: at most 0.76 N with the tare over the first 100 cycles; 1.33 N
            // (NanJoint) since the tare waits for rest, which starts force control 0.2 s later
            // on this plant: the NAIC transient after the eighth hold depends on that phase
            // (its 0.5 s windows after the resume: 1.21, 0.60, 1.33 N).
            assert!(dev < 1.5, "{what}: force not back at 10 N (measured: at most 1.33 N)");
            assert!(worst < 2.0, "{what}: |q̇| reached {worst} rad/s after the resume");
        }
    }
}
