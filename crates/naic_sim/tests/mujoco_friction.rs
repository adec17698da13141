//! The robot's joint friction on the MuJoCo plant (cargo feature `mujoco`): MuJoCo's
//! `frictionloss` + `damping` (set from the law at each step's velocity) against the
//! Table 1 model the own plant integrates, and the closed loop it damps (issue 36, mechanism 2 of
//! docs/notes/2026-12-06-issue36-mujoco-closed-loop-swings.md).
#![cfg(feature = "mujoco")]

mod common;

use common::{friction, mjcf, model, tool, ROOT};
use naic_core::model::Data6;
use naic_core::{dynamics, N_JOINTS};
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::plants::PlantChoice;
use naic_sim::{runner, scenario};
use nalgebra::Vector6;

/// The JK5 with its Table 1 friction in free space (flat's start, the table off), the
/// plant parameters, a dynamics workspace and the start joints.
struct FreeSpace {
    m: naic_core::model::Model,
    f: naic_core::friction::FrictionModel,
    s: scenario::Scenario,
    p: naic_sim::plant::PlantParams,
    data: Data6,
    q0: Vector6<f64>,
}

fn free_space() -> FreeSpace {
    let m = model();
    let f = friction();
    let mut s = scenario::preset("flat", &m).unwrap();
    s.env.enabled = false;
    let p = scenario::plant_for(&s, m.clone(), Some(f.clone()), tool()).unwrap();
    let data = Data6::try_new(&m).unwrap();
    let q0 = Vector6::from(s.task.q0);
    FreeSpace { m, f, s, p, data, q0 }
}

/// A closed loop on MuJoCo with the JK5's Table 1 friction at loop delay 1: scenario `name`,
/// seed 1, ended at `duration` if given, its plant parameters, with the tool's inertial
/// wrench in the sensor's reading when `inertial`.
struct ClosedLoop {
    m: naic_core::model::Model,
    f: naic_core::friction::FrictionModel,
    s: scenario::Scenario,
    t: (f64, nalgebra::Vector3<f64>),
    p: naic_sim::plant::PlantParams,
    settings: LoopSettings,
}

fn closed_loop(name: &str, duration: Option<f64>, inertial: bool) -> ClosedLoop {
    let m = model();
    let f = friction();
    let mut s = scenario::preset(name, &m).unwrap();
    s.seed = 1;
    if let Some(d) = duration {
        s.task.duration = d;
    }
    let t = tool();
    let mut p = scenario::plant_for(&s, m.clone(), Some(f.clone()), t).unwrap();
    if inertial {
        p.ft = p.ft.with_tool_inertia(naic_sim::sensor::tool_inertia_from_urdf(std::path::Path::new(&format!("{ROOT}/urdf/jk5.urdf"))).unwrap());
    }
    ClosedLoop { m, f, s, t, p, settings: LoopSettings { delay_cycles: 1, ..LoopSettings::default() } }
}

