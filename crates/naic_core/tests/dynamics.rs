//! Properties of the dynamics algorithms that must hold for any correct
//! implementation (the numbers themselves are cross-checked against
//! Pinocchio and MuJoCo in tests/python/test_dynamics_vs_pinocchio.py).

mod dynamics_common;

use dynamics_common::*;
use naic_core::dynamics::{self, CartesianError, Damping};
use naic_core::model::{Data, Data6, Model};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, SVector, Vector3, Vector6};

fn models() -> Vec<(&'static str, Model)> {
    vec![
        ("planar3", Model::from_urdf_str(&planar3_urdf()).unwrap()),
        ("arm6", Model::from_urdf_str(&arm6_urdf()).unwrap()),
        ("zu5", Model::from_urdf_file(zu5_path()).unwrap()),
        ("jk5", Model::from_urdf_file(jk5_path()).unwrap()),
    ]
}

/// Random joint positions inside the limits (±π for continuous joints).
fn random_q(model: &Model, rng: &mut Rng) -> DVector<f64> {
    let (lo, hi) = (model.lower_limits(), model.upper_limits());
    DVector::from_fn(model.nv(), |i, _| {
        let l = if lo[i].is_finite() { lo[i] } else { -3.14 };
        let h = if hi[i].is_finite() { hi[i] } else { 3.14 };
        rng.uniform(l, h)
    })
}

fn rel_err(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

#[test]
fn crba_is_symmetric_positive_definite() {
    for (name, model) in models() {
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(1);
        for _ in 0..200 {
            let q = random_q(&model, &mut rng);
            let m = dynamics::crba(&model, &mut data, &q).clone();
            assert!((&m - m.transpose()).amax() <= 1e-14 * m.amax(), "{name}: M not symmetric");
            let eig = m.symmetric_eigen().eigenvalues;
            assert!(eig.min() > 0.0, "{name}: M not positive definite at q = {q}: eigenvalues {eig}");
        }
    }
}

#[test]
fn crba_columns_equal_rnea_of_unit_accelerations() {
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(2);
        for _ in 0..50 {
            let q = random_q(&model, &mut rng);
            let zero = DVector::zeros(n);
            let g = dynamics::gravity_torques(&model, &mut data, &q).clone();
            let m = dynamics::crba(&model, &mut data, &q).clone();
            for i in 0..n {
                let mut e = DVector::zeros(n);
                e[i] = 1.0;
                let col = dynamics::rnea(&model, &mut data, &q, &zero, &e) - &g;
                assert!((col - m.column(i)).amax() <= 1e-12 * m.amax().max(1.0), "{name}: column {i}");
            }
        }
    }
}

#[test]
fn aba_inverts_rnea_and_rnea_inverts_aba() {
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(3);
        for _ in 0..200 {
            let q = random_q(&model, &mut rng);
            let v = rng.vec(n, -2.0, 2.0);
            let a = rng.vec(n, -10.0, 10.0);
            let tau = dynamics::rnea(&model, &mut data, &q, &v, &a).clone();
            let a2 = dynamics::aba(&model, &mut data, &q, &v, &tau).clone();
            assert!((&a2 - &a).amax() <= 1e-9 * a.amax(), "{name}: ABA(RNEA(a)) = {a2} != {a}");
            let tau_in = rng.vec(n, -50.0, 50.0);
            let acc = dynamics::aba(&model, &mut data, &q, &v, &tau_in).clone();
            let tau_out = dynamics::rnea(&model, &mut data, &q, &v, &acc).clone();
            assert!((&tau_out - &tau_in).amax() <= 1e-9 * tau_in.amax(), "{name}: RNEA(ABA(tau)) != tau");
            // and both agree with M q̈ + b
            let m = dynamics::crba(&model, &mut data, &q).clone();
            let b = dynamics::bias_torques(&model, &mut data, &q, &v).clone();
            assert!((&m * &acc + &b - &tau_in).amax() <= 1e-9 * tau_in.amax(), "{name}: M q̈ + b != tau");
        }
    }
}

