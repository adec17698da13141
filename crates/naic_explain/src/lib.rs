//! # naic_explain — find what the model gets wrong in measured data (issue 6)
//!
//! Given measured data of the JK5 (an MCAP bag, a CSV time series, or steady-state
//! friction points), [`explain`] compares it with the nominal model — rigid body from
//! `urdf/jk5.urdf` plus symmetric friction (eq. 5) whose levels are calibrated on the
//! training part — and searches a catalogue of candidate extensions
//! ([`catalogue::Effect`]). Each candidate is fitted on training folds and scored on
//! held-out time blocks; a significance rule keeps noise from becoming a finding
//! ([`analysis`]). The result is a [`report::Report`] (`report.json`, `report.md` with
//! SVG plots) and an extended friction parameter file that the friction loader reads.
//!
//! Contact data (wrench columns / `/wrench`) is also analysed per sensor axis against the
//! simulator's contact and F/T-sensor model ([`contact`]).
//!
//! Modules: [`input`] (reading and validating the three kinds), [`prepare`]
//! (Savitzky–Golay velocity/acceleration, rigid-body torques), [`contact`], [`catalogue`],
//! [`analysis`] (folds, fits, selection), [`lack_of_fit`] (what is left against the data's
//! noise floor), [`report`], [`generate`] (seeded synthetic
//! "measured" data with hidden effects, for tests and benchmarks).

pub mod analysis;
pub mod baseline;
pub mod catalogue;
pub mod closed_loop;
pub mod contact;
pub mod generate;
pub mod inertial;
pub mod input;
pub mod lack_of_fit;
pub mod plots;
pub mod prepare;
pub mod report;
pub mod resample;

use analysis::{AnalysisOptions, JointResult, JointSamples, NominalShape};
use input::{Kind, Measured};
use naic_core::friction::{FrictionParams, JointFriction};
use naic_core::model::Model;
use naic_ident::FrictionData;
use prepare::{PrepareOptions, Prepared};
use std::path::{Path, PathBuf};

/// Errors of the explain tool. `Input` = the user's data or files (exit 2), `Model` = the robot model.
#[derive(Debug, thiserror::Error)]
pub enum ExplainError {
    #[error("{0}")]
    Input(String),
    #[error("robot model: {0}")]
    Model(String),
    #[error("{0}")]
    Io(String),
}

impl ExplainError {
    pub fn input(s: impl Into<String>) -> Self {
        Self::Input(s.into())
    }
    pub fn model(s: impl Into<String>) -> Self {
        Self::Model(s.into())
    }
    pub fn is_input(&self) -> bool {
        matches!(self, Self::Input(_))
    }
}

/// Everything [`explain`] needs.
#[derive(Clone, Debug)]
pub struct ExplainOptions {
    /// The robot model (URDF) used for the rigid-body part.
    pub urdf: PathBuf,
    /// Frame where a payload would sit (and the contact point of contact data); `None`:
    /// the last link of the chain (reported in the method table).
    pub tip_frame: Option<String>,
    /// Frame of the F/T sensor (contact data).
    pub sensor_frame: String,
    /// Nominal friction parameter file; its Stribeck shape (symmetrised) is kept, its levels recalibrated.
    pub nominal: Option<PathBuf>,
    /// A friction parameter file evaluated as given (no recalibration) on the analysed
    /// friction points, for comparison (e.g. the paper's Table 1, `params/friction_jk5.yaml`).
    pub reference: Option<PathBuf>,
    pub prepare: PrepareOptions,
    pub analysis: AnalysisOptions,
    /// Held-out block length for time series [s] (raised for long files to keep ≤ 400 blocks).
    pub block_s: f64,
    /// Worker threads (joints are analysed in parallel).
    pub threads: usize,
    /// Also fit the classical baseline ([`baseline`]) on time series.
    pub baseline: bool,
    /// Choose the filter window from the fit runs ([`prepare::choose_window`]) instead of
    /// `prepare.window_s` (time series; the CLI's default when `--window` is not given).
    pub auto_window: bool,
}

impl Default for ExplainOptions {
    fn default() -> Self {
        Self {
            urdf: PathBuf::from("urdf/jk5.urdf"),
            tip_frame: None,
            sensor_frame: "ft_sensor".into(),
            nominal: None,
            reference: None,
            prepare: PrepareOptions::default(),
            analysis: AnalysisOptions::default(),
            block_s: 2.0,
            baseline: true,
            threads: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).min(8),
            auto_window: false,
        }
    }
}

