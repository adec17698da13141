//! Closed-loop checks of the stiffness-scheduled law (issue 12) on every goal scenario, at
//! loop delay 1 and 2 and with the controller's model mass off by 0.8 and 1.25.
//!
//! The goals are medians of 5 seeds; these tests run seed 1 only (run time: one
//! 5–10 s simulated run per case, a few seconds in all in release), except two-material's,
//! whose goals are asserted on the median of seeds 1–5 as in the table. Where a goal is met
//! the test asserts the goal. Where it is missed the test asserts what is achieved, with
//! a comment giving the goal and the gap (docs/controller.md, "Which controller to use"). The
//! goals as the issue defines them (medians of 5 seeds, all 42 and 74) are asserted on the
//! table itself: `naic`'s `sim_table::tests::the_table_meets_every_goal_of_issue_12`.
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
    run_k(scenario, None, controller, delay, mass_error)
}

/// [`run`] with the surface stiffness overridden (`naic sim --stiffness`).
fn run_k(scenario: &str, k_e: Option<f64>, controller: &str, delay: usize, mass_error: f64) -> RunSummary {
    run_seed(scenario, k_e, controller, delay, mass_error, 1)
}

/// [`run_k`] with the noise and sensor-bias seed (`naic sim --seed`).
fn run_seed(scenario: &str, k_e: Option<f64>, controller: &str, delay: usize, mass_error: f64, seed: u64) -> RunSummary {
    let n = runner::summarize(&simulate(scenario, k_e, controller, delay, mass_error, seed));
    eprintln!("{scenario} k={k_e:?} {controller} d={delay} F={mass_error} seed {seed}: {n:?}");
    n
}

/// The closed-loop run behind [`run_seed`], every record.
fn simulate(scenario: &str, k_e: Option<f64>, controller: &str, delay: usize, mass_error: f64, seed: u64) -> runner::RunResult {
    let m = model();
    let mut s = scenario::preset(scenario, &m).unwrap();
    s.seed = seed;
    let s = match k_e {
        Some(k) => s.with_stiffness(k).unwrap(),
        None => s,
    };
    let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
    let plant = scenario::plant_for(&s, m.clone(), Some(friction()), tool).unwrap();
    let settings = LoopSettings { delay_cycles: delay, model_mass_error: mass_error, ..LoopSettings::default() };
    let mut c = PipelineController::by_name(controller, &s, &m, Some(friction()), tool, &settings).unwrap();
    runner::run(&s, &plant, &mut c, &mut |_| {})
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
        // Goals met at d = 1 and 2 (seed 1: contact 1.4 / 1.6 %, settling 0.057 / 0.061 s,
        // step 0.5 / 1.2 %, settling after the step 0.035 / 0.033 s; with the paper's 1 N
        // contact threshold for this law: 1.0 / 1.3 %, 0.062 / 0.063 s).
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
            // Goal ≥ 30 % below AIC: met (seed 1, flat: 0.896 vs 1.427 N at d = 1, 0.899 vs
            // 1.646 N at d = 2; 0.954 / 0.934 N with the paper's 1 N contact threshold for this
            // law, whose median of 5 seeds at d = 1, −29.9 %, missed the goal).
            assert!(s <= 0.7 * a, "{sc} d = {d}: RMS scheduled {s} vs AIC {a}");
        }
    }
}

#[test]
fn foam_contact() {
    for d in [1, 2] {
        let n = run("foam", "scheduled", d, 1.0);
        // Goals met (seed 1: 1.4 / 0.9 %, settling 0.092 / 0.102 s).
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
        // Goal within ±2 % ≤ 0.05 s after contact: met (seed 1: 0.033 / 0.042 s; the
        // observer's velocity gain decays from 300 rad/s after the impact).
        assert!(settle(&n) <= 0.05, "d = {d}: {n:?}");
    }
}

/// The median of seeds 1–5 (the table's `naic_sim::metrics::median`), "never" (∞) if more
/// than half never settle.
fn median5(mut v: Vec<f64>) -> f64 {
    assert_eq!(v.len(), 5, "seeds 1-5");
    naic_sim::metrics::median(&mut v)
}