#[test]
fn bias_is_coriolis_plus_gravity() {
    // C q̇ + G = RNEA(q, q̇, 0); C q̇ is quadratic in q̇: b(2v) − G = 4 (b(v) − G).
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(4);
        for _ in 0..50 {
            let q = random_q(&model, &mut rng);
            let v = rng.vec(n, -2.0, 2.0);
            let g = dynamics::gravity_torques(&model, &mut data, &q).clone();
            let b1 = dynamics::bias_torques(&model, &mut data, &q, &v).clone();
            let b2 = dynamics::bias_torques(&model, &mut data, &q, &(&v * 2.0)).clone();
            let r = dynamics::rnea(&model, &mut data, &q, &v, &DVector::zeros(n)).clone();
            assert_eq!(b1, r, "{name}");
            let c1 = &b1 - &g;
            assert!(((&b2 - &g) - &c1 * 4.0).amax() <= 1e-9 * c1.amax().max(1e-3), "{name}: C q̇ not quadratic");
        }
    }
}

#[test]
fn static_six_dof_path_equals_dynamic_path() {
    for (name, model) in models().into_iter().filter(|(_, m)| m.nv() == 6) {
        let mut dd = Data::new(&model);
        let mut ds = Data6::try_new(&model).unwrap();
        let tip = model.frame_id(if name == "zu5" { "Link_6" } else { "tip" }).unwrap();
        let mut rng = Rng::seed(5);
        for _ in 0..50 {
            let q = random_q(&model, &mut rng);
            let v = rng.vec(6, -2.0, 2.0);
            let a = rng.vec(6, -5.0, 5.0);
            let (qs, vs, as_) = (SVector::<f64, 6>::from_iterator(q.iter().copied()), SVector::<f64, 6>::from_iterator(v.iter().copied()), SVector::<f64, 6>::from_iterator(a.iter().copied()));
            assert_eq!(dynamics::rnea(&model, &mut dd, &q, &v, &a).as_slice(), dynamics::rnea(&model, &mut ds, &qs, &vs, &as_).as_slice());
            assert_eq!(dynamics::crba(&model, &mut dd, &q).as_slice(), dynamics::crba(&model, &mut ds, &qs).as_slice());
            assert_eq!(dynamics::aba(&model, &mut dd, &q, &v, &a).as_slice(), dynamics::aba(&model, &mut ds, &qs, &vs, &as_).as_slice());
            assert_eq!(
                dynamics::frame_jacobian(&model, &mut dd, &q, tip).as_slice(),
                dynamics::frame_jacobian(&model, &mut ds, &qs, tip).as_slice()
            );
            assert_eq!(
                dynamics::frame_jdot_qdot(&model, &mut dd, &q, &v, tip),
                dynamics::frame_jdot_qdot(&model, &mut ds, &qs, &vs, tip)
            );
        }
    }
}

#[test]
fn slices_work_through_views() {
    let model = Model::from_urdf_str(&planar3_urdf()).unwrap();
    let mut data = Data::new(&model);
    let q = [0.1, -0.4, 0.7];
    let qv = nalgebra::DVectorView::from_slice(&q, 3);
    let g1 = dynamics::gravity_torques(&model, &mut data, &qv).clone();
    let g2 = dynamics::gravity_torques(&model, &mut data, &DVector::from_row_slice(&q)).clone();
    assert_eq!(g1, g2);
}

/// Total mechanical energy ½ q̇ᵀ M q̇ + Σ m g·(−c) of the unforced arm.
fn energy(model: &Model, data: &mut Data, q: &DVector<f64>, v: &DVector<f64>) -> f64 {
    let m = dynamics::crba(model, data, q).clone();
    let kinetic = 0.5 * v.dot(&(&m * v));
    dynamics::forward_kinematics(model, data, q);
    let mut potential = 0.0;
    for (i, j) in model.joints().iter().enumerate() {
        let com = data.joint_placement(i).act_point(&j.inertia.com);
        potential -= j.inertia.mass * model.gravity.dot(&com);
    }
    kinetic + potential
}

