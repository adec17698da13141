//! The whole controller step on the JK5 model (urdf/jk5.urdf), closed around
//! a perfect plant: the same model integrated with ABA. With a perfect model
//! the inverse-dynamics stage realises the commanded task acceleration, so
//! the tip error must follow the target impedance relation (eq 7) exactly.

use naic_core::dynamics;
use naic_core::model::{Data6, Model};
use naic_core::JointVec;
use naic_core::pipeline::ConfigError;
use naic_core::pipeline::control::force_law::Mode;
use naic_core::pipeline::control::Phase;
use naic_core::pipeline::controller::{self, Controller, ControllerParams, Reference};
use naic_core::pipeline::estimate::{self, ToolParams};
use naic_core::pipeline::sense::{Fault, RawMeasurements, Signal};
use nalgebra::{Rotation3, UnitQuaternion, Vector3, Vector6};

fn model() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/jk5.urdf");
    Model::from_urdf_file(path).expect("urdf/jk5.urdf loads")
}

fn params(mode: Mode) -> ControllerParams {
    let mut p = ControllerParams::paper_defaults(&model(), mode, 0.0);
    p.sense.median_window = 1;
    p.tare_samples = 10;
    p
}

/// The paper's §4.1 start: (0, −30°, 120°, 0, −90°, 0).
fn q0() -> JointVec {
    let d = std::f64::consts::PI / 180.0;
    [0.0, -30.0 * d, 120.0 * d, 0.0, -90.0 * d, 0.0]
}

/// What an ideal F/T sensor reads in free space: the tool weight.
fn free_space_reading(model: &Model, data: &mut Data6, tool: &ToolParams, q: &JointVec) -> [f64; 6] {
    dynamics::forward_kinematics(model, data, &Vector6::from(*q));
    let r = data.frame_se3(model.frame_id("ft_sensor").unwrap()).rot;
    estimate::tool_weight_wrench(tool, &r).into()
}

#[test]
fn free_space_tip_error_follows_the_target_impedance_relation() {
    let model = model();
    let ctl = Controller::new(model.clone(), params(Mode::Naic)).unwrap();
    let mut ws = ctl.workspace();
    let mut plant = Data6::try_new(&model).unwrap();
    let tip = model.frame_id("tip").unwrap();
    let (mut q, mut dq) = (q0(), [0.0; 6]);
    dynamics::forward_kinematics(&model, &mut plant, &Vector6::from(q));
    let start = *plant.frame_se3(tip);
    let offset = Vector3::new(0.02, -0.01, 0.015);
    let r_d = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot));
    let reference = Reference { p_d: start.trans + offset, r_d, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
    // Fine steps: the controller runs every step so the comparison is with the continuous relation.
    let dt = 1e-4;
    let mut s = ctl.initial_state();
    let tool = ctl.params().tool;
    let imp = ctl.params().control.impedance;
    // Reference solution of m ë + b ė + k e = 0 per translational axis, e(0) = offset, ė(0) = 0.
    let mut e_ref = offset;
    let mut edot_ref = Vector3::<f64>::zeros();
    let mut worst: f64 = 0.0;
    for k in 0..10_000 {
        let t = k as f64 * dt;
        let wrench = free_space_reading(&model, &mut plant, &tool, &q);
        let meas = RawMeasurements { t, q, dq, joints_stamp: t, wrench, wrench_stamp: t };
        let (n, out) = controller::step(&ctl, &s, &meas, &reference, &mut ws);
        s = n;
        assert!(out.status.fault.is_none(), "{:?}", out.status.fault);
        assert_eq!(out.status.phase, Phase::Free);
        // Plant: same model, ABA, semi-implicit Euler.
        let qdd = *dynamics::aba(&model, &mut plant, &Vector6::from(q), &Vector6::from(dq), &Vector6::from(out.tau));
        for i in 0..6 {
            dq[i] += qdd[i] * dt;
            q[i] += dq[i] * dt;
        }
        for i in 0..3 {
            let eddot = -(imp.b_d[i] * edot_ref[i] + imp.k_free[i] * e_ref[i]) / imp.m_d[i];
            edot_ref[i] += eddot * dt;
            e_ref[i] += edot_ref[i] * dt;
        }
        dynamics::forward_kinematics(&model, &mut plant, &Vector6::from(q));
        let e = reference.p_d - plant.frame_se3(tip).trans;
        worst = worst.max((e - e_ref).norm());
    }
    // Seen: 2.9e-8 m (Euler discretisation of plant and reference). A wrong sign or a
    // missing term in τ = RNEA(q, q̇, J⁻¹(V − J̇q̇)) + JᵀF_e gives millimetres to centimetres.
    assert!(worst < 1e-6, "tip error deviates from eq 7 by {worst} m");
    eprintln!("worst deviation from eq 7: {worst:.3e} m");
    assert!(e_ref.norm() < 0.5 * offset.norm(), "the reference itself must have moved");
}

