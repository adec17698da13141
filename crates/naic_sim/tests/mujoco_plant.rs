//! The MuJoCo plant against the own plant (cargo feature `mujoco`; tests/run_all.sh
//! turns it on): the same arm, start pose, table and sensor convention, checked on
//! MuJoCo's physics, which no one here wrote.
#![cfg(feature = "mujoco")]

use naic_core::model::Data6;
use naic_core::{dynamics, N_JOINTS};
use naic_sim::plant::PlantParams;
use naic_sim::plants::{Plant, PlantChoice};
use naic_sim::scenario::{self, Scenario};
mod common;

use common::{mjcf, model, tool};
use nalgebra::{Vector3, Vector6};

/// Scenario `name` without joint friction; contact on or off.
fn setup(name: &str, contact: bool) -> (Scenario, PlantParams) {
    let mut s = scenario::preset(name, &model()).unwrap();
    s.env.enabled = contact;
    let p = scenario::plant_for(&s, model(), None, tool()).unwrap();
    (s, p)
}

fn both(s: &Scenario, p: &PlantParams) -> (Box<dyn Plant + Send>, Box<dyn Plant + Send>) {
    let own = PlantChoice::Own.build(p, &s.task.q0, s.seed).unwrap();
    let mj = PlantChoice::Mujoco { mjcf: mjcf() }.build(p, &s.task.q0, s.seed).unwrap();
    (own, mj)
}

#[test]
fn open_loop_free_space_the_same_torques_give_the_same_joint_trajectory_within_1e_3_rad() {
    // The torques: a computed-torque joint PD on the own plant tracking q0 + 0.2 sin(2πft)
    // per joint; MuJoCo gets the same sequence open loop (it never sees its own state).
    let (s, p) = setup("flat", false);
    let (mut own, mut mj) = both(&s, &p);
    let m = model();
    let mut data = Data6::try_new(&m).unwrap();
    let freq = [0.7, 1.1, 0.9, 1.3, 1.7, 2.0];
    let n = (1.0 / p.dt).round() as usize;
    let (mut worst, mut lo, mut hi) = (0.0_f64, [f64::INFINITY; N_JOINTS], [f64::NEG_INFINITY; N_JOINTS]);
    for k in 0..n {
        let t = k as f64 * p.dt;
        let q = Vector6::from_column_slice(own.q());
        let dq = Vector6::from_column_slice(own.dq());
        let q_ref = Vector6::from_fn(|i, _| s.task.q0[i] + 0.2 * (2.0 * std::f64::consts::PI * freq[i] * t).sin());
        let g = *dynamics::gravity_torques(&m, &mut data, &q);
        let ma = *dynamics::crba(&m, &mut data, &q) * ((q_ref - q) * 400.0 - dq * 40.0);
        let tau: [f64; N_JOINTS] = std::array::from_fn(|i| g[i] + ma[i]);
        own.step(&tau);
        mj.step(&tau);
        for i in 0..N_JOINTS {
            worst = worst.max((own.q()[i] - mj.q()[i]).abs());
            lo[i] = lo[i].min(mj.q()[i]);
            hi[i] = hi[i].max(mj.q()[i]);
        }
    }
    let moved: Vec<f64> = (0..N_JOINTS).map(|i| hi[i] - lo[i]).collect();
    println!("open loop 1 s, free space, no joint friction: max |q_own − q_mujoco| = {worst:.3e} rad; joint ranges {moved:.3?} rad");
    assert!(moved.iter().all(|r| *r > 0.1), "the torques must move every joint: {moved:?}");
    assert!(worst <= 1e-3, "joint trajectories differ by {worst:.3e} rad");
}

#[test]
fn held_at_rest_the_mujoco_sensor_reads_the_tool_weight_in_naics_convention() {
    for name in ["flat", "foam"] {
        let (s, p) = setup(name, true);
        let (own, mj) = both(&s, &p);
        let (a, b) = (own.observation().truth.wrench_true, mj.observation().truth.wrench_true);
        let e = (0..6).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
        println!("{name}: own {a:.6?}\n      mujoco {b:.6?}");
        assert!(a[..3].iter().map(|x| x * x).sum::<f64>().sqrt() > 4.0, "the tool weight (4.16 N) is in the reading");
        assert!(e < 1e-6, "{name}: MuJoCo's nft_sensor and the own sensor model differ by {e:.3e}");
    }
}