#[test]
fn energy_is_conserved_by_rk4_without_torque() {
    // Unforced, frictionless: q̈ = ABA(q, q̇, 0). RK4 with dt = 1e-4 s for 1 s;
    // the total energy must stay within 1e-8 J (measured: ~1e-11 J on energies of
    // 10–160 J at joint speeds up to ~25 rad/s), far below what a wrong Coriolis
    // or gravity term would give (a drift of joules within 0.1 s).
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(6);
        let mut q = random_q(&model, &mut rng);
        let mut v = rng.vec(n, -1.0, 1.0);
        let e0 = energy(&model, &mut data, &q, &v);
        let dt = 1e-4;
        let mut f = |q: &DVector<f64>, v: &DVector<f64>| dynamics::aba(&model, &mut data, q, v, &DVector::zeros(n)).clone();
        let mut max_drift: f64 = 0.0;
        let mut max_speed: f64 = 0.0;
        for step in 0..10_000 {
            let k1q = v.clone();
            let k1v = f(&q, &v);
            let k2q = &v + &k1v * (dt / 2.0);
            let k2v = f(&(&q + &k1q * (dt / 2.0)), &k2q);
            let k3q = &v + &k2v * (dt / 2.0);
            let k3v = f(&(&q + &k2q * (dt / 2.0)), &k3q);
            let k4q = &v + &k3v * dt;
            let k4v = f(&(&q + &k3q * dt), &k4q);
            q += (&k1q + &k2q * 2.0 + &k3q * 2.0 + &k4q) * (dt / 6.0);
            v += (&k1v + &k2v * 2.0 + &k3v * 2.0 + &k4v) * (dt / 6.0);
            max_speed = max_speed.max(v.amax());
            if step % 100 == 99 {
                let mut d2 = Data::new(&model);
                max_drift = max_drift.max((energy(&model, &mut d2, &q, &v) - e0).abs());
            }
        }
        assert!(max_speed > 1.0, "{name}: the arm should be swinging (max speed {max_speed})");
        eprintln!("{name}: E0 = {e0:.6} J, max |E - E0| = {max_drift:.3e} J over 1 s, max speed {max_speed:.2} rad/s");
        assert!(max_drift < 1e-8, "{name}: energy drift {max_drift:e} J (E0 = {e0} J)");
    }
}

/// Rotation vector of a small rotation `r` (vee of its skew part; error O(θ³)).
fn log3(r: &Matrix3<f64>) -> Vector3<f64> {
    let s = (r - r.transpose()) * 0.5;
    Vector3::new(s[(2, 1)], s[(0, 2)], s[(1, 0)])
}

#[test]
fn jacobian_matches_finite_differences_of_fk() {
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let frames: Vec<_> = model.frames().iter().map(|f| model.frame_id(&f.name).unwrap()).collect();
        let mut rng = Rng::seed(7);
        let h = 1e-6;
        for _ in 0..20 {
            let q = random_q(&model, &mut rng);
            for &fid in &frames {
                let j = dynamics::frame_jacobian(&model, &mut data, &q, fid).clone();
                for i in 0..n {
                    let mut qp = q.clone();
                    qp[i] += h;
                    let mut qm = q.clone();
                    qm[i] -= h;
                    dynamics::forward_kinematics(&model, &mut data, &qp);
                    let tp = *data.frame_se3(fid);
                    dynamics::forward_kinematics(&model, &mut data, &qm);
                    let tm = *data.frame_se3(fid);
                    let lin = (tp.trans - tm.trans) / (2.0 * h);
                    let ang = log3(&(tp.rot * tm.rot.transpose())) / (2.0 * h);
                    let fd = Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z);
                    let col: Vector6<f64> = j.column(i).into_owned();
                    assert!((col - fd).amax() < 1e-7, "{name} frame {} column {i}: {col} vs fd {fd}", model.frame(fid).name);
                }
            }
        }
    }
}

#[test]
fn jdot_qdot_matches_finite_differences() {
    // At q̈ = 0: d/dt (J q̇) = J̇ q̇ = (J(q + h q̇) − J(q − h q̇)) q̇ / 2h.
    for (name, model) in models() {
        let n = model.nv();
        let mut data = Data::new(&model);
        let mut rng = Rng::seed(8);
        let h = 1e-6;
        for fname in ["tip", "Link_6", "l2", "s3", "camera"] {
            let Some(fid) = model.frame_id(fname) else { continue };
            for _ in 0..20 {
                let q = random_q(&model, &mut rng);
                let v = rng.vec(n, -2.0, 2.0);
                let jp = dynamics::frame_jacobian(&model, &mut data, &(&q + &v * h), fid).clone();
                let jm = dynamics::frame_jacobian(&model, &mut data, &(&q - &v * h), fid).clone();
                let fd = (jp - jm) * &v / (2.0 * h);
                let got = dynamics::frame_jdot_qdot(&model, &mut data, &q, &v, fid);
                let got = DVector::from_iterator(6, got.iter().copied());
                assert!((&got - &fd).amax() < 1e-6 * fd.amax().max(1.0), "{name} {fname}: {got} vs fd {fd}");
            }
        }
    }
}

