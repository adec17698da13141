//! Issue 37 item 1: the three node shells' cores on the 7-joint Franka Panda
//! (`params/robots/panda.yaml`), chained in process as `naic launch --robot
//! params/robots/panda.yaml --composed --lockstep` runs them: the driver steps naic_sim's
//! Panda on the flat scenario placed relative to its start joints, naic_controller and
//! friction_compensation read `/joint_states` by the Panda's joint names and the command
//! carries seven torques in the robot file's joint order. No DDS and no clock: deterministic.

mod common;

use common::Chain;
use naic_controller::core::FaultReport;
use naic_core::pipeline::control::Phase;
use naic_ros::alloc_check::{counted, CountingAlloc};

#[global_allocator]
static A: CountingAlloc = CountingAlloc;

const PANDA: &str = "params/robots/panda.yaml";
const NAMES: [&str; 7] = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7"];

/// Run the chain to simulated time `until` [s]; the force along n of each cycle after `from`.
fn run(c: &mut Chain<7>, from: f64, until: f64, allocations: &mut u64) -> Vec<(f64, f64, Phase)> {
    let mut out = Vec::new();
    while (c.now_ns() as f64) * 1e-9 < until {
        let (r, n) = counted(|| c.step(None, None));
        *allocations += n;
        let r = r.expect("a report every cycle");
        let t = r.stamp_ns as f64 * 1e-9;
        if t >= from {
            out.push((t, r.status.f_ext, r.status.phase));
        }
    }
    out
}

/// The Panda chain reaches contact on the flat surface and holds 10 N, with every cycle of
/// the three cores allocation-free; the names and the command are the robot file's.
#[test]
fn the_panda_chain_tracks_10_n_on_flat_by_joint_name_without_allocating() {
    let mut c = Chain::<7>::for_robot(Some(PANDA), &["scenario:=flat"], &[]);
    assert_eq!(c.cp.joints, NAMES);
    // A few cycles first: the message buffers take their size once.
    for _ in 0..5 {
        c.step(None, None).unwrap();
    }
    assert_eq!(c.state.js.name, NAMES, "the driver publishes the Panda's names");
    assert_eq!(c.last_command().len(), 7, "seven torques on /joint_effort_cmd");
    let mut allocations = 0;
    let s = run(&mut c, 2.0, 3.0, &mut allocations);
    assert_eq!(allocations, 0, "the cycles allocated");
    assert!(s.iter().all(|x| x.2 == Phase::Contact), "in contact for the whole second");
    let mean = s.iter().map(|x| x.1).sum::<f64>() / s.len() as f64;
    let worst = s.iter().map(|x| (x.1 - 10.0).abs()).fold(0.0, f64::max);
    eprintln!("Panda, flat, t 2-3 s: mean force {mean:.3} N, largest |f - 10 N| {worst:.3} N over {} cycles", s.len());
    // The DDS test's tolerance (tests/python/test_ros_robot.py): the mean within 0.2 N.
    assert!((mean - 10.0).abs() < 0.2, "mean force {mean} N");
}

/// A `/joint_states` that lacks one of the robot file's joints (a renamed joint): the
/// controller holds the arm (a sensor fault, no force control) and resumes when the name is
/// back; never a torque computed from the wrong joint.
#[test]
fn a_missing_panda_joint_name_holds_and_is_reported() {
    let mut c = Chain::<7>::for_robot(Some(PANDA), &["scenario:=flat"], &[]);
    let mut allocations = 0;
    run(&mut c, 10.0, 1.5, &mut allocations);
    let r = c.step_with(None, None, |js| js.name[3] = "panda_joint4".into()).unwrap();
    assert!(matches!(r.fault, Some(FaultReport::Sensor(_))), "{:?}", r.fault);
    assert_eq!(r.status.phase, Phase::Hold);
    for _ in 0..50 {
        let r = c.step(None, None).unwrap();
        assert_eq!(r.status.phase, Phase::Hold, "held while the name is missing");
    }
    let r = c.step_with(None, None, |js| js.name[3] = NAMES[3].into()).unwrap();
    assert_eq!(r.fault, None, "the name is back: no fault");
}
