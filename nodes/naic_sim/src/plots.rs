//! Paper-style figures of a scenario (Figs 2–4): contact force vs desired,
//! tip z vs the surface under it, and the b_d adaptation, every controller
//! overlaid.

use crate::runner::RunResult;
use crate::scenario::Scenario;
use crate::svg::{Figure, Panel, Series};

/// Line colour of a controller.
pub fn color(name: &str) -> &'static str {
    match name {
        "naic" => "#d62728",
        "aic" => "#1f77b4",
        "fixed" => "#2ca02c",
        _ => "#9467bd",
    }
}

fn label(name: &str) -> String {
    name.to_ascii_uppercase()
}

/// The three-panel figure for `runs` of scenario `s`.
pub fn figure(s: &Scenario, runs: &[RunResult]) -> Figure {
    let mut force = Panel {
        title: "(a) Contact force along the force axis (robot on environment)".into(),
        y_label: "f_ext [N]".into(),
        ..Default::default()
    };
    let mut z = Panel { title: "(b) Tip height and the surface under it".into(), y_label: "z [m]".into(), ..Default::default() };
    let mut b = Panel { title: "(c) Damping b_d on the force axis (adaptation)".into(), y_label: "b_d [N·s/m]".into(), ..Default::default() };
    for r in runs {
        let pts = |f: &dyn Fn(&crate::runner::Record) -> f64| r.records.iter().map(|x| (x.t, f(x))).collect::<Vec<_>>();
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
    Figure {
        title: format!("Scenario '{}': {}", s.name, s.description),
        x_label: "time [s]".into(),
        panels: vec![force, z, b],
    }
}