fn six(model: &Model) -> (Data6, naic_core::model::FrameId) {
    let tip = model.frame_id("tip").or_else(|| model.frame_id("Link_6")).unwrap();
    (Data6::try_new(model).unwrap(), tip)
}

#[test]
fn cartesian_terms_satisfy_eq3_identity_away_from_singularities() {
    // Jᵀ (D V + h) = M J⁻¹ (V − J̇ q̇) + C q̇ + G
    let mut checked = 0;
    for (name, model) in models().into_iter().filter(|(_, m)| m.nv() == 6) {
        let (mut data, tip) = six(&model);
        let mut rng = Rng::seed(9);
        for _ in 0..600 {
            let q = SVector::<f64, 6>::from_iterator(random_q(&model, &mut rng).iter().copied());
            let v = SVector::<f64, 6>::from_fn(|_, _| rng.uniform(-2.0, 2.0));
            let big_v = Vector6::from_fn(|_, _| rng.uniform(-3.0, 3.0));
            let c = dynamics::cartesian_terms(&model, &mut data, &q, &v, tip, &Damping::default()).unwrap();
            if c.sigma_min < 0.05 {
                continue; // near-singular: the identity holds only for the undamped inverse
            }
            assert!(!c.damped, "{name}");
            let m = *dynamics::crba(&model, &mut data, &q);
            let b = *dynamics::bias_torques(&model, &mut data, &q, &v);
            let j: Matrix6<f64> = *dynamics::frame_jacobian(&model, &mut data, &q, tip);
            let jdq = dynamics::frame_jdot_qdot(&model, &mut data, &q, &v, tip);
            let j_inv = j.try_inverse().unwrap();
            let lhs = j.transpose() * (c.d * big_v + c.h);
            let rhs = m * j_inv * (big_v - jdq) + b;
            assert!((lhs - rhs).amax() < 1e-8 * rhs.amax().max(1.0), "{name}: {lhs} vs {rhs}");
            // D is symmetric positive definite
            assert!((c.d - c.d.transpose()).amax() < 1e-9 * c.d.amax());
            assert!(c.d.symmetric_eigen().eigenvalues.min() > 0.0);
            checked += 1;
        }
    }
    assert!(checked > 300, "only {checked} non-singular states checked");
}

#[test]
fn singular_configuration_is_damped_and_finite() {
    // Whatever σ_min is, the result is finite and `damped` follows the threshold.
    let model = Model::from_urdf_str(&arm6_urdf()).unwrap();
    let model_zu5 = Model::from_urdf_file(zu5_path()).unwrap();
    for (model, q) in [
        // Zu 5 with the elbow stretched (joint 3 at 0).
        (&model_zu5, SVector::<f64, 6>::new(0.3, 1.0, 0.0, 0.5, 0.3, 0.2)),
        (&model, SVector::<f64, 6>::zeros()),
    ] {
        let (mut data, tip) = six(model);
        let v = SVector::<f64, 6>::new(0.1, -0.2, 0.3, 0.1, 0.2, -0.1);
        let j = *dynamics::frame_jacobian(model, &mut data, &q, tip);
        let sigma = j.singular_values().min();
        let c = dynamics::cartesian_terms(model, &mut data, &q, &v, tip, &Damping::default()).unwrap();
        assert!((c.sigma_min - sigma).abs() < 1e-9);
        if sigma < Damping::default().sigma_threshold {
            assert!(c.damped, "σ_min = {sigma} is below the threshold but not damped");
            assert!(c.lambda > 0.0);
        }
        assert!(c.d.iter().chain(c.h.iter()).all(|x| x.is_finite()));
    }
    // Zu 5 at joint 5 = 0 has its wrist singularity (axes 4 and 6 parallel): exactly singular.
    let (mut data, tip) = six(&model_zu5);
    let q = SVector::<f64, 6>::new(0.3, 1.0, 0.7, 0.5, 0.0, 0.2);
    let c = dynamics::cartesian_terms(&model_zu5, &mut data, &q, &SVector::zeros(), tip, &Damping::default()).unwrap();
    assert!(c.damped && c.sigma_min < 1e-9, "σ_min = {}", c.sigma_min);
    assert!(c.d.iter().chain(c.h.iter()).all(|x| x.is_finite()));
    let dmax = c.d.amax();
    assert!(dmax < 1e6, "damped D should stay bounded, got {dmax}");
    // The damping is continuous: a little away from the singularity, the result changes little.
    let q2 = SVector::<f64, 6>::new(0.3, 1.0, 0.7, 0.5, 1e-4, 0.2);
    let c2 = dynamics::cartesian_terms(&model_zu5, &mut data, &q2, &SVector::zeros(), tip, &Damping::default()).unwrap();
    assert!(c2.damped && (c2.d - c.d).amax() < 1e-2 * dmax, "{} vs {}", c2.d, c.d);
}

