//! `naic sim --table --out DIR`: the docs/controller.md "Which controller to use" table in one
//! command (issue 12): every controller × goal scenario × loop delay 1 and 2, medians over
//! `--seeds` seeds (default 5); the same for the scheduled law and its oracle under a model
//! mass error of 0.8 and 1.25 (the issue's) and 0.95 and 1.05 (a check beside them); the
//! stiffness sweep on `flat` (500 … 50 000 N/m, one
//! parameter set); the goals of the issue checked against the medians; SVG plots.
//!
//! Writes `DIR/table.md` (all tables and the goals, markdown), `DIR/sweep.svg`,
//! `DIR/<scenario>-d<d>.svg` (seed 1, every controller overlaid) and `DIR/table.json`
//! (every run's numbers). Runs on every core (`std::thread::scope`).

use super::sim::{load_model, scenario_plant};
use naic_sim::plants::PlantChoice;
use super::{CliError, CliResult};
use naic_core::friction::FrictionModel;
use naic_core::model::Model;
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::runner::{self, RunResult, RunSummary};
use naic_sim::scenario::{self, Scenario};
use naic_plot::{Figure, Panel, Series};
use nalgebra::Vector3;
use naic_core::pipeline::control::derived::DerivedParts;
use std::fmt::Write as _;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Controllers of the table, baselines first.
pub const TABLE_CONTROLLERS: [&str; 7] = ["fixed", "aic", "naic", "scheduled", "oracle", "derived", "derived_oracle"];
/// The laws scored against issue 12's goals, each with its oracle (the same law given the
/// true stiffness).
pub const LAWS: [(&str, &str); 2] = [("scheduled", "oracle"), ("derived", "derived_oracle")];
/// The issue's goal scenarios.
pub const TABLE_SCENARIOS: [&str; 6] = ["flat", "foam", "stiffness-step", "acrylic", "two-material", "slope"];
/// Loop delays of the table [control periods].
pub const DELAYS: [usize; 2] = [1, 2];
/// Model mass errors of the robustness table (scheduled and oracle, delay 1).
pub const MASS_ERRORS: [f64; 2] = [0.8, 1.25];
/// Small model mass errors, a check beside the issue's (same runs and goals as
/// [`MASS_ERRORS`]): a real arm's model is off by a few percent, neither exact nor 20 %
/// off. A change fitted to the exact model can lose here while the issue's goals hold.
pub const SMALL_MASS_ERRORS: [f64; 2] = [0.95, 1.05];
/// Every model mass error of the robustness table, in order.
const ALL_MASS_ERRORS: [f64; 4] = [MASS_ERRORS[0], SMALL_MASS_ERRORS[0], SMALL_MASS_ERRORS[1], MASS_ERRORS[1]];
/// The stiffness sweep on `flat` [N/m].
pub const SWEEP_K: [f64; 6] = [500.0, 1000.0, 2000.0, 5000.0, 20_000.0, 50_000.0];

/// One run of the table.
#[derive(Clone, Debug)]
struct Job {
    scenario: &'static str,
    controller: &'static str,
    delay: usize,
    mass_error: f64,
    stiffness: Option<f64>,
    seed: u64,
}

#[derive(Clone, Debug, serde::Serialize)]
struct Done {
    scenario: String,
    controller: String,
    delay_cycles: usize,
    model_mass_error: f64,
    stiffness: Option<f64>,
    seed: u64,
    #[serde(flatten)]
    n: RunSummary,
}

/// What every run of a protocol shares (`--table` here, `--held-out` in sim_heldout): the
/// plant, the model, the joint friction and the tool.
pub(super) struct Ctx {
    pub(super) plant: PlantChoice,
    pub(super) model: Model,
    pub(super) friction: Option<FrictionModel>,
    pub(super) tool: (f64, Vector3<f64>),
    pub(super) tool_inertia: nalgebra::Matrix3<f64>,
    /// The sensor's inertial wrench and the tare (`--inertial-wrench`, `--tare`).
    pub(super) sensor: super::sim::SensorOpts,
    /// The derived law's parts (`--ablate`: all on unless an ablation turns one off).
    pub(super) parts: DerivedParts,
}

