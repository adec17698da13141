//! SVG plots of the report, drawn with `naic_plot` (the project's one SVG writer):
//! residual vs velocity before/after for every joint (like the paper's Fig. 6, whose
//! dots are the measured friction and lines the identified law: here the residual of
//! the nominal and of the extended model, out-of-fold, averaged in velocity bins), and
//! for time series the residual vs time, plus residual·sgn(q̇) vs position when a
//! `position_ripple` was found. Friction points also get ± the data's noise floor per
//! direction ([`crate::lack_of_fit`]).
use crate::analysis::{residuals, JointSamples};
use crate::catalogue::Effect;
use crate::report::Finding;
use crate::Explained;
use naic_plot::{Figure, Panel, Series};
use serde_json::Value;

const NOMINAL: &str = "#1f77b4";
const EXTENDED: &str = "#d62728";
const FLOOR: &str = "#7f7f7f";

/// Mean of `y` in `bins` equal bins of `x` (empty bins skipped).
fn binned(x: &[f64], y: &[f64], bins: usize) -> Vec<(f64, f64)> {
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(hi > lo) {
        return x.iter().copied().zip(y.iter().copied()).collect();
    }
    let mut s = vec![(0.0, 0.0, 0usize); bins];
    for (&xi, &yi) in x.iter().zip(y) {
        let b = (((xi - lo) / (hi - lo)) * bins as f64).floor().clamp(0.0, (bins - 1) as f64) as usize;
        s[b].0 += xi;
        s[b].1 += yi;
        s[b].2 += 1;
    }
    s.into_iter().filter(|b| b.2 > 0).map(|(sx, sy, n)| (sx / n as f64, sy / n as f64)).collect()
}

fn sorted(x: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = x.iter().copied().zip(y.iter().copied()).collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    p
}

fn series(name: &str, color: &'static str, dashed: bool, points: Vec<(f64, f64)>) -> Series {
    Series { name: name.into(), color, dashed, points }
}

/// (nominal, extended) out-of-fold residuals of a joint.
fn oof(ex: &Explained, k: usize) -> (Vec<f64>, Vec<f64>) {
    let js = &ex.joints[k];
    let r = &ex.results[k];
    let sh = ex.shapes.get(js.joint - 1).copied().unwrap_or_default();
    (residuals(js, &r.nominal, &sh).0, residuals(js, &r.final_eval, &sh).0)
}

fn panel_vs(js: &JointSamples, x: &[f64], a: &[f64], b: &[f64], bins: Option<usize>, title: String, y_label: &str) -> Panel {
    let pts = |y: &[f64]| match bins {
        Some(n) => binned(x, y, n),
        None => sorted(x, y),
    };
    let _ = js;
    Panel {
        title,
        y_label: y_label.into(),
        series: vec![
            series("nominal (eq. 5 symmetric)", NOMINAL, false, pts(a)),
            series("extended", EXTENDED, false, pts(b)),
        ],
        ..Default::default()
    }
}

/// ± the noise floor of each direction of a joint (`report.json`'s `lack_of_fit`, friction
/// points), as dashed segments over the speeds of that direction.
fn floor_band(js: &JointSamples, lof: &Value) -> Option<Series> {
    let mut pts = Vec::new();
    for (key, sign) in [("positive", 1.0), ("negative", -1.0)] {
        let Some(f) = lof[key]["floor_rmse"].as_f64() else { continue };
        let v = js.v.iter().copied().filter(|v| v * sign > 0.0);
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        for y in [f, -f] {
            pts.extend([(lo, y), (hi, y), (f64::NAN, f64::NAN)]);
        }
    }
    (!pts.is_empty()).then(|| series("± noise floor", FLOOR, true, pts))
}

