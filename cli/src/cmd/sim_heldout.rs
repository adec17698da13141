//! `naic sim --held-out --out DIR`: the held-out protocol of issue 42 in one command.
//!
//! `scheduled` and `derived` are tuned on seeds 1–5 of `naic sim --table` only. This runs
//! each (or the one `--controller` names) with its oracle (`oracle`, `derived_oracle`: the
//! same law given the true stiffness) beside it, on cases it was not tuned on, on all
//! cores, and scores every run with the honest metrics (`naic_sim::metrics::Honest`,
//! docs/controller.md "How runs are scored"):
//!
//! | group | cases |
//! | --- | --- |
//! | seeds | the six table scenarios, d = 1 and 2, seeds 6–10 |
//! | stiffness | flat at 300, 1000, 8000, 20 000, 100 000, 200 000 N/m, d = 1 and 2, seeds 6–8 |
//! | delay | the six table scenarios at d = 0 and 3, seeds 6–8 |
//! | mass error | the six table scenarios, model mass error 0.7 and 1.4, d = 1, seeds 6–8 |
//! | 60 s | flat and acrylic for 60 s, d = 2, seeds 6–8 |
//! | moving surface | slope tilted so that the surface recedes under the sliding tool at 5, 10, 20 mm/s, k_e 2000 and 8000 N/m, d = 2, seeds 6–8 |
//! | MuJoCo (with `--plant mujoco`) | every group above on the MuJoCo plant instead |
//!
//! Goals per run (each a pass or a miss, counted per group and controller):
//! - **no oscillation**: peak-to-peak force over the last 0.5 s ≤ 0.4 N;
//! - **overshoot**: after the impact periods ≤ 5 % at first contact (two-material: 10 %);
//! - **impact**: the first `d + 1` periods' peak ≤ the bound `k_e v₀ (d + 1) T + b_e v₀` + 3 σ;
//! - **settles**: every phase settles into the band (`max(2 % f_d, 3 σ)`);
//! - **within 1.5× of oracle**: the first phase's settling at most 1.5× its oracle's (same
//!   case and seed; met where the oracle never settles and the law does).
//!
//! With `--robot FILE` (an arm other than the JK5, issue 37) the same cases run on that arm:
//! each scenario placed relative to its start joints (`scenario::preset_relative`), on the own
//! plant, with the robot file's friction, tool and sensor; `two-material` has no placement
//! relative to an arm and is left out.
//!
//! Writes `DIR/held_out.md` (per group the goals met, and every run's numbers) and
//! `DIR/held_out.json`.

use super::sim_table::{par_map, Ctx};
use super::{CliError, CliResult};
use naic_sim::metrics::Honest;
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::plants::PlantChoice;
use naic_sim::runner::{self, RunSummary};
use naic_sim::scenario::{self, Scenario};
use nalgebra::{Unit, Vector3};
use std::collections::BTreeMap;
use naic_core::pipeline::control::derived::DerivedParts;
use std::fmt::Write as _;
use std::path::Path;

/// The controllers compared: each law beside its oracle (the same law given the true
/// stiffness), [`super::sim_table::LAWS`].
pub const HELD_OUT_CONTROLLERS: [&str; 4] = ["scheduled", "oracle", "derived", "derived_oracle"];

/// The oracle of a law's name (`None`: it is an oracle).
fn oracle_of(law: &str) -> Option<&'static str> {
    super::sim_table::LAWS.iter().find(|(l, _)| *l == law).map(|(_, o)| *o)
}
const SCENARIOS: [&str; 6] = ["flat", "foam", "stiffness-step", "acrylic", "two-material", "slope"];

/// One held-out run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Case {
    pub group: &'static str,
    pub scenario: &'static str,
    pub controller: &'static str,
    pub delay: usize,
    pub mass_error: f64,
    pub stiffness: Option<f64>,
    /// The surface recedes under the sliding tool at this speed [m/s] (slope only).
    pub moving: Option<f64>,
    pub duration: Option<f64>,
    pub seed: u64,
}