impl Ctx {
    /// The model of `--urdf` (default the JK5's), its friction as `--friction` /
    /// `--no-friction` give it for `plant`, and the tool of its `ft_sensor` link.
    pub(super) fn load(
        urdf: Option<&Path>,
        friction_file: Option<&Path>,
        no_friction: bool,
        plant: &PlantChoice,
        sensor: super::sim::SensorOpts,
    ) -> Result<Ctx, CliError> {
        let model = load_model(urdf)?;
        let friction = super::sim::friction_for(friction_file, no_friction)?;
        let urdf_path = urdf.map(Path::to_path_buf).unwrap_or_else(|| super::sim::default_path("urdf/jk5.urdf"));
        let tool = naic_sim::sensor::tool_from_urdf(&urdf_path).map_err(|e| CliError::usage(format!("--urdf: {e}")))?;
        let tool_inertia = super::sim::tool_inertia(&urdf_path)?;
        Ok(Ctx { plant: plant.clone(), model, friction, tool, tool_inertia, sensor, parts: DerivedParts::ALL })
    }
}

fn scenario_for(ctx: &Ctx, j: &Job) -> Result<Scenario, CliError> {
    let mut s = scenario::preset(j.scenario, &ctx.model).map_err(CliError::usage)?;
    if let Some(k) = j.stiffness {
        s = s.with_stiffness(k).map_err(CliError::usage)?;
    }
    s.seed = j.seed;
    Ok(s)
}

fn run_job(ctx: &Ctx, j: &Job) -> Result<RunResult, CliError> {
    ctx.run(&scenario_for(ctx, j)?, j.controller, j.delay, j.mass_error)
}

impl Ctx {
    /// One closed-loop run of `controller` on scenario `s` with this context's plant, model,
    /// friction, tool and sensor, at loop delay `delay` [cycles] and model mass error
    /// `mass_error` (the table's and the held-out protocol's runs).
    pub(super) fn run(&self, s: &Scenario, controller: &str, delay: usize, mass_error: f64) -> Result<RunResult, CliError> {
        let mut plant = scenario_plant(s, self.model.clone(), self.friction.clone(), self.tool, &self.tool_inertia)?;
        self.sensor.apply(&mut plant);
        let settings = LoopSettings {
            delay_cycles: delay,
            model_mass_error: mass_error,
            tare_at_rest: self.sensor.tare_at_rest,
            sensor_reads_tool_inertia: self.sensor.sensor_reads_tool_inertia(&self.plant),
            derived_parts: self.parts,
            ..LoopSettings::default()
        };
        let mut c = PipelineController::by_name(controller, s, &self.model, self.friction.clone(), self.tool, &settings)
            .map_err(CliError::usage)?;
        let mut p = self.plant.build(&plant, &s.task.q0, s.seed).map_err(|e| CliError::usage(format!("--plant: {e}")))?;
        Ok(runner::run_on(s, &mut *p, &mut c, &mut |_| {}))
    }
}

/// Median of the values; `None` entries (never settled) count as +∞.
fn median_opt(v: &[Option<f64>]) -> Option<f64> {
    let mut x: Vec<f64> = v.iter().map(|o| o.unwrap_or(f64::INFINITY)).collect();
    let m = naic_sim::metrics::median(&mut x);
    m.is_finite().then_some(m)
}

fn median(v: &[f64]) -> f64 {
    median_opt(&v.iter().map(|x| Some(*x)).collect::<Vec<_>>()).unwrap_or(f64::NAN)
}

fn fmt_s(v: Option<f64>) -> String {
    v.map_or_else(|| "never".into(), |x| format!("{x:.3}"))
}

/// Medians over seeds of one (scenario, controller, delay, mass error, stiffness) cell:
/// the runs' summaries reduced field by field (same type), and how many runs never touched.
#[derive(Clone, Debug, Default)]
pub struct Cell {
    pub median: RunSummary,
    pub never: usize,
    pub seeds: usize,
}