/// Constant torque on one joint, free space: joint `j` gets naic's bias torques (gravity,
/// Coriolis; the same arm as the MJCF, `open_loop_free_space_...` in mujoco_plant.rs) plus
/// `tau_c` (the Table 1 model at 0.2 or 0.6 rad/s, both directions: Table 1 is per
/// direction; a 2 N·m kick for the first 20 ms breaks the joint away), the other joints are
/// held at the start pose by a PD. Over the last 0.1 s of
/// 0.4 s, MuJoCo's friction torque on joint `j` is measured by inverse dynamics on naic's
/// model (`τ − M(q)q̈ − b(q, q̇)`, q̈ from the velocity difference of each period) and
/// compared, as a mean over the window, with the Table 1 model at MuJoCo's speeds.
/// Tolerance: 0.5 % of `tau_c` + 0.02 N·m (model differences of the two arms, the level's
/// one step of lag).
#[test]
fn under_a_constant_torque_each_mujoco_joint_balances_the_table_1_friction_at_its_speed() {
    let FreeSpace { m, f, s, p, mut data, q0 } = free_space();
    let mut worst = 0.0_f64;
    for j in 0..N_JOINTS {
        for v_star in [0.2, 0.6, -0.2, -0.6] {
            let tau_c = f.tau_f(j, v_star);
            let mut plant = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, 1).unwrap();
            let steps = 400;
            let (mut v_sum, mut meas_sum, mut model_sum, mut tf_sum, mut n) = (0.0, 0.0, 0.0, 0.0, 0);
            for k in 0..steps {
                let q = Vector6::from_row_slice(plant.q());
                let dq = Vector6::from_row_slice(plant.dq());
                let bias = *dynamics::bias_torques(&m, &mut data, &q, &dq);
                // a breakaway kick for the first 20 ms: tau_c at speed can be below the
                // breakaway level (joint 4: 2.90 N·m at 0.2 rad/s, f_b⁺ 2.92 N·m)
                let kick = if k < 20 { v_star.signum() * 2.0 } else { 0.0 };
                let mut tau = [0.0; N_JOINTS];
                for i in 0..N_JOINTS {
                    tau[i] = bias[i] + if i == j { tau_c + kick } else { 400.0 * (q0[i] - q[i]) - 40.0 * dq[i] };
                }
                plant.step(&tau);
                if k >= steps - 100 {
                    let q1 = Vector6::from_row_slice(plant.q());
                    let dq1 = Vector6::from_row_slice(plant.dq());
                    let ddq = (dq1 - dq) / s.task.dt;
                    let (qm, vm) = ((q + q1) * 0.5, (dq + dq1) * 0.5);
                    let mm = *dynamics::crba(&m, &mut data, &qm);
                    let b = *dynamics::bias_torques(&m, &mut data, &qm, &vm);
                    meas_sum += tau[j] - (mm * ddq)[j] - b[j];
                    model_sum += f.tau_f(j, dq1[j]);
                    v_sum += dq1[j];
                    tf_sum += plant.observation().truth.tau_friction[j];
                    n += 1;
                }
            }
            let v = v_sum / n as f64;
            let measured = meas_sum / n as f64;
            let model_at_v = model_sum / n as f64;
            let reported = tf_sum / n as f64;
            let err = (model_at_v - measured).abs();
            let tol = 0.005 * tau_c.abs() + 0.02;
            worst = worst.max(err / tol);
            println!(
                "joint {}: tau_c {tau_c:8.3} N·m (the model at {v_star:+.1} rad/s): MuJoCo at {v:+.4} rad/s, friction by inverse dynamics {measured:8.3}, \
                 the model there {model_at_v:8.3}, MuJoCo's own (frictionloss force + damping) {reported:8.3}; |difference| {err:.3} (tol {tol:.3})",
                j + 1
            );
            assert!(v * v_star > 0.0 && v.abs() > 0.1, "joint {}: pushed for {v_star} rad/s, moves at {v}", j + 1);
            assert!(err <= tol, "joint {} at {v} rad/s: MuJoCo's friction {measured} N·m, the model {model_at_v} N·m", j + 1);
        }
    }
    println!("worst |model − tau_c| / tol = {worst:.3}");
}

/// Below the Coulomb level MuJoCo's `frictionloss` holds a joint: the wrist joint 6 under
/// its bias torques plus half its smallest Coulomb level (Table 1: 1.86 N·m) barely moves.
#[test]
fn below_the_coulomb_level_the_mujoco_joint_stays_at_rest() {
    let FreeSpace { m, f: _, s, p, mut data, q0 } = free_space();
    let mut plant = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, 1).unwrap();
    for _ in 0..1000 {
        let q = Vector6::from_row_slice(plant.q());
        let dq = Vector6::from_row_slice(plant.dq());
        let bias = *dynamics::bias_torques(&m, &mut data, &q, &dq);
        let mut tau = [0.0; N_JOINTS];
        for i in 0..N_JOINTS {
            tau[i] = bias[i] + if i == 5 { 0.93 } else { 400.0 * (q0[i] - q[i]) - 40.0 * dq[i] };
        }
        plant.step(&tau);
    }
    let moved = (plant.q()[5] - q0[5]).abs();
    println!("joint 6 under 0.93 N·m for 1 s: moved {moved:.2e} rad, at {:.2e} rad/s", plant.dq()[5]);
    assert!(moved < 0.01, "joint 6 slid {moved} rad under half its Coulomb level");
}