impl Case {
    /// The case without the controller (pairs a run with its oracle).
    fn key(&self) -> String {
        format!("{}|{}|{}|{}|{:?}|{:?}|{:?}|{}", self.group, self.scenario, self.delay, self.mass_error, self.stiffness, self.moving, self.duration, self.seed)
    }

    fn label(&self) -> String {
        let mut s = format!("{} d={}", self.scenario, self.delay);
        if self.mass_error != 1.0 {
            let _ = write!(s, " F={}", self.mass_error);
        }
        if let Some(k) = self.stiffness {
            let _ = write!(s, " k={k:.0}");
        }
        if let Some(v) = self.moving {
            let _ = write!(s, " moving {:.0} mm/s", v * 1e3);
        }
        if let Some(t) = self.duration {
            let _ = write!(s, " {t:.0} s");
        }
        s
    }
}

/// Every case of the protocol (module docs) for `controllers`.
pub fn cases(controllers: &[&'static str]) -> Vec<Case> {
    cases_on(controllers, &SCENARIOS)
}

/// [`cases`] on the table scenarios `scenarios` (another arm: all but `two-material`).
fn cases_on(controllers: &[&'static str], scenarios: &[&'static str]) -> Vec<Case> {
    let mut v = Vec::new();
    let base = |group, scenario, controller, delay, seed| Case { group, scenario, controller, delay, mass_error: 1.0, stiffness: None, moving: None, duration: None, seed };
    for &c in controllers {
        for &sc in scenarios {
            for d in [1, 2] {
                for seed in 6..=10 {
                    v.push(base("seeds", sc, c, d, seed));
                }
            }
            for d in [0, 3] {
                for seed in 6..=8 {
                    v.push(base("delay", sc, c, d, seed));
                }
            }
            for f in [0.7, 1.4] {
                for seed in 6..=8 {
                    v.push(Case { mass_error: f, ..base("mass error", sc, c, 1, seed) });
                }
            }
        }
        for k in [300.0, 1000.0, 8000.0, 20_000.0, 100_000.0, 200_000.0] {
            for d in [1, 2] {
                for seed in 6..=8 {
                    v.push(Case { stiffness: Some(k), ..base("stiffness", "flat", c, d, seed) });
                }
            }
        }
        for sc in ["flat", "acrylic"] {
            for seed in 6..=8 {
                v.push(Case { duration: Some(60.0), ..base("60 s", sc, c, 2, seed) });
            }
        }
        for mv in [0.005, 0.01, 0.02] {
            for k in [2000.0, 8000.0] {
                for seed in 6..=8 {
                    v.push(Case { moving: Some(mv), stiffness: Some(k), ..base("moving surface", "slope", c, 2, seed) });
                }
            }
        }
    }
    v
}


/// The scenario of a case: the preset with the stiffness, duration and (slope) the tilt that
/// makes the surface recede at `moving` under the tool sliding along the task's ramp.
fn scenario_of(ctx: &Ctx, c: &Case) -> Result<Scenario, CliError> {
    let s = scenario::preset(c.scenario, &ctx.model).map_err(CliError::usage)?;
    shape_case(s, c, Vector3::z())
}

/// A preset changed as the case asks: its stiffness, duration and, for a moving surface, the
/// plane tilted from `up` (the surface's untilted normal, facing the tool) towards the ramp.
fn shape_case<const N: usize>(mut s: Scenario<N>, c: &Case, up: Vector3<f64>) -> Result<Scenario<N>, CliError> {
    if let Some(k) = c.stiffness {
        s = s.with_stiffness(k).map_err(|e| CliError::usage(e.to_string()))?;
    }
    if let Some(t) = c.duration {
        s.task.duration = t;
    }
    if let Some(v_n) = c.moving {
        let r = &s.task.ramp;
        let v_t = (r.to - r.from).norm() / (r.t1 - r.t0).max(1e-9);
        if !(v_t > 0.0) {
            return Err(CliError::usage(format!("held-out: scenario '{}' does not slide: no moving surface", c.scenario)));
        }
        // The plane falls towards the ramp's direction by v_n / v_t (the tip slides down it).
        let dir = (r.to - r.from).normalize();
        let slope = v_n / v_t;
        s.env.normal = Unit::new_normalize(up + dir * slope);
        s.description = format!("{} (tilted: the surface recedes at {:.0} mm/s under the tool)", s.description, v_n * 1e3);
    }
    s.seed = c.seed;
    Ok(s)
}

/// One run's numbers.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Scored {
    #[serde(flatten)]
    pub case: Case,
    pub summary: RunSummary,
    pub honest: Vec<Honest>,
}