/// The analysed data and its results (input to [`report`]).
#[derive(Clone, Debug)]
pub struct Explained {
    pub path: String,
    pub kind: Kind,
    /// Raw samples (time series) or points.
    pub samples: usize,
    pub joints: Vec<JointSamples>,
    pub results: Vec<JointResult>,
    pub shapes: Vec<NominalShape>,
    pub notes: Vec<String>,
    /// Analysis rate, filter window etc. (time series).
    pub method: Vec<(String, String)>,
    pub nominal_source: String,
    /// Friction points left out as outlier segments (friction-points kind only).
    pub outliers: Vec<Outlier>,
    /// Friction points: (joint, held-out RMSE, + , −) of the extended model before outliers were left out.
    pub first_pass: Vec<(usize, f64, f64, f64)>,
    /// `--reference`: its path and law (friction points only).
    pub reference: Option<(String, naic_core::friction::FrictionModel)>,
    /// The classical identification on the same samples (time series without contact).
    pub baseline: Option<baseline::Baseline>,
    /// Names of the baseline's base columns (`link3.Izz`, …).
    pub baseline_names: Vec<String>,
    /// The all-joint `inertial_parameters` stage (time series without contact).
    pub inertial: Option<inertial::InertialFit>,
    /// The robot model file the data were analysed with.
    pub urdf: PathBuf,
    /// Wall time of each stage of the analysis [s], in order (time series; `naic explain
    /// --bench` prints them).
    pub timings: Vec<(String, f64)>,
}

/// Wall-clock laps of the analysis stages (see [`Explained::timings`]).
struct Laps {
    last: std::time::Instant,
    v: Vec<(String, f64)>,
}

impl Laps {
    fn new() -> Self {
        Self { last: std::time::Instant::now(), v: Vec::new() }
    }
    /// Ends the stage `name` (it began where the previous one ended).
    fn lap(&mut self, name: &str) {
        let now = std::time::Instant::now();
        self.v.push((name.to_string(), (now - self.last).as_secs_f64()));
        self.last = now;
    }
}

/// Nominal Stribeck shape per joint from a params file (symmetrised by averaging the directions).
pub fn nominal_shapes(params: Option<&FrictionParams>, n: usize) -> Vec<NominalShape> {
    let mut out = vec![NominalShape::default(); n];
    if let Some(p) = params {
        for jp in &p.joints {
            if jp.joint == 0 || jp.joint > n {
                continue;
            }
            let (fa, fb, qs) = match jp.friction {
                JointFriction::CoulombViscous { .. } => continue,
                JointFriction::Stribeck(s) => (s.f_a, s.f_b, s.q_s),
                JointFriction::StribeckPerDirection { positive, negative } => (
                    0.5 * (positive.f_a + negative.f_a),
                    0.5 * (positive.f_b + negative.f_b),
                    0.5 * (positive.q_s + negative.q_s),
                ),
            };
            if fa > 0.0 && qs > 0.0 {
                out[jp.joint - 1] = NominalShape { r0: fb / fa - 1.0, q_s0: qs };
            }
        }
    }
    out
}

/// The held-out fold of time `t` in prepared time-series data: blocks of `block_s`
/// seconds (longer for long files, ≤ 400 blocks), block b in fold b mod `folds`.
pub fn time_fold(p: &Prepared, block_s: f64, folds: usize) -> impl Fn(f64) -> u8 {
    let t0 = p.t.first().copied().unwrap_or(0.0);
    let t1 = p.t.last().copied().unwrap_or(1.0);
    let dur = (t1 - t0).max(1e-9);
    let block = block_s.max(dur / 400.0);
    move |t: f64| (((t - t0) / block).floor() as usize % folds) as u8
}

/// Per-joint samples from prepared time-series data.
pub fn joint_samples_from_series(p: &Prepared, block_s: f64, folds: usize) -> Vec<JointSamples> {
    let t0 = p.t.first().copied().unwrap_or(0.0);
    let t1 = p.t.last().copied().unwrap_or(1.0);
    let dur = (t1 - t0).max(1e-9);
    let fold_of = time_fold(p, block_s, folds);
    let corr = (p.window_samples as f64 / p.stride as f64).max(1.0);
    (0..p.nj())
        .map(|j| {
            let v_s = naic_core::friction::DEFAULT_V_S;
            let mut js = JointSamples { joint: j + 1, corr_len: corr, time_series: true, coulomb_width: v_s, ..Default::default() };
            for i in 0..p.len() {
                if !p.keep[i][j] {
                    continue;
                }
                js.y.push(p.tau[i][j] - p.tau_rb[i][j]);
                js.v.push(p.v[i][j]);
                // sgn(q̇) as the project's simulation friction evaluates it: tanh(q̇/v_s), 0 at rest
                js.s.push(if p.regime[i][j] == 0 { 0.0 } else { (p.v[i][j] / v_s).tanh() });
                js.q.push(p.q[i][j]);
                js.t.push(p.t[i]);
                js.tn.push((p.t[i] - t0) / dur - 0.5);
                js.a.push(p.a[i][j]);
                js.dtau.push(p.dtau[i][j]);
                js.payload.push(p.payload[i][j]);
                js.tau_rb.push(p.tau_rb[i][j]);
                js.fold.push(fold_of(p.t[i]));
                js.jerk.push(p.jerk[i][j]);
                js.dtau_rb.push(p.dtau_rb[i][j]);
                js.ddtau_rb.push(p.ddtau_rb[i][j]);
            }
            js
        })
        .collect()
}

