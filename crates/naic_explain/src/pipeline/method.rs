//! The report stage of a time-series run: the notes and the method table of
//! [`crate::Explained`].

use crate::analysis::{self, JointSamples};
use crate::prepare::{Prepared, WindowChoice};
use crate::{resample, ExplainOptions, Run};

/// Notes: the contact stage's, and the columns each run ignored.
pub(crate) fn series_notes(contact_note: Option<String>, fit: &[Run], validate: &[Run]) -> Vec<String> {
    let mut notes = Vec::new();
    notes.extend(contact_note);
    for run in fit.iter().chain(validate) {
        if !run.ts.ignored_columns.is_empty() {
            notes.push(format!("{}: columns ignored: {}.", run.name, run.ts.ignored_columns.join(", ")));
        }
    }
    notes
}

/// What the method table says about a time-series run.
pub(crate) struct SeriesMethod<'a> {
    pub opts: &'a ExplainOptions,
    pub nj: usize,
    pub urdf_joints: &'a str,
    pub tip_note: &'a str,
    pub prep: &'a Prepared,
    pub window_choice: Option<&'a WindowChoice>,
    pub sampling: &'a [(String, resample::Sampling)],
    pub name: &'a str,
    pub validate: &'a [Run<'a>],
    pub joints: &'a [JointSamples],
}

/// The method table (robot model, filter, rates, folds, Coulomb law, samples used).
pub(crate) fn series_method(m: &SeriesMethod) -> Vec<(String, String)> {
    let SeriesMethod { opts, nj, urdf_joints, tip_note, prep, window_choice, sampling, name, validate, joints } = *m;
    let mut method = vec![
        ("robot model".into(), format!("{} ({nj} joints: {urdf_joints}); tool frame {tip_note}", opts.urdf.display())),
        ("velocity/acceleration".into(), format!(
            "Savitzky–Golay, polynomial order {}, window {} samples ({:.0} ms), derivatives of q; torque smoothed by the same filter",
            opts.prepare.order,
            prep.window_samples,
            prep.window_samples as f64 * prep.dt_raw * 1e3
        )),
        ("filter window".into(), window_choice.map_or_else(|| format!("{:.3} s given", opts.prepare.window_s), |c| c.describe())),
        ("analysis rate".into(), format!("{:.1} Hz (every {} raw samples, raw dt {:.4} ms)", 1.0 / prep.dt(), prep.stride, prep.dt_raw * 1e3)),
    ];
    for (n, s) in sampling {
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
    method
}