fn run_case(ctx: &Ctx, c: &Case) -> Result<Scored, CliError> {
    let s = scenario_of(ctx, c)?;
    let r = ctx.run(&s, c.controller, c.delay, c.mass_error)?;
    let honest = runner::honest_of(&s, &r.records, &r.metrics, c.delay, runner::force_noise_sigma());
    Ok(Scored { case: c.clone(), summary: runner::summarize(&r), honest })
}

/// The goals of one run (module docs): `(name, met, measured)`.
fn goals(r: &Scored, oracle: Option<&Scored>) -> Vec<(&'static str, bool, String)> {
    let sigma = runner::force_noise_sigma();
    let mut g = Vec::new();
    g.push(("no oscillation", r.summary.late_p2p_n <= 0.4, format!("{:.2} N", r.summary.late_p2p_n)));
    let Some(first) = r.honest.first() else {
        g.push(("contact", false, "never touched".into()));
        return g;
    };
    let limit = if r.case.scenario == "two-material" { 10.0 } else { 5.0 };
    g.push(("overshoot", first.overshoot_after_impact_pct <= limit, format!("{:.1} %", first.overshoot_after_impact_pct)));
    if let (Some(i), Some(b)) = (first.impact_n, first.impact_bound_n) {
        g.push(("impact", i <= b + 3.0 * sigma, format!("{i:.2} / {b:.2} N")));
    }
    let all = r.honest.iter().all(|h| h.settling_band_s.is_some());
    let fmt = |x: Option<f64>| x.map_or_else(|| "never".to_string(), |v| format!("{v:.3}"));
    g.push(("settles", all, r.honest.iter().map(|h| fmt(h.settling_band_s)).collect::<Vec<_>>().join(", ") + " s"));
    if let Some(o) = oracle.and_then(|o| o.honest.first()) {
        let (mine, theirs) = (first.settling_band_s, o.settling_band_s);
        let met = match (mine, theirs) {
            (Some(a), Some(b)) => a <= 1.5 * b.max(1e-3),
            (Some(_), None) => true,
            (None, _) => false,
        };
        g.push(("within 1.5× of oracle", met, format!("{} vs {} s", fmt(mine), fmt(theirs))));
    }
    g
}

/// ", without PART, …" for the derived law's parts that are off (empty: none).
pub(super) fn ablation_label(parts: &DerivedParts) -> String {
    parts.off().iter().map(|n| format!(", without {n}")).collect()
}

/// Runs the protocol into `out` (module docs).
/// `law`: one of [`super::sim_table::LAWS`]' laws, run with its oracle (None: every law).
pub fn run(
    out: &Path,
    urdf: Option<&Path>,
    friction_file: Option<&Path>,
    no_friction: bool,
    plant: &PlantChoice,
    sensor: super::sim::SensorOpts,
    law: Option<&str>,
    parts: DerivedParts,
) -> CliResult {
    let t0 = std::time::Instant::now();
    let controllers = controllers_of(law)?;
    let ctx = Ctx { parts, ..Ctx::load(urdf, friction_file, no_friction, plant, sensor)? };
    let jobs = cases(&controllers);
    std::fs::create_dir_all(out).map_err(|e| CliError::failure(format!("--out {}: {e}", out.display())))?;
    eprintln!("naic sim --held-out: {} runs on the {} plant{} -> {}", jobs.len(), plant.name(), ablation_label(&parts), out.display());
    let done = par_map(&jobs, |c| run_case(&ctx, c), true)?;
    report(out, &format!("{} plant", plant.name()), &parts, &done, t0)
}