/// Per-joint samples from friction points (interleaved velocity folds, see [`analysis`]).
/// Points slower than `v_min` (pre-sliding / stiction: the joint did not slide steadily,
/// so no friction law of eq. 4/5 applies) are left out.
pub fn joint_samples_from_points(d: &FrictionData, folds: usize, v_min: f64) -> Vec<JointSamples> {
    d.joints()
        .into_iter()
        .map(|joint| {
            let pts: Vec<_> = d.joint_samples(joint).filter(|s| s.qdot.abs() >= v_min).collect();
            let n = pts.len();
            let mut js = JointSamples { joint, corr_len: 1.0, time_series: false, ..Default::default() };
            for (r, s) in pts.iter().enumerate() {
                js.y.push(s.tau);
                js.v.push(s.qdot);
                js.s.push(if s.qdot > 0.0 { 1.0 } else if s.qdot < 0.0 { -1.0 } else { 0.0 });
                js.q.push(0.0);
                js.t.push(s.line as f64);
                js.tn.push(r as f64 / n.max(2) as f64 - 0.5);
                js.a.push(0.0);
                js.dtau.push(0.0);
                js.payload.push(0.0);
                js.fold.push(0);
            }
            js.assign_velocity_folds(folds);
            js
        })
        .collect()
}

/// Runs the analysis on every joint (in parallel), calling `progress(fraction, what)`.
pub fn analyse_all(
    joints: &[JointSamples],
    shapes: &[NominalShape],
    o: &AnalysisOptions,
    threads: usize,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Vec<JointResult> {
    let n = joints.len();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<Option<JointResult>>> = std::sync::Mutex::new(vec![None; n]);
    std::thread::scope(|sc| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            sc.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                if k >= n {
                    break;
                }
                let js = &joints[k];
                let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
                let r = analysis::analyse_joint(js, &sh, o);
                if let Ok(mut g) = results.lock() {
                    g[k] = Some(r);
                }
                let d = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                progress(d as f64 / n as f64, &format!("{} analysed", contact::target_key(js.joint)));
            });
        }
    });
    let mut results: Vec<JointResult> = results.into_inner().unwrap_or_default().into_iter().flatten().collect();
    // A payload is one mass: keep it only if it is significant on ≥ 2 joints with
    // consistent positive mass estimates (max/min < 2); otherwise re-analyse the joints
    // that selected it without the payload candidate.
    let with_payload: Vec<usize> = results
        .iter()
        .enumerate()
        .filter(|(_, r)| r.final_eval.full_structure.has(catalogue::Effect::Payload))
        .map(|(k, _)| k)
        .collect();
    if !with_payload.is_empty() {
        let masses: Vec<f64> = with_payload
            .iter()
            .filter_map(|&k| results[k].final_eval.coef(analysis::Col::Payload))
            .collect();
        let lo = masses.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = masses.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let consistent = masses.len() >= 2 && lo > 0.0 && hi / lo < 2.0;
        if !consistent {
            let mut o2 = o.clone();
            o2.effects.retain(|e| *e != catalogue::Effect::Payload);
            for k in with_payload {
                let js = &joints[k];
                let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
                let mut r = analysis::analyse_joint(js, &sh, &o2);
                // keep the payload's score as a rejected candidate for the report
                r.rejected.extend(results[k].steps.iter().filter(|c| c.effect == catalogue::Effect::Payload).map(|c| {
                    let mut c = c.clone();
                    c.significant = false;
                    c
                }));
                results[k] = r;
            }
        }
    }
    // The torque channel has one delay. A joint whose own torque shows it weakly (a wrist joint
    // carrying little torque) took part of it as a negative `rotor_inertia` (the viscous
    // friction's share of −d·τ̇ is −d·f_v·q̈) instead. When the delay is found on any joint,
    // every joint is analysed again with `delay` fixed at the median of the joints' estimates.
    let delays: Vec<f64> = results
        .iter()
        .filter(|r| r.final_eval.full_structure.has(catalogue::Effect::Delay))
        .map(|r| r.final_eval.full_structure.delay)
        .collect();
    if !delays.is_empty() && o.delay_fixed.is_none() {
        let d = median(&delays);
        let o2 = AnalysisOptions { delay_fixed: Some(d), ..o.clone() };
        let again = analyse_all(joints, shapes, &o2, threads, progress);
        for (r, a) in results.iter_mut().zip(again) {
            if !joints.iter().any(|js| js.joint == a.joint && js.contact) {
                *r = a;
            }
        }
    }
    results
}

/// The median of `x` (not empty).
fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One recording to analyse: its name (file) and data.
#[derive(Clone, Copy)]
pub struct Run<'a> {
    pub name: &'a str,
    pub ts: &'a input::TimeSeries,
}