#[test]
fn two_material_switch() {
    for d in [1, 2] {
        let runs: Vec<RunSummary> = (1..=5).map(|seed| run_seed("two-material", None, "scheduled", d, 1.0, seed)).collect();
        let n = &runs[0];
        // Goal ≤ 10 % at first contact (acrylic, f_d = 3 N, approach 5 mm/s), on the median of
        // seeds 1–5 as in the table: met at d = 1 and 2 (8.7 / 8.2 %) since the tangential
        // reference's start is shaped in contact (`reference_shaping`, docs/controller.md).
        // The "contact" phase lasts until the foam; its peak was at the slide start (t ≈ 5.01 s:
        // the joints' breakaway is a step disturbance along n, faster than the force loop
        // behind the delay): 8.5 / 13.4 % before (seed 5 at d = 2: 4.23 N at 5.114 s, 3.41 N
        // shaped). Single seeds are not the goal: seed 1 at d = 1 peaks at 3.35 N (11.6 %) at
        // 5.38 s, in the slide; over seeds 1–10 the median is 10.8 / 13.6 % (10.1 / 13.3 %
        // unshaped: at d = 2 the first 0.3 s after contact alone peak at 3.14–3.74 N in seeds 1–10).
        let overshoot = median5(runs.iter().map(|r| r.contact_overshoot_pct).collect());
        assert!(overshoot <= 10.0, "d = {d}: first-contact overshoot, median of seeds 1-5 {overshoot} %");
        // Goal after the switch to foam ≤ 0.3 s recovery, per seed (seed 1 at d = 1 and 2: 0.189 /
        // 0.180 s). One sample of F/T noise through the force loop on the foam (SD 0.014 N) can
        // leave the ±0.06 N band long after the force is back, hence also the median below.
        assert!(!n.later_settle_s.is_empty() && later_settle(n, 0) <= 0.3, "d = {d}: {n:?}");
        assert!(n.later_recovery_overshoot_pct[0] <= 10.0, "d = {d}: {n:?}");
        // The goal itself on the median of the table's seeds 1–5 (single samples of F/T noise
        // decide single seeds, above): asserted as the goal.
        let recovery = median5(runs.iter().map(|r| later_settle(r, 0)).collect());
        assert!(recovery <= 0.3, "d = {d}: recovery after the switch to foam, median of seeds 1-5 {recovery} s");
        // Goal: settling within 1.5× of `oracle` in every phase (medians of seeds 1–5): met at
        // d = 1 and 2 since the shaping (d = 2: never vs 3.033 s before; 3.179 vs 3.144 s and
        // 0.203 vs 0.145 s with it).
        let oracle: Vec<RunSummary> = (1..=5).map(|seed| run_seed("two-material", None, "oracle", d, 1.0, seed)).collect();
        for (phase, of) in [("contact", &(|r: &RunSummary| settle(r)) as &dyn Fn(&RunSummary) -> f64), ("foam", &|r: &RunSummary| later_settle(r, 0))] {
            let (law, best) = (median5(runs.iter().map(of).collect()), median5(oracle.iter().map(of).collect()));
            assert!(law <= 1.5 * best, "d = {d}, {phase}: settling {law} s against oracle's {best} s");
        }
    }
}

