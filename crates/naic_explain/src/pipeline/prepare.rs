//! The prepare stage: the tool frame, the filter window, and every run split at gaps,
//! resampled, filtered and evaluated ([`crate::prepare::prepare`]).

use super::Laps;
use crate::prepare::{self, Prepared};
use crate::{input, resample, ExplainError, ExplainOptions, Run};
use naic_core::model::Model;
use std::path::Path;

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
pub(crate) fn prepare_runs<'r>(
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
    // the lattice of exact model shifts (`delay`) only on recordings of at most
    // SHIFT_LATTICE_MAX_INSTANTS analysis instants in all (the same for every segment)
    let instants: f64 = runs
        .iter()
        .map(|r| (r.ts.t.last().copied().unwrap_or(0.0) - r.ts.t.first().copied().unwrap_or(0.0)) * opts.prepare.rate_hz)
        .sum();
    let popts = prepare::PrepareOptions { shift_lattice: opts.prepare.shift_lattice && instants <= prepare::SHIFT_LATTICE_MAX_INSTANTS, ..opts.prepare.clone() };
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
            let p = prepare::prepare(seg, model, tip, &popts, &mut |f| {
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


/// With `opts.auto_window`, the filter window chosen from the fit runs
/// ([`prepare::choose_window`]).
pub(crate) fn choose_window(
    fit: &[Run],
    opts: &ExplainOptions,
    laps: &mut Laps,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Result<Option<prepare::WindowChoice>, ExplainError> {
    if !opts.auto_window {
        return Ok(None);
    }
    progress(0.0, "choosing the filter window");
    let min_len = (4.0 * prepare::WINDOW_LADDER_START_S).max(0.5);
    let mut segs = Vec::new();
    for run in fit {
        segs.extend(resample::uniform_segments(run.name, run.ts, min_len)?.0);
    }
    let c = prepare::choose_window(&segs, opts.prepare.order);
    laps.lap("choosing the filter window");
    Ok(Some(c))
}
