//! The catalogue stage: forward selection on every joint in parallel, the payload and
//! delay consistency rules across joints, and the classical baseline beside it.

use crate::analysis::{self, AnalysisOptions, JointResult, JointSamples, NominalShape};
use crate::{catalogue, contact};

/// Runs the analysis on every joint (in parallel), calling `progress(fraction, what)`.
pub fn analyse_all(
    joints: &[JointSamples],
    shapes: &[NominalShape],
    o: &AnalysisOptions,
    threads: usize,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> Vec<JointResult> {
    // the family of the significance test: every candidate on every target of this analysis
    let with_family;
    let o = if o.comparisons == 0 {
        with_family = AnalysisOptions { comparisons: analysis::bootstrap::comparisons(joints), ..o.clone() };
        &with_family
    } else {
        o
    };
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
        // detected with the Taylor expansion about t; estimated with the exact shift of the
        // model (the lattice, `JointSamples::target` with `delay_fixed`): per joint that found
        // it, the delay of least whole-data SSR within ±5 ms of its scan's, 0.1 ms steps
        let refined: Vec<f64> = results
            .iter()
            .filter(|r| r.final_eval.full_structure.has(catalogue::Effect::Delay))
            .filter_map(|r| {
                let js = joints.iter().find(|js| js.joint == r.joint && !js.contact)?;
                let sh = shapes.get(js.joint - 1).copied().unwrap_or_default();
                let mut st = r.final_eval.full_structure.clone();
                st.delay_fixed = true;
                let d0 = st.delay;
                let mut best = (f64::INFINITY, d0);
                for k in -50..=50 {
                    st.delay = d0 + f64::from(k) * 1e-4;
                    let ssr = analysis::evaluate(js, &st, &[], &sh, o.folds).full_ssr;
                    if ssr < best.0 {
                        best = (ssr, st.delay);
                    }
                }
                Some(best.1)
            })
            .collect();
        let d = median(if refined.is_empty() { &delays } else { &refined });
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


/// The classical identification ([`crate::baseline`]) and its base columns' names.
pub(crate) struct BaselineFit {
    pub baseline: Option<crate::baseline::Baseline>,
    pub names: Vec<String>,
}

/// The catalogue on every joint and, when `run_baseline`, the classical identification on
/// the same samples and folds (not for contact data: its measured torques carry the contact
/// wrench). The baseline needs nothing of the catalogue, so with more than one thread it
/// runs on its own thread beside the per-joint selection (same results: each is
/// deterministic on its own).
#[allow(clippy::too_many_arguments)]
pub(crate) fn catalogue_and_baseline(
    model: &naic_core::model::Model,
    prep: &crate::prepare::Prepared,
    val_prep: Option<&crate::prepare::Prepared>,
    joints: &[JointSamples],
    shapes: &[NominalShape],
    opts: &crate::ExplainOptions,
    run_baseline: bool,
    p0: f64,
    laps: &mut super::Laps,
    progress: &(dyn Fn(f64, &str) + Sync),
) -> (BaselineFit, Vec<JointResult>) {
    use crate::baseline;
    let fit_baseline = || {
        let t = std::time::Instant::now();
        let b = baseline::fit(model, prep, val_prep, &super::time_fold(prep, opts.block_s, opts.analysis.folds), opts.analysis.folds);
        let names: Vec<String> = b.base_columns.iter().map(|&c| baseline::Baseline::column_name(model, c)).collect();
        (b, names, t.elapsed().as_secs_f64())
    };
    if run_baseline {
        progress(0.3, "baseline: base-parameter least squares + viscous/Coulomb/offset friction");
    }
    let catalogue = || analyse_all(joints, shapes, &opts.analysis, opts.threads, &|f, w| progress(p0 + (1.0 - p0) * f, w));
    let (base_fit, results) = if run_baseline && opts.threads > 1 {
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
    let (baseline, names) = match base_fit {
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
    (BaselineFit { baseline, names }, results)
}