fn cell(runs: &[&RunSummary]) -> Cell {
    let col = |f: &dyn Fn(&RunSummary) -> f64| median(&runs.iter().map(|r| f(r)).collect::<Vec<_>>());
    let opt = |f: &dyn Fn(&RunSummary) -> Option<f64>| median_opt(&runs.iter().map(|r| f(r)).collect::<Vec<_>>());
    let n_later = runs.iter().map(|r| r.later_overshoot_pct.len()).min().unwrap_or(0);
    let median = RunSummary {
        contact_time_s: opt(&|r| r.contact_time_s),
        contact_overshoot_pct: col(&|r| r.contact_overshoot_pct),
        contact_settle_s: opt(&|r| r.contact_settle_s),
        later_overshoot_pct: (0..n_later).map(|i| col(&|r| r.later_overshoot_pct[i])).collect(),
        later_settle_s: (0..n_later).map(|i| opt(&|r| r.later_settle_s[i])).collect(),
        later_recovery_overshoot_pct: (0..n_later).map(|i| col(&|r| r.later_recovery_overshoot_pct[i])).collect(),
        ss_error_n: col(&|r| r.ss_error_n),
        rms_n: Some(col(&|r| r.rms_n.unwrap_or(f64::NAN))),
        peak_n: col(&|r| r.peak_n),
        late_p2p_n: col(&|r| r.late_p2p_n),
    };
    Cell { median, never: runs.iter().filter(|r| r.contact_time_s.is_none()).count(), seeds: runs.len() }
}

fn join<T>(v: &[T], f: impl Fn(&T) -> String) -> String {
    if v.is_empty() {
        "–".into()
    } else {
        v.iter().map(f).collect::<Vec<_>>().join(" / ")
    }
}

const HEADER: &str = "| scenario | d | controller | overshoot at contact [%] | settle ±2 % after contact [s] | overshoot at step / jump [%] | recovery overshoot [%] | settle ±2 % after step / jump [s] | ss error [N] | RMS [N] | peak [N] | late p-p [N] |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";

fn row(label: &str, d: &str, controller: &str, cell: &Cell) -> String {
    let no_contact = if cell.never > 0 { format!(" (no contact in {}/{})", cell.never, cell.seeds) } else { String::new() };
    let c = &cell.median;
    format!(
        "| {label} | {d} | {controller}{no_contact} | {:.1} | {} | {} | {} | {} | {:.3} | {:.3} | {:.2} | {:.2} |\n",
        c.contact_overshoot_pct,
        fmt_s(c.contact_settle_s),
        join(&c.later_overshoot_pct, |x| format!("{x:.1}")),
        join(&c.later_recovery_overshoot_pct, |x| format!("{x:.1}")),
        join(&c.later_settle_s, |x| fmt_s(*x)),
        c.ss_error_n,
        c.rms_n.unwrap_or(f64::NAN),
        c.peak_n,
        c.late_p2p_n
    )
}

/// `f` over every job on all cores; results in job order.
pub(super) fn par_map<J: Sync, T: Send>(jobs: &[J], f: impl Fn(&J) -> Result<T, CliError> + Sync, progress: bool) -> Result<Vec<T>, CliError> {
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let out: Vec<Mutex<Option<Result<T, CliError>>>> = (0..jobs.len()).map(|_| Mutex::new(None)).collect();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(jobs.len().max(1));
    std::thread::scope(|sc| {
        for _ in 0..threads {
            sc.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(j) = jobs.get(i) else { break };
                let r = f(j);
                if let Ok(mut slot) = out[i].lock() {
                    *slot = Some(r);
                }
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                if progress && (k % 10 == 0 || k == jobs.len()) {
                    eprint!("\rnaic sim: {k}/{} runs", jobs.len());
                }
            });
        }
    });
    if progress {
        eprintln!();
    }
    out.into_iter()
        .map(|m| m.into_inner().ok().flatten().unwrap_or_else(|| Err(CliError::failure("a table run did not finish"))))
        .collect()
}

fn select<'a>(done: &'a [Done], f: impl Fn(&Done) -> bool) -> Vec<&'a RunSummary> {
    done.iter().filter(|d| f(d)).map(|d| &d.n).collect()
}

/// One goal of issue 12 and whether the medians meet it.
struct Goal {
    what: String,
    measured: String,
    met: bool,
}

