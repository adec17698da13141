//! Closed-loop checks of the `derived` law (issue 42) under a model mass error.
//!
//! The controller's model with every mass and inertia × F also scales the gravity it
//! compensates, so along n a constant force (1 − F) m g pushes the tool. In free space the
//! approach servo's integral absorbs it; in contact it must not come back as a step: the
//! law holds that integral as a feedforward (`law.rs`, `step_derived`). The bound asserted
//! is the approach's own (item 5 of issue 42): the peak force is at most f_d (1 + ε), ε the
//! impact fraction, on the stiffest surface of the table (acrylic, 50 000 N/m) and at the
//! lowest target (two-material, 3 N). Seed 1; without the feedforward the peaks were
//! 29 / 14 / 267 N (acrylic) and 29 / 9.6 / 4.3 N (two-material) at F = 0.8 / 0.95 / 1.25.
//! The peak is the contact's: up to the task's tangential move where the tool meets the
//! surface at rest (two-material; acrylic slides from the start). The break-away of the
//! joints when a static 3 N contact on acrylic starts to slide is item 6's stick-slip, not
//! the contact step (F 0.8, seed 1: 4.63 N at 5.06 s, 64 ms after the move).

mod common;

use common::{friction, model};
use naic_core::pipeline::control::derived::IMPACT_FRACTION;
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::runner::{self, RunSummary};
use naic_sim::scenario;
use nalgebra::Vector3;

fn run(scenario: &str, delay: usize, mass_error: f64) -> RunSummary {
    run_with_peak(scenario, delay, mass_error).0
}

/// The run's summary and its peak force before the task's tangential move (the whole run
/// where the tool moves along the surface from the start).
fn run_with_peak(scenario: &str, delay: usize, mass_error: f64) -> (RunSummary, f64) {
    let m = model();
    let s = scenario::preset(scenario, &m).unwrap();
    let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
    let plant = scenario::plant_for(&s, m.clone(), Some(friction()), tool).unwrap();
    let settings = LoopSettings { delay_cycles: delay, model_mass_error: mass_error, ..LoopSettings::default() };
    let mut c = PipelineController::by_name("derived", &s, &m, Some(friction()), tool, &settings).unwrap();
    let r = runner::run(&s, &plant, &mut c, &mut |_| {});
    let n = runner::summarize(&r);
    let t_move = if s.task.ramp.t0 > 0.0 { s.task.ramp.t0 } else { f64::INFINITY };
    let peak = r.records.iter().filter(|x| x.t < t_move).map(|x| x.f_ext).fold(f64::NEG_INFINITY, f64::max);
    eprintln!("{scenario} derived d={delay} F={mass_error}: peak before the move {peak} N; {n:?}");
    (n, peak)
}

#[test]
fn a_model_mass_error_does_not_step_the_contact() {
    for (scenario, f_d) in [("acrylic", 10.0), ("two-material", 3.0)] {
        for f in [0.8, 0.95, 1.25] {
            let (_, peak) = run_with_peak(scenario, 1, f);
            let bound = f_d * (1.0 + IMPACT_FRACTION);
            assert!(peak <= bound, "{scenario}, F = {f}: peak {peak} N > f_d (1 + ε) = {bound} N");
        }
    }
}

/// Group F of issue 42: the braking approach (`derived::braking_speed`) keeps the impact
/// bound of item 5 (the unit tests in `law.rs` check it at `k̄`) but reaches the impact-bounded
/// speed only `surface_uncertainty` before the expected surface instead of holding it over the
/// whole `approach_band`. On two-material (3 N, `k̄` = `stiffness_max` = 500 000 N/m) the
/// constant-speed band took 4.9 s at d 1 and 8.3 s at d 2: the first contact came at 6.4 /
/// 9.6 s, after the tangential move had started (its ramp's `t0`). With the braking profile
/// it comes before that move, and the first contact adds no more than the bound.
#[test]
fn the_braking_approach_meets_the_surface_before_the_move() {
    let m = model();
    let s = scenario::preset("two-material", &m).unwrap();
    let t_move = s.task.ramp.t0;
    for d in [1, 2] {
        let n = run("two-material", d, 1.0);
        let t = n.contact_time_s.expect("two-material: the tool reaches the surface");
        assert!(t < t_move, "d {d}: first contact at {t} s, after the move at {t_move} s");
        let bound = 3.0 * (1.0 + IMPACT_FRACTION);
        assert!(n.peak_n <= bound, "d {d}: peak {} N > f_d (1 + ε) = {bound} N", n.peak_n);
    }
}