#[test]
fn the_same_descent_touches_the_table_at_the_same_time_on_both_plants() {
    // The own plant (no friction) under a computed-torque joint PD (ω = 8 rad/s) towards a
    // pose 5 cm under the surface; the torques it applied are applied to MuJoCo too.
    for name in ["flat", "foam", "slope"] {
        let (s, p) = setup(name, true);
        let (mut own, mut mj) = both(&s, &p);
        let m = model();
        let (tip0, r0) = scenario::tip_pose(&m, &s.task.q0);
        let below = Vector3::new(tip0.x, tip0.y, s.env.height_at(tip0.x, tip0.y) - 0.05);
        let (q_t, ik_err) = scenario::inverse_kinematics(&m, &s.task.q0, &below, &r0);
        assert!(ik_err < 1e-6, "IK to {below:?}: residual {ik_err}");
        let mut data = Data6::try_new(&m).unwrap();
        let (mut t_own, mut t_mj) = (None, None);
        let mut gap = 0.0_f64;
        for k in 0..4000 {
            let q = Vector6::from_column_slice(own.q());
            let dq = Vector6::from_column_slice(own.dq());
            let g = *dynamics::gravity_torques(&m, &mut data, &q);
            let mm = *dynamics::crba(&m, &mut data, &q);
            let w = 8.0;
            let a = (Vector6::from(q_t) - q) * (w * w) - dq * (2.0 * w);
            let ma = mm * a;
            let tau: [f64; N_JOINTS] = std::array::from_fn(|i| g[i] + ma[i]);
            own.step(&tau);
            mj.step(&tau);
            if t_own.is_none() && t_mj.is_none() {
                gap = (0..N_JOINTS).map(|i| (own.q()[i] - mj.q()[i]).abs()).fold(gap, f64::max);
            }
            let t = (k + 1) as f64 * p.dt;
            if t_own.is_none() && own.observation().truth.contact.in_contact {
                t_own = Some(t);
            }
            if t_mj.is_none() && mj.observation().truth.contact.in_contact {
                t_mj = Some(t);
            }
            if t_own.is_some() && t_mj.is_some() {
                break;
            }
        }
        println!("{name}: first contact own {t_own:?} s, MuJoCo {t_mj:?} s; max |q_own − q_mujoco| before it {gap:.2e} rad");
        let (a, b) = (t_own.expect("the own plant touched"), t_mj.expect("MuJoCo touched"));
        assert!((a - b).abs() <= 0.002, "{name}: first contact at {a} s (own) vs {b} s (MuJoCo)");
    }
}

#[test]
fn every_scenario_has_a_measured_static_stiffness_on_mujoco() {
    for name in scenario::SCENARIOS {
        let s = scenario::preset(name, &model()).unwrap();
        let p = scenario::plant_for(&s, model(), None, tool()).unwrap();
        let rows = naic_sim::mujoco_plant::static_stiffness(&mjcf(), &p, &s.task.q0, [5.0, 15.0]).unwrap();
        assert!(!rows.is_empty());
        for r in rows {
            println!(
                "{name}: k_e {} N/m -> solref {:?}: {:.2} N at {:.3} mm, {:.2} N at {:.3} mm: static stiffness {:.0} N/m",
                r.k_e, r.solref, r.forces_n[0], r.penetration_mm[0], r.forces_n[1], r.penetration_mm[1], r.k_static
            );
            // the pushes reached the surface: in contact at both, deeper at the larger
            assert!(r.forces_n[0] > 0.5 && r.forces_n[1] > r.forces_n[0] + 5.0, "{name}: {r:?}");
            assert!(r.penetration_mm[0] > 0.0 && r.penetration_mm[1] > r.penetration_mm[0], "{name}: {r:?}");
            assert!(r.k_static.is_finite() && r.k_static > 0.0, "{name}: {r:?}");
        }
    }
}

#[test]
fn a_missing_mjcf_is_an_error_that_names_it() {
    let (s, p) = setup("flat", true);
    let e = PlantChoice::Mujoco { mjcf: "no/such/model.xml".into() }.build(&p, &s.task.q0, 1).err().expect("must fail");
    let m = e.to_string();
    assert!(m.contains("no/such/model.xml") && m.contains("--mjcf"), "{m}");
}

/// The contact estimator (`naic_core::pipeline::control::contact`) on MuJoCo's contact of
/// the authors' JK5: the tip lowered onto `flat` (at 30 mm/s over the last centimetre) and held at 10 N by a Cartesian
/// computed-torque loop on naic's model (the push along n known exactly), the force read
/// from MuJoCo's contact with mini45-like noise one period late, the tip quantised to
/// 1.5 µm. The reference is MuJoCo's own contact solve differentiated at these states by
/// `tools/mujoco_contact_model.py` (docs/simulation.md, "The contact as the force laws see
/// it"): μ = 0.072, k_e = 1556 N/m on flat; μ = 0.073, k_e = 776 N/m on foam (medians
/// over a `naic` run's contact, the table's contact parameters taken by priority). (Acrylic's 10 N stays inside solimp's first millimetre, where
/// MuJoCo's contact is not linear: not checked here.)
#[test]
fn the_contact_estimator_reads_mujocos_contact_on_the_jk5() {
    estimate_on_mujoco("flat", 1556.0, 0.072);
}

