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
//! "measured" data with hidden effects, for tests and benchmarks). The stages of a run
//! (read → prepare → nominal → catalogue → inertial → report) are functions in
//! `pipeline/`; this file keeps the public entry points and calls them in order.

pub mod analysis;
pub mod baseline;
pub mod catalogue;
pub mod closed_loop;
pub mod contact;
pub mod generate;
pub mod inertial;
pub mod input;
pub mod lack_of_fit;
mod pipeline;
pub mod prepare;
pub mod report;
pub mod resample;

pub use report::plots;

use analysis::{AnalysisOptions, JointResult, JointSamples, NominalShape};
use input::{Kind, Measured};
use naic_core::friction::FrictionParams;
use naic_core::model::Model;
use naic_ident::FrictionData;
use pipeline::Laps;
use prepare::PrepareOptions;
use std::path::{Path, PathBuf};

pub use pipeline::{
    analyse_all, joint_samples_from_points, joint_samples_from_series, nominal_shapes, time_fold, tip_frame, Outlier, OUTLIER_K,
    POINTS_V_MIN,
};

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
    /// Time series: per joint, the torque noise floor after the filter [N·m]
    /// ([`prepare::Prepared::noise_floor`]); empty for friction points.
    pub noise_floor: Vec<f64>,
    /// Wall time of each stage of the analysis [s], in order (time series; `naic explain
    /// --bench` prints them).
    pub timings: Vec<(String, f64)>,
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
    // read: the robot model, its tool frame and the nominal friction shape
    let model = Model::from_urdf_file(&opts.urdf).map_err(|e| ExplainError::model(format!("{}: {e}", opts.urdf.display())))?;
    let urdf_joints = model.joint_names().collect::<Vec<_>>().join(", ");
    let (tip, tip_note) = tip_frame(&model, &opts.urdf, opts.tip_frame.as_deref())?;
    let nj = model.nv();
    let name = fit.iter().map(|r| r.name).collect::<Vec<_>>().join(", ");
    let (params, nominal_source) = pipeline::load_nominal(opts)?;
    let shapes = nominal_shapes(params.as_ref(), nj);
    // prepare: filter window, gaps, resampling, filtering, rigid-body torques
    let share = if validate.is_empty() { 0.3 } else { 0.2 };
    let window_choice = pipeline::choose_window(fit, opts, &mut laps, progress)?;
    let chosen = window_choice
        .as_ref()
        .map(|c| ExplainOptions { prepare: PrepareOptions { window_s: c.window_s, ..opts.prepare.clone() }, ..opts.clone() });
    let opts = chosen.as_ref().unwrap_or(opts);
    let (mut prep, mut sampling, segs) =
        pipeline::prepare_runs(fit, &model, tip, opts, &urdf_joints, &mut laps, &mut |f, w| progress(share * f, w))?;
    let val_prep = if validate.is_empty() {
        None
    } else {
        let (vp, vs, _) =
            pipeline::prepare_runs(validate, &model, tip, opts, &urdf_joints, &mut laps, &mut |f, w| progress(0.2 + 0.1 * f, w))?;
        sampling.extend(vs.into_iter().map(|(n, s)| (format!("{n} (validation)"), s)));
        Some(vp)
    };
    // contact data: the sensor axes first, then the contact wrench out of the joint residual
    let contact = pipeline::contact_stage(fit, validate, &name, &segs, &mut prep, &model, tip, opts, progress)?;
    if !contact.axes.is_empty() {
        laps.lap("contact: sensor axes");
    }
    // nominal: per-joint samples and folds, the Coulomb law per joint
    let mut joints = pipeline::series_joint_samples(&prep, val_prep.as_ref(), &name, opts.block_s, opts.analysis.folds, &mut laps)?;
    pipeline::calibrate_coulomb_widths(&mut joints, &shapes, opts.analysis.folds);
    laps.lap("Coulomb smoothing width per joint");
    // catalogue (and the classical baseline beside it)
    let run_baseline = contact.axes.is_empty() && opts.baseline;
    let p0 = if contact.axes.is_empty() { 0.3 } else { 0.5 };
    let (base, mut results) =
        pipeline::catalogue_and_baseline(&model, &prep, val_prep.as_ref(), &joints, &shapes, opts, run_baseline, p0, &mut laps, progress);
    // inertial: the link inertials on all joints together
    let inertial = pipeline::inertial_stage(
        &model,
        &prep,
        val_prep.as_ref(),
        &mut joints,
        &mut results,
        &shapes,
        opts,
        !contact.axes.is_empty(),
        progress,
    );
    if inertial.is_some() {
        laps.lap("inertial_parameters: all joints (and the selection again when significant)");
    }
    // report: the joints and axes together, notes and method table
    joints.extend(contact.axes);
    results.extend(contact.results);
    let notes = pipeline::series_notes(contact.note, fit, validate);
    let method = pipeline::series_method(&pipeline::SeriesMethod {
        opts,
        nj,
        urdf_joints: &urdf_joints,
        tip_note: &tip_note,
        prep: &prep,
        window_choice: window_choice.as_ref(),
        sampling: &sampling,
        name: &name,
        validate,
        joints: &joints,
    });
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
        baseline: base.baseline,
        baseline_names: base.names,
        inertial,
        urdf: opts.urdf.clone(),
        noise_floor: prep.noise_floor(),
        timings: {
            laps.lap("method notes");
            laps.v
        },
    })
}

/// Analyses steady-state friction points.
pub fn explain_points(name: &str, d: &FrictionData, opts: &ExplainOptions, progress: &(dyn Fn(f64, &str) + Sync)) -> Result<Explained, ExplainError> {
    // read: the nominal and the reference law
    let (params, nominal_source) = pipeline::load_nominal(opts)?;
    let reference = match &opts.reference {
        Some(p) => {
            let model = FrictionParams::from_yaml_file(p)
                .and_then(|f| f.to_model())
                .map_err(|e| ExplainError::input(format!("--reference: {e}")))?;
            Some((p.display().to_string(), model))
        }
        None => None,
    };
    // nominal: shapes and per-joint samples (too slow points left out)
    let nmax = d.joints().into_iter().max().unwrap_or(1);
    let shapes = nominal_shapes(params.as_ref(), nmax);
    let v_min = POINTS_V_MIN;
    let joints = joint_samples_from_points(d, opts.analysis.folds, v_min);
    let mut notes = pipeline::points_notes(d, v_min);
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
    // catalogue, outlier segments left out, and the catalogue again on the rest
    let mut joints = joints;
    let joints_before = joints.clone();
    let mut results = analyse_all(&joints, &shapes, &opts.analysis, opts.threads, progress);
    let (outliers, cleaned) = pipeline::leave_out_outliers(&mut joints, &results, &shapes, opts.analysis.folds);
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
    // report
    let method = pipeline::points_method(opts.analysis.folds, v_min);
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
        noise_floor: vec![],
        timings: vec![],
    })
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

