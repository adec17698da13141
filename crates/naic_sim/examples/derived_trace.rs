//! Trace of the derived law's first contact (docs/controller.md, "The derived law"): the
//! force, the tip's true penetration, the contact estimator's state (surface speed, damping,
//! whether the sample updated it and `k_e`, the tip along n as the controller read it, the
//! regressor's origin `x₀` and the surface `x̂_e − x₀`), the estimate's bounds and the
//! rule's gains every `EVERY_MS` from contact to `WINDOW_S` after it, one seed.
//!
//! ```text
//! cargo run --release -p naic_sim --example derived_trace -- SCENARIO CONTROLLER D SEED [WINDOW_S] [EVERY_MS] [STIFFNESS]
//! ```
//! `CONTROLLER` is `derived` or `derived_oracle`; `STIFFNESS` [N/m] overrides the surface's
//! k_e (0: the scenario's).

use naic_core::pipeline::controller::Status;
use naic_sim::controllers::{LoopSettings, Observed, PipelineController};
use naic_sim::scenario;
use naic_sim::test_support::{model, table1_friction};
use nalgebra::Vector3;

/// Why a trace could not be made.
#[derive(Debug, thiserror::Error)]
enum TraceError {
    #[error("argument {index} {value:?}: not a number (usage in the file's doc comment)")]
    Arg { index: usize, value: String },
    #[error("{what}: {problem}")]
    Setup { what: String, problem: String },
}

fn setup<E: std::fmt::Display>(what: impl Into<String>) -> impl FnOnce(E) -> TraceError {
    let what = what.into();
    move |e| TraceError::Setup { what, problem: e.to_string() }
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let num = |i: usize, d: f64| a.get(i).map_or(Ok(d), |s| s.parse::<f64>().map_err(|_| TraceError::Arg { index: i, value: s.clone() }));
    let run = || -> Result<(), TraceError> {
        let sc = a.get(1).map_or("flat", |s| s.as_str());
        let ctl = a.get(2).map_or("derived", |s| s.as_str());
        let (d, seed, window, every, k_e) = (num(3, 1.0)? as usize, num(4, 1.0)? as u64, num(5, 0.3)?, num(6, 5.0)?, num(7, 0.0)?);
        let m = model();
        let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
        let mut s = scenario::preset(sc, &m).map_err(setup(format!("scenario {sc:?}")))?;
        if k_e > 0.0 {
            s = s.with_stiffness(k_e).map_err(setup(format!("stiffness {k_e}")))?;
        }
        s.seed = seed;
        let friction = Some(table1_friction());
        let plant = scenario::plant_for(&s, m.clone(), friction.clone(), tool).map_err(setup("plant"))?;
        let settings = LoopSettings { delay_cycles: d, ..LoopSettings::default() };
        let mut c = PipelineController::by_name(ctl, &s, &m, friction, tool, &settings).map_err(setup(format!("controller {ctl:?}")))?;
        let mut rows = vec![];
        // The derived law's state after every step.
        let mut tr = Observed {
            inner: &mut c,
            after: |c: &PipelineController, st: &Status| {
                let p = &c.params().control.force_law.derived;
                let d = &c.state().controller.control.derived;
                let e = naic_core::pipeline::control::contact::estimate(&p.contact, &d.contact, 0.0);
                rows.push(format!(
                    "{:7.2} {:6.1} {:4} {:10.2} {:10.2} {:8.2} {:8.3} {:8.0} {:8.0} {:8.0} {:7.3} {:7.3} {:8.3} {:8.1} {:8.4} {:6.2} {:7.3} {:7.3}",
                    d.contact.theta[2] * 1e3,
                    d.contact.theta[4],
                    match (d.contact.used, d.contact.excited[0]) {
                        (true, true) => "k",
                        (true, false) => "u",
                        _ => "-",
                    },
                    st.tip_position.dot(&c.params().control.force_axis.n) * 1e6,
                    d.contact.x0 * 1e6,
                    d.contact.theta[1] / d.contact.theta[0].max(1.0) * 1e6,
                    st.f_ext,
                    e.k_hat, e.k_upper, e.k_lower, e.mu_hat, e.mu_upper, d.m_d, d.b_d, d.k_i, d.integral, d.f_ref, d.u_prev
                ));
            },
        };
        let r = naic_sim::runner::run(&s, &plant, &mut tr, &mut |_| {});
        let Some(i0) = r.records.iter().position(|x| x.in_contact) else {
            println!("no contact");
            return Ok(());
        };
        let t0 = r.records[i0].t;
        let settle = r.metrics.phases.first().and_then(|p| p.settling_time_2pct_s);
        println!("contact at {t0:.3} s; ±2 % settling {settle:?}");
        // pen: the true penetration [µm]; w: ẋ̂_e [mm/s]; b: b̂_e [N·s/m]; upd: the sample
        // updated k_e (k), the other states only (u), nothing (-); x_n, x0, xe-x0 [µm] along n
        println!("  t_ms   f_true      pen       w      b  upd        x_n         x0    xe-x0   f_meas    k_hat  k_upper  k_lower  mu_hat mu_upper    m_d      b_d      k_i     I     f_ref  u_prev");
        let step = (every * 1e-3 / s.task.dt).round().max(1.0) as usize;
        for (x, row) in r.records.iter().zip(rows.iter()).skip(i0.saturating_sub(3 * step)).step_by(step) {
            if x.t > t0 + window {
                break;
            }
            println!("{:6.0} {:8.3} {:8.2} {row}", (x.t - t0) * 1e3, x.f_ext, x.penetration * 1e6);
        }
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("derived_trace: {e}");
        std::process::exit(2);
    }
}