/// The per-scenario goals of issue 12 for one cell `c` of `scheduled` (`at`: "d = 1", "F = 0.8", ...).
/// `title: m of n met.` and the goals' table, into the table's markdown.
fn goal_table(md: &mut String, title: &str, gs: &[Goal]) {
    let met = gs.iter().filter(|g| g.met).count();
    let _ = writeln!(md, "\n{title}: {met} of {} met.\n\n| goal | measured | met |\n|---|---|---|", gs.len());
    for g in gs {
        let _ = writeln!(md, "| {} | {} | {} |", g.what, g.measured, if g.met { "yes" } else { "**no**" });
    }
}

fn scenario_goals(sc: &str, at: &str, c: &RunSummary) -> Vec<Goal> {
    let mut g = Vec::new();
    let le = |x: Option<f64>, b: f64| x.is_some_and(|x| x <= b);
    match sc {
        "flat" | "foam" => {
            let settle = if sc == "flat" { 0.15 } else { 0.20 };
            g.push(Goal { what: format!("{sc}, {at}: overshoot ≤ 5 % at first contact"), measured: format!("{:.1} %", c.contact_overshoot_pct), met: c.contact_overshoot_pct <= 5.0 });
            g.push(Goal { what: format!("{sc}, {at}: ±2 % settling ≤ {settle} s after contact"), measured: fmt_s(c.contact_settle_s) + " s", met: le(c.contact_settle_s, settle) });
            if !c.later_overshoot_pct.is_empty() {
                g.push(Goal { what: format!("{sc}, {at}: overshoot ≤ 5 % at the 10 → 20 N step"), measured: format!("{:.1} %", c.later_overshoot_pct[0]), met: c.later_overshoot_pct[0] <= 5.0 });
                g.push(Goal { what: format!("{sc}, {at}: ±2 % settling ≤ {settle} s after the step"), measured: fmt_s(c.later_settle_s[0]) + " s", met: le(c.later_settle_s[0], settle) });
            }
        }
        "stiffness-step" => g.push(Goal {
            what: format!("stiffness-step, {at}: back within ±2 % ≤ 0.20 s after each jump"),
            measured: join(&c.later_settle_s, |x| fmt_s(*x)) + " s",
            met: !c.later_settle_s.is_empty() && c.later_settle_s.iter().all(|x| le(*x, 0.20)),
        }),
        "acrylic" => {
            g.push(Goal { what: format!("acrylic, {at}: within ±2 % ≤ 0.05 s after contact"), measured: fmt_s(c.contact_settle_s) + " s", met: le(c.contact_settle_s, 0.05) });
            g.push(Goal { what: format!("acrylic, {at}: peak ≤ 12 N (1.2 f_d)"), measured: format!("{:.2} N", c.peak_n), met: c.peak_n <= 12.0 });
            g.push(Goal { what: format!("acrylic, {at}: no limit cycle (late peak-to-peak ≤ 0.4 N, the ±2 % band)"), measured: format!("{:.2} N", c.late_p2p_n), met: c.late_p2p_n <= 0.4 });
        }
        "two-material" => {
            g.push(Goal { what: format!("two-material, {at}: overshoot ≤ 10 % at first contact (f_d = 3 N)"), measured: format!("{:.1} %", c.contact_overshoot_pct), met: c.contact_overshoot_pct <= 10.0 });
            g.push(Goal {
                what: format!("two-material, {at}: after the switch to foam ≤ 10 % overshoot (of the recovery) and ≤ 0.3 s recovery"),
                measured: format!("{} %, {} s", join(&c.later_recovery_overshoot_pct, |x| format!("{x:.1}")), join(&c.later_settle_s, |x| fmt_s(*x))),
                met: !c.later_settle_s.is_empty() && c.later_recovery_overshoot_pct[0] <= 10.0 && le(c.later_settle_s[0], 0.3),
            });
        }
        "slope" => g.push(Goal {
            what: format!("slope, {at}: |steady-state error| ≤ 0.05 N with ≤ 5 % contact overshoot"),
            measured: format!("{:.3} N, {:.1} %", c.ss_error_n, c.contact_overshoot_pct),
            met: c.ss_error_n.abs() <= 0.05 && c.contact_overshoot_pct <= 5.0,
        }),
        _ => {}
    }
    g
}