#[test]
fn bad_sensor_data_holds_the_arm_and_recovers() {
    let model = model();
    let ctl = Controller::new(model.clone(), params(Mode::Naic)).unwrap();
    let mut ws = ctl.workspace();
    let mut plant = Data6::try_new(&model).unwrap();
    let q = q0();
    let reference = Reference {
        p_d: Vector3::new(-0.4, -0.11, 0.05),
        r_d: UnitQuaternion::identity(),
        v_d: Vector6::zeros(),
        a_d: Vector6::zeros(),
        f_d: 10.0,
    };
    let mut s = ctl.initial_state();
    let good = free_space_reading(&model, &mut plant, &ctl.params().tool, &q);
    for k in 0..20 {
        let t = k as f64 * 1e-3;
        let meas = RawMeasurements { t, q, dq: [0.0; 6], joints_stamp: t, wrench: good, wrench_stamp: t };
        s = controller::step(&ctl, &s, &meas, &reference, &mut ws).0;
    }
    let t = 0.02;
    let mut bad = good;
    bad[2] = f64::NAN;
    let meas = RawMeasurements { t, q, dq: [0.1; 6], joints_stamp: t, wrench: bad, wrench_stamp: t };
    let (s2, out) = controller::step(&ctl, &s, &meas, &reference, &mut ws);
    assert_eq!(out.status.phase, Phase::Hold);
    assert_eq!(out.status.fault, Some(Fault::NonFinite { signal: Signal::Wrench, index: 2 }));
    assert_eq!(out.status.fault_count, 1);
    let g = *dynamics::gravity_torques(&model, &mut plant, &Vector6::from(q));
    // Hold = gravity − damping, the damping capped per joint for stability at the 1 ms
    // period (pipeline::hold): the big joints get the full 5 N m s/rad, the wrist roll less.
    let expect = naic_core::pipeline::hold::torque(&model, &mut plant, &q, &[0.1; 6], &[5.0; 6], 1e-3);
    for i in 0..6 {
        assert!((out.tau[i] - expect[i]).abs() < 1e-9, "hold = gravity − damping on joint {i}");
        assert!(out.tau[i] <= g[i] + 1e-12 && out.tau[i] >= g[i] - 5.0 * 0.1 - 1e-12, "joint {i}");
    }
    for i in 0..3 {
        assert!((out.tau[i] - (g[i] - 5.0 * 0.1)).abs() < 1e-9, "full damping on joint {i}");
    }
    // NaN joint positions: hold at the last valid q, never a NaN torque.
    let mut qn = q;
    qn[1] = f64::NAN;
    let meas = RawMeasurements { t, q: qn, dq: [0.0; 6], joints_stamp: t, wrench: good, wrench_stamp: t };
    let (s3, out) = controller::step(&ctl, &s2, &meas, &reference, &mut ws);
    assert!(out.tau.iter().all(|x| x.is_finite()));
    assert_eq!(s3.fault_count, 1, "still the same fault event");
    // Stale wrench.
    let meas = RawMeasurements { t: 0.1, q, dq: [0.0; 6], joints_stamp: 0.1, wrench: good, wrench_stamp: 0.05 };
    let (_, out) = controller::step(&ctl, &s3, &meas, &reference, &mut ws);
    assert!(matches!(out.status.fault, Some(Fault::Stale { signal: Signal::Wrench, .. })));
    // Valid data again: back to free space.
    let meas = RawMeasurements { t: 0.1, q, dq: [0.0; 6], joints_stamp: 0.1, wrench: good, wrench_stamp: 0.1 };
    let (s4, out) = controller::step(&ctl, &s3, &meas, &reference, &mut ws);
    assert_eq!(out.status.phase, Phase::Free);
    assert!(out.status.fault.is_none() && s4.fault.is_none());
}