#[test]
fn cartesian_terms_reject_bad_input_without_panicking() {
    let planar = Model::from_urdf_str(&planar3_urdf()).unwrap();
    let mut data = Data::new(&planar);
    let tip = planar.frame_id("tip").unwrap();
    let z = DVector::zeros(3);
    assert_eq!(
        dynamics::cartesian_terms(&planar, &mut data, &z, &z, tip, &Damping::default()),
        Err(CartesianError::NotSixDof { nv: 3 })
    );
    let arm = Model::from_urdf_str(&arm6_urdf()).unwrap();
    let (mut data, tip) = six(&arm);
    let mut q = SVector::<f64, 6>::zeros();
    q[2] = f64::NAN;
    let r = dynamics::cartesian_terms(&arm, &mut data, &q, &SVector::zeros(), tip, &Damping::default());
    assert_eq!(r, Err(CartesianError::NonFinite));
}

#[test]
fn planar_arm_matches_closed_form() {
    let model = Model::from_urdf_str(&planar3_urdf()).unwrap();
    assert_eq!(model.nv(), 3);
    assert_eq!(model.joint_names().collect::<Vec<_>>(), ["q1", "q2", "q3"]);
    let mut data = Data::new(&model);
    let tip = model.frame_id("tip").unwrap();
    let g = 9.81;
    let mut rng = Rng::seed(10);
    for _ in 0..50 {
        let q = rng.vec(3, -3.0, 3.0);
        // Rotation about +y by φ maps x to (cos φ, 0, −sin φ).
        let phi = [q[0], q[0] + q[1], q[0] + q[1] + q[2]];
        let point = |i: usize| -> (f64, f64) {
            (0..=i).fold((0.0, 0.0), |(x, z), k| (x + PLANAR_L[k] * phi[k].cos(), z - PLANAR_L[k] * phi[k].sin()))
        };
        dynamics::forward_kinematics(&model, &mut data, &q);
        let p = data.frame_placement(tip).translation.vector;
        let (x, z) = point(2);
        assert!((p - Vector3::new(x, 0.0, z)).amax() < 1e-14);
        // G_j = ∂U/∂q_j with U = Σ m_i g z_i
        let gt = dynamics::gravity_torques(&model, &mut data, &q).clone();
        let mut m = DMatrix::zeros(3, 3);
        for j in 0..3 {
            let mut gj = 0.0;
            for i in j..3 {
                gj -= PLANAR_M[i] * g * (j..=i).map(|k| PLANAR_L[k] * phi[k].cos()).sum::<f64>();
            }
            assert!((gt[j] - gj).abs() < 1e-12, "G[{j}] = {} vs {gj}", gt[j]);
        }
        // M = Σ m_i J_iᵀ J_i with the point-mass Jacobians in the x–z plane
        for i in 0..3 {
            let mut ji = DMatrix::zeros(2, 3);
            for j in 0..=i {
                ji[(0, j)] = -(j..=i).map(|k| PLANAR_L[k] * phi[k].sin()).sum::<f64>();
                ji[(1, j)] = -(j..=i).map(|k| PLANAR_L[k] * phi[k].cos()).sum::<f64>();
            }
            m += ji.transpose() * ji * PLANAR_M[i];
        }
        let mc = dynamics::crba(&model, &mut data, &q).clone();
        assert!(rel_err(&mc, &m) < 1e-13, "{mc} vs {m}");
    }
}

