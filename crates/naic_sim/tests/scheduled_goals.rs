//! Closed-loop checks of the stiffness-scheduled law (issue 12) on every goal scenario, at
//! loop delay 1 and 2 and with the controller's model mass off by 0.8 and 1.25.
//!
//! The issue's goals are medians of 5 seeds; these tests run seed 1 only (run time: one
//! 5–10 s simulated run per case, a few seconds in all in release). Where a goal is met
//! the test asserts the goal. Where it is missed the test asserts what is achieved, with
//! a comment giving the goal and the gap (docs/controller.md, "Which controller to use"), and
//! `issue_12_goals` (ignored) asserts the goals themselves: it fails until they are met.
//! No bound here was tuned per seed: the numbers are from `naic sim --table`, seed 1,
//! with a small margin above what is measured.

mod common;

use common::{friction, model};
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::runner::{self, RunSummary};
use naic_sim::scenario;
use nalgebra::Vector3;

/// One closed-loop run (seed 1) of `controller` on `scenario`.
fn run(scenario: &str, controller: &str, delay: usize, mass_error: f64) -> RunSummary {
    let m = model();
    let s = scenario::preset(scenario, &m).unwrap();
    let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
    let plant = scenario::plant_for(&s, m.clone(), Some(friction()), tool).unwrap();
    let settings = LoopSettings { delay_cycles: delay, model_mass_error: mass_error, ..LoopSettings::default() };
    let mut c = PipelineController::by_name(controller, &s, &m, Some(friction()), tool, &settings).unwrap();
    let r = runner::run(&s, &plant, &mut c, &mut |_| {});
    let n = runner::summarize(&r);
    eprintln!("{scenario} {controller} d={delay} F={mass_error}: {n:?}");
    n
}

fn settle(n: &RunSummary) -> f64 {
    n.contact_settle_s.unwrap_or(f64::INFINITY)
}

fn later_settle(n: &RunSummary, i: usize) -> f64 {
    n.later_settle_s.get(i).copied().flatten().unwrap_or(f64::INFINITY)
}

#[test]
fn flat_contact_overshoot_and_step() {
    for d in [1, 2] {
        let n = run("flat", "scheduled", d, 1.0);
        // Goals met at d = 1 and 2 (seed 1: contact 1.0 / 1.3 %, settling 0.062 / 0.063 s,
        // step 0.6 / 1.2 %, settling after the step 0.035 / 0.033 s).
        assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.15, "d = {d}: {n:?}");
        assert!(n.later_overshoot_pct[0] <= 5.0 && later_settle(&n, 0) <= 0.15, "d = {d}: {n:?}");
        assert!(n.ss_error_n.abs() < 0.05, "d = {d}: {n:?}");
    }
}

#[test]
fn flat_and_stiffness_step_rms_against_aic() {
    for sc in ["flat", "stiffness-step"] {
        for d in [1, 2] {
            let s = run(sc, "scheduled", d, 1.0);
            let a = run(sc, "aic", d, 1.0);
            let (s, a) = (s.rms_n.unwrap(), a.rms_n.unwrap());
            // Goal ≥ 30 % below AIC: met (seed 1, flat: 0.954 vs 1.427 N at d = 1, 0.934 vs
            // 1.646 N at d = 2; stiffness-step: 1.240 vs 2.324, 1.227 vs 2.594).
            assert!(s <= 0.7 * a, "{sc} d = {d}: RMS scheduled {s} vs AIC {a}");
        }
    }
}

#[test]
fn foam_contact() {
    for d in [1, 2] {
        let n = run("foam", "scheduled", d, 1.0);
        // Goals met (seed 1: 1.2 / 0.9 %, settling 0.115 / 0.116 s).
        assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.20, "d = {d}: {n:?}");
    }
}

#[test]
fn stiffness_step_recovery() {
    for d in [1, 2] {
        let n = run("stiffness-step", "scheduled", d, 1.0);
        assert_eq!(n.later_settle_s.len(), 2, "two jumps: {n:?}");
        // Goal met: back within ±2 % ≤ 0.20 s after each jump (seed 1: 0.032 / 0.042 s at
        // d = 1, 0.031 / 0.042 s at d = 2).
        assert!(later_settle(&n, 0) <= 0.20 && later_settle(&n, 1) <= 0.20, "d = {d}: {n:?}");
    }
}

#[test]
fn acrylic_hard_surface() {
    for d in [1, 2] {
        let n = run("acrylic", "scheduled", d, 1.0);
        // Goals met: peak ≤ 1.2 f_d = 12 N (10.14 / 10.18 N), no limit cycle (late peak-to-peak
        // 0.21 / 0.22 N ≤ 0.4 N). Every paper law limit-cycles here (peaks 54-276 N).
        assert!(n.peak_n <= 12.0 && n.late_p2p_n <= 0.4, "d = {d}: {n:?}");
        // Goal within ±2 % ≤ 0.05 s after contact: met at d = 1 (0.042 s); missed at d = 2 by
        // 3 ms (0.053 s): one more period before the law sees the contact, and the approach
        // at 5 mm/s (the last 0.2 N of the rise takes ≈ 40 ms at this loop's bandwidth).
        assert!(settle(&n) <= if d == 1 { 0.05 } else { 0.056 }, "d = {d}: {n:?}");
    }
}

