//! `naic explain`: find what the nominal model gets wrong in measured data (issue 6).
//!
//! * `naic explain --measured FILE… [--validate FILE…] --out DIR [--urdf robot.urdf] [--tip FRAME]
//!   [--nominal params/…]` — analyse bags or CSV time series of any serial arm (the joint
//!   count comes from the URDF), or a friction-points CSV; writes `DIR/report.json`,
//!   `DIR/report.md` (+ SVG plots) and `DIR/extended_params.yaml`; `--write-urdf PATH`: the URDF
//!   with the link inertials an `inertial_parameters` finding corrected. With `--validate` the
//!   models fitted on the `--measured` runs are scored on those whole other runs.
//! * `naic explain --generate FILE.csv --seed N [--hide effect,…] [--contact]` — write seeded
//!   synthetic data with hidden effects (the tests' generators; contact data with wrench
//!   columns when a contact effect is hidden or `--contact` is given), to try the tool.
//! * `naic explain --closed-loop [--out DIR]` — force tracking (`flat`, `stiffness-step`)
//!   with symmetric vs extended friction compensation against the simulator's true
//!   per-direction friction (see `naic_explain::closed_loop`).
//! * `naic explain --bench [--urdf PATH [--tip FRAME]] [--minutes M] [--json]` — time the
//!   analysis of M minutes (default 60) of generated 1 kHz data with the arm's own joint
//!   count (six for the default JK5, seven for `urdf/panda.urdf`), with progress and the
//!   time per stage on stderr, against one RNEA per sample and numpy's least-squares
//!   friction fit (`bench/reference/explain_numpy_bench.py`) measured in the same run
//!   (`--out DIR` also writes its report).
use super::{CliError, CliResult};
use naic_core::model::Model;
use naic_explain::catalogue::Effect;
use naic_explain::generate::{generate, GenSpec};
use naic_explain::{input, report, ExplainError, ExplainOptions};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Default)]
pub struct ExplainArgs {
    /// Measured data to fit: .mcap bags (/joint_states …) or CSV time series `t,q1..qN,dq1..dqN,tau1..tauN`
    /// (N joints of the URDF; several runs are analysed together; non-uniform timestamps are
    /// resampled onto a uniform grid, gaps split the run), or one friction-points CSV
    /// `joint,velocity_rad_s,torque_nm`.
    #[arg(long, num_args = 1.., value_name = "FILE")]
    measured: Vec<PathBuf>,
    /// Whole other runs (time series) to score the fitted models on; without it, time blocks
    /// of the --measured runs are held out.
    #[arg(long, num_args = 1.., value_name = "FILE")]
    validate: Vec<PathBuf>,
    /// Tool frame of the URDF (where a payload sits; the contact point of wrench data)
    /// [default: the last link of the chain].
    #[arg(long, value_name = "FRAME")]
    tip: Option<String>,
    /// Output directory for report.json, report.md, plots and extended_params.yaml.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Savitzky–Golay window for velocity, acceleration and torque [s] (longer: less noise
    /// in q̈, less bandwidth) [default: chosen from the data: the shortest of 51 ms·√2ᵏ whose
    /// q̈ changes by ≤ 10 % RMS when made √2 longer; the report's method table gives the numbers].
    #[arg(long, value_name = "S")]
    window: Option<f64>,
    /// Family-wise error rate of the significance test: the chance, on data where no candidate
    /// helps, that any candidate on any joint is found (block bootstrap over candidates ×
    /// joints: each joint's share of α, balanced over its candidates; never less than α/m each).
    #[arg(long, default_value_t = 0.05)]
    alpha: f64,
    /// Write the URDF with the link inertials corrected by an `inertial_parameters` finding
    /// here (only when found and the corrected links are physically consistent; the report
    /// says why otherwise).
    #[arg(long, value_name = "PATH")]
    write_urdf: Option<PathBuf>,
    /// Nominal friction params YAML; its Stribeck shape is kept (directions averaged), its levels recalibrated.
    #[arg(long)]
    nominal: Option<PathBuf>,
    /// Friction params YAML evaluated as given on the analysed friction points, next to the
    /// extended model (e.g. params/friction_jk5.yaml, the paper's Table 1).
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Robot model for the rigid-body part.
    #[arg(long, default_value = "urdf/jk5.urdf")]
    urdf: PathBuf,
    /// Comma-separated effects to consider; `+name,…` adds to the default [default: the whole
    /// catalogue, position_torque included].
    #[arg(long)]
    effects: Option<String>,
    /// Write seeded synthetic data to this CSV instead of analysing.
    #[arg(long)]
    generate: Option<PathBuf>,
    /// Seed for --generate.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Comma-separated effects to hide in --generate data (empty: noise only).
    #[arg(long, default_value = "")]
    hide: String,
    /// Sample rate of --generate data [Hz] (100–2000 tested).
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// --generate contact data (pressing into a surface, with wrench columns fx..mz) even
    /// when no contact effect is hidden.
    #[arg(long)]
    contact: bool,
    /// Benchmark: analyse --minutes of generated 1 kHz data and print the timing.
    #[arg(long)]
    bench: bool,
    /// Length of the benchmark data [min].
    #[arg(long, default_value_t = 60.0)]
    minutes: f64,
    /// Print the benchmark result as JSON.
    #[arg(long)]
    json: bool,
    /// Closing the loop: RMS force error with symmetric vs extended friction compensation in the simulator.
    #[arg(long)]
    closed_loop: bool,
    /// True per-direction friction of the simulated plant for --closed-loop.
    #[arg(long, default_value = "params/friction_jk5.yaml")]
    truth: PathBuf,
    /// No progress on stderr.
    #[arg(long)]
    quiet: bool,
}

