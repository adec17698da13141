//! Contact physics of the full plant (URDF dynamics + contact + sensor):
//! static equilibrium, stiffness steps at the stated times.

use naic_core::dynamics;
use naic_core::model::{Data6, Model};
use naic_core::JointVec;
use naic_sim::environment::{Environment, Material, MaterialMap};
use naic_sim::plant::{self, Integrator, PlantParams, PlantState, PlantWorkspace};
use naic_sim::rng::Rng;
use naic_sim::scenario::{deg, inverse_kinematics, tip_pose, Q0_FLAT_DEG};
use naic_sim::sensor::{Encoders, Mini45};
use nalgebra::{Vector3, Vector6};

fn model() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/jk5.urdf");
    Model::from_urdf_file(path).expect("urdf/jk5.urdf loads")
}

fn plant(env: Environment, integrator: Integrator) -> PlantParams {
    let m = model();
    let ft = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(1)).ideal();
    PlantParams::new(m, None, integrator, 1e-3, 1, env, ft, Encoders::ideal()).unwrap()
}

/// Joints with the tip `depth` below z = 0.08 at (−0.4, −0.1135), tool down.
fn pressed_pose(m: &Model, depth: f64) -> JointVec {
    let q0 = deg(Q0_FLAT_DEG);
    let (_, r0) = tip_pose(m, &q0);
    let (q, err) = inverse_kinematics(m, &q0, &Vector3::new(-0.4, -0.1135, 0.08 - depth), &r0);
    assert!(err < 1e-9);
    q
}

/// The torque that balances gravity and a contact force `f` (N, along +z on the tip).
fn balancing_torque(m: &Model, q: &JointVec, f: f64) -> JointVec {
    let mut d = Data6::try_new(m).unwrap();
    let qv = Vector6::from(*q);
    let g = *dynamics::gravity_torques(m, &mut d, &qv);
    let j = *dynamics::frame_jacobian(m, &mut d, &qv, m.frame_id("tip").unwrap());
    let jl = j.fixed_rows::<3>(0).into_owned();
    (g - jl.transpose() * Vector3::new(0.0, 0.0, f)).into()
}

#[test]
fn static_equilibrium_force_is_k_e_times_penetration() {
    for k_e in [2000.0, 5000.0] {
        let env = Environment::horizontal(0.08, MaterialMap::Uniform(Material { k_e, b_e: 0.0, mu: 0.0 }));
        let p = plant(env, Integrator::SemiImplicitEuler);
        let depth = 0.005;
        let q = pressed_pose(&p.model, depth);
        let tau = balancing_torque(&p.model, &q, k_e * depth);
        let mut ws = PlantWorkspace::new(&p);
        let mut s = PlantState::at_rest(q, 1);
        let mut obs = plant::observe(&p, &s, &mut ws, [0.0; 6], false).1;
        for _ in 0..1000 {
            (s, obs) = plant::step(&p, &s, &tau, &mut ws);
        }
        // the arm stays put and the contact force is k_e × penetration
        let drift = s.q.iter().zip(&q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(drift < 1e-7, "joints drifted by {drift} rad");
        let c = obs.truth.contact;
        assert!((c.penetration - depth).abs() < 1e-7, "penetration {}", c.penetration);
        assert!((c.force.z - k_e * c.penetration).abs() < 1e-9);
        assert!((c.force.z - k_e * depth).abs() < 1e-3 * k_e * depth, "force {}", c.force.z);
        // the sensor (ideal) sees tool weight minus the contact force along its z (tool down)
        let w = obs.meas.wrench;
        assert!((w[2] - (0.424 * 9.81 - k_e * depth)).abs() < 1e-3, "Fz_sensor {}", w[2]);
    }
}

#[test]
fn wrong_balance_moves_the_arm() {
    // control for the test above: balancing half the contact force pushes the arm up
    let env = Environment::horizontal(0.08, MaterialMap::Uniform(Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 }));
    let p = plant(env, Integrator::SemiImplicitEuler);
    let q = pressed_pose(&p.model, 0.005);
    let tau = balancing_torque(&p.model, &q, 5.0);
    let mut ws = PlantWorkspace::new(&p);
    let mut s = PlantState::at_rest(q, 1);
    let mut obs = plant::observe(&p, &s, &mut ws, [0.0; 6], false).1;
    for _ in 0..50 {
        (s, obs) = plant::step(&p, &s, &tau, &mut ws);
    }
    assert!(obs.truth.tip_velocity.z > 1e-4, "the tip must be pushed up, v_z = {}", obs.truth.tip_velocity.z);
}

#[test]
fn stiffness_steps_take_effect_at_2_s_and_4_s() {
    let env = Environment::horizontal(
        0.08,
        MaterialMap::StiffnessSchedule {
            base: Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 },
            switches: vec![(2.0, 5000.0), (4.0, 2000.0)],
        },
    );
    let p = plant(env, Integrator::SemiImplicitEuler);
    let q = pressed_pose(&p.model, 0.005);
    // hold the pose with a stiff joint PD + gravity: force changes only with k_e
    let mut ws = PlantWorkspace::new(&p);
    let mut s = PlantState::at_rest(q, 1);
    let mut d = Data6::try_new(&p.model).unwrap();
    let mut log = Vec::new();
    for _ in 0..5000 {
        let qv = Vector6::from(s.q);
        let g = *dynamics::gravity_torques(&p.model, &mut d, &qv);
        let tau: JointVec = std::array::from_fn(|i| g[i] + 2.0e4 * (q[i] - s.q[i]) - 200.0 * s.dq[i]);
        let obs;
        (s, obs) = plant::step(&p, &s, &tau, &mut ws);
        log.push((s.t, obs.truth.contact.k_e, obs.truth.contact.force.z / obs.truth.contact.penetration));
    }
    for &(t, k, ratio) in &log {
        let expected = if t < 2.0 - 1e-9 || t >= 4.0 - 1e-9 { 2000.0 } else { 5000.0 };
        assert_eq!(k, expected, "k_e at t = {t}");
        assert!((ratio - expected).abs() < 1e-6 * expected, "F/d at t = {t}: {ratio}");
    }
    // the first sample at or after 2 s already has the new stiffness, the one before not
    let i2 = log.iter().position(|e| e.0 >= 2.0 - 1e-9).unwrap();
    assert!((log[i2].0 - 2.0).abs() < 1e-9 && log[i2].1 == 5000.0 && log[i2 - 1].1 == 2000.0);
}

#[test]
fn sim_arm_handle_matches_the_pure_step() {
    let env = Environment::horizontal(0.08, MaterialMap::Uniform(Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 }));
    let p = plant(env, Integrator::SemiImplicitEuler);
    let q = pressed_pose(&p.model, 0.005);
    let tau = balancing_torque(&p.model, &q, 10.0);
    let mut arm = naic_sim::arm::SimArm::new(p.clone(), q, 1);
    let mut ws = PlantWorkspace::new(&p);
    let mut s = PlantState::at_rest(q, 1);
    let mut obs = plant::observe(&p, &s, &mut ws, [0.0; 6], false).1;
    for _ in 0..10 {
        arm.step(&tau);
        (s, obs) = plant::step(&p, &s, &tau, &mut ws);
    }
    assert_eq!(arm.wrench(), obs.meas.wrench);
    assert_eq!(arm.joints().0, obs.meas.q);
    assert!((arm.time() - 0.01).abs() < 1e-12);
}