/// Foam, as [`the_contact_estimator_reads_mujocos_contact_on_the_jk5`]: a goal not met since
/// the scenarios' contact takes the table's parameters (geom priority).
#[test]
#[ignore = "issue 42 not met: on MuJoCo's foam (priority contact) mu_hat reads 0.205 against the reference 0.073 (tolerance 0.1)"]
fn the_contact_estimator_reads_mujocos_foam_on_the_jk5() {
    estimate_on_mujoco("foam", 776.0, 0.073);
}

fn estimate_on_mujoco(name: &str, k_ref: f64, mu_ref: f64) {
    use naic_core::dynamics::{cartesian_terms, Damping};
    use naic_core::pipeline::control::contact::{self, ContactInputs, ContactParams, ContactState};
    let (s, p) = setup(name, true);
    let m = model();
    let tip = m.frame_id("tip").expect("tip frame");
    let mut mj = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, s.seed).unwrap();
    let mut data = Data6::try_new(&m).unwrap();
    let n = Vector3::new(0.0, 0.0, -1.0);
    let (p0, r0) = scenario::tip_pose(&m, &s.task.q0);
    let params = ContactParams::default();
    let mut est = ContactState::default();
    let (mut in_contact, mut t_contact) = (false, f64::NAN);
    let mut f_prev = 0.0;
    let mut u_prev = 0.0;
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut noise = || {
        // xorshift, Box–Muller: the sensor's noise, σ = 1/16 N
        let mut uni = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (uni(), uni());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos() / 16.0
    };
    let mut last = None;
    for k in 0..5000 {
        let t = k as f64 * p.dt;
        let obs = mj.observation().clone();
        let q = Vector6::from_column_slice(mj.q());
        let dq = Vector6::from_column_slice(mj.dq());
        let ct = cartesian_terms(&m, &mut data, &q, &dq, tip, &Damping::default()).unwrap();
        let vel = ct.j * dq;
        let x = n.dot(&obs.truth.tip.translation.vector);
        let v = n.dot(&vel.fixed_rows::<3>(0).into_owned());
        // the force one period late, with noise, quantised to 1/16 N
        let f_now = ((obs.truth.contact.normal_force + noise()) * 16.0).round() / 16.0;
        let f_m = f_prev;
        f_prev = f_now;
        let start = !in_contact && f_m > 0.5;
        if start {
            in_contact = true;
            t_contact = t;
        }
        let inputs = ContactInputs {
            x: (x / 1.5e-6).round() * 1.5e-6,
            x_dot: v,
            f: f_m,
            u: u_prev,
            contact_start: start,
            in_contact,
            dt: p.dt,
            delay_cycles: 1,
            x_resolution: 1.5e-6,
            sigma_f: 1.0 / 16.0,
        };
        let (ns, e) = contact::step(&params, &est, &inputs);
        est = ns;
        if k % 250 == 0 && std::env::var("CONTACT_TRACE").is_ok() {
            println!("t {t:.3} x {x:.5} v {v:.4} f {f_m:.2} u {u_prev:.2} k̂ {:.0} μ̂ {:.3} surface {:.4}", e.k_hat, e.mu_hat, s.env.height_at(p0.x, p0.y));
        }
        if in_contact && t - t_contact > 1.5 {
            last = Some(e);
            break;
        }
        // the loop: hold the tangential position and the orientation, along n approach at
        // 30 mm/s, then an admittance to 10 N; the measured force's target fed forward
        let pos = obs.truth.tip.translation.vector;
        let rot_err = (r0 * obs.truth.tip.rotation.to_rotation_matrix().transpose()).scaled_axis();
        let mut a_lin = (p0 - pos) * 400.0 - vel.fixed_rows::<3>(0).into_owned() * 40.0;
        a_lin -= n * n.dot(&a_lin);
        let gap = pos.z - s.env.height_at(pos.x, pos.y);
        let v_c = if in_contact {
            (10.0 - f_m) / 400.0
        } else if gap > 0.01 {
            0.1
        } else {
            0.03
        };
        a_lin += n * (60.0 * (v_c - v));
        let a_ang = rot_err * 400.0 - vel.fixed_rows::<3>(3).into_owned() * 40.0;
        let a = Vector6::new(a_lin.x, a_lin.y, a_lin.z, a_ang.x, a_ang.y, a_ang.z);
        let f_ff = if in_contact { 10.0 } else { 0.0 };
        let push = ct.d * a;
        let mut w = push + ct.h;
        for i in 0..3 {
            w[i] += n[i] * f_ff;
        }
        u_prev = n.dot(&push.fixed_rows::<3>(0).into_owned()) + f_ff;
        let tau = ct.j.transpose() * w;
        mj.step(&[tau[0], tau[1], tau[2], tau[3], tau[4], tau[5]]);
    }
    let e = last.expect("contact for 1.5 s");
    println!("{name} on MuJoCo: k̂ {:.0} [{:.0}, {:.0}] N/m, μ̂ {:.3} (μ̄ {:.3})", e.k_hat, e.k_lower, e.k_upper, e.mu_hat, e.mu_upper);
    assert!((e.k_hat - k_ref).abs() < 0.1 * k_ref, "{name}: k̂ {e:?}");
    assert!((e.mu_hat - mu_ref).abs() < 0.1, "{name}: μ̂ {e:?}");
}

