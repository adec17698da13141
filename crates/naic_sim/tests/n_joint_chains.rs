//! No 6-joint assumption left in the 1 kHz path (issue 37): 3-, 6- and 7-joint
//! serial chains, each chosen at run time by its URDF's joint count through the one
//! dispatch point (`naic_core::with_joints!`), run the controller cycle with its
//! friction feedforward stage (the friction node's law, `pipeline::feedforward::step`)
//! and actuation limits, in closed loop with the simulator plant (implicit friction
//! solve, contact model), without touching the heap; the arm holds its start pose.

use naic_core::alloc_count::{counted, CountingAlloc};
use naic_core::friction::{FrictionModel, JointFriction, Smoothing, DEFAULT_V_S};
use naic_core::model::Model;
use naic_core::pipeline::actuate::ActuateParams;
use naic_core::pipeline::control::force_law::Mode;
use naic_core::pipeline::controller::{Controller, ControllerParams, Reference};
use naic_core::pipeline::{self, Pipeline};
use naic_core::{task, JointVec};
use naic_sim::environment::{Environment, Material, MaterialMap};
use naic_sim::plant::{self, Integrator, PlantParams, PlantState, PlantWorkspace};
use naic_sim::rng::Rng;
use naic_sim::sensor::{Encoders, Mini45};
use nalgebra::{Vector3, Vector6};

#[global_allocator]
static A: CountingAlloc = CountingAlloc;

