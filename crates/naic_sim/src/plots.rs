//! Paper-style figures of a scenario (Figs 2–4): contact force vs desired,
//! tip z vs the surface under it, and the b_d adaptation, every controller
//! overlaid.

use crate::runner::RunResult;
use crate::scenario::Scenario;
use naic_plot::{Figure, Panel, Series};

/// Line colour of a controller.
pub fn color(name: &str) -> &'static str {
    match name {
        "naic" => "#d62728",
        "aic" => "#1f77b4",
        "fixed" => "#2ca02c",
        "derived" => "#ff7f0e",
        "derived_oracle" => "#8c564b",
        _ => "#9467bd",
    }
}

fn label(name: &str) -> String {
    name.to_ascii_uppercase()
}

/// The three-panel figure for `runs` of scenario `s`.
pub fn figure<const N: usize>(s: &Scenario<N>, runs: &[RunResult<N>]) -> Figure {
    let mut force = Panel {
        title: "(a) Contact force along the force axis (robot on environment)".into(),
        y_label: "f_ext [N]".into(),
        ..Default::default()
    };
    let mut z = Panel { title: "(b) Tip height and the surface under it".into(), y_label: "z [m]".into(), ..Default::default() };
    let mut b = Panel { title: "(c) Damping b_d on the force axis (adaptation)".into(), y_label: "b_d [N·s/m]".into(), ..Default::default() };
    for r in runs {
        let pts = |f: &dyn Fn(&crate::runner::Record<N>) -> f64| r.records.iter().map(|x| (x.t, f(x))).collect::<Vec<_>>();
        force.series.push(Series { name: label(&r.controller), color: color(&r.controller), dashed: false, points: pts(&|x| x.f_ext) });
        z.series.push(Series { name: label(&r.controller), color: color(&r.controller), dashed: false, points: pts(&|x| x.tip[2]) });
        b.series.push(Series { name: label(&r.controller), color: color(&r.controller), dashed: false, points: pts(&|x| x.b_d) });
    }
    if let Some(r) = runs.first() {
        force.series.push(Series {
            name: "desired f_d".into(),
            color: "#000000",
            dashed: true,
            points: r.records.iter().map(|x| (x.t, x.f_d)).collect(),
        });
        z.series.push(Series {
            name: "surface".into(),
            color: "#000000",
            dashed: true,
            points: r.records.iter().map(|x| (x.t, x.surface_z)).collect(),
        });
    }
    // NAIC's three weights (eq 12) relative to their initial values
    let mut w = Panel {
        title: "(d) NAIC weights relative to their initial values (eq 12–15)".into(),
        y_label: "w / w(0)".into(),
        ..Default::default()
    };
    if let Some(r) = runs.iter().find(|r| r.controller == "naic") {
        if let Some(r0) = r.records.first() {
            let rel = |f: &dyn Fn(&crate::runner::Record<N>) -> f64, x0: f64| {
                r.records.iter().map(|x| (x.t, f(x) / x0)).collect::<Vec<_>>()
            };
            w.series.push(Series { name: "m_d / m_d(0)".into(), color: "#ff7f0e", dashed: false, points: rel(&|x| x.m_d, r0.m_d) });
            w.series.push(Series { name: "b_d / b_d(0)".into(), color: "#d62728", dashed: false, points: rel(&|x| x.b_d, r0.b_d) });
            w.series.push(Series { name: "σ / σ(0)".into(), color: "#8c564b", dashed: false, points: rel(&|x| x.sigma, r0.sigma) });
        }
    }
    let mut panels = vec![force, z, b];
    if !w.series.is_empty() {
        panels.push(w);
    }
    Figure { title: format!("Scenario '{}'", s.task.name), subtitle: s.description.clone(), x_label: "time [s]".into(), panels }
}