/// MuJoCo combines the parameters of the two geoms in a contact; the plant gives the table
/// geoms a higher `priority` than the MJCF's so that the contact is the scenario's: read
/// back from `mjData.contact` with the tip held on each material at 10 N, every
/// table contact is frictionless (`dim` 1) with the material's `solref` and the authors'
/// `solimp`, and carries no tangential force.
#[test]
fn a_mujoco_contact_takes_the_scenarios_contact_parameters() {
    use naic_sim::mujoco_plant::{solref_for, MujocoPlant, AUTHORS_SOLIMP};
    for name in ["flat", "foam", "acrylic", "slope"] {
        let (s, p) = setup(name, true);
        let mut mj = MujocoPlant::new(&mjcf(), &p, &s.task.q0, s.seed).unwrap();
        mj.approach(15.0).unwrap(); // onto the surface (as the stiffness report)
        let (f, _) = mj.push_along(10.0, None, 1.0);
        let tip = mj.tip_position();
        let want = solref_for(&p.env.material.at(1.0, &tip));
        let cs = mj.table_contacts();
        println!("{name}: {f:.2} N; contacts {cs:?}");
        assert!(f > 5.0 && !cs.is_empty(), "{name}: the push reached the table ({f} N, {} contacts)", cs.len());
        for c in &cs {
            assert_eq!(c.dim, 1, "{name}: condim of the contact (the table's 1, not the tip sphere's 3): {c:?}");
            assert_eq!(c.solref, want, "{name}: solref {c:?}");
            assert_eq!(c.solimp, AUTHORS_SOLIMP, "{name}: solimp {c:?}");
            assert_eq!(c.tangential_n, 0.0, "{name}: {c:?}");
        }
    }
}

/// The table meets the tip's sphere alone: pushed at 25 N on flat and foam (MuJoCo's
/// contact sinks the sphere past its 10 mm radius there, so the tool's stick, a cylinder
/// ending at the sphere's centre, would reach the table), the push settles on one contact,
/// the sphere's, carrying the push.
#[test]
fn past_one_tip_radius_of_penetration_the_table_still_meets_the_tip_sphere_alone() {
    use naic_sim::mujoco_plant::MujocoPlant;
    for name in ["flat", "foam"] {
        let (s, p) = setup(name, true);
        let mut mj = MujocoPlant::new(&mjcf(), &p, &s.task.q0, s.seed).unwrap();
        mj.approach(15.0).unwrap(); // onto the surface (as the stiffness report)
        let r = mj.push_to(25.0, None, 3.0);
        let cs = mj.table_contacts();
        println!("{name}: {r:?}; contacts {cs:?}");
        assert!(r.penetration > 10.5e-3, "{name}: the tip sank {:.2} mm, not past the sphere's radius: the test proves nothing", r.penetration * 1e3);
        assert!(r.settled(25.0), "{name}: the push did not settle: {r:?}");
        assert_eq!(cs.len(), 1, "{name}: the table met more than the tip sphere: {cs:?}");
        assert!((cs[0].normal_n - 25.0).abs() < 0.5, "{name}: the sphere's contact carries the push: {cs:?}");
    }
}

