//! Trace of the scheduled law's first contact (docs/controller.md):
//! for each seed, the true force and the law's internal state every cycle from `PRE_S` (20 ms) before
//! the first contact to `WINDOW` after it.
//!
//! ```text
//! cargo run --release -p naic_sim --example contact_trace -- SCENARIO CONTROLLER D SEED_FROM SEED_TO [WINDOW_S] [CSV_DIR] [PRE_S] [MASS_ERROR] [STIFFNESS] [FRICTION]
//! ```
//! Prints one summary line per seed (contact time, the first-contact peak in the window and
//! when, the first phase's ±2 % settling); with `CSV_DIR` also writes
//! `CSV_DIR/<scenario>-<controller>-d<D>-s<seed>.csv` (with the true joint velocities
//! `dq1`…`dq6` [mrad/s] and joint 4's commanded torque). `STIFFNESS` [N/m] overrides the
//! surface's k_e (0: the scenario's). `FRICTION`
//! is the joint friction of the plant and of the feedforward alike: `table1` (default),
//! `nodrop4` (joint 4 without its Stribeck drop, f_b = f_a in both directions), `nodrop`
//! (every joint without it), `none` (no joint friction, no feedforward).

use naic_core::pipeline::control::scheduled::estimator;
use naic_core::pipeline::controller::Status;
use naic_sim::controllers::{LoopSettings, Observed, PipelineController};
use naic_sim::scenario;
use naic_core::friction::{FrictionModel, JointFriction, Smoothing, DEFAULT_V_S};
use naic_sim::test_support::{model, table1_friction};
use nalgebra::Vector3;
use std::fmt::Write as _;

fn main() {
    if let Err(e) = run() {
        eprintln!("contact_trace: {e}");
        std::process::exit(2);
    }
}