/// The controllers `--held-out --controller LAW` names: LAW and its oracle (None: all).
fn controllers_of(law: Option<&str>) -> Result<Vec<&'static str>, CliError> {
    match law {
        None => Ok(HELD_OUT_CONTROLLERS.to_vec()),
        Some(l) => match super::sim_table::LAWS.iter().find(|(x, _)| *x == l) {
            Some((x, o)) => Ok(vec![*x, *o]),
            None => {
                let names: Vec<&str> = super::sim_table::LAWS.iter().map(|(x, _)| *x).collect();
                Err(CliError::usage(format!("--held-out --controller '{l}': give one of {} (each runs with its oracle), or no --controller for all", names.join(", "))))
            }
        },
    }
}

/// The protocol on another arm (`--robot FILE`, module docs), on the own plant.
pub fn run_robot(out: &Path, robot: &naic_core::robot_file::Robot, law: Option<&str>, parts: DerivedParts) -> CliResult {
    let n = robot.model.nv();
    naic_core::with_joints!(n, N => run_robot_n::<N>(out, robot, law, parts)).map_err(|e| CliError::usage(format!("--robot {}: {e}", robot.file.display())))?
}

fn run_robot_n<const N: usize>(out: &Path, robot: &naic_core::robot_file::Robot, law: Option<&str>, parts: DerivedParts) -> CliResult {
    let t0 = std::time::Instant::now();
    let controllers = controllers_of(law)?;
    let Some(q) = &robot.start_q else {
        return Err(CliError::usage(format!("--robot {}: the scenarios start at the robot file's `start_q`, and it has none: add start_q (joints [rad], the tool pointing along a base axis)", robot.file.display())));
    };
    let q0: naic_core::JointVec<N> = std::array::from_fn(|i| q[i]);
    let scenarios: Vec<&'static str> = SCENARIOS.iter().copied().filter(|s| *s != "two-material").collect();
    let jobs = cases_on(&controllers, &scenarios);
    let tool = robot.tool_tuple();
    let tool_inertia = super::sim::tool_inertia(&robot.urdf)?;
    let friction = robot.friction.as_ref().map(|f| f.1.clone());
    std::fs::create_dir_all(out).map_err(|e| CliError::failure(format!("--out {}: {e}", out.display())))?;
    eprintln!("naic sim --held-out: {} runs on the own plant, {}{} -> {}", jobs.len(), robot.file.display(), ablation_label(&parts), out.display());
    let run = |c: &Case| -> Result<Scored, CliError> {
        let bad = |e: String| CliError::usage(format!("--robot {}: {e}", robot.file.display()));
        let base = scenario::preset_relative::<N>(c.scenario, &robot.model, q0).map_err(|e| bad(e.to_string()))?;
        let up = -base.task.force_axis;
        let mut s = shape_case(base, c, up)?;
        s.seed = c.seed;
        let mut plant = super::sim::scenario_plant(&s, robot.model.clone(), friction.clone(), tool, &tool_inertia)?;
        scenario::apply_sensor_spec(&mut plant, &robot.sensor);
        let settings = LoopSettings { delay_cycles: c.delay, model_mass_error: c.mass_error, derived_parts: parts, ..LoopSettings::default() };
        let mut ctl = PipelineController::<N>::by_name(c.controller, &s, &robot.model, friction.clone(), tool, &settings).map_err(CliError::usage)?;
        let mut p = PlantChoice::Own.build_n::<N>(&plant, &s.task.q0, s.seed).map_err(|e| bad(format!("plant: {e}")))?;
        let r = runner::run_on(&s, &mut *p, &mut ctl, &mut |_| {});
        let honest = runner::honest_of(&s, &r.records, &r.metrics, c.delay, runner::force_noise_sigma());
        Ok(Scored { case: c.clone(), summary: runner::summarize(&r), honest })
    };
    let done = par_map(&jobs, run, true)?;
    report(out, &format!("own plant, {}", robot.file.display()), &parts, &done, t0)
}

