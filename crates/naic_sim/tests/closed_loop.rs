//! The closed loop on the paper's scenarios: deterministic, tracks the force,
//! and the implicit friction keeps a resting arm at rest.

use naic_core::friction::FrictionModel;
use naic_core::model::Model;
use naic_core::JointVec;
use naic_core::pipeline::control::force_law::Mode;
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::environment::{Environment, Material, MaterialMap};
use naic_sim::plant::{self, Integrator, PlantParams, PlantState, PlantWorkspace};
use naic_sim::rng::Rng;
use naic_sim::runner;
use naic_sim::scenario::{self, deg, tip_pose, Q0_FLAT_DEG};
use naic_sim::sensor::{Encoders, Mini45};
use nalgebra::{Vector3, Vector6};

/// Root of an increasing function on a range by bisection.
trait Bisect {
    fn step_by_bisect(self, f: impl Fn(f64) -> f64) -> f64;
}
impl Bisect for std::ops::Range<f64> {
    fn step_by_bisect(self, f: impl Fn(f64) -> f64) -> f64 {
        let (mut a, mut b) = (self.start, self.end);
        for _ in 0..200 {
            let c = 0.5 * (a + b);
            if f(c) > 0.0 { b = c } else { a = c }
        }
        0.5 * (a + b)
    }
}

mod common;

use common::{friction, model};

fn plant_for(s: &scenario::Scenario, m: &Model, f: Option<FrictionModel>) -> PlantParams {
    let ft = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(s.seed));
    let mut p = PlantParams::new(m.clone(), f, Integrator::ImplicitFriction, s.task.dt, 1, s.env.clone(), ft, Encoders::default()).unwrap();
    p.substeps = p.substeps_for_contact(&s.task.q0, s.task.dt);
    p
}

#[test]
fn initial_pose_is_above_the_surface_with_the_tool_down() {
    let m = model();
    let (p, r) = tip_pose(&m, &deg(Q0_FLAT_DEG));
    assert!((p - Vector3::new(-0.284, -0.1135, 0.2470608)).norm() < 1e-6, "{p:?}");
    assert!(p.z > 0.08);
    // the tool axis (tip frame z) points straight down
    assert!((r * Vector3::z() + Vector3::z()).norm() < 1e-9);
    // foam / two-material start 0.538 m above the base, tool down
    for name in ["foam", "two-material"] {
        let s = scenario::preset(name, &m).unwrap();
        let (p, r) = tip_pose(&m, &s.task.q0);
        assert!((p.z - 0.538).abs() < 1e-9 && (r * Vector3::z() + Vector3::z()).norm() < 1e-9);
    }
}

#[test]
fn flat_closed_loop_is_deterministic_and_tracks_the_force() {
    let m = model();
    let mut s = scenario::preset("flat", &m).unwrap();
    s.task.duration = 3.0;
    let p = plant_for(&s, &m, Some(friction()));
    let run = |seed: u64| {
        let mut s = s.clone();
        s.seed = seed;
        let mut c = PipelineController::new(Mode::Fixed, &s, &m, Some(friction()), 0.424, Vector3::new(0.0, 0.0, 0.015), &LoopSettings::default()).unwrap();
        runner::run(&s, &p, &mut c, &mut |_| {})
    };
    let a = run(1);
    let b = run(1);
    assert_eq!(a.records, b.records, "same seed, same run");
    let c = run(2);
    assert_ne!(a.records, c.records, "another seed changes the noise");
    // contact happens, and the force ends within 5 % of f_d = 10 N
    let t_c = a.metrics.contact_time_s.expect("contact");
    assert!(t_c > 0.5 && t_c < 2.5, "contact at {t_c}");
    let last = a.records.last().unwrap();
    assert!((last.f_ext - 10.0).abs() < 0.5, "final force {}", last.f_ext);
    assert!(!a.limit_violation);
    // the controller's estimate of f_ext (tared sensor) agrees with the truth in contact
    let r = &a.records[a.records.len() - 500];
    assert!((r.f_ext_est - r.f_ext).abs() < 0.3, "estimate {} vs truth {}", r.f_ext_est, r.f_ext);
}