#[test]
fn controller_rejects_a_model_without_the_tool_frames() {
    let urdf = r#"<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
        <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
    let m = Model::from_urdf_str(urdf).unwrap();
    let e = Controller::new(m, params(Mode::Aic)).unwrap_err();
    assert!(matches!(e, ConfigError::Model(_)) && e.to_string().contains("6-joint"), "{e}");
    let mut p = params(Mode::Naic);
    p.control.force_law.gamma = f64::NAN;
    let e = Controller::new(model(), p).unwrap_err();
    // Structured: the field, the value and the rule it breaks.
    match &e {
        ConfigError::Invalid { field, value, rule } => {
            assert_eq!((field.as_str(), value.as_str()), ("learning_rate (gamma)", "NaN"));
            assert!(rule.contains(">= 0"), "{rule}");
        }
        other => panic!("{other:?}"),
    }
}

/// Issue 37 item 4: the null-space posture task exists for arms of more than six joints only.
/// On the JK5 its settings (stiffness, damping, posture) change nothing, bit for bit: the
/// 6-joint path is the square solve it always was.
#[test]
fn the_null_space_settings_leave_a_six_joint_arm_bit_identical() {
    let model = model();
    let a = Controller::new(model.clone(), params(Mode::Naic)).unwrap();
    let mut pb = params(Mode::Naic);
    pb.nullspace.stiffness = 300.0;
    pb.nullspace.damping = 40.0;
    pb.nullspace.q = Some(q0().map(|x| x + 0.3));
    let b = Controller::new(model.clone(), pb).unwrap();
    let (mut wa, mut wb) = (a.workspace(), b.workspace());
    let (mut sa, mut sb) = (a.initial_state(), b.initial_state());
    let mut data = Data6::try_new(&model).unwrap();
    let tip = model.frame_id("tip").unwrap();
    dynamics::forward_kinematics(&model, &mut data, &Vector6::from(q0()));
    let start = *data.frame_se3(tip);
    let r_d = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot));
    let reference = Reference { p_d: start.trans + Vector3::new(0.01, 0.0, -0.02), r_d, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
    let tool = a.params().tool;
    let mut moved = 0.0_f64;
    for k in 0..200 {
        let t = k as f64 * 1e-3;
        // A moving arm (after the tare), so the posture task's damping term would act too.
        let q: JointVec = std::array::from_fn(|i| q0()[i] + if k > 20 { 0.01 * (t * (i + 1) as f64).sin() } else { 0.0 });
        let dq: JointVec = std::array::from_fn(|i| if k > 20 { 0.01 * (i + 1) as f64 * (t * (i + 1) as f64).cos() } else { 0.0 });
        let wrench = free_space_reading(&model, &mut data, &tool, &q);
        let m = RawMeasurements { t, q, dq, joints_stamp: t, wrench, wrench_stamp: t };
        let (na, oa) = controller::step(&a, &sa, &m, &reference, &mut wa);
        let (nb, ob) = controller::step(&b, &sb, &m, &reference, &mut wb);
        assert_eq!(oa.tau, ob.tau, "cycle {k}: the null-space settings changed a 6-joint torque");
        assert_eq!(nb.q_posture, None, "no posture on six joints");
        moved = moved.max(oa.tau.iter().map(|x| x.abs()).fold(0.0, f64::max));
        (sa, sb) = (na, nb);
    }
    assert!(moved > 1.0, "the cycles produced no torque ({moved} N m): the comparison would be empty");
}