/// Every seed of the table ends in contact on the foam at f_d (the table's medians hid two
/// failures): at d = 2 seed 3 lifted off the acrylic for good (the velocity observer, slow at
/// the stiff schedule, kept +2 mm/s into the surface while the tool rose at up to 30 mm/s;
/// fixed by the fast velocity gain off the surface), and with that fix alone seeds 2, 3 and 4
/// at d = 1 ended at 1 N on the foam (an integral of −2 N from the wander on acrylic, frozen
/// outside the 0.5 N band; fixed by releasing it after 0.2 s outside the band).
#[test]
fn two_material_every_seed_ends_tracking_on_the_foam() {
    for seed in 1..=5 {
        for d in [1, 2] {
            let n = run_seed("two-material", None, "scheduled", d, 1.0, seed);
            assert!(n.ss_error_n.abs() <= 0.05 && n.peak_n <= 5.5, "seed {seed} d = {d}: {n:?}");
        }
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
    // Goal: every goal under a model mass error of 0.8 and 1.25 (the delays; here d = 1).
    // Before the approach servo, at 1.25 the free-space impedance stalled ≈ 6 mm above every
    // surface but the slope (no contact in 5 s).
    for f in [0.8, 1.25] {
        let n = run("flat", "scheduled", 1, f);
        // Met (seed 1: 0.8: 4.98 % [at the goal: no margin], 0.089 s, step 2.8 %, 0.032 s;
        // 1.25: 0.5 %, 0.100 s, step 0.6 %, 0.040 s).
        assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.15, "flat F = {f}: {n:?}");
        assert!(n.later_overshoot_pct[0] <= 5.0 && later_settle(&n, 0) <= 0.15, "flat F = {f}: {n:?}");
        let n = run("foam", "scheduled", 1, f);
        // Met (3.1 %, 0.160 s; 0.6 %, 0.169 s).
        assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.20, "foam F = {f}: {n:?}");
        let n = run("stiffness-step", "scheduled", 1, f);
        // Met (0.078 / 0.043 s; 0.061 / 0.042 s).
        assert!(later_settle(&n, 0) <= 0.20 && later_settle(&n, 1) <= 0.20, "stiffness-step F = {f}: {n:?}");
        let n = run("slope", "scheduled", 1, f);
        assert!(n.ss_error_n.abs() <= 0.05 && n.contact_overshoot_pct <= 5.0, "slope F = {f}: {n:?}");
        let n = run("acrylic", "scheduled", 1, f);
        // Peak ≤ 12 N and no limit cycle: met (0.8 was 42.8 N with +3.6 N steady error before
        // the disturbance feedforward).
        assert!(n.peak_n <= 12.0 && n.late_p2p_n <= 0.4, "acrylic F = {f}: {n:?}");
        // ±2 % ≤ 0.05 s. At 0.8 a light model realises 0.8 of every commanded acceleration;
        // the model's gain along n estimated in the approach (scheduled::gain) divides the
        // commands by it. Single seeds can dip 9 mN outside the ±0.2 N band 0.15–0.2 s after
        // contact, so at 0.8 the check is on the median of seeds 1–5, the goal's statistic as
        // in the table (seeds 0.062 / 0.036 / 0.034 / 0.060 / 0.034 s, median 0.036 s).
        if f < 1.0 {
            let runs: Vec<f64> = (1..=5).map(|seed| settle(&run_seed("acrylic", None, "scheduled", 1, f, seed))).collect();
            let median = median5(runs.clone());
            assert!(median <= 0.05, "acrylic F = {f}: ±2 % settling, median of seeds 1-5 {median} s ({runs:?})");
        } else {
            assert!(settle(&n) <= 0.05, "acrylic F = {f}: {n:?}");
        }
    }
}

/// Two-material's recovery on the foam under a model mass error of 0.8 and 1.25 (d = 1): the
/// goal, ≤ 10 % recovery overshoot and back within ±2 % in ≤ 0.3 s after the switch, on the
/// median of seeds 1–5 as in the table. What holds them:
/// - at 0.8, the disturbance the force observer fed forward on acrylic (w̄ ≈ 1.8 m/s², the
///   light model's gravity) is kept on the foam, where no observer runs
///   (`ScheduledParams::disturbance_hold`);
/// - at 1.25, `m_d_min` 0.125 kg keeps the foam's loop from passing single samples of F/T
///   noise out of the band 1–2 s after the force is back;
/// - under a light model the gravity compensation is corrected by the frozen model gain
///   (`scheduled::gain::GravityCorrection`): without it the first phase's maximum is the
///   slide's start on acrylic (joints 2 and 3 breaking away 30–40 ms apart under the
///   uncompensated `(1 − F) G(q)`); the correction waits for the static reading
///   (`light_static`). Beside the issue, acrylic at F = 0.95: ±2 % ≤ 0.05 s;
/// - under a heavy model the gravity is corrected from statics
///   (`scheduled::gain::GravityCorrection::heavy_threshold`): the approach servo's integral
///   along n against the model's free fall along n reads F as 1.22–1.24 at d = 1 and 2 (an
///   exact model 0.99), where the dynamic `ĝ` cannot tell 1.25 at d = 1 from an exact model
///   at d = 2.
///
/// One test, so that each model's five runs are simulated once: every two-material goal at
/// F = 0.8 and 1.25 (first contact ≤ 10 %, recovery on the foam ≤ 10 % and ≤ 0.3 s), medians
/// of seeds 1–5, and acrylic's settling at F = 0.95.
#[test]
fn two_material_under_model_mass_error() {
    for f in [0.8, 1.25] {
        let runs: Vec<RunSummary> = (1..=5).map(|seed| run_seed("two-material", None, "scheduled", 1, f, seed)).collect();
        assert!(runs.iter().all(|r| !r.later_settle_s.is_empty()), "F = {f}: a seed never reached the foam");
        let first = median5(runs.iter().map(|r| r.contact_overshoot_pct).collect());
        assert!(first <= 10.0, "F = {f}: first-contact overshoot, median of seeds 1-5 {first} %");
        let overshoot = median5(runs.iter().map(|r| r.later_recovery_overshoot_pct[0]).collect());
        let recovery = median5(runs.iter().map(|r| later_settle(r, 0)).collect());
        assert!(overshoot <= 10.0, "F = {f}: recovery overshoot on the foam, median of seeds 1-5 {overshoot} %");
        assert!(recovery <= 0.3, "F = {f}: recovery within ±2 % on the foam, median of seeds 1-5 {recovery} s");
    }
    let acrylic: Vec<f64> = (1..=5).map(|seed| settle(&run_seed("acrylic", None, "scheduled", 1, 0.95, seed))).collect();
    let median = median5(acrylic.clone());
    assert!(median <= 0.05, "acrylic F = 0.95: ±2 % settling, median of seeds 1-5 {median} s ({acrylic:?})");
}