/// The paper's AIC (eq 6 with the paper's B_d/M_d on the rotations) at loop delay 1 on
/// flat, the 10 N phase (to 2.9 s, before the 20 N step): on MuJoCo without joint friction
/// the wrist swings at about 70 Hz up to 10 rad/s (the delayed velocity loop past its
/// bound, docs/controller.md); with the JK5's joint friction on the MuJoCo plant and the
/// controller's feedforward on, no joint exceeds the 2 rad/s and the force estimate
/// never reaches the force limit (no retract).
#[test]
fn the_papers_aic_at_delay_1_on_mujoco_flat_keeps_every_joint_below_2_rad_s_without_a_retract() {
    let ClosedLoop { m, f, s, t, p, settings } = closed_loop("flat", Some(2.9), true);
    let mut c = PipelineController::by_name("aic", &s, &m, Some(f), t, &settings).unwrap();
    let mut plant = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, s.seed).unwrap();
    let r = runner::run_on(&s, plant.as_mut(), &mut c, &mut |_| {});
    let fastest = r.records.iter().flat_map(|x| x.dq.iter().map(|v| v.abs())).fold(0.0, f64::max);
    let peak_est = r.records.iter().map(|x| x.f_ext_est).fold(f64::NEG_INFINITY, f64::max);
    let contact = r.records.iter().any(|x| x.in_contact);
    println!("aic, d = 1, flat to 2.9 s on MuJoCo with joint friction: fastest joint {fastest:.2} rad/s, peak force estimate {peak_est:.1} N, contact {contact}");
    assert!(contact, "the tip never reached the table");
    assert!(fastest <= 2.0, "a joint reached {fastest} rad/s");
    assert!(peak_est < settings.force_limit_n, "the force estimate reached {peak_est} N (limit {} N): a retract", settings.force_limit_n);
}

/// The start-up tare at rest (the node's default, `naic sim --tare at-rest`) on MuJoCo with
/// the JK5's joint friction, flat to 2.9 s, the derived and the paper's NAIC law, the tool's
/// inertial wrench in the reading: the tare's hold evaluates the friction feedforward at the
/// blend of the measured velocity and its own (zero), the joints come to rest, the tare
/// completes and the law reaches the table. With the feedforward at the measured velocity the
/// encoders' noise put ±f_b on every joint, the wrist stuck and slipped at up to 0.18 rad/s
/// and no law made contact in 5 s.
#[test]
fn the_tare_at_rest_completes_on_mujoco_with_the_joint_friction() {
    let ClosedLoop { m, f, s, t, p, mut settings } = closed_loop("flat", Some(2.9), true);
    settings.tare_at_rest = true;
    settings.sensor_reads_tool_inertia = true;
    for law in ["derived", "naic"] {
        let mut c = PipelineController::by_name(law, &s, &m, Some(f.clone()), t, &settings).unwrap();
        let mut plant = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, s.seed).unwrap();
        let r = runner::run_on(&s, plant.as_mut(), &mut c, &mut |_| {});
        let touch = r.records.iter().find(|x| x.in_contact).map(|x| x.t);
        println!("{law}: tare at rest on MuJoCo with friction, first contact at {touch:?} s");
        assert!(touch.is_some_and(|t| t < 2.5), "{law}: no contact by 2.5 s ({touch:?}): the tare did not complete");
    }
}

/// The derived law's stiction-aware hold (issue 42 item 6, naic_core::pipeline::control::stiction)
/// on MuJoCo's foam with the JK5's joint friction, d = 1, seeds 1–5: with the hold the late
/// force (the last 0.5 s) stays within 0.4 N peak-to-peak; with the hold off (its ablation
/// switch, `naic sim --ablate stiction-hold`: the feedforward at the stuck joints' velocity
/// noise) every run moves more, and the stick-slip hunting, intermittent, goes beyond 0.4 N
/// in at least one of them.
#[test]
fn the_derived_laws_stiction_hold_keeps_foam_on_mujoco_from_hunting() {
    let ClosedLoop { m, f, s, t, p, settings } = closed_loop("foam", None, true);
    let late_p2p = |hold: bool, seed: u64| {
        let s = scenario::Scenario { seed, ..s.clone() };
        let mut c = PipelineController::by_name("derived", &s, &m, Some(f.clone()), t, &settings).unwrap();
        if !hold {
            let mut q = *c.params();
            q.control.force_law.derived.parts.stiction_hold = false;
            c.set_params(q).unwrap();
        }
        let mut plant = PlantChoice::Mujoco { mjcf: mjcf() }.build(&p, &s.task.q0, s.seed).unwrap();
        let r = runner::run_on(&s, plant.as_mut(), &mut c, &mut |_| {});
        let t_end = r.records.last().unwrap().t;
        let late = r.records.iter().filter(|x| x.t >= t_end - 0.5).map(|x| x.f_ext);
        let (lo, hi) = late.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), f| (lo.min(f), hi.max(f)));
        hi - lo
    };
    let mut worst_without = 0.0_f64;
    for seed in 1..=5 {
        let (with, without) = (late_p2p(true, seed), late_p2p(false, seed));
        println!("derived, foam, d = 1, seed {seed} on MuJoCo with joint friction: late peak-to-peak {with:.3} N with the hold, {without:.3} N without");
        assert!(with <= 0.4, "seed {seed}, with the hold: {with} N");
        assert!(without > with, "seed {seed}: {without} N without the hold, {with} N with it");
        worst_without = worst_without.max(without);
    }
    assert!(worst_without > 0.4, "without the hold at most {worst_without} N (the test no longer shows the hunting)");
}