/// (file name, SVG text) of every plot; `report` is the `report.json` value.
pub fn plots(ex: &Explained, fs: &[Finding], report: &Value) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let ts = ex.joints.first().is_some_and(|j| j.time_series);
    let bins = if ts { Some(80) } else { None };
    let mut fig = Figure {
        title: format!("Held-out residual vs velocity (before / after), {}", ex.kind.name()),
        x_label: "joint velocity [rad/s]".into(),
        ..Default::default()
    };
    let mut figt = Figure { title: "Held-out residual vs time".into(), x_label: "time [s]".into(), ..Default::default() };
    let mut figc = Figure {
        title: "Held-out residual of the sensor axes vs penetration (before / after)".into(),
        x_label: "penetration h − z_tip of the extended model [mm]".into(),
        ..Default::default()
    };
    for (k, js) in ex.joints.iter().enumerate() {
        let (a, b) = oof(ex, k);
        if js.contact {
            let key = crate::contact::target_key(js.joint);
            let unit = crate::contact::target_unit(js.joint);
            let h = ex.results[k].final_eval.full_structure.h;
            if js.coupled {
                let x: Vec<f64> = js.cz.iter().map(|z| 1e3 * (h - z)).collect();
                // the contact region and 5 mm above it
                let idx: Vec<usize> = (0..js.len()).filter(|&i| x[i] > -5.0).collect();
                let xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
                let pa: Vec<f64> = idx.iter().map(|&i| a[i]).collect();
                let pb: Vec<f64> = idx.iter().map(|&i| b[i]).collect();
                figc.panels.push(panel_vs(js, &xs, &pa, &pb, Some(60), key.clone(), &format!("residual [{unit}]")));
            }
            figt.panels.push(panel_vs(js, &js.t, &a, &b, Some(120), key, &format!("residual [{unit}]")));
            continue;
        }
        let model = ex.results[k].final_eval.full_structure.effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ");
        let title = format!("joint {}: extended = nominal{}{}", js.joint, if model.is_empty() { "" } else { " + " }, model);
        let mut panel = panel_vs(js, &js.v, &a, &b, bins, title.clone(), "residual [N·m]");
        panel.series.extend(floor_band(js, &report["lack_of_fit"][crate::contact::target_key(js.joint)]));
        fig.panels.push(panel);
        if ts {
            figt.panels.push(panel_vs(js, &js.t, &a, &b, Some(120), format!("joint {}", js.joint), "residual [N·m]"));
        }
    }
    out.push(("residual_vs_velocity.svg".to_string(), fig.to_svg()));
    if ts {
        out.push(("residual_vs_time.svg".to_string(), figt.to_svg()));
    }
    if !figc.panels.is_empty() {
        out.push(("residual_vs_penetration.svg".to_string(), figc.to_svg()));
    }
    if let Some(f) = fs.iter().find(|f| f.significant && f.effect == Effect::PositionRipple) {
        let mut figq = Figure {
            title: "Held-out residual × sgn(q̇) vs position (position_ripple)".into(),
            x_label: "joint position [rad]".into(),
            ..Default::default()
        };
        for (k, js) in ex.joints.iter().enumerate().filter(|(_, j)| f.targets.contains(&j.joint)) {
            let (a, b) = oof(ex, k);
            let sa: Vec<f64> = a.iter().zip(&js.s).map(|(r, s)| r * s.signum()).collect();
            let sb: Vec<f64> = b.iter().zip(&js.s).map(|(r, s)| r * s.signum()).collect();
            let idx: Vec<usize> = (0..js.len()).filter(|&i| js.s[i] != 0.0).collect();
            let x: Vec<f64> = idx.iter().map(|&i| js.q[i]).collect();
            let pa: Vec<f64> = idx.iter().map(|&i| sa[i]).collect();
            let pb: Vec<f64> = idx.iter().map(|&i| sb[i]).collect();
            figq.panels.push(panel_vs(js, &x, &pa, &pb, Some(150), format!("joint {}", js.joint), "residual·sgn(q̇) [N·m]"));
        }
        out.push(("residual_vs_position.svg".to_string(), figq.to_svg()));
    }
    out
}