#[test]
fn zu5_loads_and_matches_its_provenance_numbers() {
    let model = Model::from_urdf_file(zu5_path()).unwrap();
    assert_eq!(model.nv(), 6);
    assert_eq!(model.joint_names().collect::<Vec<_>>(), ["joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6"]);
    // Link_0 hangs from `world` by a fixed joint: it is part of the base, so the moving mass excludes it.
    assert!((model.moving_mass() - 92.35).abs() < 0.01, "moving mass {}", model.moving_mass());
    for f in ["world", "Link_0", "Link_6", "joint_1"] {
        assert!(model.frame_id(f).is_some(), "frame {f} missing");
    }
    assert_eq!(model.frame(model.frame_id("Link_0").unwrap()).parent, None);
    assert_eq!(model.effort_limits(), [2000.0, 5000.0, 5000.0, 2000.0, 3000.0, 1000.0]);
    assert!(model.velocity_limits().iter().all(|v| (*v - 3.14).abs() < 1e-12));
    assert_eq!(model.lower_limits()[1], -1.48);
    assert_eq!(model.upper_limits()[1], 4.62);
    assert_eq!(model.gravity, Vector3::new(0.0, 0.0, -9.81));
    // PROVENANCE.md (check_output.txt, pinocchio 4.1 and MuJoCo):
    let mut data = Data6::try_new(&model).unwrap();
    let g0 = *dynamics::gravity_torques(&model, &mut data, &SVector::zeros());
    let want = [0.0, 310.96, 81.92, 0.0001, 0.0, 0.0004];
    for k in 0..6 {
        assert!((g0[k] - want[k]).abs() < 0.006, "G(0)[{k}] = {} vs {}", g0[k], want[k]);
    }
    let g1 = *dynamics::gravity_torques(&model, &mut data, &SVector::<f64, 6>::new(0.0, 0.5, -1.0, 0.5, 0.0, 0.0));
    let want = [0.0, 272.89, 71.89, 0.0001, 0.0, 0.0004];
    for k in 0..6 {
        assert!((g1[k] - want[k]).abs() < 0.006, "G(q)[{k}] = {} vs {}", g1[k], want[k]);
    }
    dynamics::forward_kinematics(&model, &mut data, &SVector::zeros());
    let flange = data.frame_placement(model.frame_id("Link_6").unwrap());
    assert!((flange.translation.vector - Vector3::new(0.7985, 0.0070, 0.0066)).amax() < 6e-5);
    // "The flange z-axis points along −y."
    assert!((flange.rotation * Vector3::z() - Vector3::new(0.0, -1.0, 0.0)).amax() < 1e-5);
}

#[test]
fn fixed_links_are_merged_into_their_body_and_kept_as_frames() {
    let model = Model::from_urdf_str(&arm6_urdf()).unwrap();
    assert_eq!(model.nv(), 6);
    // world and base_link are the fixed base; camera merges into s2; tool (and massless tip) into s6.
    assert!((model.moving_mass() - (4.0 + 6.0 + 0.3 + 3.0 + 1.5 + 1.0 + 0.4 + 0.5)).abs() < 1e-12);
    assert!((model.joints()[1].inertia.mass - 6.3).abs() < 1e-12);
    assert!((model.joints()[5].inertia.mass - 0.9).abs() < 1e-12);
    for f in ["world", "world_joint", "base_link", "camera", "cam_mount", "tool", "tool_joint", "tip", "tip_joint", "j4", "s4"] {
        assert!(model.frame_id(f).is_some(), "frame {f} missing");
    }
    assert_eq!(model.frame(model.frame_id("camera").unwrap()).parent, Some(1));
    assert_eq!(model.frame(model.frame_id("tip").unwrap()).parent, Some(5));
    assert_eq!(model.joints()[3].jtype, naic_core::model::JointType::Prismatic);
    assert_eq!(model.joints()[4].jtype, naic_core::model::JointType::Continuous);
    assert!(model.lower_limits()[4].is_infinite() && model.upper_limits()[4].is_infinite());
    assert!((model.joints()[2].axis.norm() - 1.0).abs() < 1e-15, "axes are normalised");
    // The merged model has the same dynamics as one whose camera is a separate (fixed) body:
    // compare M with the same URDF where the camera mass is zero plus the camera's own contribution
    // computed from its Jacobian: M_cam = m Jᵥᵀ Jᵥ + Jωᵀ R I Rᵀ Jω at the camera's centre of mass.
    let no_cam = arm6_urdf().replace(
        r#"<mass value="0.3"/><inertia ixx="0.0004" ixy="0" ixz="0" iyy="0.0005" iyz="0" izz="0.0003"/>"#,
        r#"<mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>"#,
    );
    let bare = Model::from_urdf_str(&no_cam).unwrap();
    assert!((model.moving_mass() - bare.moving_mass() - 0.3).abs() < 1e-12);
    let mut d1 = Data::new(&model);
    let mut d2 = Data::new(&bare);
    let cam = model.frame_id("camera").unwrap();
    let mut rng = Rng::seed(11);
    for _ in 0..20 {
        let q = random_q(&model, &mut rng);
        let m_full = dynamics::crba(&model, &mut d1, &q).clone();
        let m_bare = dynamics::crba(&bare, &mut d2, &q).clone();
        // camera frame Jacobian at the frame origin; the camera's com is at (0,0,0.02) in its frame
        let j = dynamics::frame_jacobian(&model, &mut d1, &q, cam).clone();
        let t = *d1.frame_se3(cam);
        let r = t.rot;
        let c_world = r * Vector3::new(0.0, 0.0, 0.02);
        let jv = j.rows(0, 3) - nalgebra::Matrix3::new(0.0, -c_world.z, c_world.y, c_world.z, 0.0, -c_world.x, -c_world.y, c_world.x, 0.0) * j.rows(3, 3);
        let jw = j.rows(3, 3).into_owned();
        let i_world = r * Matrix3::from_diagonal(&Vector3::new(0.0004, 0.0005, 0.0003)) * r.transpose();
        let m_cam = jv.transpose() * &jv * 0.3 + jw.transpose() * i_world * &jw;
        assert!(rel_err(&m_full, &(m_bare + m_cam)) < 1e-13);
    }
}