#[test]
fn two_material_switch() {
    for d in [1, 2] {
        let n = run("two-material", "scheduled", d, 1.0);
        // Goal ≤ 10 % at first contact (acrylic, f_d = 3 N, approach 5 mm/s): missed, 64 % (d = 1),
        // 73 % (d = 2). The impact at 5 mm/s is 0.6 N (20 %); the rest is the tool at rest on
        // acrylic: the velocity observer (needed against the encoder noise at b_d ≈ 430 N s/m)
        // lags the joints' stiction and the force swings at ≈ 12 Hz. Achieved: peak below
        // 5.5 N (AIC: 31 N).
        assert!(n.peak_n <= 5.5, "d = {d}: {n:?}");
        // Goal after the switch to foam ≤ 0.3 s recovery: missed, 3.0 s: the ±2 % band at
        // 3 N is ±0.06 N, one F/T resolution step; the true force (SD 0.016 N on the foam)
        // leaves it for single samples — with a noiseless sensor it is back in 0.25 s.
        // ≤ 10 % overshoot of the recovery: met (3.7 % / 2.6 %).
        assert!(!n.later_settle_s.is_empty() && later_settle(&n, 0) <= 3.1, "d = {d}: {n:?}");
        assert!(n.later_recovery_overshoot_pct[0] <= 10.0, "d = {d}: {n:?}");
    }
}

#[test]
fn slope_steady_state() {
    for d in [1, 2] {
        let n = run("slope", "scheduled", d, 1.0);
        // Goals met: |ss error| ≤ 0.05 N (0.004 / 0.005 N; fixed: 0.41 N) with ≤ 5 % contact
        // overshoot (1.6 / 1.7 %).
        assert!(n.ss_error_n.abs() <= 0.05 && n.contact_overshoot_pct <= 5.0, "d = {d}: {n:?}");
    }
}

#[test]
fn model_mass_error() {
    // Goal: every goal under a model mass error of 0.8 and 1.25.
    let lo = run("flat", "scheduled", 1, 0.8);
    // Met on flat at 0.8 (4.5 %, 0.081 s; step 2.9 %, 0.032 s) and foam at 0.8 (3.1 %, 0.135 s).
    assert!(lo.contact_overshoot_pct <= 5.0 && settle(&lo) <= 0.15, "{lo:?}");
    assert!(lo.later_overshoot_pct[0] <= 5.0 && later_settle(&lo, 0) <= 0.15, "{lo:?}");
    let foam_lo = run("foam", "scheduled", 1, 0.8);
    assert!(foam_lo.contact_overshoot_pct <= 5.0 && settle(&foam_lo) <= 0.20, "{foam_lo:?}");
    // Missed at 1.25 on flat: no contact in 5 s. The free-space approach (the paper's
    // k_d = 50 N/m on z, 1.5 N at the surface) stalls 6 mm above it against gravity
    // over-compensated by 25 % and joint friction (the scenario sets no expected surface, so
    // the approach servo is not used).
    let hi = run("flat", "scheduled", 1, 1.25);
    assert!(hi.contact_time_s.is_none(), "{hi:?}");
    // Missed on acrylic at 0.8: peak 42.8 N, steady error +3.6 N (the approach holds 5 mm/s;
    // the contact law with a 20 % light model on 50 000 N/m was not analysed further).
    let ac = run("acrylic", "scheduled", 1, 0.8);
    assert!(ac.peak_n < 45.0, "{ac:?}");
}

#[test]
#[ignore = "issue 12 goals not all met (docs/controller.md 'Goals of issue 12'): acrylic settling at d = 2, two-material, model mass error 1.25 and acrylic at 0.8"]
fn issue_12_goals() {
    let mut missed = Vec::new();
    for d in [1, 2] {
        let f = run("flat", "scheduled", d, 1.0);
        if !(f.contact_overshoot_pct <= 5.0 && settle(&f) <= 0.15 && f.later_overshoot_pct[0] <= 5.0 && later_settle(&f, 0) <= 0.15) {
            missed.push(format!("flat d={d}"));
        }
        let f = run("foam", "scheduled", d, 1.0);
        if !(f.contact_overshoot_pct <= 5.0 && settle(&f) <= 0.20) {
            missed.push(format!("foam d={d}"));
        }
        let f = run("stiffness-step", "scheduled", d, 1.0);
        if !(later_settle(&f, 0) <= 0.2 && later_settle(&f, 1) <= 0.2) {
            missed.push(format!("stiffness-step d={d}"));
        }
        let f = run("acrylic", "scheduled", d, 1.0);
        if !(f.peak_n <= 12.0 && settle(&f) <= 0.05 && f.late_p2p_n <= 0.4) {
            missed.push(format!("acrylic d={d}"));
        }
        let f = run("two-material", "scheduled", d, 1.0);
        if !(f.contact_overshoot_pct <= 10.0 && later_settle(&f, 0) <= 0.3 && f.later_recovery_overshoot_pct[0] <= 10.0) {
            missed.push(format!("two-material d={d}"));
        }
        let f = run("slope", "scheduled", d, 1.0);
        if !(f.ss_error_n.abs() <= 0.05 && f.contact_overshoot_pct <= 5.0) {
            missed.push(format!("slope d={d}"));
        }
    }
    for m in [0.8, 1.25] {
        for sc in ["flat", "foam", "acrylic"] {
            let f = run(sc, "scheduled", 1, m);
            if !(f.contact_time_s.is_some() && f.contact_overshoot_pct <= 5.0 && f.peak_n <= 1.2 * if sc == "flat" { 20.0 } else { 10.0 }) {
                missed.push(format!("{sc} mass error {m}"));
            }
        }
    }
    assert!(missed.is_empty(), "goals missed: {missed:?}");
}
