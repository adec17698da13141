//! `naic plot FILE.mcap --out DIR`: the force-tracking figures of any recording
//! (a bag from `naic record`, `naic sim` or `ros2 bag record`), drawn with the
//! simulator's SVG plotter.
use super::{CliError, CliResult};
use naic_bag::{Bag, RunData};
use naic_plot::{Figure, Panel, Series};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct PlotArgs {
    /// The bag.
    pub file: PathBuf,
    /// Output directory (created if missing); the figure is `<bag name>.svg`.
    #[arg(long)]
    pub out: PathBuf,
    /// Robot description for the tip height (forward kinematics of /joint_states).
    #[arg(long, default_value = "urdf/jk5.urdf")]
    pub urdf: PathBuf,
    /// Frame whose height is plotted.
    #[arg(long, default_value = "tip")]
    pub frame: String,
}

/// One colour per joint.
const JOINT_COLORS: [&str; naic_core::N_JOINTS] = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"];

pub fn run(a: PlotArgs) -> CliResult {
    let bag = Bag::open(&a.file).map_err(|e| CliError::usage(e.to_string()))?;
    for d in bag.damage() {
        eprintln!("naic plot: {}: {d}", a.file.display());
    }
    let run = RunData::load(&bag, ..);
    if run.params.is_empty() && run.joint_states.is_empty() && run.effort_cmd.is_empty() {
        return Err(CliError::usage(format!(
            "{} has none of /naic/params, /joint_states, /joint_effort_cmd to plot; it has: {}",
            a.file.display(),
            bag.topics().iter().map(|t| format!("{} ({})", t.topic, t.type_name)).collect::<Vec<_>>().join(", ")
        )));
    }
    let t0 = [
        run.params.first().map(|m| m.log_time),
        run.joint_states.first().map(|m| m.log_time),
        run.effort_cmd.first().map(|m| m.log_time),
    ]
    .into_iter()
    .flatten()
    .min()
    .unwrap_or(0);
    let t = |log: u64| (log as f64 - t0 as f64) * 1e-9;
    let mut panels = Vec::new();

    if !run.params.is_empty() {
        let p = &run.params;
        let pts = |f: &dyn Fn(&naic_msgs::NaicParams) -> f64| p.iter().map(|m| (t(m.log_time), f(&m.msg))).collect();
        panels.push(Panel {
            title: "(a) Contact force along the force axis (robot on environment)".into(),
            y_label: "force [N]".into(),
            series: vec![
                Series { name: "measured f_ext".into(), color: "#d62728", dashed: false, points: pts(&|m| m.measured_force) },
                Series { name: "desired f_d".into(), color: "#000000", dashed: true, points: pts(&|m| m.desired_force) },
            ],
            y_range: None,
        });
    }
    // Tip height by forward kinematics of the measured joint positions.
    if !run.joint_states.is_empty() {
        match naic_core::model::Model::from_urdf_file(&a.urdf) {
            Ok(model) => match model.frame_id(&a.frame) {
                Some(frame) => {
                    let mut data = naic_core::model::Data::new(&model);
                    let mut q = nalgebra::DVector::zeros(model.nv());
                    let mut pts = Vec::with_capacity(run.joint_states.len());
                    let mut skipped = 0usize;
                    for m in &run.joint_states {
                        if m.msg.position.len() != model.nv() || m.msg.position.iter().any(|x| !x.is_finite()) {
                            skipped += 1;
                            continue;
                        }
                        q.copy_from_slice(&m.msg.position);
                        naic_core::dynamics::forward_kinematics(&model, &mut data, &q);
                        pts.push((t(m.log_time), data.frame_placement(frame).translation.vector.z));
                    }
                    if skipped > 0 {
                        eprintln!(
                            "naic plot: {skipped} /joint_states message(s) without {} finite positions left out of the tip height",
                            model.nv()
                        );
                    }
                    panels.push(Panel {
                        title: format!("(b) Height of frame '{}' (forward kinematics of /joint_states)", a.frame),
                        y_label: "z [m]".into(),
                        series: vec![Series { name: format!("{} z", a.frame), color: "#1f77b4", dashed: false, points: pts }],
                        y_range: None,
                    });
                }
                None => eprintln!("naic plot: {} has no frame '{}'; tip height not plotted (use --frame)", a.urdf.display(), a.frame),
            },
            Err(e) => eprintln!("naic plot: tip height not plotted: {e} (use --urdf)"),
        }
    }
    if !run.params.is_empty() {
        let p = &run.params;
        let pts = |f: &dyn Fn(&naic_msgs::NaicParams) -> f64| p.iter().map(|m| (t(m.log_time), f(&m.msg))).collect();
        panels.push(Panel {
            title: "(c) Damping b_d on the force axis (adaptation)".into(),
            y_label: "b_d [N·s/m]".into(),
            series: vec![Series { name: "b_d".into(), color: "#d62728", dashed: false, points: pts(&|m| m.b_d) }],
            y_range: None,
        });
        let m0 = &p[0].msg;
        let rel = |v: f64, v0: f64| if v0 != 0.0 { v / v0 } else { f64::NAN };
        panels.push(Panel {
            title: "(d) NAIC weights relative to their first recorded values (eq 12–15)".into(),
            y_label: "w / w(0)".into(),
            series: vec![
                Series { name: "m_d / m_d(0)".into(), color: "#ff7f0e", dashed: false, points: pts(&|m| rel(m.m_d, m0.m_d)) },
                Series { name: "b_d / b_d(0)".into(), color: "#d62728", dashed: false, points: pts(&|m| rel(m.b_d, m0.b_d)) },
                Series { name: "σ / σ(0)".into(), color: "#8c564b", dashed: false, points: pts(&|m| rel(m.sigma, m0.sigma)) },
            ],
            y_range: None,
        });
        panels.push(Panel {
            title: "(e) Learning rate γ applied and its eq-15 bound".into(),
            y_label: "γ".into(),
            series: vec![
                Series { name: "γ".into(), color: "#2ca02c", dashed: false, points: pts(&|m| m.gamma) },
                Series {
                    name: "bound 2Σf²/Σf⁴".into(),
                    color: "#000000",
                    dashed: true,
                    points: p.iter().filter(|m| m.msg.gamma_bound.is_finite()).map(|m| (t(m.log_time), m.msg.gamma_bound)).collect(),
                },
            ],
            y_range: None,
        });
    }
    if !run.effort_cmd.is_empty() {
        let series = (0..6)
            .map(|j| Series {
                name: format!("τ{}", j + 1),
                color: JOINT_COLORS[j],
                dashed: false,
                points: run.effort_cmd.iter().filter_map(|m| m.msg.data.get(j).map(|v| (t(m.log_time), *v))).collect(),
            })
            .filter(|s: &Series| !s.points.is_empty())
            .collect();
        panels.push(Panel {
            title: "(f) Joint torque commands (/joint_effort_cmd)".into(),
            y_label: "τ [N·m]".into(),
            series,
            y_range: None,
        });
    }
    let (start, end) = bag.time_bounds().unwrap_or((0, 0));
    let modes: std::collections::BTreeSet<&str> = run.params.iter().map(|m| m.msg.mode.as_str()).collect();
    let fig = Figure {
        title: format!("Recording {}", a.file.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()),
        subtitle: format!(
            "{} messages over {:.3} s; controller mode: {}",
            bag.message_count(),
            end.saturating_sub(start) as f64 * 1e-9,
            if modes.is_empty() { "not recorded".to_string() } else { modes.into_iter().collect::<Vec<_>>().join(", ") }
        ),
        x_label: "time since the first message [s]".into(),
        panels,
    };
    std::fs::create_dir_all(&a.out)
        .map_err(|e| CliError::usage(format!("could not create output directory {}: {e}", a.out.display())))?;
    let stem = a.file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "bag".into());
    let path = a.out.join(format!("{stem}.svg"));
    std::fs::write(&path, fig.to_svg()).map_err(|e| CliError::failure(format!("could not write {}: {e}", path.display())))?;
    println!("{}", path.display());
    Ok(())
}