/// The model's gain along n (`scheduled::gain`) is learnt in flat's approach and
/// reported with every record (and on /naic/params): 1 at the start, near the mass error `F`
/// at contact for a light model (measured 0.93–1.03 F on the table's approaches), held at its
/// bound 1 for a heavy one; the paper's laws report 1 throughout. With it the factor on the
/// model's gravity (`gravity_scale`, `scheduled::gain::GravityCorrection`): `1/ĝ` for the
/// light model, `1/F̂_s` for the heavy one (F̂_s read from statics in the
/// approach, 1.20–1.27 at F = 1.25; the light side only where F̂_s < 0.96 too),
/// exactly 1 for the exact model (ĝ ≥ 0.93 and F̂_s 0.984–0.985 there) and for the paper's laws; 1 before any motion; ramped in before contact.
#[test]
fn the_model_gain_is_learnt_in_the_approach_and_reported() {
    for (controller, f, lo, hi, g_lo, g_hi) in [
        ("scheduled", 0.8, 0.72, 0.85, 1.17, 1.39),
        ("scheduled", 1.0, 0.9, 1.0, 1.0, 1.0),
        ("scheduled", 1.25, 1.0, 1.0, 0.77, 0.87),
        ("aic", 0.8, 1.0, 1.0, 1.0, 1.0),
    ] {
        let r = simulate("flat", None, controller, 1, f, 1);
        let first = r.records.first().expect("records");
        let contact = r.records.iter().find(|x| x.in_contact).unwrap_or_else(|| panic!("{controller} F = {f}: no contact"));
        let g = contact.model_gain;
        eprintln!("{controller} F = {f}: model_gain {g} at contact ({} s)", contact.t);
        assert_eq!(first.model_gain, 1.0, "{controller} F = {f}: before any motion");
        assert!((lo..=hi).contains(&g), "{controller} F = {f}: model_gain {g} at contact, expected [{lo}, {hi}]");
        let last = r.records.last().expect("records").model_gain;
        assert_eq!(last, g, "{controller} F = {f}: learnt in free space only, held in contact");
        let s = contact.gravity_scale;
        eprintln!("{controller} F = {f}: gravity_scale {s} at contact");
        assert_eq!(first.gravity_scale, 1.0, "{controller} F = {f}: gravity_scale before any motion");
        assert!((g_lo..=g_hi).contains(&s), "{controller} F = {f}: gravity_scale {s} at contact, expected [{g_lo}, {g_hi}]");
        let end = r.records.last().expect("records").gravity_scale;
        assert_eq!(end, s, "{controller} F = {f}: the gravity correction is complete before contact and held");
    }
}

/// The stiffness sweep on flat (`--stiffness`, flat's approach: no expected surface, 37 mm/s at
/// the surface), one parameter set.
#[test]
fn stiffness_sweep() {
    for d in [1, 2] {
        for k in [500.0, 1000.0, 2000.0, 5000.0, 20_000.0, 50_000.0] {
            let n = run_k("flat", Some(k), "scheduled", d, 1.0);
            assert!(n.contact_time_s.is_some(), "k = {k} d = {d}: {n:?}");
            if k <= 5000.0 {
                // Met up to 5000 N/m (seed 1: ≤ 1.4 %, 0.04-0.15 s).
                assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.15, "k = {k} d = {d}: {n:?}");
                assert!(n.later_overshoot_pct[0] <= 5.0 && later_settle(&n, 0) <= 0.15, "k = {k} d = {d}: {n:?}");
            } else {
                // 20 000 and 50 000 N/m: held by the friction feedforward on the unfiltered
                // velocity in contact, in joint 4's Stribeck drop, led by 2 periods on stiff
                // surfaces (without it joint 4 oscillates at 44–46 Hz and ±2 % takes 1.1–1.3 s).
                assert!(n.contact_overshoot_pct <= 5.0 && settle(&n) <= 0.15, "k = {k} d = {d}: {n:?}");
                assert!(n.later_overshoot_pct[0] <= 5.0 && later_settle(&n, 0) <= 0.15, "k = {k} d = {d}: {n:?}");
            }
        }
    }
}