/// A chain of `n` revolute joints (axes z, y, z, −y, z, −y, z, … as on a Panda-like arm),
/// links of 0.2–0.35 m with off-axis inertias, a tool, `ft_sensor` and `tip` frames.
fn chain_urdf(n: usize) -> String {
    let axes = ["0 0 1", "0 1 0", "0 0 1", "0 -1 0", "0 0 1", "0 -1 0", "0 0 1", "0 1 0"];
    let mut links = String::from(r#"<link name="base"/>"#);
    let mut joints = String::new();
    let mut parent = "base".to_string();
    for i in 0..n {
        let m = 3.0 - 0.3 * i as f64;
        let len = 0.35 - 0.02 * i as f64;
        links += &format!(
            r#"<link name="l{i}"><inertial><origin xyz="0.01 0.005 {c}"/><mass value="{m}"/><inertia ixx="{a}" ixy="0.001" ixz="0" iyy="{a}" iyz="0.0005" izz="{b}"/></inertial></link>"#,
            c = len / 2.0,
            a = m * len * len / 12.0 + 0.002,
            b = 0.004 + 0.001 * i as f64
        );
        let z = if i == 0 { 0.1 } else { 0.35 - 0.02 * (i - 1) as f64 };
        joints += &format!(
            r#"<joint name="joint_{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/><origin xyz="0 0 {z}"/><axis xyz="{ax}"/><limit lower="-2.9" upper="2.9" effort="{e}" velocity="2.5"/></joint>"#,
            ax = axes[i],
            e = 150.0 - 15.0 * i as f64
        );
        parent = format!("l{i}");
    }
    format!(
        r#"<robot name="chain{n}">{links}<link name="ft_sensor"/><link name="tool"><inertial><origin xyz="0 0 0.03"/><mass value="0.4"/><inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.0003"/></inertial></link><link name="tip"/>{joints}
<joint name="sensor_mount" type="fixed"><parent link="{parent}"/><child link="ft_sensor"/><origin xyz="0 0 0.3"/></joint>
<joint name="tool_mount" type="fixed"><parent link="ft_sensor"/><child link="tool"/><origin xyz="0 0 0.01"/></joint>
<joint name="tip_joint" type="fixed"><parent link="tool"/><child link="tip"/><origin xyz="0 0 0.1"/></joint></robot>"#
    )
}

/// What one chain's run showed.
#[derive(Debug)]
struct Outcome {
    joints: usize,
    allocations: u64,
    tip_drift_m: f64,
    max_tau: f64,
    friction_fed_forward: bool,
    posture_drift_rad: f64,
}

fn run<const N: usize>(model: Model) -> Outcome {
    let q0: JointVec<N> = std::array::from_fn(|i| [0.3, 0.6, -0.2, -1.2, 0.25, 1.1, 0.4, -0.3][i]);
    let law = |i: usize| JointFriction::CoulombViscous { f_c: 0.8 + 0.1 * i as f64, f_v: 0.3 };
    let friction = FrictionModel::new((0..N).map(law).collect()).unwrap().with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S }).unwrap();
    // A surface far below the arm: free space throughout (the contact model still runs).
    let env = Environment::horizontal(-5.0, MaterialMap::Uniform(Material { k_e: 5000.0, b_e: 10.0, mu: 0.0 }));
    let ft = Mini45::si_145_5(0.4, Vector3::new(0.0, 0.0, 0.04), &mut Rng::seed(3));
    let p = PlantParams::<N>::new(model.clone(), Some(friction.clone()), Integrator::ImplicitFriction, 1e-3, 2, env, ft, Encoders::default()).unwrap();
    let mut params = ControllerParams::<N>::paper_defaults(&model, Mode::Fixed, 0.0);
    params.tool.mass = 0.4;
    params.tool.com = Vector3::new(0.0, 0.0, 0.04);
    let controller = Controller::<N>::new(model.clone(), params).unwrap();
    let pipe = Pipeline::<N> { controller, friction: Some(friction), actuate: ActuateParams { effort_limit: p.effort_limit, max_delta: [f64::INFINITY; N] } };
    let (p0, r0) = task::tip_pose(&model, &q0);
    let reference = Reference { p_d: p0, r_d: r0, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 0.0 };
    let mut ws_c = pipe.controller.workspace();
    let mut cs = pipe.initial_state();
    let mut ws_p = PlantWorkspace::new(&p);
    let (mut st, mut obs) = plant::observe(&p, &PlantState::at_rest(q0, 1), &mut ws_p, [0.0; N], false);
    let mut max_tau = 0.0f64;
    let mut friction_fed_forward = false;
    let mut cycle = |k: usize, max_tau: &mut f64, ff: &mut bool| {
        assert_eq!(obs.meas.t, k as f64 * 1e-3);
        let (next, out) = pipeline::step(&pipe, &cs, &obs.meas, &reference, &mut ws_c);
        cs = next;
        *ff |= out.control.status.fault.is_none() && (0..N).any(|i| out.tau[i] != out.control.tau[i]);
        *max_tau = max_tau.max(out.tau.iter().fold(0.0, |a, t| a.max(t.abs())));
        (st, obs) = plant::step(&p, &st, &out.tau, &mut ws_p);
    };
    for k in 0..300 {
        cycle(k, &mut max_tau, &mut friction_fed_forward);
    }
    let ((), allocations) = counted(|| {
        for k in 300..1500 {
            cycle(k, &mut max_tau, &mut friction_fed_forward);
        }
    });
    assert!(counted(|| drop(vec![0u8; 8])).1 >= 1, "no allocation counted: the check would pass vacuously");
    assert!(cs.controller.fault.is_none(), "{N} joints: the controller holds: {:?}", cs.controller.fault);
    let tip_drift_m = (obs.truth.tip.translation.vector - p0).norm();
    let posture_drift_rad = (0..N).map(|i| (st.q[i] - q0[i]).abs()).fold(0.0, f64::max);
    Outcome { joints: N, allocations, tip_drift_m, max_tau, friction_fed_forward, posture_drift_rad }
}

#[test]
fn three_six_and_seven_joint_chains_run_the_1khz_path_without_allocating() {
    for n in [3, 6, 7] {
        let model = Model::from_urdf_str(&chain_urdf(n)).unwrap();
        assert_eq!(model.nv(), n);
        // The joint count is read from the URDF at run time: the one dispatch point.
        let out = naic_core::with_joints!(model.nv(), N => run::<N>(model.clone())).unwrap();
        eprintln!("{out:?}");
        assert_eq!(out.joints, n);
        assert_eq!(out.allocations, 0, "{n} joints: {} heap allocations in 1200 closed-loop cycles", out.allocations);
        assert!(out.max_tau.is_finite() && out.max_tau > 1.0, "{n} joints: torques {}", out.max_tau);
        assert!(out.friction_fed_forward, "{n} joints: the friction feedforward stage never acted");
        if n >= 6 {
            // Six task directions and at least six joints: the impedance holds the start pose.
            assert!(out.tip_drift_m < 5e-3, "{n} joints: the tip drifted {:.4} m", out.tip_drift_m);
            // The null-space posture task keeps the seventh joint's self-motion in check.
            assert!(out.posture_drift_rad < 0.05, "{n} joints: a joint drifted {:.4} rad", out.posture_drift_rad);
        }
    }
    assert!(naic_core::with_joints!(13, N => N).is_err_and(|e| e.to_string().contains("13 joints")));
}