/// Analyses a time series that is already in memory (one run, time blocks held out).
pub fn explain_series(
    name: &str,
    kind: Kind,
    ts: &input::TimeSeries,
    opts: &ExplainOptions,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Result<Explained, ExplainError> {
    explain_runs(&[Run { name, ts }], &[], kind, opts, progress)
}

/// The tool frame: `--tip` when given, else the last link of the chain (the last URDF
/// link carried by the last joint).
pub fn tip_frame(model: &Model, urdf: &Path, tip: Option<&str>) -> Result<(naic_core::model::FrameId, String), ExplainError> {
    use naic_core::model::FrameKind;
    match tip {
        Some(t) => model.frame_id(t).map(|id| (id, format!("`{t}` (--tip)"))).ok_or_else(|| {
            let links: Vec<&str> = model.frames().iter().filter(|f| f.kind == FrameKind::Link).map(|f| f.name.as_str()).collect();
            ExplainError::model(format!(
                "{} has no frame `{t}`; give --tip one of its links: {}",
                urdf.display(),
                links.join(", ")
            ))
        }),
        None => {
            let last = model.nv().checked_sub(1);
            model
                .frames()
                .iter()
                .enumerate()
                .rev()
                .find(|(_, f)| f.kind == FrameKind::Link && f.parent == last)
                .map(|(k, f)| (naic_core::model::FrameId(k), format!("`{}` (the last link; no --tip given)", f.name)))
                .ok_or_else(|| ExplainError::model(format!("{}: no link on the last joint; give --tip FRAME", urdf.display())))
        }
    }
}

/// Prepares every run: split at gaps, resampled where the clock jitters, filtered and
/// evaluated ([`prepare::prepare`]); the segments are appended in order.
fn prepare_runs<'r>(
    runs: &[Run<'r>],
    model: &Model,
    tip: naic_core::model::FrameId,
    opts: &ExplainOptions,
    urdf_joints: &str,
    laps: &mut Laps,
    progress: &mut dyn FnMut(f64, &str),
) -> Result<(Prepared, Vec<(String, resample::Sampling)>, Vec<std::borrow::Cow<'r, input::TimeSeries>>), ExplainError> {
    let mut prep = Prepared::default();
    let mut sampling = Vec::new();
    let mut segments_all = Vec::new();
    let min_len = (4.0 * opts.prepare.window_s).max(0.5);
    for (r, run) in runs.iter().enumerate() {
        if run.ts.nj() != model.nv() {
            return Err(ExplainError::input(format!(
                "{}: the data has {} joints (q1..q{}), the robot model {} has {} ({urdf_joints}); give the URDF of this robot with --urdf",
                run.name,
                run.ts.nj(),
                run.ts.nj(),
                opts.urdf.display(),
                model.nv()
            )));
        }
        let (segs, s) = resample::uniform_segments(run.name, run.ts, min_len)?;
        laps.lap("prepare: clock check, gaps, resampling (resample::uniform_segments)");
        let ns = segs.len();
        for (k, seg) in segs.iter().enumerate() {
            let f0 = (r as f64 + k as f64 / ns as f64) / runs.len() as f64;
            let p = prepare::prepare(seg, model, tip, &opts.prepare, &mut |f| {
                progress(f0 + f / (ns * runs.len()) as f64, "estimating velocity, acceleration, rigid-body torque")
            })
            .map_err(|e| ExplainError::input(format!("{}: {e}", run.name)))?;
            prep.append(p);
            laps.lap("prepare: Savitzky–Golay filter, rigid-body torque and regressors at the analysis instants");
        }
        sampling.push((run.name.to_string(), s));
        segments_all.extend(segs);
    }
    Ok((prep, sampling, segments_all))
}

/// Analyses the time series `fit` (the catalogue is selected on time blocks held out of
/// them) and, when `validate` is not empty, scores the nominal and final models, fitted
/// on all of `fit`, on those whole other runs.
pub fn explain_runs(
    fit: &[Run],
    validate: &[Run],
    kind: Kind,
    opts: &ExplainOptions,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Result<Explained, ExplainError> {
    let mut laps = Laps::new();
    let model = Model::from_urdf_file(&opts.urdf).map_err(|e| ExplainError::model(format!("{}: {e}", opts.urdf.display())))?;
    let urdf_joints = model.joint_names().collect::<Vec<_>>().join(", ");
    let (tip, tip_note) = tip_frame(&model, &opts.urdf, opts.tip_frame.as_deref())?;
    let tip_name = model.frame(tip).name.clone();
    let nj = model.nv();
    let name = fit.iter().map(|r| r.name).collect::<Vec<_>>().join(", ");
    let (params, nominal_source) = load_nominal(opts)?;
    let shapes = nominal_shapes(params.as_ref(), nj);
    let share = if validate.is_empty() { 0.3 } else { 0.2 };
    let window_choice = if opts.auto_window {
        progress(0.0, "choosing the filter window");
        let min_len = (4.0 * prepare::WINDOW_LADDER_START_S).max(0.5);
        let mut segs = Vec::new();
        for run in fit {
            segs.extend(resample::uniform_segments(run.name, run.ts, min_len)?.0);
        }
        let c = prepare::choose_window(&segs, opts.prepare.order);
        laps.lap("choosing the filter window");
        Some(c)
    } else {
        None
    };
    let chosen = window_choice
        .as_ref()
        .map(|c| ExplainOptions { prepare: PrepareOptions { window_s: c.window_s, ..opts.prepare.clone() }, ..opts.clone() });
    let opts = chosen.as_ref().unwrap_or(opts);
    let (mut prep, mut sampling, segs) =
        prepare_runs(fit, &model, tip, opts, &urdf_joints, &mut laps, &mut |f, w| progress(share * f, w))?;
    let val_prep = if validate.is_empty() {
        None
    } else {
        let (vp, vs, _) = prepare_runs(validate, &model, tip, opts, &urdf_joints, &mut laps, &mut |f, w| progress(0.2 + 0.1 * f, w))?;
        sampling.extend(vs.into_iter().map(|(n, s)| (format!("{n} (validation)"), s)));
        Some(vp)
    };
    // contact data: analyse the sensor axes first, then take the measured contact wrench
    // (sensor errors found removed) out of the joint residual
    let mut axes: Vec<JointSamples> = Vec::new();
    let mut axis_results: Vec<JointResult> = Vec::new();
    let mut contact_note = None;
    let has_wrench = fit.iter().chain(validate).any(|r| r.ts.wrench.is_some());
    if has_wrench && (fit.len() != 1 || !validate.is_empty() || segs.len() != 1) {
        return Err(ExplainError::input(format!(
            "{name}: contact data (wrench columns) is analysed from one continuous recording: give one --measured file \
             without gaps and no --validate"
        )));
    }
    if let Some(w) = segs.first().and_then(|s| s.wrench.as_ref()) {
        let sensor = model.frame_id(&opts.sensor_frame).ok_or_else(|| {
            ExplainError::model(format!(
                "{} has no frame `{}`; wrench data needs the F/T sensor frame (and the tool frame, --tip) in the URDF",
                opts.urdf.display(),
                opts.sensor_frame,
            ))
        })?;
        let (mass, com) = naic_sim::sensor::tool_from_urdf(&opts.urdf).map_err(ExplainError::model)?;
        let tool = contact::Tool { mass, com };
        progress(0.3, "contact: sensor and tip kinematics");
        let ck = contact::kinematics(&prep, &model, sensor, tip)?;
        axes = contact::axis_samples(&prep, w, &ck, &tool, &time_fold(&prep, opts.block_s, opts.analysis.folds));
        // One surface: its height is calibrated on the axis that sees the contact force
        // most; the other axes get that height and their own scale of the spring column
        // (a weak axis alone would place the surface where its noise fits best).
        if let Some(dom) = contact::dominant_axis(&axes) {
            let r = analysis::analyse_joint(&axes[dom], &NominalShape::default(), &opts.analysis);
            let h = r.final_eval.full_structure.h;
            for (a, js) in axes.iter_mut().enumerate() {
                if a != dom && js.coupled {
                    js.h_grid = vec![h];
                }
            }
        }
        axis_results = analyse_all(&axes, &[], &opts.analysis, opts.threads, &|f, w| progress(0.3 + 0.2 * f, w));
        let tau_ext = contact::external_torques(&prep, &model, sensor, &ck, &tool, &axis_results)?;
        for (rb, te) in prep.tau_rb.iter_mut().zip(tau_ext.iter()) {
            for j in 0..nj {
                rb[j] -= te[j];
            }
        }
        contact_note = Some(format!(
            "Contact data: the wrench (`ft_sensor` frame) is analysed per axis against the simulator's contact model — a \
             horizontal surface (normal +z) acting as a linear spring k·δ on `{}`, δ = h − z_tip, seen by the F/T sensor \
             with the URDF's tool ({mass:.3} kg, centre of mass {:.4}, {:.4}, {:.4} m in the sensor frame); h is \
             calibrated on the axis that sees the contact force most, the spring's scale per axis, on the training folds. The joint residual has the measured contact wrench \
             (J_ftᵀ W; the URDF tool's weight and any ft_bias found removed) taken out.",
            tip_name, com.x, com.y, com.z
        ));
    }
    if !axes.is_empty() {
        laps.lap("contact: sensor axes");
    }
    let mut joints = joint_samples_from_series(&prep, opts.block_s, opts.analysis.folds);
    laps.lap("joint samples and folds");
    for js in &joints {
        if js.len() < 50 {
            return Err(ExplainError::input(format!(
                "{name}: joint {} has only {} usable samples (moving or resting steadily); record longer or move the joint",
                js.joint,
                js.len()
            )));
        }
    }
    if let Some(vp) = &val_prep {
        let vj = joint_samples_from_series(vp, opts.block_s, opts.analysis.folds);
        for (js, mut v) in joints.iter_mut().zip(vj) {
            v.fold.iter_mut().for_each(|f| *f = analysis::VALIDATION_FOLD);
            js.append(&v);
        }
    }
    // the nominal's Coulomb law at the lowest speeds (sign or tanh of some width), per joint
    for js in joints.iter_mut() {
        let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
        analysis::calibrate_coulomb_width(js, &sh, opts.analysis.folds);
    }
    laps.lap("Coulomb smoothing width per joint");
    // the classical identification on the same samples and folds (not for contact data:
    // its measured torques carry the contact wrench); it needs nothing of the catalogue, so
    // with more than one thread it runs on its own thread beside the per-joint selection
    // (same results: each is deterministic on its own)
    let run_baseline = axes.is_empty() && opts.baseline;
    let fit_baseline = || {
        let t = std::time::Instant::now();
        let b = baseline::fit(&model, &prep, val_prep.as_ref(), &time_fold(&prep, opts.block_s, opts.analysis.folds), opts.analysis.folds);
        let names: Vec<String> = b.base_columns.iter().map(|&c| baseline::Baseline::column_name(&model, c)).collect();
        (b, names, t.elapsed().as_secs_f64())
    };
    if run_baseline {
        progress(0.3, "baseline: base-parameter least squares + viscous/Coulomb/offset friction");
    }
    let p0 = if axes.is_empty() { 0.3 } else { 0.5 };
    let catalogue = || analyse_all(&joints, &shapes, &opts.analysis, opts.threads, &|f, w| progress(p0 + (1.0 - p0) * f, w));
    let (base_fit, mut results) = if run_baseline && opts.threads > 1 {
        std::thread::scope(|sc| {
            let b = sc.spawn(fit_baseline);
            let r = catalogue();
            (Some(b.join().unwrap_or_else(|e| std::panic::resume_unwind(e))), r)
        })
    } else {
        let b = run_baseline.then(fit_baseline);
        (b, catalogue())
    };
    let baseline_s = base_fit.as_ref().map(|b| b.2);
    let (baseline, baseline_names) = match base_fit {
        Some((b, names, _)) => (Some(b), names),
        None => (None, vec![]),
    };
    if run_baseline && opts.threads > 1 {
        laps.lap("catalogue: forward selection per joint (cross-validated), with the baseline on a thread beside it");
    } else {
        laps.lap("baseline and catalogue: forward selection per joint (cross-validated)");
    }
    if let Some(s) = baseline_s {
        // not a lap: the baseline's own wall time, inside the stage above
        laps.v.push(("  of which the baseline (base parameters + viscous/Coulomb/offset friction), its own time".into(), s));
    }
    // the link inertials: one correction shared by every joint, scored on all joints together
    // after the per-joint catalogue; when significant, each joint gets its cross-fitted column
    // and the per-joint selection runs again with it as a candidate (crate::inertial)
    let inertial = if axes.is_empty() && opts.analysis.effects.contains(&catalogue::Effect::InertialParameters) {
        progress(0.95, "inertial_parameters: base parameters on all joints");
        let fit = inertial::fit(&model, &prep, val_prep.as_ref(), &joints, &results, &shapes, &opts.analysis, true);
        if fit.significant {
            for (js, c) in joints.iter_mut().zip(&fit.corrections) {
                js.inertial = c.clone();
            }
            results = analyse_all(&joints, &shapes, &opts.analysis, opts.threads, &|f, w| progress(0.95 + 0.05 * f, w));
            // the estimate beside the effects that survived the second pass
            let mut fit = fit;
            fit.delta = inertial::fit(&model, &prep, val_prep.as_ref(), &joints, &results, &shapes, &opts.analysis, false).delta;
            Some(fit)
        } else {
            Some(fit)
        }
    } else {
        None
    };
    if inertial.is_some() {
        laps.lap("inertial_parameters: all joints (and the selection again when significant)");
    }
    joints.extend(axes);
    results.extend(axis_results);
    let mut notes = Vec::new();
    notes.extend(contact_note);
    for run in fit.iter().chain(validate) {
        if !run.ts.ignored_columns.is_empty() {
            notes.push(format!("{}: columns ignored: {}.", run.name, run.ts.ignored_columns.join(", ")));
        }
    }
    let mut method = vec![
        ("robot model".into(), format!("{} ({nj} joints: {urdf_joints}); tool frame {tip_note}", opts.urdf.display())),
        ("velocity/acceleration".into(), format!(
            "Savitzky–Golay, polynomial order {}, window {} samples ({:.0} ms), derivatives of q; torque smoothed by the same filter",
            opts.prepare.order,
            prep.window_samples,
            prep.window_samples as f64 * prep.dt_raw * 1e3
        )),
        ("filter window".into(), window_choice.as_ref().map_or_else(|| format!("{:.3} s given", opts.prepare.window_s), |c| c.describe())),
        ("analysis rate".into(), format!("{:.1} Hz (every {} raw samples, raw dt {:.4} ms)", 1.0 / prep.dt(), prep.stride, prep.dt_raw * 1e3)),
    ];
    for (n, s) in &sampling {
        method.push((format!("sampling of {n}"), s.describe()));
    }
    method.push(("held-out".into(), format!("{} folds of interleaved time blocks of ≥ {} s", opts.analysis.folds, opts.block_s)));
    if !validate.is_empty() {
        method.push((
            "validation".into(),
            format!(
                "the catalogue is selected on the held-out time blocks of the fit runs ({name}); the nominal and final models, \
                 fitted on all of them, are then scored on the whole validation runs ({})",
                validate.iter().map(|r| r.name).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    method.push((
        "Coulomb law".into(),
        format!(
            "sgn(q̇) as tanh(q̇/w), w chosen per joint on the nominal's fit in 0–{:.0} mrad/s (0 = the exact sign): {}",
            analysis::COULOMB_WIDTH_MAX * 1e3,
            joints
                .iter()
                .filter(|j| !j.contact)
                .map(|j| format!("joint {} {:.2} mrad/s", j.joint, j.coulomb_width * 1e3))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    ));
    method.push((
        "samples used".into(),
        format!(
            "steady motion (|q̇| > {:.1} mrad/s) and rest (|q̇| < {:.1} mrad/s); creeping samples between the two, and samples within a \
             filter window of a change of direction or of rest/creep/motion, are left out",
            opts.prepare.v_rest * 1e3,
            opts.prepare.v_still * 1e3
        ),
    ));
    Ok(Explained {
        path: name,
        kind,
        samples: fit.iter().map(|r| r.ts.len()).sum(),
        joints,
        results,
        shapes,
        notes,
        method,
        nominal_source,
        outliers: vec![],
        first_pass: vec![],
        reference: None,
        baseline,
        baseline_names,
        inertial,
        urdf: opts.urdf.clone(),
        timings: {
            laps.lap("method notes");
            laps.v
        },
    })
}

fn load_nominal(opts: &ExplainOptions) -> Result<(Option<FrictionParams>, String), ExplainError> {
    match &opts.nominal {
        Some(p) => {
            let params = FrictionParams::from_yaml_file(p).map_err(|e| ExplainError::input(format!("--nominal: {e}")))?;
            Ok((Some(params), format!("Stribeck shape (f_b/f_a, q_s; directions averaged) from {}; levels f_a, f_v calibrated on the training folds", p.display())))
        }
        None => Ok((None, "eq. 5 symmetric with a flat shape (f_b = f_a, no --nominal given); levels f_a, f_v calibrated on the training folds".into())),
    }
}

/// Analyses steady-state friction points.
pub fn explain_points(name: &str, d: &FrictionData, opts: &ExplainOptions, progress: &(dyn Fn(f64, &str) + Sync)) -> Result<Explained, ExplainError> {
    let (params, nominal_source) = load_nominal(opts)?;
    let reference = match &opts.reference {
        Some(p) => {
            let model = FrictionParams::from_yaml_file(p)
                .and_then(|f| f.to_model())
                .map_err(|e| ExplainError::input(format!("--reference: {e}")))?;
            Some((p.display().to_string(), model))
        }
        None => None,
    };
    let nmax = d.joints().into_iter().max().unwrap_or(1);
    let shapes = nominal_shapes(params.as_ref(), nmax);
    let v_min = POINTS_V_MIN;
    let joints = joint_samples_from_points(d, opts.analysis.folds, v_min);
    let mut notes: Vec<String> = Vec::new();
    let slow: Vec<String> = d
        .samples
        .iter()
        .filter(|s| s.qdot.abs() < v_min)
        .map(|s| format!("joint {} at {:.2e} rad/s, {:.3} N·m (line {})", s.joint, s.qdot, s.tau, s.line))
        .collect();
    if !slow.is_empty() {
        notes.push(format!(
            "{} point(s) slower than {v_min} rad/s left out (pre-sliding/stiction, not steady sliding friction): {}",
            slow.len(),
            slow.join("; ")
        ));
    }
    notes.push(
        "torque_offset, delay, drift, position_ripple, payload and rotor_inertia cannot be told apart in steady-state \
         segment means (no time, position or acceleration; an offset is indistinguishable from a friction asymmetry \
         without rest segments), so only friction_asymmetry, stribeck and viscous_nonlinearity are scored."
            .into(),
    );
    for js in &joints {
        if js.len() < 2 * opts.analysis.folds {
            return Err(ExplainError::input(format!(
                "{name}: joint {} has only {} points; the held-out scheme needs at least {} (two per fold)",
                js.joint,
                js.len(),
                2 * opts.analysis.folds
            )));
        }
    }
    let mut joints = joints;
    let joints_before = joints.clone();
    let mut results = analyse_all(&joints, &shapes, &opts.analysis, opts.threads, progress);
    // Outlier segments: points whose out-of-fold residual under the joint's final model
    // exceeds OUTLIER_K robust standard deviations (1.4826·MAD). They are listed, left
    // out, and the analysis is repeated once on the rest.
    let mut outliers = Vec::new();
    let mut cleaned = false;
    for (k, js) in joints.iter_mut().enumerate() {
        let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
        let (oof, _) = analysis::residuals(js, &results[k].final_eval, &sh);
        let mut abs: Vec<f64> = oof.iter().map(|r| r.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let sigma = 1.4826 * abs[abs.len() / 2];
        let bad: Vec<usize> = (0..js.len()).filter(|&i| oof[i].abs() > OUTLIER_K * sigma && sigma > 0.0).collect();
        if bad.is_empty() {
            continue;
        }
        for &i in &bad {
            outliers.push(Outlier { joint: js.joint, line: js.t[i] as usize, velocity: js.v[i], torque: js.y[i], residual: oof[i], sigma });
        }
        let keep: Vec<bool> = (0..js.len()).map(|i| !bad.contains(&i)).collect();
        *js = js.filtered(&keep, opts.analysis.folds);
        cleaned = true;
    }
    let first_pass: Vec<(usize, f64, f64, f64)> = results
        .iter()
        .zip(&joints_before)
        .map(|(r, js)| {
            let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
            let (p, n) = report::direction_rmse(js, &r.final_eval, &sh);
            (r.joint, r.final_eval.heldout_rmse(), p, n)
        })
        .collect();
    if cleaned {
        results = analyse_all(&joints, &shapes, &opts.analysis, opts.threads, progress);
        notes.push(format!(
            "{} outlier segment(s) (out-of-fold residual > {OUTLIER_K}·1.4826·MAD of the joint) left out and the analysis repeated: {}",
            outliers.len(),
            outliers
                .iter()
                .map(|o| format!("joint {} line {} ({:+.4} rad/s, {:.3} N·m, residual {:+.3} = {:.0} σ)", o.joint, o.line, o.velocity, o.torque, o.residual, o.residual.abs() / o.sigma))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    let method = vec![
        ("outliers".into(), format!("points with out-of-fold residual > {OUTLIER_K} robust σ (1.4826·MAD) are listed in the notes, left out, and the analysis repeated once")),
        ("held-out".into(), format!(
            "{} folds of interleaved velocity blocks: per joint and direction, points sorted by speed, point r in fold r mod {}",
            opts.analysis.folds, opts.analysis.folds
        )),
        ("samples used".into(), format!("points with |velocity| ≥ {v_min} rad/s (slower ones are stiction, see notes)")),
    ];
    Ok(Explained {
        path: name.to_string(),
        kind: Kind::FrictionPoints,
        samples: d.samples.len(),
        joints,
        results,
        shapes,
        notes,
        method,
        nominal_source,
        outliers,
        first_pass,
        reference,
        baseline: None,
        baseline_names: vec![],
        inertial: None,
        urdf: opts.urdf.clone(),
        timings: vec![],
    })
}

/// Friction points slower than this [rad/s] are not sliding (0.1 mrad/s ≈ one encoder
/// count per second on a 2²⁰-count encoder): left out.
pub const POINTS_V_MIN: f64 = 1e-4;

/// Robust-σ multiple beyond which a friction point is an outlier segment.
pub const OUTLIER_K: f64 = 6.0;

/// A friction point left out as an outlier segment.
#[derive(Clone, Debug)]
pub struct Outlier {
    pub joint: usize,
    /// 1-based line in the CSV file.
    pub line: usize,
    pub velocity: f64,
    pub torque: f64,
    /// Out-of-fold residual under the first-pass model [N·m].
    pub residual: f64,
    /// Robust residual σ of the joint [N·m].
    pub sigma: f64,
}

/// Reads `path` (any kind) and analyses it.
pub fn explain(path: &Path, opts: &ExplainOptions, progress: &(dyn Fn(f64, &str) + Sync)) -> Result<Explained, ExplainError> {
    explain_files(&[path.to_path_buf()], &[], opts, progress)
}

/// Reads the fit files `measured` and the validation files `validate` and analyses them.
/// Several files must all be time series (bags or CSV); friction points are one file.
pub fn explain_files(
    measured: &[PathBuf],
    validate: &[PathBuf],
    opts: &ExplainOptions,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Result<Explained, ExplainError> {
    if measured.is_empty() {
        return Err(ExplainError::input("give at least one --measured file"));
    }
    let mut fit = Vec::new();
    let mut kind = Kind::TimeSeries;
    for (k, path) in measured.iter().chain(validate).enumerate() {
        let (kd, m) = input::load(path)?;
        let name = path.display().to_string();
        match m {
            Measured::Points(d) => {
                if measured.len() > 1 || !validate.is_empty() {
                    return Err(ExplainError::input(format!(
                        "{name}: friction points (joint,velocity_rad_s,torque_nm) are analysed one file at a time, with their \
                         own interleaved velocity folds: give it alone, without --validate"
                    )));
                }
                return explain_points(&name, &d, opts, progress);
            }
            Measured::Series(_) if opts.reference.is_some() => {
                return Err(ExplainError::input(format!(
                    "{name}: --reference evaluates a friction law on steady-state friction points (joint,velocity_rad_s,torque_nm); \
                     this file is a time series: leave --reference out"
                )))
            }
            Measured::Series(ts) => {
                if k == 0 {
                    kind = kd;
                }
                fit.push((name, ts));
            }
        }
    }
    let val = fit.split_off(measured.len());
    let runs: Vec<Run> = fit.iter().map(|(n, ts)| Run { name: n, ts }).collect();
    let vruns: Vec<Run> = val.iter().map(|(n, ts)| Run { name: n, ts }).collect();
    explain_runs(&runs, &vruns, kind, opts, progress)
}