/// Issue 37 item 4 on the Panda (7 joints, params/robots/panda.yaml): the posture task's torque
/// is in the dynamically consistent null space of the tip's Jacobian: it changes the joint
/// acceleration (so the posture is held) but not the tip's, `J M⁻¹ Δτ = 0`.
#[test]
fn the_posture_torque_of_a_seven_joint_arm_moves_nothing_of_the_task() {
    use naic_core::model::DataN;
    use nalgebra::SVector;
    let robot = naic_core::robot_file::Robot::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../params/robots/panda.yaml")).unwrap();
    let model = robot.model.clone();
    let q_start: [f64; 7] = std::array::from_fn(|i| robot.start_q.as_ref().unwrap()[i]);
    let mut pa = ControllerParams::<7>::paper_defaults(&model, Mode::Naic, 0.0);
    (pa.sense.median_window, pa.tare_samples) = (1, 10);
    (pa.tool.mass, pa.tool.com) = (robot.tool.mass, robot.tool.com);
    pa.tool.tip = robot.tip_in_sensor().unwrap();
    pa.nullspace.stiffness = 0.0;
    pa.nullspace.damping = 0.0;
    let mut pb = pa;
    pb.nullspace = controller::NullSpace { stiffness: 50.0, damping: 5.0, q: Some(q_start.map(|x| x + 0.2)) };
    let (a, b) = (Controller::new(model.clone(), pa).unwrap(), Controller::new(model.clone(), pb).unwrap());
    let (mut wa, mut wb) = (a.workspace(), b.workspace());
    let mut data = DataN::<7>::try_new(&model).unwrap();
    let (tip, sensor) = (model.frame_id("tip").unwrap(), model.frame_id("ft_sensor").unwrap());
    let reading = |data: &mut DataN<7>, q: &[f64; 7]| -> [f64; 6] {
        dynamics::forward_kinematics(&model, data, &SVector::<f64, 7>::from(*q));
        estimate::tool_weight_wrench(&pa.tool, &data.frame_se3(sensor).rot).into()
    };
    dynamics::forward_kinematics(&model, &mut data, &SVector::<f64, 7>::from(q_start));
    let start = *data.frame_se3(tip);
    let r_d = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot));
    let reference = Reference { p_d: start.trans + Vector3::new(0.0, 0.01, -0.01), r_d, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
    let mut s = a.initial_state();
    for k in 0..=10 {
        let t = k as f64 * 1e-3;
        let m = RawMeasurements { t, q: q_start, dq: [0.0; 7], joints_stamp: t, wrench: reading(&mut data, &q_start), wrench_stamp: t };
        s = controller::step(&a, &s, &m, &reference, &mut wa).0;
    }
    assert!(s.tare.done(10), "tared");
    // The posture the state keeps wins over nullspace_q (the first one taken is kept): start
    // without one, so B takes its nullspace_q and A (stiffness 0) the measured q.
    s.q_posture = None;
    // One cycle from the same state and measurement, with and without the posture task.
    let t = 0.011;
    let q: [f64; 7] = std::array::from_fn(|i| q_start[i] + 0.01 * i as f64);
    let dq: [f64; 7] = std::array::from_fn(|i| 0.05 - 0.02 * i as f64);
    let m = RawMeasurements { t, q, dq, joints_stamp: t, wrench: reading(&mut data, &q), wrench_stamp: t };
    let (_, oa) = controller::step(&a, &s, &m, &reference, &mut wa);
    let (nb, ob) = controller::step(&b, &s, &m, &reference, &mut wb);
    assert_eq!(nb.q_posture, pb.nullspace.q, "the posture in use is nullspace_q");
    assert!(!oa.status.jacobian_damped, "a regular pose: the inverse is exact");
    let dtau = SVector::<f64, 7>::from(ob.tau) - SVector::<f64, 7>::from(oa.tau);
    let qv = SVector::<f64, 7>::from(q);
    let minv_dtau = dynamics::crba(&model, &mut data, &qv).cholesky().unwrap().solve(&dtau);
    let j = *dynamics::frame_jacobian(&model, &mut data, &qv, tip);
    let task = j * minv_dtau;
    eprintln!("posture torque {:.3} N m; its tip acceleration {:.3e} of the joint acceleration {:.3e}", dtau.norm(), task.norm(), minv_dtau.norm());
    // Seen: 0.37 N m, a joint acceleration of 10 rad/s², 2e-12 of it at the tip.
    assert!(dtau.norm() > 0.1 && minv_dtau.norm() > 1.0, "the posture task did nothing: {dtau}");
    assert!(task.norm() < 1e-9 * minv_dtau.norm().max(1.0), "the posture torque moves the tip: J M⁻¹ Δτ = {task}");
}