/// The table meets the tip's geoms only, so an MJCF whose body `tip` has none is refused
/// with a message that names the body and the fix (the authors' JK5 with its tip sphere
/// taken out).
#[test]
fn an_mjcf_whose_tip_has_no_geom_is_refused() {
    use naic_sim::mujoco_plant::MujocoPlant;
    let text = std::fs::read_to_string(mjcf()).unwrap();
    let sphere = "<geom type=\"sphere\" pos=\"0 0 0\" group=\"1\" size=\"0.01 0.01 0.01\" />";
    // the last one (the first is in a comment)
    let at = text.rfind(sphere).expect("the authors' tip sphere is where the test expects it");
    let path = std::env::temp_dir().join(format!("naic-no-tip-geom-{}.xml", std::process::id()));
    std::fs::write(&path, format!("{}{}", &text[..at], &text[at + sphere.len()..])).unwrap();
    let (s, p) = setup("flat", true);
    let err = MujocoPlant::new(&path, &p, &s.task.q0, s.seed).err().map(|e| e.to_string());
    std::fs::remove_file(&path).ok();
    let err = err.expect("an MJCF whose tip has no geom was accepted");
    assert!(err.contains("'tip' has no geom") && err.contains("sphere"), "{err}");
}

/// A tangential push on the flat table meets no friction: held on the table at 10 N, a
/// 3 N push along x for 0.5 s moves the tip as free motion along the surface would,
/// `F t² / 2Λ` with Λ the arm's apparent mass along x at the tip (naic's model at the
/// push's start: between `1/(x Jp M⁻¹ Jpᵀ x)` with the orientation free and the 6-D
/// `(J M⁻¹ Jᵀ)⁻¹` entry with it held; the push holds it with a soft spring), and no contact
/// carries a tangential force at any point of the push (read every 10 ms; each 10 ms push
/// re-anchors the orientation hold). MuJoCo's friction is soft: in one unbroken 0.5 s push
/// the tip slid 25.2 mm without friction and still 20.75 mm with MuJoCo's default mix
/// (condim 3, friction 1), whose contacts carried 0.6 N of friction; the tangential force
/// is the check that separates the two, the distance only that the tip slid.
#[test]
fn a_tangential_push_on_the_flat_table_meets_no_friction() {
    use naic_sim::mujoco_plant::MujocoPlant;
    let (s, p) = setup("flat", true);
    let mut mj = MujocoPlant::new(&mjcf(), &p, &s.task.q0, s.seed).unwrap();
    mj.approach(15.0).unwrap(); // onto the surface (as the stiffness report)
    mj.push_along(10.0, None, 1.0);
    let x0 = mj.tip_position();
    let m = model();
    let mut data = Data6::try_new(&m).unwrap();
    let q = Vector6::from_column_slice(mj.q());
    let tip = m.frame_id("tip").expect("tip frame");
    let j = *dynamics::frame_jacobian(&m, &mut data, &q, tip);
    let mass = *dynamics::crba(&m, &mut data, &q);
    let a_inv = j * mass.try_inverse().expect("M invertible") * j.transpose();
    let x = Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let lambda_free = 1.0 / (x.transpose() * a_inv * x)[0];
    let lambda_held = a_inv.try_inverse().expect("J M⁻¹ Jᵀ invertible")[(0, 0)];
    let (f_t, t): (f64, f64) = (3.0, 0.5);
    let (mut f, mut friction) = (0.0, 0.0_f64);
    let chunk: f64 = 0.01;
    for _ in 0..(t / chunk).round() as usize {
        mj.push_along(10.0, Some(Vector3::new(f_t, 0.0, 0.0)), chunk);
        let cs = mj.table_contacts();
        f = cs.iter().map(|c| c.normal_n).sum::<f64>();
        friction = cs.iter().map(|c| c.tangential_n).fold(friction, f64::max);
    }
    let moved = mj.tip_position() - x0;
    let (hi, lo) = (f_t * t * t / (2.0 * lambda_free), f_t * t * t / (2.0 * lambda_held));
    println!(
        "flat: held at {f:.2} N (largest tangential contact force {friction:.3} N), a {f_t} N tangential push for {t} s moved the tip {:.2} mm along x ({:.3} mm along z); \
         free sliding: {:.2} mm (Λ {lambda_held:.2} kg, orientation held) to {:.2} mm (Λ {lambda_free:.2} kg, free)",
        moved.x * 1e3,
        moved.z * 1e3,
        lo * 1e3,
        hi * 1e3
    );
    assert!(f > 5.0, "still on the table: {f} N");
    assert_eq!(friction, 0.0, "the contact carried a tangential force");
    assert!(moved.x > 0.5 * lo, "the tip slid {:.2} mm, under half of free sliding ({:.2} mm): the contact resists a tangential push", moved.x * 1e3, lo * 1e3);
}