fn err(e: ExplainError) -> CliError {
    if e.is_input() {
        CliError::usage(e.to_string())
    } else {
        CliError::failure(e.to_string())
    }
}

fn parse_effects(s: &str) -> Result<Vec<Effect>, CliError> {
    s.split(',')
        .map(str::trim)
        .filter(|x| !x.is_empty())
        .map(|x| {
            Effect::parse(x).ok_or_else(|| {
                CliError::usage(format!(
                    "unknown effect `{x}`; known: {}",
                    naic_explain::catalogue::ALL_EFFECTS.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ")
                ))
            })
        })
        .collect()
}

fn progress_printer(quiet: bool) -> impl Fn(f64, &str) + Sync {
    let start = Instant::now();
    move |f: f64, what: &str| {
        if !quiet {
            eprint!("\r[{:5.1} s] {:3.0} % {what:<60}", start.elapsed().as_secs_f64(), 100.0 * f);
            let _ = std::io::stderr().flush();
        }
    }
}

pub fn run(a: ExplainArgs) -> CliResult {
    if let Some(out) = &a.generate {
        return run_generate(&a, out);
    }
    if a.bench {
        return run_bench(&a);
    }
    if a.closed_loop {
        return run_closed_loop(&a);
    }
    if a.measured.is_empty() {
        return Err(CliError::usage(
            "give --measured FILE… (bags, time-series CSVs, or one friction-points CSV) and --out DIR; or --generate / --bench",
        ));
    }
    let out = a.out.as_ref().ok_or_else(|| CliError::usage("give --out DIR for report.json, report.md and extended_params.yaml"))?;
    let mut opts = ExplainOptions {
        urdf: a.urdf.clone(),
        tip_frame: a.tip.clone(),
        nominal: a.nominal.clone(),
        reference: a.reference.clone(),
        ..Default::default()
    };
    match a.window {
        Some(w) if !(w > 0.0 && w.is_finite()) => {
            return Err(CliError::usage(format!("--window {w}: give the filter window in seconds, e.g. 0.051")));
        }
        Some(w) => opts.prepare.window_s = w,
        None => opts.auto_window = true,
    }
    if !(a.alpha > 0.0 && a.alpha < 1.0) {
        return Err(CliError::usage(format!("--alpha {}: give the family-wise error rate, between 0 and 1 (default 0.05)", a.alpha)));
    }
    opts.analysis.family_alpha = a.alpha;
    if let Some(e) = &a.effects {
        match e.trim().strip_prefix('+') {
            Some(extra) => {
                for x in parse_effects(&extra.replace(",+", ","))? {
                    if !opts.analysis.effects.contains(&x) {
                        opts.analysis.effects.push(x);
                    }
                }
            }
            None => opts.analysis.effects = parse_effects(e)?,
        }
    }
    let progress = progress_printer(a.quiet);
    let ex = naic_explain::explain_files(&a.measured, &a.validate, &opts, &progress).map_err(err)?;
    let v = report::write_all(&ex, out).map_err(err)?;
    if !a.quiet {
        eprintln!();
    }
    let sig: Vec<String> = v["findings"]
        .as_array()
        .map(|fs| {
            fs.iter()
                .filter(|f| f["significant"].as_bool() == Some(true))
                .map(|f| {
                    // a finding below 5 % of its joint's residual says so, with the share left
                    let small = if f["small"].as_bool() == Some(true) {
                        let ev = f["evidence"].as_str().unwrap_or("");
                        ev.rfind("(small:").map_or(String::new(), |i| format!(" {}", ev[i..].trim_end_matches('.')))
                    } else {
                        String::new()
                    };
                    format!(
                        "{} (gain {:.4}, step gain {:.3}, {}){small}",
                        f["effect"].as_str().unwrap_or("?"),
                        f["gain"].as_f64().unwrap_or(0.0),
                        f["step_gain"].as_f64().unwrap_or(0.0),
                        f["targets"]
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let any_sig = !sig.is_empty();
    if sig.is_empty() {
        let floor = v["noise_floor"]
            .as_object()
            .filter(|m| !m.is_empty())
            .map(|m| {
                let vals: Vec<String> = m.values().map(|x| format!("{:.3}", x.as_f64().unwrap_or(f64::NAN))).collect();
                format!(" (torque noise floor per joint after the filter [N·m]: {})", vals.join(" / "))
            })
            .unwrap_or_default();
        println!("nothing significant: {}{floor}; report in {}", naic_explain::report::NO_EFFECT, out.display());
    } else {
        println!("findings, ranked by held-out gain:");
        for s in sig {
            println!("  {s}");
        }
        println!("report in {}", out.display());
    }
    if any_sig {
        print_explained(&v);
    } else if let (Some(floor), Some(nom)) = (v["noise_floor"].as_object(), v["nominal"]["heldout_rmse"].as_object()) {
        // "no effect beyond noise" is what the catalogue can say; a joint whose residual stays
        // well above its noise floor has structure left that no candidate names
        let above: Vec<String> = floor
            .iter()
            .filter_map(|(k, f)| {
                let (f, r) = (f.as_f64()?, nom.get(k)?.as_f64()?);
                (r > 2.0 * f).then(|| format!("{k} {r:.3} vs {f:.3}"))
            })
            .collect();
        if !above.is_empty() {
            println!("held-out RMSE above twice the noise floor, structure no candidate names [N·m]: {}", above.join(", "));
        }
    }
    print_lack_of_fit(&v);
    if let Some(path) = &a.write_urdf {
        match report::inertial_links(&ex) {
            None => println!("no corrected URDF written to {}: no inertial_parameters finding", path.display()),
            Some(Err(e)) => println!("no corrected URDF written to {}: {e}", path.display()),
            Some(Ok(links)) => match naic_explain::inertial::write_urdf(&a.urdf, &links, path) {
                Ok(()) => println!("corrected URDF (inertial_parameters) written to {}", path.display()),
                Err(e) => println!("no corrected URDF written to {}: {e}", path.display()),
            },
        }
    }
    Ok(())
}

/// The share of the nominal residual explained, and the validation RMSEs (time series).
fn print_explained(v: &serde_json::Value) {
    let Some(total) = v["explained"]["all_joints"].as_f64() else { return };
    if total < naic_explain::report::MOSTLY_LEFT {
        println!(
            "most of the residual is left: the findings explain {:.0} % of the nominal held-out mean square (all joints)",
            100.0 * total
        );
    } else {
        println!("the findings explain {:.0} % of the nominal held-out mean square (all joints)", 100.0 * total);
    }
    let row = |m: &serde_json::Map<String, serde_json::Value>, key: &str| {
        m.values().map(|d| format!("{:.3}", d[key].as_f64().unwrap_or(f64::NAN))).collect::<Vec<_>>().join(" / ")
    };
    if let Some(val) = v["validation"].as_object() {
        println!("validation-run RMSE per joint [N·m]: nominal {}; extended {}", row(val, "nominal_rmse"), row(val, "extended_rmse"));
    }
    if let Some(b) = v["baseline"]["joints"].as_object() {
        let val = if v["validation"].is_object() { format!("; on the validation runs {}", row(b, "validation_rmse")) } else { String::new() };
        println!("baseline (base parameters + viscous/Coulomb/offset friction) held-out RMSE per joint [N·m]: {}{val}", row(b, "heldout_rmse"));
    }
}

/// One line on what the extended model leaves (friction points): the directions whose
/// held-out residual is well above the data's own scatter.
fn print_lack_of_fit(v: &serde_json::Value) {
    let Some(m) = v["lack_of_fit"].as_object() else { return };
    let mut left = Vec::new();
    for (joint, d) in m.iter().filter(|(k, _)| k.as_str() != "method") {
        for (dir, sign) in [("positive", "+"), ("negative", "−")] {
            if d[dir]["lack_of_fit"].as_bool() == Some(true) {
                left.push(format!("{joint}{sign} ({:.1}× the noise floor's mean square)", d[dir]["ms_ratio"].as_f64().unwrap_or(f64::NAN)));
            }
        }
    }
    if left.is_empty() {
        println!("what is left is at the data's noise level on every joint and direction");
    } else {
        println!("structure left that no catalogue effect names: {}", left.join(", "));
    }
}

fn load_model(a: &ExplainArgs) -> Result<Model, CliError> {
    Model::from_urdf_file(&a.urdf).map_err(|e| CliError::usage(format!("--urdf {}: {e}", a.urdf.display())))
}

fn run_generate(a: &ExplainArgs, out: &PathBuf) -> CliResult {
    let model = load_model(a)?;
    let effects = parse_effects(&a.hide)?;
    if (a.contact || effects.iter().any(|e| e.is_contact())) && model.nv() != naic_core::N_JOINTS {
        return Err(CliError::usage(format!(
            "--urdf {}: contact data is scripted for the JK5's {} joints (urdf/jk5.urdf); this model has {}",
            a.urdf.display(),
            naic_core::N_JOINTS,
            model.nv()
        )));
    }
    if !(a.rate.is_finite() && (10.0..=100_000.0).contains(&a.rate)) {
        return Err(CliError::usage(format!("--rate {}: give the sample rate in Hz, 10–100000 (e.g. --rate 1000)", a.rate)));
    }
    let g = generate(&model, &GenSpec { contact: a.contact, tip: a.tip.clone(), dt: 1.0 / a.rate, ..GenSpec::new(a.seed, &effects) });
    std::fs::write(out, input::write_timeseries_csv(&g.ts)).map_err(|e| CliError::failure(format!("{}: {e}", out.display())))?;
    println!("wrote {} ({} samples, torque noise σ = {:.3} N·m)", out.display(), g.ts.len(), g.noise_tau);
    for inj in &g.injected {
        let ps: Vec<String> = inj.params.iter().map(|(j, k, v)| format!("{} {k} = {v:.4}", naic_explain::contact::target_key(*j))).collect();
        let ts: Vec<String> = inj.joints.iter().map(|&j| naic_explain::contact::target_key(j)).collect();
        println!("hidden: {} on {}: {}", inj.effect.name(), ts.join(", "), ps.join(", "));
    }
    Ok(())
}

fn run_bench(a: &ExplainArgs) -> CliResult {
    if !(a.minutes > 0.0 && a.minutes.is_finite()) {
        return Err(CliError::usage("--minutes must be > 0"));
    }
    let model = load_model(a)?;
    let nj = model.nv();
    // the tool frame the analysis will use (a clear error for a wrong --tip before generating)
    naic_explain::tip_frame(&model, &a.urdf, a.tip.as_deref()).map_err(err)?;
    let progress = progress_printer(a.quiet);
    let t0 = Instant::now();
    let mut spec = GenSpec { tip: a.tip.clone(), ..GenSpec::new(a.seed, &[Effect::FrictionAsymmetry, Effect::TorqueOffset]) };
    // one excitation period is ~100 s (six joints) to ~115 s (seven); repeat it to reach the length asked for
    spec.repeats = spec.repeats_for(nj, a.minutes * 60.0);
    progress(0.0, &format!("generating {} × {:.1} s of {nj}-joint data", spec.repeats, naic_explain::generate::excitation_period_s(nj, &spec)));
    let g = generate(&model, &spec);
    let gen_s = t0.elapsed().as_secs_f64();
    let opts = ExplainOptions { urdf: a.urdf.clone(), tip_frame: a.tip.clone(), ..Default::default() };
    let t1 = Instant::now();
    let cpu1 = process_cpu_s();
    let ex = naic_explain::explain_series("bench", input::Kind::TimeSeries, &g.ts, &opts, &progress).map_err(err)?;
    let series_s = t1.elapsed().as_secs_f64();
    let fs = report::findings(&ex);
    let analyse_s = t1.elapsed().as_secs_f64();
    // CPU time of the analysis, all its threads: the wall time on a core of one's own is at
    // least this over the thread count, and does not grow with other processes' load
    let analyse_cpu_s = process_cpu_s().zip(cpu1).map(|(b, a)| b - a);
    if let Some(out) = &a.out {
        report::write_all(&ex, out).map_err(err)?;
    }
    if !a.quiet {
        eprintln!();
    }
    let mut stages: Vec<(String, f64)> = ex.timings.clone();
    stages.push(("findings (report::findings)".into(), analyse_s - series_s));
    if !a.quiet {
        for (name, s) in &stages {
            eprintln!("  {s:7.3} s  {name}");
        }
        if let Some(c) = analyse_cpu_s {
            eprintln!("  {analyse_s:7.3} s  the analysis, wall; {c:.3} s of CPU on {} threads", opts.threads);
        }
    }
    // Reference 1, measured in the same run: one RNEA(q, dq, 0) per raw sample, the least
    // work any model-based analysis of every sample must do (single thread).
    if !a.quiet {
        eprintln!("reference: one RNEA per sample ({} samples, {nj} joints)", g.ts.len());
    }
    let reference_s = rnea_every_sample(&model, &g.ts);
    // Reference 2: numpy's least squares of per-joint viscous + Coulomb + offset friction on
    // as many samples and joints (bench/reference/explain_numpy_bench.py).
    let numpy = numpy_reference(g.ts.len(), nj, a.seed, a.quiet);
    let hours = g.ts.len() as f64 * spec.dt / 3600.0;
    let found: Vec<&str> = fs.iter().filter(|f| f.significant).map(|f| f.effect.name()).collect();
    let hidden: Vec<serde_json::Value> = g
        .injected
        .iter()
        .map(|inj| {
            let found = fs.iter().find(|f| f.significant && f.effect == inj.effect);
            serde_json::json!({
                "effect": inj.effect.name(),
                "joints": inj.joints,
                "truth": inj.params.iter().map(|(j, k, v)| serde_json::json!({"joint": j, "param": k, "value": v})).collect::<Vec<_>>(),
                "found_on": found.map(|f| f.targets.clone()),
                "estimate": found.map(|f| {
                    f.params
                        .iter()
                        .flat_map(|(j, ps)| ps.iter().map(move |(k, v)| serde_json::json!({"joint": j, "param": k, "value": v})))
                        .collect::<Vec<_>>()
                }),
            })
        })
        .collect();
    let mut v = serde_json::json!({
        "benchmark": "explain",
        "urdf": a.urdf.display().to_string(),
        "joints": nj,
        "samples": g.ts.len(),
        "hours_of_1khz_data": hours,
        "generate_s": gen_s,
        "analyse_s": analyse_s,
        "analyse_s_per_hour": analyse_s / hours,
        "analyse_cpu_s": analyse_cpu_s,
        "stages_s": stages.iter().map(|(n, s)| serde_json::json!({"stage": n, "s": s})).collect::<Vec<_>>(),
        "threads": opts.threads,
        "reference_rnea_every_sample_s": reference_s,
        "ratio_analyse_to_reference": analyse_s / reference_s,
        "found": found,
        "hidden": hidden,
        "load_average_1min": load_average(),
    });
    match &numpy {
        Ok(r) => {
            v["reference_numpy_lstsq_s"] = serde_json::json!(r["lstsq_s"]);
            if let Some(s) = r["lstsq_s"].as_f64() {
                v["ratio_analyse_to_numpy_lstsq"] = serde_json::json!(analyse_s / s);
            }
            v["numpy_reference"] = r.clone();
        }
        Err(why) => v["numpy_reference_skipped"] = serde_json::json!(why.to_string()),
    }
    if a.json {
        println!("{v}");
    } else {
        let np = match &numpy {
            Ok(r) => format!("; numpy lstsq friction fit {:.2} s, ratio {:.1}", r["lstsq_s"].as_f64().unwrap_or(f64::NAN), v["ratio_analyse_to_numpy_lstsq"].as_f64().unwrap_or(f64::NAN)),
            Err(why) => format!("; numpy reference skipped: {why}"),
        };
        println!(
            "{} samples of {nj} joints ({hours:.3} h at 1 kHz): analysed in {analyse_s:.2} s ({:.2} s per hour of data), generation {gen_s:.2} s; reference (one RNEA per sample) {reference_s:.2} s, ratio {:.1}{np}; found {found:?}",
            g.ts.len(),
            analyse_s / hours,
            analyse_s / reference_s
        );
    }
    Ok(())
}

/// Seconds for one `rnea(q, q̇, 0)` per raw sample of `ts` (the joint-space vectors sized
/// at compile time for six and seven joints, as the controllers' fast path; dynamic otherwise).
fn rnea_every_sample(model: &Model, ts: &input::TimeSeries) -> f64 {
    fn run<D: nalgebra::Dim>(model: &Model, ts: &input::TimeSeries, dim: D) -> f64
    where
        nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>
            + nalgebra::allocator::Allocator<D, D>
            + nalgebra::allocator::Allocator<nalgebra::U6, D>,
    {
        let Ok(mut data) = naic_core::model::Data::<D>::try_new(model) else { return f64::NAN };
        let mut q = nalgebra::OVector::<f64, D>::zeros_generic(dim, nalgebra::U1);
        let mut v = q.clone();
        let zero = q.clone();
        let t = Instant::now();
        let mut acc = 0.0;
        for i in 0..ts.len() {
            q.as_mut_slice().copy_from_slice(&ts.q[i]);
            v.as_mut_slice().copy_from_slice(&ts.dq[i]);
            acc += naic_core::dynamics::rnea(model, &mut data, &q, &v, &zero)[1];
        }
        let s = t.elapsed().as_secs_f64();
        std::hint::black_box(acc);
        s
    }
    match model.nv() {
        6 => run(model, ts, nalgebra::U6),
        7 => run(model, ts, nalgebra::U7),
        n => run(model, ts, nalgebra::Dyn(n)),
    }
}

/// Runs `bench/reference/explain_numpy_bench.py --samples N --joints J` with $NAIC_PYTHON
/// (else $NAIC_VENV/bin/python, else python3); its last stdout line is JSON. Err: why it
/// was skipped (no Python, no numpy, failed).
fn numpy_reference(samples: usize, joints: usize, seed: u64, quiet: bool) -> Result<serde_json::Value, NumpySkipped> {
    let script = super::sim::default_path("bench/reference/explain_numpy_bench.py");
    if !script.exists() {
        return Err(NumpySkipped::NoScript { script: script.display().to_string() });
    }
    let py = super::sim::python();
    if !quiet {
        eprintln!("reference: numpy least squares ({py} {})", script.display());
    }
    let o = std::process::Command::new(&py)
        .arg(&script)
        .args(["--samples", &samples.to_string(), "--joints", &joints.to_string(), "--seed", &seed.to_string()])
        .stderr(if quiet { std::process::Stdio::piped() } else { std::process::Stdio::inherit() })
        .output()
        .map_err(|e| NumpySkipped::CannotRun { python: py.clone(), problem: e.to_string() })?;
    let text = String::from_utf8_lossy(&o.stdout);
    let last = text.lines().last().unwrap_or("");
    let stderr = || String::from_utf8_lossy(&o.stderr).trim().to_string();
    let script = script.display().to_string();
    let v: serde_json::Value = serde_json::from_str(last).map_err(|e| NumpySkipped::NoJson {
        python: py.clone(),
        script: script.clone(),
        exit: o.status.code(),
        problem: e.to_string(),
        stderr: stderr(),
    })?;
    if let Some(why) = v["skipped"].as_str() {
        return Err(NumpySkipped::ScriptSaid { why: why.to_string() });
    }
    if !o.status.success() {
        return Err(NumpySkipped::Failed { python: py, script, stderr: stderr() });
    }
    Ok(v)
}

/// Why the numpy reference of the explain benchmark was skipped (reported, not fatal).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
enum NumpySkipped {
    #[error("{script} not found (run from the repository)")]
    NoScript { script: String },
    #[error("cannot run {python} (set NAIC_PYTHON or NAIC_VENV): {problem}")]
    CannotRun { python: String, problem: String },
    #[error("{python} {script}: exit {exit:?}, no JSON on stdout ({problem}): {stderr}")]
    NoJson { python: String, script: String, exit: Option<i32>, problem: String, stderr: String },
    /// The script's own reason (e.g. numpy missing).
    #[error("{why}")]
    ScriptSaid { why: String },
    #[error("{python} {script} failed: {stderr}")]
    Failed { python: String, script: String, stderr: String },
}

/// The 1-minute load average (`/proc/loadavg`), to say how busy the machine was.
/// User + system CPU time of this process, all threads [s] (`getrusage`).
fn process_cpu_s() -> Option<f64> {
    // SAFETY: getrusage writes one `rusage` into the zeroed struct it is given.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) } != 0 {
        return None;
    }
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(s(ru.ru_utime) + s(ru.ru_stime))
}

fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

fn run_closed_loop(a: &ExplainArgs) -> CliResult {
    let progress = progress_printer(a.quiet);
    let rows = naic_explain::closed_loop::closed_loop(&a.urdf, &a.truth, a.out.as_deref(), &progress).map_err(err)?;
    if !a.quiet {
        eprintln!();
    }
    let mut md = String::from("| scenario | friction compensation | RMS force error from first contact [N] |\n| --- | --- | --- |\n");
    for r in &rows {
        md.push_str(&format!(
            "| {} | {} | {} |\n",
            r.scenario,
            r.compensation,
            r.rms_force_error.map_or_else(|| "no contact".to_string(), |v| format!("{v:.4}"))
        ));
    }
    print!("{md}");
    if let Some(dir) = &a.out {
        let v: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| serde_json::json!({"scenario": r.scenario, "compensation": r.compensation, "rms_force_error_n": r.rms_force_error}))
            .collect();
        std::fs::write(dir.join("closed_loop.json"), serde_json::to_string_pretty(&v).unwrap_or_default())
            .map_err(|e| CliError::failure(format!("{}: {e}", dir.display())))?;
        std::fs::write(dir.join("closed_loop.md"), md).map_err(|e| CliError::failure(format!("{}: {e}", dir.display())))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numpy_skip_reasons_name_the_interpreter_and_the_fix() {
        let m = NumpySkipped::CannotRun { python: "nopython3".into(), problem: "No such file or directory (os error 2)".into() }.to_string();
        assert!(m.starts_with("cannot run nopython3") && m.contains("NAIC_PYTHON") && m.contains("os error 2"), "{m}");
        let m = NumpySkipped::NoJson { python: "py".into(), script: "b.py".into(), exit: Some(1), problem: "EOF".into(), stderr: "Traceback".into() }
            .to_string();
        assert_eq!(m, "py b.py: exit Some(1), no JSON on stdout (EOF): Traceback");
        assert_eq!(NumpySkipped::ScriptSaid { why: "numpy is not installed".into() }.to_string(), "numpy is not installed");
    }
}