/// Why a trace could not be made.
#[derive(Debug, thiserror::Error)]
enum TraceError {
    #[error("{name} {value:?}: not a number (usage in the file's doc comment)")]
    Arg { name: &'static str, value: String },
    #[error("{what}: {problem}")]
    Setup { what: String, problem: String },
    #[error("{path}: {source}")]
    Write { path: String, source: std::io::Error },
}

/// Argument `i` parsed, or `default` when absent.
fn arg<T: std::str::FromStr>(a: &[String], i: usize, name: &'static str, default: T) -> Result<T, TraceError> {
    a.get(i).map_or(Ok(default), |s| s.parse().map_err(|_| TraceError::Arg { name, value: s.clone() }))
}

fn run() -> Result<(), TraceError> {
    let a: Vec<String> = std::env::args().collect();
    let sc = a.get(1).map_or("two-material", |s| s.as_str());
    let ctl = a.get(2).map_or("scheduled", |s| s.as_str());
    let d: usize = arg(&a, 3, "D", 2)?;
    let s0: u64 = arg(&a, 4, "SEED_FROM", 1)?;
    let s1: u64 = arg(&a, 5, "SEED_TO", 10)?;
    let window: f64 = arg(&a, 6, "WINDOW_S", 0.3)?;
    let dir = a.get(7);
    let pre: f64 = arg(&a, 8, "PRE_S", 0.02)?;
    let mass: f64 = arg(&a, 9, "MASS_ERROR", 1.0)?;
    let k_e: f64 = arg(&a, 10, "STIFFNESS", 0.0)?;
    let friction = friction_variant(a.get(11).map_or("table1", |s| s.as_str()))?;
    let m = model();
    let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
    for seed in s0..=s1 {
        let mut s = scenario::preset(sc, &m).map_err(|e| TraceError::Setup { what: format!("scenario {sc:?}"), problem: e.to_string() })?;
        if k_e > 0.0 {
            s = s.with_stiffness(k_e).map_err(|e| TraceError::Setup { what: format!("stiffness {k_e}"), problem: e.to_string() })?;
        }
        s.seed = seed;
        let plant = scenario::plant_for(&s, m.clone(), friction.clone(), tool).map_err(|e| TraceError::Setup { what: "plant".into(), problem: e.to_string() })?;
        let settings = LoopSettings { delay_cycles: d, model_mass_error: mass, ..LoopSettings::default() };
        let mut c = PipelineController::by_name(ctl, &s, &m, friction.clone(), tool, &settings).map_err(|e| TraceError::Setup { what: format!("controller {ctl:?}"), problem: e.to_string() })?;
        let mut rows: Vec<(f64, String)> = vec![];
        // The scheduled law's state after every step, with the step's time.
        let (mut t, dt) = (0.0, s.task.dt);
        let mut tracer = Observed {
            inner: &mut c,
            after: |c: &PipelineController, st: &Status| {
                let p = &c.params().control.force_law.scheduled;
                let c = &c.state().controller.control;
                let sc = &c.sched;
                let e = estimator::estimate(&p.estimator, &sc.est);
                rows.push((
                    t,
                    format!(
                        "{:.4},{:?},{:.0},{:.0},{:.3},{:.3},{:.1},{:.4},{:.3},{:.3},{:.3},{},{:.3},{:.4},{:.4}",
                        st.f_ext, c.phase, e.k_e, e.k_std, e.confidence, sc.gains.m_d, sc.gains.b_d, sc.integral, sc.observer.v * 1e3, sc.observer.w, sc.force_observer.w, sc.contact_cycles, sc.approach_integral, sc.gain.g, sc.gain.raw(&p.model_gain)
                    ),
                ));
                t += dt;
            },
        };
        let r = naic_sim::runner::run(&s, &plant, &mut tracer, &mut |_| {});
        let rec = &r.records;
        let Some(i0) = rec.iter().position(|x| x.in_contact).filter(|&i| i > 0) else {
            println!("seed {seed}: no contact");
            continue;
        };
        let t0 = rec[i0].t;
        let g = &c.state().controller.control.sched.gain;
        println!("seed {seed}: ĝ frozen {:?}, static F̂_s {:?}", g.frozen, g.heavy);
        let (mut pk, mut tpk) = (0.0, 0.0);
        for x in rec.iter().filter(|x| x.t >= t0 && x.t <= t0 + window) {
            if x.f_ext > pk {
                (pk, tpk) = (x.f_ext, x.t - t0);
            }
        }
        let vz = (rec[i0].tip[2] - rec[i0 - 1].tip[2]) / s.task.dt;
        let f_d = rec[i0].f_d;
        println!(
            "seed {seed}: contact {t0:.3} s at {:.2} mm/s, peak in {window} s {pk:.3} N ({:.1} %) at +{:.0} ms; metric {:.1} %, ±2 % {}",
            -vz * 1e3,
            100.0 * (pk - f_d) / f_d,
            tpk * 1e3,
            r.metrics.phases.first().map_or(f64::NAN, |p| p.overshoot_pct),
            r.metrics.phases.first().and_then(|p| p.settling_time_2pct_s).map_or("never".into(), |t| format!("{t:.3} s"))
        );
        if let Some(dir) = dir.filter(|d| !d.is_empty()) {
            let mut out = String::from("t_ms,f_true,z_um,vz_mm_s,f_meas,phase,k_hat,k_std,conf,m_d,b_d,integral,v_bar,w_bar,w_force,cycles,a_I,g_hat,g_raw,tau2,tau3,dq1,dq2,dq3,dq4,dq5,dq6,tau4\n");
            let tr: std::collections::BTreeMap<i64, &String> = rows.iter().map(|(t, s)| ((t * 1e6).round() as i64, s)).collect();
            for (k, x) in rec.iter().enumerate() {
                if x.t < t0 - pre || x.t > t0 + window || k == 0 {
                    continue;
                }
                let vz = (x.tip[2] - rec[k - 1].tip[2]) / s.task.dt;
                let st = tr.get(&((x.t * 1e6).round() as i64)).map_or("", |s| s.as_str());
                let dq: Vec<String> = x.dq.iter().map(|v| format!("{:.3}", v * 1e3)).collect();
                let _ = writeln!(out, "{:.0},{:.4},{:.2},{:.3},{st},{:.2},{:.2},{},{:.3}", (x.t - t0) * 1e3, x.f_ext, (x.surface_z - x.tip[2]) * 1e6, -vz * 1e3, x.tau[1], x.tau[2], dq.join(","), x.tau[3]);
            }
            let path = format!("{dir}/{sc}-{ctl}-d{d}-s{seed}.csv");
            std::fs::write(&path, out).map_err(|source| TraceError::Write { path: path.clone(), source })?;
        }
    }
    Ok(())
}

/// The joint friction of the plant and the feedforward (`FRICTION` in the file's doc comment).
fn friction_variant(name: &str) -> Result<Option<FrictionModel>, TraceError> {
    let no_drop = |j: &JointFriction| match *j {
        JointFriction::StribeckPerDirection { mut positive, mut negative } => {
            positive.f_b = positive.f_a;
            negative.f_b = negative.f_a;
            JointFriction::StribeckPerDirection { positive, negative }
        }
        JointFriction::Stribeck(mut p) => {
            p.f_b = p.f_a;
            JointFriction::Stribeck(p)
        }
        other => other,
    };
    let t1 = table1_friction();
    let joints: Vec<JointFriction> = match name {
        "table1" => return Ok(Some(t1)),
        "none" => return Ok(None),
        "nodrop4" => t1.joints().iter().enumerate().map(|(i, j)| if i == 3 { no_drop(j) } else { *j }).collect(),
        "nodrop" => t1.joints().iter().map(no_drop).collect(),
        other => return Err(TraceError::Setup { what: format!("friction {other:?}"), problem: "use table1, nodrop4, nodrop or none".into() }),
    };
    FrictionModel::new(joints)
        .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S }))
        .map(Some)
        .map_err(|e| TraceError::Setup { what: format!("friction {name}"), problem: e.to_string() })
}