/// The MuJoCo plant warm-starts the constraint solver (the authors' file disables it): at every
/// period of the closed loop (`aic`, d = 1, flat to 2.9 s: contact and the six friction rows),
/// the state's constraint solution is solved again from the authors' cold start (warmstart
/// off, MuJoCo's default tolerance 1e-8, line-search tolerance 0.01, 100 iterations) and
/// compared. The table's contact force on the tip differs by less than the mini45's z
/// resolution at every period, and the constraint torques agree to rounding (1e-9 N·m) at
/// 99.9 % of the periods (the rest: states where a friction row's stick/slip is decided
/// within the tolerance).
#[test]
fn the_warm_started_solver_gives_the_cold_starts_constraint_forces() {
    use naic_sim::mujoco_plant::MujocoPlant;
    use naic_sim::plants::Plant;
    struct Gap {
        p: MujocoPlant,
        normal: f64,
        torques: Vec<f64>,
    }
    impl Plant for Gap {
        fn name(&self) -> &'static str {
            "mujoco"
        }
        fn dof(&self) -> usize {
            N_JOINTS
        }
        fn dt(&self) -> f64 {
            Plant::dt(&self.p)
        }
        fn step(&mut self, tau: &[f64]) {
            self.p.step(tau);
            let g = self.p.solution_gap(|o| {
                o.disableflags |= mujoco_rs::mujoco_c::mjtDisableBit::mjDSBL_WARMSTART as i32;
                o.tolerance = 1e-8;
                o.ls_tolerance = 0.01;
                o.iterations = 100;
            });
            self.normal = self.normal.max(g.contact_normal);
            self.torques.push(g.qfrc_constraint);
        }
        fn observation(&self) -> &naic_sim::plant::Observation {
            self.p.observation()
        }
        fn q(&self) -> &[f64] {
            self.p.q()
        }
        fn dq(&self) -> &[f64] {
            self.p.dq()
        }
    }
    let ClosedLoop { m, f, s, t, p, settings } = closed_loop("flat", Some(2.9), false);
    let mut c = PipelineController::by_name("aic", &s, &m, Some(f), t, &settings).unwrap();
    let mut plant = Gap { p: MujocoPlant::new(&mjcf(), &p, &s.task.q0, s.seed).unwrap(), normal: 0.0, torques: Vec::new() };
    let r = runner::run_on(&s, &mut plant, &mut c, &mut |_| {});
    assert!(r.records.iter().any(|x| x.in_contact), "the tip never reached the table");
    let mut tq = plant.torques.clone();
    tq.sort_by(f64::total_cmp);
    let p999 = tq[tq.len() * 999 / 1000];
    let work = plant.p.solver_work();
    println!(
        "warm start vs the authors' cold start over {} periods: contact force gap ≤ {:.2e} N, constraint torque gap p99.9 {p999:.2e} N·m, max {:.2e} N·m; {:.2} iterations and {:.1} line-search evaluations per solve",
        tq.len(),
        plant.normal,
        tq[tq.len() - 1],
        work.iterations as f64 / work.solves as f64,
        work.evaluations as f64 / work.solves as f64
    );
    let resolution_z = p.ft.resolution[2];
    assert!(plant.normal < resolution_z, "the contact force differs by {} N (the mini45 resolves {resolution_z} N)", plant.normal);
    assert!(p999 < 1e-9, "the constraint torques differ by {p999} N·m at the 99.9th percentile of periods");
}