/// Writes `held_out.md` and `held_out.json` of the scored runs `done` into `out` and prints
/// the goals met per group and controller.
fn report(out: &Path, plant: &str, parts: &DerivedParts, done: &[Scored], t0: std::time::Instant) -> CliResult {
    let oracle: BTreeMap<(String, &str), &Scored> = done.iter().filter(|r| oracle_of(r.case.controller).is_none()).map(|r| ((r.case.key(), r.case.controller), r)).collect();
    let mut md = String::new();
    let _ = writeln!(md, "Held-out protocol (issue 42), {plant}: `scheduled` and `derived` were tuned on seeds 1–5 of `naic sim --table` only; every case here is outside that. Goals per run: late peak-to-peak ≤ 0.4 N; overshoot after the impact periods ≤ 5 % (two-material 10 %); impact ≤ k_e v₀ (d + 1) T + b_e v₀ + 3 σ; every phase settles into max(2 % f_d, 3 σ); first-phase settling within 1.5× of the law's oracle's.\n");
    if !parts.off().is_empty() {
        let _ = writeln!(md, "Ablation: the derived law (and its oracle){}.\n", ablation_label(parts));
    }
    // Per group and controller: goals met / goals.
    let mut counts: BTreeMap<(&str, &str), (usize, usize)> = BTreeMap::new();
    let mut rows = String::new();
    for r in done {
        let o = oracle_of(r.case.controller).and_then(|oc| oracle.get(&(r.case.key(), oc)).copied());
        let gs = goals(r, o);
        let e = counts.entry((r.case.group, r.case.controller)).or_default();
        e.0 += gs.iter().filter(|g| g.1).count();
        e.1 += gs.len();
        let _ = writeln!(
            rows,
            "| {} | {} | {} | {} | {} |",
            r.case.group,
            r.case.label(),
            r.case.seed,
            r.case.controller,
            gs.iter().map(|(n, m, v)| format!("{}{n}: {v}", if *m { "" } else { "**miss** " })).collect::<Vec<_>>().join("; ")
        );
    }
    let _ = writeln!(md, "| group | controller | goals met |\n|---|---|---|");
    for ((group, c), (met, all)) in &counts {
        let _ = writeln!(md, "| {group} | {c} | {met} of {all} |");
    }
    let _ = writeln!(md, "\n| group | case | seed | controller | goals |\n|---|---|---|---|---|");
    md.push_str(&rows);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let _ = writeln!(md, "\n{} runs in {:.0} s on {threads} thread(s).", done.len(), t0.elapsed().as_secs_f64());
    let fail = |p: &Path, e: std::io::Error| CliError::failure(format!("cannot write {}: {e}", p.display()));
    let p = out.join("held_out.md");
    std::fs::write(&p, &md).map_err(|e| fail(&p, e))?;
    let p = out.join("held_out.json");
    let json = serde_json::to_string(done).map_err(|e| CliError::failure(e.to_string()))?;
    std::fs::write(&p, json + "\n").map_err(|e| fail(&p, e))?;
    for ((group, c), (met, all)) in &counts {
        println!("{group:>15} {c:>10}: {met} of {all} goals met");
    }
    println!("wrote {} ({:.0} s)", out.display(), t0.elapsed().as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::sim::load_model;
    use super::*;

    /// The tilt makes the surface recede under the sliding tool at the asked speed: the
    /// surface height along the ramp falls at `moving`.
    #[test]
    fn the_moving_surface_recedes_at_the_asked_speed() {
        let model = load_model(None).unwrap();
        let ctx = Ctx { plant: PlantChoice::Own, model, friction: None, tool: (0.0, Vector3::zeros()), tool_inertia: nalgebra::Matrix3::zeros(), sensor: super::super::sim::SensorOpts { inertial_wrench: false, tare_at_rest: false }, parts: DerivedParts::ALL };
        let c = Case { group: "moving surface", scenario: "slope", controller: "scheduled", delay: 2, mass_error: 1.0, stiffness: Some(2000.0), moving: Some(0.01), duration: None, seed: 6 };
        let s = scenario_of(&ctx, &c).unwrap();
        let r = s.task.ramp;
        let v_t = (r.to - r.from).norm() / (r.t1 - r.t0);
        let (a, b) = (r.from, r.from + (r.to - r.from) * 0.1);
        let dz = s.env.height_at(b.x, b.y) - s.env.height_at(a.x, a.y);
        let dt = 0.1 * (r.t1 - r.t0);
        assert!((dz / dt + 0.01).abs() < 1e-4, "the surface falls at {} m/s (tip at {v_t} m/s)", dz / dt);
    }

    /// On another arm (the Panda, tool pointing down its base's −z) the tilt is taken from the
    /// plane's own normal and the surface recedes under the sliding tool at the asked speed;
    /// the arm's cases leave out `two-material` (placed for the JK5 only) and keep the rest.
    #[test]
    fn on_another_arm_the_moving_surface_recedes_at_the_asked_speed() {
        let robot = super::super::sim::load_robot(Some(&super::super::sim::default_path("params/robots/panda.yaml"))).unwrap();
        let q = robot.start_q.clone().expect("the Panda's robot file has start_q");
        let q0: naic_core::JointVec<7> = std::array::from_fn(|i| q[i]);
        let c = Case { group: "moving surface", scenario: "slope", controller: "derived", delay: 2, mass_error: 1.0, stiffness: Some(2000.0), moving: Some(0.01), duration: None, seed: 6 };
        let base = scenario::preset_relative::<7>("slope", &robot.model, q0).unwrap();
        let up = -base.task.force_axis;
        let s = shape_case(base, &c, up).unwrap();
        let r = s.task.ramp;
        let (a, b) = (r.from, r.from + (r.to - r.from) * 0.1);
        let dz = s.env.height_at(b.x, b.y) - s.env.height_at(a.x, a.y);
        let dt = 0.1 * (r.t1 - r.t0);
        assert!((dz / dt + 0.01).abs() < 1e-4, "the surface falls at {} m/s", dz / dt);
        let on_arm = cases_on(&["derived"], &["flat", "foam", "stiffness-step", "acrylic", "slope"]);
        assert!(on_arm.iter().all(|c| c.scenario != "two-material"));
        // two-material took 2 delays × 5 seeds, 2 delays × 3 seeds and 2 mass errors × 3 seeds
        assert_eq!(on_arm.len() + 2 * 5 + 2 * 3 + 2 * 3, cases(&["derived"]).len(), "the JK5's cases less two-material's");
    }

    #[test]
    fn every_case_is_outside_the_tuned_table() {
        let cs = cases(&HELD_OUT_CONTROLLERS);
        assert!(cs.iter().all(|c| c.seed > 5), "seeds 1–5 are the tuning set");
        for c in HELD_OUT_CONTROLLERS {
            assert_eq!(cs.iter().filter(|x| x.controller == c).count(), cs.len() / HELD_OUT_CONTROLLERS.len());
        }
        // Every law is paired with its own oracle.
        assert_eq!(oracle_of("scheduled"), Some("oracle"));
        assert_eq!(oracle_of("derived"), Some("derived_oracle"));
        assert_eq!(oracle_of("derived_oracle"), None);
    }
}
