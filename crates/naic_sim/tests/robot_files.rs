//! Robot files in the simulator (issue 37): scenarios placed relative to the arm, and a
//! 7-joint closed loop from `params/robots/panda.yaml`.

use naic_core::pipeline::control::force_law::Mode;
use naic_core::robot_file::Robot;
use naic_core::task::{self, TaskError};
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::plants::PlantChoice;
use naic_sim::{runner, scenario};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn robot(file: &str) -> Robot {
    Robot::load_with_env(&root().join(file), &|_| None).unwrap()
}

#[test]
fn the_relative_rule_puts_the_jk5_surface_where_the_paper_has_it() {
    // Independent of the rule: the paper's §4.1 table is at z = 0.08 m with the force along −z.
    let r = robot("params/robots/jk5.yaml");
    let paper = task::preset("flat", &r.model).unwrap();
    let rel = task::preset_relative::<6>("flat", &r.model, paper.q0).unwrap();
    assert_eq!(rel.force_axis, -Vector3::z());
    assert!((rel.surface - paper.surface).abs() < 1e-3, "{} vs {}", rel.surface, paper.surface);
    assert!((rel.ramp.from.z - paper.ramp.from.z).abs() < 1e-3);
    assert_eq!(rel.f_d_steps, paper.f_d_steps);
    assert_eq!(rel.duration, paper.duration);
}

#[test]
fn the_panda_task_starts_under_its_tip_and_crosses_the_front_of_the_arm() {
    let r = robot("params/robots/panda.yaml");
    let q0: [f64; 7] = std::array::from_fn(|i| r.start_q.as_ref().unwrap()[i]);
    let (p0, _) = task::tip_pose(&r.model, &q0);
    let t = task::preset_relative::<7>("flat", &r.model, q0).unwrap();
    assert_eq!(t.force_axis, -Vector3::z());
    assert!((t.surface - (p0.z - 0.167)).abs() < 1e-12);
    assert!((t.ramp.from - Vector3::new(p0.x, p0.y, p0.z - 0.197)).norm() < 1e-12);
    // p0.y = -0.225 is nearer 0 than p0.x = 0.45: the path runs along +y.
    assert!((t.ramp.to - t.ramp.from - Vector3::new(0.0, 0.45, 0.0)).norm() < 1e-12);
    // The two-material boundary is the JK5 table's: refused, not misplaced.
    assert!(scenario::preset_relative::<7>("two-material", &r.model, q0).is_err());
}

#[test]
fn a_start_that_does_not_point_the_tool_along_an_axis_or_leaves_the_reach_is_refused() {
    let r = robot("params/robots/panda.yaml");
    let mut q: [f64; 7] = std::array::from_fn(|i| r.start_q.as_ref().unwrap()[i]);
    q[5] -= 0.5; // tilt the wrist by ~29°
    match task::preset_relative::<7>("flat", &r.model, q) {
        Err(TaskError::ToolAxis { angle_deg, .. }) => assert!(angle_deg > 10.0),
        other => panic!("{other:?}"),
    }
    // Stretched out: the tip straight down at 0.8 m has no room for the 0.45 m path.
    let q_far = [0.0, 0.9, 0.0, -0.5, 0.0, 1.4 + 0.0, 0.785];
    let e = task::preset_relative::<7>("flat", &r.model, q_far).unwrap_err();
    assert!(matches!(e, TaskError::OutOfReach { .. } | TaskError::ToolAxis { .. }), "{e}");
}

#[test]
fn the_panda_tracks_10_n_on_the_flat_scenario_with_the_scheduled_law() {
    let r = robot("params/robots/panda.yaml");
    let q0: [f64; 7] = std::array::from_fn(|i| r.start_q.as_ref().unwrap()[i]);
    let mut s = scenario::preset_relative::<7>("flat", &r.model, q0).unwrap();
    s.task.duration = 2.9; // the 10 N phase only
    let mut plant = scenario::plant_for(&s, r.model.clone(), None, r.tool_tuple()).unwrap();
    scenario::apply_sensor_spec(&mut plant, &r.sensor);
    let settings = LoopSettings { delay_cycles: 1, ..LoopSettings::default() };
    let mut c = PipelineController::<7>::new(Mode::Scheduled, &s, &r.model, None, r.tool.mass, r.tool.com, &settings).unwrap();
    let mut p = PlantChoice::Own.build_n::<7>(&plant, &q0, s.seed).unwrap();
    let run = runner::run_on(&s, &mut *p, &mut c, &mut |_| {});
    assert!(!run.limit_violation && !run.saturated);
    let ph = &run.metrics.phases[0];
    assert!(ph.overshoot_pct <= 5.0, "overshoot {} %", ph.overshoot_pct);
    assert!(ph.settling_time_2pct_s.is_some_and(|t| t <= 0.15), "settling {:?}", ph.settling_time_2pct_s);
    let last = run.records.last().unwrap();
    assert!((last.f_ext - 10.0).abs() < 0.2, "{} N", last.f_ext);
    // The arm's 7 joints move (the null-space posture keeps the elbow, the tip follows the path).
    assert_eq!(last.q.len(), 7);
    assert!((last.tip[1] - (s.task.ramp.from.y + 0.09 * last.t)).abs() < 0.01, "tip y {}", last.tip[1]);
    // A MuJoCo plant for another arm is refused, not run on the JK5's MJCF.
    assert!(PlantChoice::Mujoco { mjcf: "x.xml".into() }.build_n::<7>(&plant, &q0, 1).is_err());
}