fn goals(get: &dyn Fn(&str, &str, usize) -> RunSummary, law: &str, oracle: &str) -> Vec<Goal> {
    let mut g = Vec::new();
    let rms = |c: &RunSummary| c.rms_n.unwrap_or(f64::NAN);
    for d in DELAYS {
        let s = |sc: &str| get(sc, law, d);
        let o = |sc: &str| get(sc, oracle, d);
        for sc in TABLE_SCENARIOS {
            g.extend(scenario_goals(sc, &format!("d = {d}"), &s(sc)));
        }
        for sc in ["flat", "stiffness-step"] {
            let (c, a) = (s(sc), get(sc, "aic", d));
            g.push(Goal {
                what: format!("{sc}, d = {d}: RMS ≥ 30 % below AIC's"),
                measured: format!("{:.3} vs {:.3} N ({:+.0} %)", rms(&c), rms(&a), 100.0 * (rms(&c) / rms(&a) - 1.0)),
                met: rms(&c) <= 0.7 * rms(&a),
            });
        }
        for sc in TABLE_SCENARIOS {
            let (c, or) = (s(sc), o(sc));
            let mut pairs = vec![(c.contact_settle_s, or.contact_settle_s)];
            pairs.extend(c.later_settle_s.iter().copied().zip(or.later_settle_s.iter().copied()));
            // Met where both settle and scheduled is within 1.5× of oracle, or where only
            // scheduled settles; a phase where neither settles is not met.
            let ok = pairs.iter().all(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => *a <= 1.5 * b.max(1e-3),
                (Some(_), None) => true,
                (None, _) => false,
            });
            g.push(Goal {
                what: format!("{sc}, d = {d}: settling within 1.5× of oracle in every phase"),
                measured: pairs.iter().map(|(a, b)| format!("{} vs {}", fmt_s(*a), fmt_s(*b))).collect::<Vec<_>>().join("; "),
                met: ok,
            });
        }
    }
    g
}

/// The sweep figure: per stiffness, medians of the scheduled law, the oracle and the
/// paper laws (delay 1 solid, delay 2 dashed).
fn sweep_figure(get: &dyn Fn(f64, &str, usize) -> RunSummary) -> Figure {
    let mut panels = vec![
        Panel { title: "(a) Overshoot at first contact".into(), y_label: "overshoot [%]".into(), ..Default::default() },
        Panel { title: "(b) ±2 % settling after contact (never settled: not drawn)".into(), y_label: "settling [s]".into(), ..Default::default() },
        Panel { title: "(c) Peak contact force (f_d = 10 N, then 20 N)".into(), y_label: "peak [N]".into(), ..Default::default() },
        Panel { title: "(d) RMS of f − f_d over the contact period".into(), y_label: "RMS [N]".into(), ..Default::default() },
    ];
    for c in TABLE_CONTROLLERS {
        for d in DELAYS {
            let cells: Vec<(f64, RunSummary)> = SWEEP_K.iter().map(|&k| (k.log10(), get(k, c, d))).collect();
            let mk = |f: &dyn Fn(&RunSummary) -> Option<f64>| Series {
                name: format!("{} d={d}", c.to_ascii_uppercase()),
                color: color(c),
                dashed: d == 2,
                points: cells.iter().filter_map(|(x, cl)| f(cl).filter(|v| v.is_finite()).map(|v| (*x, v))).collect(),
            };
            panels[0].series.push(mk(&|cl| Some(cl.contact_overshoot_pct.min(200.0))));
            panels[1].series.push(mk(&|cl| cl.contact_settle_s));
            panels[2].series.push(mk(&|cl| Some(cl.peak_n.min(100.0))));
            panels[3].series.push(mk(&|cl| cl.rms_n.map(|r| r.min(20.0))));
        }
    }
    Figure {
        title: "Stiffness sweep on 'flat' (one parameter set; medians of the seeds)".into(),
        subtitle: "x: log10 k_e for k_e = 500, 1000, 2000, 5000, 20 000, 50 000 N/m; overshoot clipped at 200 %, peak at 100 N, RMS at 20 N".into(),
        x_label: "log10 k_e [N/m]".into(),
        panels,
    }
}