/// `controller::update` (the caller keeps one state) is `controller::step` (state in, state
/// out) bit for bit: the same states and outputs on the Panda through the tare held at rest,
/// a rejected cycle and its hold, and force control in contact.
#[test]
fn the_in_place_update_is_the_step_bit_for_bit() {
    use naic_core::model::DataN;
    use nalgebra::SVector;
    let robot = naic_core::robot_file::Robot::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../params/robots/panda.yaml")).unwrap();
    let model = robot.model.clone();
    let q_start: [f64; 7] = std::array::from_fn(|i| robot.start_q.as_ref().unwrap()[i]);
    let mut p = ControllerParams::<7>::paper_defaults(&model, Mode::Naic, 1e-6);
    (p.sense.median_window, p.tare_samples, p.tare_at_rest) = (3, 10, true);
    (p.tool.mass, p.tool.com) = (robot.tool.mass, robot.tool.com);
    p.tool.tip = robot.tip_in_sensor().unwrap();
    let ctl = Controller::new(model.clone(), p).unwrap();
    let (mut wa, mut wb) = (ctl.workspace(), ctl.workspace());
    let mut data = DataN::<7>::try_new(&model).unwrap();
    let (tip, sensor) = (model.frame_id("tip").unwrap(), model.frame_id("ft_sensor").unwrap());
    let tool = ctl.params().tool;
    let mut reading = |q: &[f64; 7], push: f64| -> [f64; 6] {
        dynamics::forward_kinematics(&model, &mut data, &SVector::<f64, 7>::from(*q));
        let r = data.frame_se3(sensor).rot;
        let f = r.transpose() * Vector3::new(0.0, 0.0, push);
        let m = tool.tip.cross(&f);
        (estimate::tool_weight_wrench(&tool, &r) + Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)).into()
    };
    let mut fk = DataN::<7>::try_new(&model).unwrap();
    dynamics::forward_kinematics(&model, &mut fk, &SVector::<f64, 7>::from(q_start));
    let start = *fk.frame_se3(tip);
    let r_d = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot));
    let reference = Reference { p_d: start.trans - Vector3::new(0.0, 0.0, 0.01), r_d, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
    let (mut s, mut kept) = (ctl.initial_state(), ctl.initial_state());
    let (mut held, mut contact) = (false, false);
    for k in 0..300 {
        let t = k as f64 * 1e-3;
        // At rest while taring, then moving a little; pushed with 10 N from cycle 60.
        let moving = if k > 20 { 1.0 } else { 0.0 };
        let q: [f64; 7] = std::array::from_fn(|i| q_start[i] + moving * 0.02 * (0.01 * k as f64 + i as f64).sin());
        let dq: [f64; 7] = std::array::from_fn(|i| moving * 0.05 * (0.02 * k as f64 + i as f64).cos());
        let mut wrench = reading(&q, if k >= 60 { 10.0 } else { 0.0 });
        if k == 40 {
            wrench[2] = f64::NAN;
        }
        let m = RawMeasurements { t, q, dq, joints_stamp: t, wrench, wrench_stamp: t };
        let (next, out) = controller::step(&ctl, &s, &m, &reference, &mut wa);
        let out_kept = controller::update(&ctl, &mut kept, &m, &reference, &mut wb);
        // Debug prints every f64 so that it reads back to the same bits (NaN included).
        assert_eq!(format!("{next:?}"), format!("{kept:?}"), "state after cycle {k}");
        assert_eq!(format!("{out:?}"), format!("{out_kept:?}"), "outputs of cycle {k}");
        held |= out.status.phase == Phase::Hold && out.status.fault.is_some();
        contact |= out.status.phase == Phase::Contact;
        s = next;
    }
    assert!(s.tare.done(10), "the tare completed");
    assert!(held, "cycle 40 was rejected and held");
    assert!(contact, "contact was reached");
}