#[test]
fn jk5_loads_with_its_frames_and_is_singular_when_straight_up() {
    let model = Model::from_urdf_file(jk5_path()).unwrap();
    assert_eq!(model.nv(), 6);
    assert_eq!(model.joint_names().collect::<Vec<_>>(), ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]);
    // links 1-6 + sensor/rod (urdf/README.md): 20.514 kg moving
    assert!((model.moving_mass() - 20.514).abs() < 1e-12);
    let (tip, fts) = (model.frame_id("tip").unwrap(), model.frame_id("ft_sensor").unwrap());
    assert_eq!(model.frame(tip).parent, Some(5));
    assert_eq!(model.frame(fts).parent, Some(5));
    let mut data = Data6::try_new(&model).unwrap();
    dynamics::forward_kinematics(&model, &mut data, &SVector::zeros());
    // PROVENANCE.md: at q = 0 the arm points straight up, tip at (0, −0.3765, 1.0635) m.
    let p = data.frame_placement(tip).translation.vector;
    assert!((p - Vector3::new(0.0, -0.3765, 1.0635)).amax() < 1e-12, "{p}");
    // Straight up, joint 5 at 0: axes 4 and 6 are parallel (wrist singularity).
    let c = dynamics::cartesian_terms(&model, &mut data, &SVector::zeros(), &SVector::zeros(), tip, &Damping::default()).unwrap();
    assert!(c.damped && c.sigma_min < 1e-12, "σ_min = {}", c.sigma_min);
    assert!(c.d.iter().chain(c.h.iter()).all(|x| x.is_finite()));
    // The damped inverse is bounded by 1/(2λ) per singular direction.
    let lambda = Damping::default().lambda_max;
    assert!((c.lambda - lambda).abs() < 1e-9);
    assert!(c.j_inv.singular_values().max() <= 1.0 / (2.0 * lambda) + 1e-9);
}