fn color(name: &str) -> &'static str {
    match name {
        "oracle" => "#7f7f7f",
        other => naic_sim::plots::color(other),
    }
}

/// `naic sim --table`.
pub fn run(
    out: &Path,
    seeds: u32,
    urdf: Option<&Path>,
    friction_file: Option<&Path>,
    no_friction: bool,
    plant: &PlantChoice,
    sensor: super::sim::SensorOpts,
    parts: DerivedParts,
) -> CliResult {
    if seeds == 0 {
        return Err(CliError::usage("--seeds 0: give at least 1"));
    }
    let t0 = std::time::Instant::now();
    let ctx = Ctx { parts, ..Ctx::load(urdf, friction_file, no_friction, plant, sensor)? };
    let mut jobs = Vec::new();
    for seed in 1..=u64::from(seeds) {
        for sc in TABLE_SCENARIOS {
            for d in DELAYS {
                for c in TABLE_CONTROLLERS {
                    jobs.push(Job { scenario: sc, controller: c, delay: d, mass_error: 1.0, stiffness: None, seed });
                }
            }
            for f in ALL_MASS_ERRORS {
                for c in LAWS.iter().flat_map(|(l, o)| [*l, *o]) {
                    jobs.push(Job { scenario: sc, controller: c, delay: 1, mass_error: f, stiffness: None, seed });
                }
            }
        }
        for k in SWEEP_K {
            for d in DELAYS {
                for c in TABLE_CONTROLLERS {
                    jobs.push(Job { scenario: "flat", controller: c, delay: d, mass_error: 1.0, stiffness: Some(k), seed });
                }
            }
        }
    }
    std::fs::create_dir_all(out).map_err(|e| CliError::failure(format!("--out {}: {e}", out.display())))?;
    eprintln!("naic sim --table: {} runs ({} seeds){} -> {}", jobs.len(), seeds, super::sim_heldout::ablation_label(&parts), out.display());
    let done = par_map(
        &jobs,
        |j| {
            run_job(&ctx, j).map(|r| Done {
                scenario: j.scenario.to_string(),
                controller: j.controller.to_string(),
                delay_cycles: j.delay,
                model_mass_error: j.mass_error,
                stiffness: j.stiffness,
                seed: j.seed,
                n: runner::summarize(&r),
            })
        },
        true,
    )?;
    let cell_of = |sc: &str, c: &str, d: usize| {
        cell(&select(&done, |x| x.scenario == sc && x.controller == c && x.delay_cycles == d && x.model_mass_error == 1.0 && x.stiffness.is_none()))
    };
    let get = |sc: &str, c: &str, d: usize| cell_of(sc, c, d).median;
    let mut md = String::new();
    let _ = writeln!(md, "Medians of {seeds} seed(s); d = loop delay [control periods]; settling is \"never\" when the force is outside the band at the end of the phase (median: never if more than half never settle). Overshoot: at first contact and f_d steps beyond the new f_d in % of the step; at a stiffness jump the peak |f − f_d| in % of f_d (the instantaneous jump is physics). Recovery overshoot: after a step or jump, the excursion beyond f_d on the far side once the force has first crossed f_d, in % of f_d. Step / jump columns: flat the 10 → 20 N step at 3 s, stiffness-step the jumps at 2 s and 4 s, two-material the move onto the foam. late p-p: peak-to-peak force over the last 0.5 s.\n");
    if !parts.off().is_empty() {
        let _ = writeln!(md, "Ablation: the derived law (and its oracle){}.\n", super::sim_heldout::ablation_label(&parts));
    }
    md.push_str(HEADER);
    for sc in TABLE_SCENARIOS {
        for d in DELAYS {
            for c in TABLE_CONTROLLERS {
                md.push_str(&row(sc, &d.to_string(), c, &cell_of(sc, c, d)));
            }
        }
    }
    let _ = writeln!(md, "\nModel mass error (the controller's model with every mass and inertia × F), d = 1:\n");
    md.push_str(&HEADER.replace("| d |", "| F |"));
    for sc in TABLE_SCENARIOS {
        for f in ALL_MASS_ERRORS {
            for c in LAWS.iter().flat_map(|(l, o)| [*l, *o]) {
                let cl = cell(&select(&done, |x| x.scenario == sc && x.controller == c && x.model_mass_error == f));
                md.push_str(&row(sc, &f.to_string(), c, &cl));
            }
        }
    }
    let sweep_cell = |k: f64, c: &str, d: usize| {
        cell(&select(&done, |x| x.stiffness == Some(k) && x.controller == c && x.delay_cycles == d))
    };
    let sweep = |k: f64, c: &str, d: usize| sweep_cell(k, c, d).median;
    let _ = writeln!(md, "\nStiffness sweep on flat (`--stiffness K`), one parameter set:\n");
    md.push_str(&HEADER.replace("| scenario |", "| k_e [N/m] |"));
    for k in SWEEP_K {
        for d in DELAYS {
            for c in TABLE_CONTROLLERS {
                md.push_str(&row(&format!("{k:.0}"), &d.to_string(), c, &sweep_cell(k, c, d)));
            }
        }
    }
    for (law, oracle) in LAWS {
        // The scheduled law's lines first, as before; each other law's lines name it first.
        let head = |scheduled: &str, other: &str| if law == "scheduled" { scheduled.to_string() } else { format!("For `{law}`: {other}") };
        let gs = goals(&get, law, oracle);
        goal_table(&mut md, &format!("Goals of issue 12 for `{law}` (medians above)"), &gs);
        // The per-scenario goals at each model mass error F (d = 1).
        let at_mass_errors = |fs: &[f64]| {
            let mut v = Vec::new();
            for &f in fs {
                for sc in TABLE_SCENARIOS {
                    let c = cell(&select(&done, |x| x.scenario == sc && x.controller == law && x.model_mass_error == f));
                    v.extend(scenario_goals(sc, &format!("F = {f}, d = 1"), &c.median));
                }
            }
            v
        };
        // The issue's "every goal holds under --model-mass-error 0.8 and 1.25 and over the whole
        // stiffness sweep": the same per-scenario goals at F (d = 1), and flat's goals at every k_e.
        let mut rg = at_mass_errors(&MASS_ERRORS);
        for k in SWEEP_K {
            for d in DELAYS {
                rg.extend(scenario_goals("flat", &format!("k_e = {k:.0} N/m, d = {d}"), &sweep(k, law, d)));
            }
        }
        let what = "the same goals under model mass error (d = 1) and over the stiffness sweep (flat's goals at each k_e)";
        goal_table(&mut md, &head("The same goals under model mass error (d = 1) and over the stiffness sweep (flat's goals at each k_e)", what), &rg);
        let small = at_mass_errors(&SMALL_MASS_ERRORS);
        let what = "a check beside the issue's goals, the same goals at a small model mass error (d = 1)";
        goal_table(&mut md, &head("A check beside the issue's goals: the same goals at a small model mass error (d = 1)", what), &small);
    }
    let secs = t0.elapsed().as_secs_f64();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let _ = writeln!(md, "\n{} runs in {secs:.0} s on {threads} thread(s).", jobs.len());
    let fail = |p: &Path, e: std::io::Error| CliError::failure(format!("cannot write {}: {e}", p.display()));
    let p = out.join("table.md");
    std::fs::write(&p, &md).map_err(|e| fail(&p, e))?;
    let p = out.join("table.json");
    let json = serde_json::to_string(&done).map_err(|e| CliError::failure(e.to_string()))?;
    std::fs::write(&p, json + "\n").map_err(|e| fail(&p, e))?;
    let p = out.join("sweep.svg");
    std::fs::write(&p, sweep_figure(&sweep).to_svg()).map_err(|e| fail(&p, e))?;
    // Seed-1 time series of every controller per scenario and delay.
    let mut fig_jobs = Vec::new();
    for sc in TABLE_SCENARIOS {
        for d in DELAYS {
            for c in TABLE_CONTROLLERS {
                fig_jobs.push(Job { scenario: sc, controller: c, delay: d, mass_error: 1.0, stiffness: None, seed: 1 });
            }
        }
    }
    for chunk in fig_jobs.chunks(TABLE_CONTROLLERS.len()) {
        let runs = par_map(chunk, |j| run_job(&ctx, j), false)?;
        let mut s = scenario_for(&ctx, &chunk[0])?;
        s.description = format!("{} — loop delay d = {} (seed 1)", s.description, chunk[0].delay);
        let p = out.join(format!("{}-d{}.svg", chunk[0].scenario, chunk[0].delay));
        std::fs::write(&p, naic_sim::plots::figure(&s, &runs).to_svg()).map_err(|e| fail(&p, e))?;
    }
    println!("{md}");
    println!("wrote {} ({:.0} s)", out.display(), t0.elapsed().as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `X of Y met` of the goals line that starts with `head` in the table's markdown.
    fn counted(md: &str, head: &str) -> (usize, usize) {
        let line = md.lines().find(|l| l.starts_with(head)).unwrap_or_else(|| panic!("no line {head:?} in table.md"));
        let words: Vec<&str> = line.rsplit(": ").next().unwrap_or("").split(' ').collect();
        match words.as_slice() {
            [met, "of", all, "met."] => (met.parse().expect("met"), all.parse().expect("all")),
            _ => panic!("cannot read the count of {line:?}"),
        }
    }

    /// Issue 12's goals as the issue defines them: medians of 5 seeds of `naic sim --table`,
    /// at d = 1 and 2 (42 goals), and the same goals under model mass error 0.8 / 1.25 and
    /// over the stiffness sweep (74), with one parameter set; every one met
    /// (docs/controller.md, "Goals of issue 12"). Beside the issue, at mass error 0.95 / 1.05,
    /// 25 of 26 are met (two-material's first contact at 0.95 misses, 10.6 %): asserted as
    /// achieved, so that a change cannot lose one silently. The whole table (840 runs, ≈ 20 s
    /// on 2 cores in release).
    #[test]
    fn the_table_meets_every_goal_of_issue_12() {
        let out = std::env::temp_dir().join(format!("naic-table-test-{}", std::process::id()));
        let r = run(&out, 5, None, None, false, &PlantChoice::Own, super::super::sim::SensorOpts { inertial_wrench: false, tare_at_rest: false }, DerivedParts::ALL);
        let md = std::fs::read_to_string(out.join("table.md"));
        let _ = std::fs::remove_dir_all(&out);
        r.unwrap_or_else(|e| panic!("naic sim --table: {e}"));
        let md = md.expect("table.md written");
        let misses: Vec<&str> = md.lines().filter(|l| l.ends_with("| **no** |")).collect();
        let (met, all) = counted(&md, "Goals of issue 12 for `scheduled`");
        assert_eq!((met, all), (42, 42), "the core goals; misses: {misses:#?}");
        let (met, all) = counted(&md, "The same goals under model mass error");
        assert_eq!((met, all), (74, 74), "under mass error and over the sweep; misses: {misses:#?}");
        let (met, all) = counted(&md, "A check beside the issue's goals");
        assert!(all == 26 && met >= 25, "beside the issue {met} of {all}; misses: {misses:#?}");
    }

    #[test]
    fn medians_count_never_settled_as_infinite() {
        assert_eq!(median_opt(&[Some(1.0), None, Some(3.0)]), Some(3.0));
        assert_eq!(median_opt(&[Some(1.0), None, None]), None);
        assert_eq!(median_opt(&[Some(1.0), Some(2.0)]), Some(1.5));
        assert_eq!(median_opt(&[]), None);
        let runs = [
            RunSummary { contact_time_s: Some(1.0), peak_n: 10.0, later_overshoot_pct: vec![5.0, 1.0], later_settle_s: vec![None, Some(0.1)], later_recovery_overshoot_pct: vec![1.0, 2.0], ..Default::default() },
            RunSummary { contact_time_s: None, peak_n: 30.0, ..Default::default() },
            RunSummary { contact_time_s: Some(2.0), peak_n: 20.0, later_overshoot_pct: vec![7.0], later_settle_s: vec![Some(0.2)], later_recovery_overshoot_pct: vec![3.0], ..Default::default() },
        ];
        let c = cell(&runs.iter().collect::<Vec<_>>());
        assert_eq!((c.never, c.seeds), (1, 3));
        assert_eq!(c.median.peak_n, 20.0);
        // Later phases: as many as every run has (here none for the run without contact).
        assert!(c.median.later_overshoot_pct.is_empty());
    }
}
