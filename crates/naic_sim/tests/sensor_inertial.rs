//! The own plant's F/T reading includes the tool's inertial wrench (issue 36 item 4): the
//! sensor frame's acceleration the plant takes from its forward dynamics must be the one
//! its trajectory has. Checked against central differences of the sensor frame's pose
//! along an open-loop swing (both wrist joints driven), and the inertial part must be
//! large against the tolerance (so the check can fail).

use naic_core::dynamics;
use naic_core::model::{Data6, Model};
use naic_sim::environment::{Environment, Material, MaterialMap};
use naic_sim::plant::{self, Integrator, PlantParams, PlantState, PlantWorkspace};
use naic_sim::rng::Rng;
use naic_sim::sensor::{tool_inertia_from_urdf, Encoders, Mini45, SensorMotion};
use nalgebra::{Rotation3, Vector3, Vector6};

const URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/jk5.urdf");

#[test]
fn the_plants_sensor_acceleration_matches_its_trajectory_and_the_inertial_wrench_is_read() {
    let m = Model::from_urdf_file(URDF).unwrap();
    let ft = Mini45 {
        inertial: true,
        ..Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(1))
            .ideal()
            .with_tool_inertia(tool_inertia_from_urdf(std::path::Path::new(URDF)).unwrap())
    };
    let env = Environment { enabled: false, ..Environment::horizontal(0.0, MaterialMap::Uniform(Material { k_e: 0.0, b_e: 0.0, mu: 0.0 })) };
    let dt = 1e-3;
    let p = PlantParams::new(m.clone(), None, Integrator::Rk4, dt, 10, env, ft.clone(), Encoders::ideal()).unwrap();
    let mut ws = PlantWorkspace::new(&p);
    let q0 = [0.0, 0.3, 1.8, 0.0, 1.0, 0.0];
    let mut s = PlantState::at_rest(q0, 0);
    let mut d = Data6::try_new(&m).unwrap();
    let sensor = m.frame_id("ft_sensor").unwrap();
    let tip = m.frame_id("tip").unwrap();
    // Gravity compensated at the current pose plus smooth torques on joints 4-6: the
    // wrist swings and the tool spins.
    let n = 400;
    let (mut poses, mut wrenches) = (Vec::new(), Vec::new());
    for k in 0..n {
        let t = k as f64 * dt;
        let mut tau: [f64; 6] = (*dynamics::gravity_torques(&m, &mut d, &Vector6::from(s.q))).into();
        tau[3] += 0.15 * (8.0 * t).sin();
        tau[4] += 0.2 * (6.0 * t).sin();
        tau[5] += 0.03 * (10.0 * t).sin();
        let (next, obs) = plant::step(&p, &s, &tau, &mut ws);
        s = next;
        dynamics::forward_kinematics(&m, &mut d, &Vector6::from(s.q));
        let (o, c) = (*d.frame_se3(sensor), *d.frame_se3(tip));
        poses.push((Rotation3::from_matrix_unchecked(o.rot), o.trans, c.trans - o.trans));
        wrenches.push(obs.truth.wrench_true);
    }
    let (mut worst, mut biggest) = (0.0f64, 0.0f64);
    for k in 2..n - 2 {
        let (r, p0, r_tip) = poses[k];
        let accel = (poses[k + 1].1 - 2.0 * p0 + poses[k - 1].1) / (dt * dt);
        let omega_at = |j: usize| (poses[j + 1].0 * poses[j - 1].0.inverse()).scaled_axis() / (2.0 * dt);
        let omega = omega_at(k);
        let alpha = (omega_at(k + 1) - omega_at(k - 1)) / (2.0 * dt);
        let want = ft.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &SensorMotion { accel, omega, alpha });
        let rest = ft.true_wrench(&r, &r_tip, &Vector3::zeros());
        for i in 0..6 {
            worst = worst.max((wrenches[k][i] - want[i]).abs());
            biggest = biggest.max((wrenches[k][i] - rest[i]).abs());
        }
    }
    // The torque of a period is held over it, so the plant's acceleration at a sample and the
    // central difference around it differ by the torque's change over one period: small.
    eprintln!("worst {worst} biggest {biggest}");
    assert!(worst < 5e-3, "plant's inertial wrench vs the trajectory's: worst {worst}");
    assert!(biggest > 20.0 * worst && biggest > 0.05, "inertial part {biggest} against the tolerance {worst}");
}