/// `Data` reuses joint placements when an algorithm is called again at the same q
/// (e.g. FK, Jacobian, J̇q̇ and RNEA of one controller cycle): any interleaving of the
/// algorithms at repeated and changing q gives bit-identical results to a fresh `Data`.
#[test]
fn reused_placements_give_bit_identical_results_in_any_call_order() {
    for (name, model) in models() {
        let mut rng = Rng::seed(7);
        let mut data = Data::new(&model);
        let n = model.nv();
        let frames: Vec<_> = model.frames().iter().enumerate().map(|(k, _)| naic_core::model::FrameId(k)).collect();
        let qs: Vec<DVector<f64>> = (0..4).map(|_| random_q(&model, &mut rng)).collect();
        let v = DVector::from_fn(n, |_, _| rng.uniform(-1.0, 1.0));
        let a = DVector::from_fn(n, |_, _| rng.uniform(-5.0, 5.0));
        let mut calls = [0usize; 8];
        for step in 0..400 {
            // mostly repeat the last q, sometimes switch (also back to an earlier one)
            let q = &qs[if rng.uniform(0.0, 1.0) < 0.7 { (step / 7) % 4 } else { (rng.uniform(0.0, 4.0) as usize).min(3) }];
            let algo = (rng.uniform(0.0, 8.0) as usize).min(7);
            calls[algo] += 1;
            let mut fresh = Data::new(&model);
            let frame = frames[(rng.uniform(0.0, frames.len() as f64) as usize).min(frames.len() - 1)];
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            let (got, want): (Vec<u64>, Vec<u64>) = match algo {
                0 => {
                    dynamics::forward_kinematics(&model, &mut data, q);
                    dynamics::forward_kinematics(&model, &mut fresh, q);
                    let pose = |d: &Data| {
                        let mut x = Vec::new();
                        for &f in &frames {
                            let p = d.frame_placement(f).to_homogeneous();
                            x.extend(p.iter().copied());
                        }
                        for i in 0..n {
                            x.extend(d.joint_placement(i).rot.iter().copied());
                            x.extend(d.joint_placement(i).trans.iter().copied());
                        }
                        x
                    };
                    (bits(&pose(&data)), bits(&pose(&fresh)))
                }
                1 => (
                    bits(dynamics::frame_jacobian(&model, &mut data, q, frame).as_slice()),
                    bits(dynamics::frame_jacobian(&model, &mut fresh, q, frame).as_slice()),
                ),
                2 => (
                    bits(dynamics::frame_jdot_qdot(&model, &mut data, q, &v, frame).as_slice()),
                    bits(dynamics::frame_jdot_qdot(&model, &mut fresh, q, &v, frame).as_slice()),
                ),
                3 => (bits(dynamics::rnea(&model, &mut data, q, &v, &a).as_slice()), bits(dynamics::rnea(&model, &mut fresh, q, &v, &a).as_slice())),
                4 => (bits(dynamics::bias_torques(&model, &mut data, q, &v).as_slice()), bits(dynamics::bias_torques(&model, &mut fresh, q, &v).as_slice())),
                5 => (bits(dynamics::gravity_torques(&model, &mut data, q).as_slice()), bits(dynamics::gravity_torques(&model, &mut fresh, q).as_slice())),
                6 => (bits(dynamics::crba(&model, &mut data, q).as_slice()), bits(dynamics::crba(&model, &mut fresh, q).as_slice())),
                _ => (bits(dynamics::aba(&model, &mut data, q, &v, &a).as_slice()), bits(dynamics::aba(&model, &mut fresh, q, &v, &a).as_slice())),
            };
            assert_eq!(got, want, "{name}: step {step}, algorithm {algo}: reused placements changed the result");
        }
        assert!(calls.iter().all(|&c| c > 20), "{name}: every algorithm must be exercised: {calls:?}");
    }
}

/// `frame_placement` places one frame with exactly the numbers `forward_kinematics` gives
/// it (the controller places only its sensor and tip frames), on every frame of every model
/// and on the Panda's URDF with its many frames.
#[test]
fn frame_placement_is_forward_kinematics_bit_for_bit() {
    let mut all = models();
    all.push(("panda", Model::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/panda.urdf")).unwrap()));
    let mut rng = Rng::seed(37);
    for (name, model) in &all {
        let (mut fk, mut one) = (Data::new(model), Data::new(model));
        for _ in 0..20 {
            let q = random_q(model, &mut rng);
            dynamics::forward_kinematics(model, &mut fk, &q);
            for (k, frame) in model.frames().iter().enumerate() {
                let id = naic_core::model::FrameId(k);
                let placed = *dynamics::frame_placement(model, &mut one, &q, id);
                let want = fk.frame_se3(id);
                let same = placed.rot.iter().chain(placed.trans.iter()).zip(want.rot.iter().chain(want.trans.iter())).all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{name}: frame {k} '{}' placed at {placed:?}, forward kinematics {want:?}", frame.name);
            }
        }
    }
}