/// The first cycle in contact phase and the first with the tip on the surface, of a run of
/// the fixed law from rest towards a target 10 cm below the start (5 m/s² at the start of
/// the approach: 2.1 N of inertial force), on a 2000 N/m surface 20 mm below the tip, with a sensor that reads the tool's inertial force `m (g − a)`
/// (`a` the tool's centre-of-mass acceleration over the step into the reading), a perfect
/// plant (the model, ABA) and the tare at rest.
fn entry_with_an_inertial_sensor(inertial: bool) -> (Option<f64>, Option<f64>) {
    let model = model();
    let mut p = params(Mode::Fixed);
    (p.tare_at_rest, p.sensor_reads_tool_inertia) = (true, inertial);
    let ctl = Controller::new(model.clone(), p).unwrap();
    let mut ws = ctl.workspace();
    let mut plant = Data6::try_new(&model).unwrap();
    let (tip, sensor) = (model.frame_id("tip").unwrap(), model.frame_id("ft_sensor").unwrap());
    let tool = ctl.params().tool;
    let (mut q, mut dq) = (q0(), [0.0; 6]);
    dynamics::forward_kinematics(&model, &mut plant, &Vector6::from(q));
    let start = *plant.frame_se3(tip);
    let z_surface = start.trans.z - 0.020;
    let r_d = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot));
    let reference = Reference { p_d: start.trans - Vector3::new(0.0, 0.0, 0.1), r_d, v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
    let com_velocity = |plant: &mut Data6, q: &JointVec, dq: &JointVec| {
        let j = *dynamics::frame_jacobian(&model, plant, &Vector6::from(*q), sensor);
        let v6 = j * Vector6::from(*dq);
        let r = plant.frame_se3(sensor).rot;
        Vector3::new(v6[0], v6[1], v6[2]) + Vector3::new(v6[3], v6[4], v6[5]).cross(&(r * tool.com))
    };
    let dt = 1e-3;
    let mut s = ctl.initial_state();
    let mut a = Vector3::zeros();
    let (mut entered, mut touched) = (None, None);
    for k in 0..600 {
        let t = k as f64 * dt;
        dynamics::forward_kinematics(&model, &mut plant, &Vector6::from(q));
        let (x, r) = (*plant.frame_se3(tip), plant.frame_se3(sensor).rot);
        let f_c = Vector3::new(0.0, 0.0, 2000.0 * (z_surface - x.trans.z).max(0.0)); // the surface on the tip
        if f_c.z > 0.0 && touched.is_none() {
            touched = Some(t);
        }
        let w = estimate::tool_wrench(&tool, &r, &a);
        let f_s = r.transpose() * f_c;
        let m_s = tool.tip.cross(&f_s);
        let wrench = [f_s.x + w[0], f_s.y + w[1], f_s.z + w[2], m_s.x + w[3], m_s.y + w[4], m_s.z + w[5]];
        let meas = RawMeasurements { t, q, dq, joints_stamp: t, wrench, wrench_stamp: t };
        let (n, out) = controller::step(&ctl, &s, &meas, &reference, &mut ws);
        s = n;
        if out.status.phase == Phase::Contact && entered.is_none() {
            entered = Some(t);
        }
        let v0 = com_velocity(&mut plant, &q, &dq);
        let j = *dynamics::frame_jacobian(&model, &mut plant, &Vector6::from(q), tip);
        let tau = Vector6::from(out.tau) + j.fixed_rows::<3>(0).transpose() * f_c;
        let qdd = *dynamics::aba(&model, &mut plant, &Vector6::from(q), &Vector6::from(dq), &tau);
        for i in 0..6 {
            dq[i] += qdd[i] * dt;
            q[i] += dq[i] * dt;
        }
        dynamics::forward_kinematics(&model, &mut plant, &Vector6::from(q));
        a = (com_velocity(&mut plant, &q, &dq) - v0) / dt;
    }
    (entered, touched)
}

/// A tool accelerating towards the surface in free space reads its inertial force as a push
/// (here 2.1 N at the start of the approach, over the fixed law's 1 N entry level): with
/// `sensor_reads_tool_inertia` the contact decisions read the contact force without it and enter
/// contact only on the touch; without, in the air.
#[test]
fn a_tool_accelerating_in_free_space_does_not_enter_contact_and_a_touch_does() {
    let (entered, touched) = entry_with_an_inertial_sensor(true);
    let (entered, touched) = (entered.expect("contact entered"), touched.expect("the tip touched"));
    // after the touch, within the time the force takes to reach the 1 N entry level and the
    // window's 16 cycles
    assert!(entered >= touched && entered < touched + 0.05, "entered {entered} s, touched {touched} s");
    let (entered_raw, touched_raw) = entry_with_an_inertial_sensor(false);
    let entered_raw = entered_raw.expect("contact entered");
    assert!(entered_raw < touched_raw.unwrap_or(f64::INFINITY) - 0.01, "the reading alone enters in the air: {entered_raw} s, touched {touched_raw:?}");
}