#[test]
fn implicit_friction_holds_a_resting_arm_and_breaks_away_above_friction() {
    let m = model();
    let env = Environment { enabled: false, ..Environment::horizontal(0.0, MaterialMap::Uniform(Material { k_e: 0.0, b_e: 0.0, mu: 0.0 })) };
    let ft = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(1)).ideal();
    let f = friction();
    let p = PlantParams::new(m.clone(), Some(f.clone()), Integrator::ImplicitFriction, 1e-3, 1, env, ft, Encoders::ideal()).unwrap();
    let q0 = deg(Q0_FLAT_DEG);
    let mut d = naic_core::model::Data6::try_new(&m).unwrap();
    let g = *naic_core::dynamics::gravity_torques(&m, &mut d, &Vector6::from(q0));
    // gravity compensated plus ±half the breakaway torque of each joint, flipping
    // every period: the arm must stay put (no chatter, no drift)
    let mut ws = PlantWorkspace::new(&p);
    let mut s = PlantState::at_rest(q0, 1);
    let half: JointVec = std::array::from_fn(|i| 0.5 * f.tau_f(i, 1e-2).abs().min(f.tau_f(i, -1e-2).abs()));
    for k in 0..500 {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let qv = Vector6::from(s.q);
        let g_now = *naic_core::dynamics::gravity_torques(&m, &mut d, &qv);
        let tau: JointVec = std::array::from_fn(|i| g_now[i] + sign * half[i]);
        s = plant::step(&p, &s, &tau, &mut ws).0;
        assert!(s.dq.iter().all(|v| v.abs() < 5e-3), "k = {k}: dq = {:?}", s.dq);
    }
    let drift = s.q.iter().zip(&q0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(drift < 1e-3, "drift {drift} rad");
    // 3× the friction level on joint 6 makes it move
    let mut s = PlantState::at_rest(q0, 1);
    let mut tau: JointVec = g.into();
    tau[5] += 3.0 * f.tau_f(5, 0.05);
    for _ in 0..100 {
        s = plant::step(&p, &s, &tau, &mut ws).0;
    }
    // steady sliding where τ_f(q̇) = τ: q̇ ≈ 1.17 rad/s for joint 6 of Table 1
    let expected = (0.0..5.0).step_by_bisect(|v| f.tau_f(5, v) - (tau[5] - g[5]));
    assert!((s.dq[5] - expected).abs() < 0.01 * expected, "joint 6 slides at {} rad/s, expected {expected}", s.dq[5]);
}

#[test]
fn scenario_presets_match_the_paper_settings() {
    let m = model();
    let flat = scenario::preset("flat", &m).unwrap();
    assert_eq!(flat.f_d(2.999), 10.0);
    assert_eq!(flat.f_d(3.0), 20.0);
    let r = flat.reference(0.0);
    assert!((r.p_d - Vector3::new(-0.3, -0.1135, 0.05)).norm() < 1e-12);
    assert!((flat.reference(5.0).p_d.x + 0.75).abs() < 1e-12);
    assert!((r.v_d[0] + 0.09).abs() < 1e-12, "0.45 m over 5 s");
    assert_eq!(flat.task.impedance.params.b_d, [500.0, 500.0, 40.0, 500.0, 500.0, 500.0]);
    assert_eq!(flat.task.impedance.params.k_contact[2], 0.0);
    assert_eq!(flat.task.impedance.sigma, 0.01);
    let ev = flat.events();
    assert_eq!(ev.len(), 1);
    assert_eq!(ev[0].t_start, 3.0);
    let st = scenario::preset("stiffness-step", &m).unwrap();
    let times: Vec<f64> = st.events().iter().map(|e| e.t_start).collect();
    assert_eq!(times, vec![2.0, 4.0]);
    // the chosen slope passes through the paper's contact point and meets 0.08 m at the path end
    let sl = scenario::preset("slope", &m).unwrap();
    let x_c = -0.3 - 0.09 * 0.621;
    assert!((sl.env.height_at(x_c, -0.1135) - 0.124).abs() < 1e-12);
    assert!((sl.env.height_at(-0.75, -0.1135) - 0.08).abs() < 1e-12);
    // foam and two-material: desired force 10 N / 3 N pushing = −10 N / −3 N along the sensor z (tool down)
    assert_eq!(scenario::preset("foam", &m).unwrap().f_d(5.0), 10.0);
    assert_eq!(scenario::preset("two-material", &m).unwrap().f_d(5.0), 3.0);
    assert!(scenario::preset("moon", &m).is_err());
}
