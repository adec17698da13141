//! `naic sim`: run a paper scenario in the in-process simulator with one or
//! every controller; write `metrics.json`, one CSV of recorded signals per
//! controller and the paper-style figure; print a summary table.
//!
//! `naic sim --replay TORQUES.csv --q0 …` instead applies a joint torque
//! sequence open loop (no contact, no friction, ideal sensors) and writes the
//! joint trajectory: the cross-check against MuJoCo uses it.

use super::{CliError, CliResult};
use naic_core::friction::{FrictionModel, FrictionParams};
use naic_core::model::Model;
use naic_core::{JointVec, N_JOINTS};
use naic_core::pipeline::control::force_law::Mode;
use naic_sim::controllers::{LoopSettings, PipelineController, CONTROLLERS, MAX_DELAY_CYCLES};
use naic_sim::environment::{Environment, Material, MaterialMap};
use naic_sim::metrics::MetricsFile;
use naic_sim::plant::{self, Integrator, PlantParams};
use naic_sim::plants::{PlantChoice, DEFAULT_MJCF};
use naic_sim::rng::Rng;
use naic_core::pipeline::control::derived::DerivedParts;
use naic_sim::runner::{self, RunResult};
use naic_sim::scenario::{self, Scenario, SCENARIOS};
use naic_sim::sensor::{Encoders, Mini45};
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Default, Debug)]
pub struct SimArgs {
    /// Scenario: flat, acrylic, stiffness-step, slope, foam or two-material [default: flat].
    #[arg(long)]
    pub scenario: Option<String>,
    /// Controller: naic, aic, fixed, scheduled, derived, oracle or derived_oracle
    /// (benchmarks: the scheduled or derived law given the true k_e) or all (= naic, aic,
    /// fixed, scheduled) [default: all].
    #[arg(long)]
    pub controller: Option<String>,
    /// Output folder [default: a new folder runs/<UTC time>-<scenario>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The arm: a robot file (docs/robots.md: URDF, frames, start joints, friction, sensor,
    /// tool) [default: params/robots/jk5.yaml]. Scenarios are placed relative to its start
    /// tip pose (the JK5 keeps the paper's placements).
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Robot model, replacing the robot file's URDF (a JK5 variant) [default: the robot file's].
    #[arg(long)]
    pub urdf: Option<PathBuf>,
    /// Joint friction of the plant and of the feedforward [default: params/friction_jk5.yaml].
    #[arg(long)]
    pub friction: Option<PathBuf>,
    /// Run without joint friction (plant and feedforward).
    #[arg(long)]
    pub no_friction: bool,
    /// NAIC learning rate γ requested (clipped to the eq-15 bound every cycle) [default: 1e-4].
    #[arg(long, allow_hyphen_values = true)]
    pub gamma: Option<f64>,
    /// NAIC σ margin: fraction of the force-loop stability limit σ may reach;
    /// `inf` runs the law as written [default: 0.5].
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_margin: Option<f64>,
    /// Median window on the measured joint velocity (1 = off) [default: 5].
    #[arg(long)]
    pub median_window: Option<usize>,
    /// Override the surface stiffness k_e [N/m] of a one-material scenario
    /// (a stiffness schedule is scaled to start at K).
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub stiffness: Option<f64>,
    /// Sensor-to-torque delay of the loop in control periods (0 in process; 1–2 is
    /// the DDS chain) [default: 0].
    #[arg(long, value_name = "N")]
    pub delay_cycles: Option<usize>,
    /// Scale the controller's dynamic model (every mass and inertia) by F, e.g. 0.8 or 1.25 [default: 1].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub model_mass_error: Option<f64>,
    /// The scheduled law's (and oracle's) contact threshold [N]: it enters contact when the
    /// measured force exceeds this; the paper's laws keep 1 N [default: 0.5].
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub scheduled_contact_threshold: Option<f64>,
    /// The true tool (the plant's sensor) is F times as heavy as the URDF's `ft_sensor`
    /// link says, which the controller keeps [default: 1].
    #[arg(long, value_name = "F")]
    pub tool_mass_error: Option<f64>,
    /// The true tool's centre of mass is this far from the URDF's [m], sensor frame,
    /// 3 comma-separated numbers [default: 0,0,0].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub tool_com_offset: Option<String>,
    /// The controller's tool from a YAML with the tool section of a robot file (what
    /// `naic tool identify --out` writes) instead of the URDF's.
    #[arg(long, value_name = "FILE")]
    pub tool_file: Option<PathBuf>,
    /// Seed of the simulated noise and sensor bias [default: 1].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Run this many seeds (from --seed on) and write a median [min–max]
    /// table to OUT/summary.md (each seed in OUT/seed-<k>/).
    #[arg(long)]
    pub seeds: Option<u32>,
    /// Simulated duration [s] [default: the scenario's].
    #[arg(long, allow_hyphen_values = true)]
    pub duration: Option<f64>,
    /// Open-loop replay of a torque CSV (header tau1..tau6, one row per period).
    #[arg(long, value_name = "CSV")]
    pub replay: Option<PathBuf>,
    /// Replay: initial joints, 6 comma-separated radians.
    #[arg(long, allow_hyphen_values = true)]
    pub q0: Option<String>,
    /// Replay: initial joint velocities [default: zeros].
    #[arg(long, allow_hyphen_values = true)]
    pub dq0: Option<String>,
    /// Replay: integrator euler | rk4 | implicit-friction [default: euler].
    #[arg(long)]
    pub integrator: Option<String>,
    /// Replay: period of one torque row [s] [default: 0.001].
    #[arg(long)]
    pub dt: Option<f64>,
    /// Replay: integration steps per period [default: 1].
    #[arg(long)]
    pub substeps: Option<u32>,
    /// Regenerate the docs/controller.md "Which controller to use" table into --out: every
    /// controller × goal scenario × delay 1 and 2, mass errors, the stiffness sweep,
    /// the goals of issue 12 and the plots; medians of --seeds seeds [default: 5].
    #[arg(long)]
    pub table: bool,
    /// Run the held-out protocol of issue 42 into --out: `scheduled` and `derived`, each
    /// with its oracle (`--controller LAW`: that law alone with its oracle), on cases
    /// outside the tuned table (seeds 6–10, stiffness 300–200 000 N/m, delay 0 and 3, model
    /// mass error 0.7 / 1.4, 60 s runs, a surface receding at 5–20 mm/s), scored with the
    /// honest metrics (docs/controller.md); on --plant, or with --robot FILE on that arm
    /// (own plant, without two-material).
    #[arg(long)]
    pub held_out: bool,
    /// The plant: own (naic's simulator) or mujoco (MuJoCo on --mjcf; needs a build with
    /// `--features mujoco`, docs/simulation.md) [default: own].
    #[arg(long)]
    pub plant: Option<String>,
    /// MuJoCo model of the arm, tool and sensor for --plant mujoco
    /// [default: ../shared/reference/jk5/jk5_table.nomesh.mjcf.xml, the paper authors' JK5].
    #[arg(long, value_name = "FILE")]
    pub mjcf: Option<PathBuf>,
    /// With --plant mujoco: measure and print the static stiffness MuJoCo's contact gives
    /// on each scenario's materials, then exit.
    #[arg(long)]
    pub stiffness_report: bool,
    /// The own plant's F/T sensor reads the tool's inertial wrench, as a real sensor and
    /// MuJoCo's do (off: the tool's weight only) [default: naic_sim::sensor::INERTIAL_WRENCH].
    #[arg(long)]
    pub inertial_wrench: bool,
    /// The start-up F/T tare: `at-rest` (readings at rest only, the arm held meanwhile: the
    /// node's) or `moving` (the first samples, controlled as usual) [default: moving; see
    /// docs/simulation.md for what at-rest does on a sensor that reads the tool's inertia].
    #[arg(long, value_name = "at-rest|moving")]
    pub tare: Option<String>,
    /// Ablation study of the derived law (and derived_oracle): run it with these parts off,
    /// comma-separated: disturbance-feedforward, stiction-hold, contact-loss, reference-band,
    /// tool-inertia, velocity-observer (docs/controller.md) [default: none; every part on].
    #[arg(long, value_name = "PART[,PART]")]
    pub ablate: Option<String>,
    /// The joint encoders' velocity noise, 1 σ per joint [rad/s] (single runs)
    /// [default: 0.002, naic_sim::sensor::Encoders].
    #[arg(long, value_name = "RAD_PER_S", allow_hyphen_values = true)]
    pub velocity_noise: Option<f64>,
}

/// The derived law's parts with those `--ablate` names off.
pub fn derived_parts(ablate: Option<&str>) -> Result<DerivedParts, CliError> {
    let mut parts = DerivedParts::ALL;
    for name in ablate.unwrap_or("").split(',').map(str::trim).filter(|n| !n.is_empty()) {
        parts = parts
            .without(name)
            .ok_or_else(|| CliError::usage(format!("--ablate '{name}': use one or more of {}, comma-separated", DerivedParts::NAMES.join(", "))))?;
    }
    if ablate.is_some() && parts == DerivedParts::ALL {
        return Err(CliError::usage(format!("--ablate: give a part to turn off ({})", DerivedParts::NAMES.join(", "))));
    }
    Ok(parts)
}

/// The F/T sensor and tare of a `naic sim` run (`--inertial-wrench`, `--tare`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorOpts {
    /// The own plant's sensor reads the tool's inertial wrench (MuJoCo's always does).
    pub inertial_wrench: bool,
    /// `LoopSettings::tare_at_rest`.
    pub tare_at_rest: bool,
}

impl SensorOpts {
    pub fn from_args(inertial_wrench: bool, tare: Option<&str>) -> Result<Self, CliError> {
        let inertial_wrench = inertial_wrench || naic_sim::sensor::INERTIAL_WRENCH;
        let tare_at_rest = match tare {
            None => false,
            Some("at-rest") => true,
            Some("moving") => false,
            Some(o) => return Err(CliError::usage(format!("--tare '{o}': use at-rest or moving"))),
        };
        Ok(Self { inertial_wrench, tare_at_rest })
    }

    /// `LoopSettings::sensor_reads_tool_inertia`: the plant's sensor reads the tool's inertial force
    /// (MuJoCo's always; the own plant's with `--inertial-wrench`).
    pub fn sensor_reads_tool_inertia(&self, plant: &PlantChoice) -> bool {
        self.inertial_wrench || matches!(plant, PlantChoice::Mujoco { .. })
    }

    /// `p` with this sensor (the own plant's; MuJoCo's sensor is MuJoCo's).
    pub fn apply<const N: usize>(&self, p: &mut PlantParams<N>) {
        p.ft.inertial |= self.inertial_wrench;
    }
}

/// The plant of `--plant`/`--mjcf`.
pub fn plant_choice(plant: Option<&str>, mjcf: Option<PathBuf>) -> Result<PlantChoice, CliError> {
    PlantChoice::parse(plant.unwrap_or("own"), mjcf, default_path(DEFAULT_MJCF)).map_err(|e| CliError::usage(format!("--plant: {e}")))
}

/// The joint friction of a run, on either plant (MuJoCo computes it, `naic_sim::mujoco_plant`)
/// and in the controller's feedforward: `--friction` (default the JK5's) unless `--no-friction`.
pub fn friction_for(file: Option<&Path>, no_friction: bool) -> Result<Option<FrictionModel>, CliError> {
    if no_friction {
        Ok(None)
    } else {
        Ok(Some(load_friction(file)?))
    }
}

/// Default files, found from the current directory or the source tree.
pub(crate) fn default_path(rel: &str) -> PathBuf {
    let here = PathBuf::from(rel);
    if here.exists() {
        return here;
    }
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel);
    if src.exists() {
        src
    } else {
        here
    }
}

pub fn load_model(path: Option<&Path>) -> Result<Model, CliError> {
    let p = path.map_or_else(|| default_path("urdf/jk5.urdf"), Path::to_path_buf);
    Model::from_urdf_file(&p).map_err(|e| CliError::usage(format!("--urdf {}: {e}", p.display())))
}

/// The identified friction model, smooth (tanh) variant.
pub fn load_friction(path: Option<&Path>) -> Result<FrictionModel, CliError> {
    let p = path.map_or_else(|| default_path("params/friction_jk5.yaml"), Path::to_path_buf);
    FrictionParams::load_feedforward_model(&p)
        .map_err(|e| CliError::usage(format!("--friction {}: {e} (or run with --no-friction)", p.display())))
}

fn parse_joints(s: &str, what: &str) -> Result<JointVec, CliError> {
    parse_numbers::<N_JOINTS>(s, what, "rad")
}

/// `K` finite comma-separated numbers of flag `what` (their unit in `unit`, for the message).
fn parse_numbers<const K: usize>(s: &str, what: &str, unit: &str) -> Result<[f64; K], CliError> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| CliError::usage(format!("{what} '{s}': {e}; give {K} comma-separated numbers ({unit})")))?;
    if v.len() != K || v.iter().any(|x| !x.is_finite()) {
        return Err(CliError::usage(format!("{what} '{s}': give exactly {K} finite comma-separated numbers ({unit})")));
    }
    Ok(std::array::from_fn(|i| v[i]))
}

/// Plant of a scenario (see `naic_sim::scenario::plant_for`), its sensor with the tool's
/// inertia about its centre of mass (the inertial wrench a real sensor reads; issue 36).
pub fn scenario_plant<const N: usize>(
    s: &Scenario<N>,
    model: Model,
    friction: Option<FrictionModel>,
    tool: (f64, Vector3<f64>),
    tool_inertia: &nalgebra::Matrix3<f64>,
) -> Result<PlantParams<N>, CliError> {
    let mut p = scenario::plant_for(s, model, friction, tool).map_err(|e| CliError::usage(e.to_string()))?;
    p.ft = p.ft.with_tool_inertia(*tool_inertia);
    Ok(p)
}

/// The true tool from the URDF's and `--tool-mass-error`, `--tool-com-offset`.
fn true_tool(urdf: (f64, Vector3<f64>), mass_error: Option<f64>, com_offset: Option<&str>) -> Result<(f64, Vector3<f64>), CliError> {
    let f = mass_error.unwrap_or(1.0);
    if !(f > 0.0 && f.is_finite()) {
        return Err(CliError::usage(format!("--tool-mass-error {f}: give a factor > 0 (e.g. 1.2 for a tool 20 % heavier than the URDF's)")));
    }
    let off = match com_offset {
        None => Vector3::zeros(),
        Some(t) => Vector3::from(parse_numbers::<3>(t, "--tool-com-offset", "m, sensor frame, e.g. 0.002,0,0.01")?),
    };
    Ok((urdf.0 * f, urdf.1 + off))
}

/// The tool section of a robot file (`tool: mass: KG, com: [X, Y, Z]`).
pub fn tool_file(path: &Path) -> Result<(f64, Vector3<f64>), CliError> {
    let bad = |why: String| CliError::usage(format!("--tool-file {}: {why}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let y: serde_yaml::Value = serde_yaml::from_str(&text).map_err(|e| bad(format!("not YAML: {e}")))?;
    let t = &y["tool"];
    let mass = t["mass"].as_f64().filter(|m| *m >= 0.0 && m.is_finite()).ok_or_else(|| bad("no tool.mass (kg, >= 0)".into()))?;
    let com: Vec<f64> = t["com"].as_sequence().map(|s| s.iter().filter_map(|v| v.as_f64()).collect()).unwrap_or_default();
    if com.len() != 3 || !com.iter().all(|x| x.is_finite()) {
        return Err(bad("tool.com must be [x, y, z] in m, sensor frame".into()));
    }
    Ok((mass, Vector3::new(com[0], com[1], com[2])))
}

/// The tool's inertia about its centre of mass, from the `ft_sensor` link of the URDF; a robot
/// file whose sensor frame is a new frame (no such link) gives its tool as a point mass.
pub fn tool_inertia(urdf_path: &Path) -> Result<nalgebra::Matrix3<f64>, CliError> {
    match naic_sim::sensor::tool_inertia_from_urdf(urdf_path) {
        Err(naic_sim::sensor::ToolError::NoSensorLink { .. }) => Ok(nalgebra::Matrix3::zeros()),
        r => r.map_err(|e| CliError::usage(format!("--urdf: {e}"))),
    }
}

/// The robot file of `--robot` (default `params/robots/jk5.yaml`), loaded and checked.
pub fn load_robot(path: Option<&Path>) -> Result<naic_core::robot_file::Robot, CliError> {
    let p = path.map_or_else(|| default_path(naic_core::robot_file::DEFAULT_ROBOT_FILE), Path::to_path_buf);
    naic_core::robot_file::Robot::load(&p).map_err(|e| CliError::usage(format!("--robot: {e}")))
}

/// `--stiffness-report`: MuJoCo's static stiffness on every scenario's materials.
#[cfg(feature = "mujoco")]
fn stiffness_report(choice: &PlantChoice, model: &Model, urdf: Option<&Path>) -> CliResult {
    let PlantChoice::Mujoco { mjcf } = choice else {
        return Err(CliError::usage("--stiffness-report measures MuJoCo's contact: add --plant mujoco"));
    };
    let urdf_path = urdf.map(Path::to_path_buf).unwrap_or_else(|| default_path("urdf/jk5.urdf"));
    let tool = naic_sim::sensor::tool_from_urdf(&urdf_path).map_err(|e| CliError::usage(format!("--urdf: {e}")))?;
    let tool_i = tool_inertia(&urdf_path)?;
    println!("| scenario | naic k_e [N/m] | MuJoCo solref | force [N] | penetration [mm] | static stiffness [N/m] |");
    println!("|---|---|---|---|---|---|");
    for name in SCENARIOS {
        let s = scenario::preset(name, model).map_err(CliError::usage)?;
        let p = scenario_plant(&s, model.clone(), None, tool, &tool_i)?;
        let rows = naic_sim::mujoco_plant::static_stiffness(mjcf, &p, &s.task.q0, [5.0, 15.0])
            .map_err(|e| CliError::usage(format!("--plant: {e}")))?;
        for r in rows {
            println!(
                "| {name} | {} | {} {} | {:.2} / {:.2} | {:.3} / {:.3} | {:.0} |",
                r.k_e, r.solref[0], r.solref[1], r.forces_n[0], r.forces_n[1], r.penetration_mm[0], r.penetration_mm[1], r.k_static
            );
        }
    }
    Ok(())
}

#[cfg(not(feature = "mujoco"))]
fn stiffness_report(choice: &PlantChoice, model: &Model, urdf: Option<&Path>) -> CliResult {
    let _ = (model, urdf);
    match choice {
        PlantChoice::Own => Err(CliError::usage("--stiffness-report measures MuJoCo's contact: add --plant mujoco")),
        PlantChoice::Mujoco { .. } => Err(CliError::usage(format!("--plant: {}", naic_sim::plant::PlantError::MujocoNotBuilt))),
    }
}

fn replay(a: &SimArgs) -> CliResult {
    let csv = a.replay.as_ref().expect("checked");
    let q0 = parse_joints(a.q0.as_deref().ok_or_else(|| CliError::usage("--replay needs --q0 (6 joint angles in rad)"))?, "--q0")?;
    let dq0 = match &a.dq0 {
        Some(s) => parse_joints(s, "--dq0")?,
        None => [0.0; N_JOINTS],
    };
    let integrator = Integrator::parse(a.integrator.as_deref().unwrap_or("euler")).map_err(|e| CliError::usage(format!("--integrator: {e}")))?;
    let text = std::fs::read_to_string(csv).map_err(|e| CliError::usage(format!("--replay {}: {e}", csv.display())))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').map(str::trim).collect();
    let cols: Vec<usize> = (1..=6)
        .map(|i| header.iter().position(|h| *h == format!("tau{i}")))
        .collect::<Option<_>>()
        .ok_or_else(|| CliError::usage(format!("--replay {}: the header must name columns tau1..tau6", csv.display())))?;
    let mut torques = Vec::new();
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let mut row = [0.0; N_JOINTS];
        for (j, &c) in cols.iter().enumerate() {
            row[j] = f.get(c).and_then(|x| x.trim().parse::<f64>().ok()).filter(|x| x.is_finite()).ok_or_else(|| {
                CliError::usage(format!("--replay {} line {}: tau{} is missing or not a finite number", csv.display(), n + 2, j + 1))
            })?;
        }
        torques.push(row);
    }
    let model = load_model(a.urdf.as_deref())?;
    let dt = a.dt.unwrap_or(1e-3);
    let env = Environment { enabled: false, ..Environment::horizontal(0.0, MaterialMap::Uniform(Material { k_e: 0.0, b_e: 0.0, mu: 0.0 })) };
    let ft = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(0)).ideal();
    let mut p = PlantParams::new(model, None, integrator, dt, a.substeps.unwrap_or(1), env, ft, Encoders::ideal())
        .map_err(|e| CliError::usage(e.to_string()))?;
    p.effort_limit = [f64::INFINITY; N_JOINTS];
    let states = plant::replay(&p, q0, dq0, &torques);
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("."));
    std::fs::create_dir_all(&out).map_err(|e| CliError::failure(format!("--out {}: {e}", out.display())))?;
    let mut s = String::from("t,q1,q2,q3,q4,q5,q6,dq1,dq2,dq3,dq4,dq5,dq6\n");
    for st in &states {
        s.push_str(&format!("{:.6}", st.t));
        for v in st.q.iter().chain(&st.dq) {
            s.push_str(&format!(",{v:.17e}"));
        }
        s.push('\n');
    }
    let path = out.join("replay.csv");
    std::fs::write(&path, s).map_err(|e| CliError::failure(format!("{}: {e}", path.display())))?;
    eprintln!("wrote {} ({} periods)", path.display(), torques.len());
    Ok(())
}

/// `YYYYmmdd-HHMMSS` in UTC.
fn utc_stamp() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (y, m, d, hh, mm, ss) = super::utc_civil(secs);
    format!("{y:04}{m:02}{d:02}-{hh:02}{mm:02}{ss:02}")
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "never".to_string(), |x| format!("{x:.3}"))
}

/// A plant builder of [`run_scenario`]: the plant's parameters, start joints and seed in.
pub type BuildPlant<'a, const N: usize> =
    &'a dyn Fn(&PlantParams<N>, &JointVec<N>, u64) -> Result<Box<dyn naic_sim::plants::Plant<N> + Send>, naic_sim::plant::PlantError>;

/// Run the scenario with the given controllers on the plants `build` makes; returns the runs.
#[allow(clippy::too_many_arguments)]
pub fn run_scenario<const N: usize>(
    s: &Scenario<N>,
    build: BuildPlant<'_, N>,
    plant: &PlantParams<N>,
    model: &Model,
    friction_ff: Option<&FrictionModel>,
    tool: (f64, Vector3<f64>),
    controllers: &[&str],
    settings: &LoopSettings,
    show_progress: bool,
) -> Result<Vec<RunResult<N>>, CliError> {
    let mut runs = Vec::new();
    for &name in controllers {
        let mut c = PipelineController::by_name(name, s, model, friction_ff.cloned(), tool, settings).map_err(CliError::usage)?;
        let mut last = -1i64;
        let mut progress = |f: f64| {
            if !show_progress {
                return;
            }
            let pct = (f * 100.0) as i64;
            if pct != last {
                last = pct;
                let filled = (pct / 4) as usize;
                eprint!("\r{:<6} [{}{}] {:3}%", name, "#".repeat(filled), ".".repeat(25 - filled.min(25)), pct);
                let _ = std::io::stderr().flush();
            }
        };
        let mut p = build(plant, &s.task.q0, s.seed).map_err(|e| CliError::usage(format!("--plant: {e}")))?;
        let r = runner::run_on(s, &mut *p, &mut c, &mut progress);
        if show_progress {
            eprintln!();
        }
        runs.push(r);
    }
    Ok(runs)
}

/// The honest metrics of a scenario's runs (markdown; naic_sim::metrics::Honest).
pub fn honest_table<const N: usize>(runs: &[RunResult<N>]) -> String {
    let mut t = String::from("| controller | phase | band [N] | settle in band [s] | impact [N] | impact bound [N] | overshoot after impact [%] |\n|---|---|---|---|---|---|---|\n");
    for r in runs {
        for (k, h) in r.metrics.honest.iter().enumerate() {
            let o = |v: Option<f64>, d: usize| v.map_or_else(|| "–".to_string(), |x| format!("{x:.d$}"));
            t.push_str(&format!(
                "| {} | {} | {:.3} | {} | {} | {} | {:.1} |\n",
                r.controller,
                k + 1,
                h.band_n,
                h.settling_band_s.map_or_else(|| "never".to_string(), |x| format!("{x:.3}")),
                o(h.impact_n, 2),
                o(h.impact_bound_n, 2),
                h.overshoot_after_impact_pct
            ));
        }
    }
    t
}

/// The summary table (markdown) of a scenario's runs.
pub fn summary_table<const N: usize>(s: &Scenario<N>, runs: &[RunResult<N>]) -> String {
    let mut t = String::new();
    t.push_str("| scenario | controller | contact [s] | phase start [s] | f_d [N] | settle 2 % [s] | settle 5 % [s] | overshoot [%] | ss error [N] | RMS error [N] | max force [N] |\n");
    t.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in runs {
        let m = &r.metrics;
        if m.phases.is_empty() {
            t.push_str(&format!("| {} | {} | {} | – | – | – | – | – | – | – | – |\n", s.task.name, r.controller, fmt_opt(m.contact_time_s)));
        }
        for ph in &m.phases {
            t.push_str(&format!(
                "| {} | {} | {} | {:.3} | {:.1} | {} | {} | {:.1} | {:.3} | {:.3} | {:.2} |\n",
                s.task.name,
                r.controller,
                fmt_opt(m.contact_time_s),
                ph.t_start_s,
                ph.desired_force_n,
                fmt_opt(ph.settling_time_2pct_s),
                fmt_opt(ph.settling_time_5pct_s),
                ph.overshoot_pct,
                ph.steady_state_error_n,
                ph.rms_error_n,
                ph.max_force_n
            ));
        }
    }
    t
}

/// Write metrics.json, the recordings and the figure into `out`: per controller
/// a rosbag2 MCAP bag `<controller>.mcap` with the node suite's topics (what the
/// robot side publishes; `naic bag export-csv` turns it into CSV), and
/// `<controller>.truth.csv` with the simulator's ground truth that no ROS topic
/// carries (true contact force, surface height under the tip, …).
pub fn write_outputs<const N: usize>(out: &Path, s: &Scenario<N>, runs: &[RunResult<N>], joint_names: &[String]) -> Result<(), CliError> {
    let fail = |p: &Path, e: std::io::Error| CliError::failure(format!("cannot write {}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| fail(out, e))?;
    let n = s.task.force_axis;
    let force_axis = (0..3).max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs())).unwrap_or(2) as u8;
    let mut controllers = BTreeMap::new();
    for r in runs {
        controllers.insert(r.controller.clone(), r.metrics.clone());
        let p = out.join(format!("{}.mcap", r.controller));
        super::bag::write_sim_run(&p, &r.controller, &r.records, force_axis, joint_names)?;
        let p = out.join(format!("{}.truth.csv", r.controller));
        std::fs::write(&p, runner::to_csv(&r.records)).map_err(|e| fail(&p, e))?;
    }
    let mf = MetricsFile { scenario: s.task.name.clone(), controllers };
    let p = out.join("metrics.json");
    let json = serde_json::to_string_pretty(&mf).map_err(|e| CliError::failure(e.to_string()))?;
    std::fs::write(&p, json + "\n").map_err(|e| fail(&p, e))?;
    let p = out.join(format!("{}.svg", s.task.name));
    std::fs::write(&p, naic_sim::plots::figure(s, runs).to_svg()).map_err(|e| fail(&p, e))?;
    Ok(())
}

pub fn run(a: SimArgs) -> CliResult {
    if a.replay.is_some() {
        return replay(&a);
    }
    if a.table || a.held_out {
        let what = if a.table { "--table" } else { "--held-out" };
        let given = [
            ("--scenario", a.scenario.is_some()),
            // --held-out --controller LAW: that law with its oracle.
            ("--controller", a.controller.is_some() && !a.held_out),
            ("--stiffness", a.stiffness.is_some()),
            ("--delay-cycles", a.delay_cycles.is_some()),
            ("--model-mass-error", a.model_mass_error.is_some()),
            ("--seed", a.seed.is_some()),
            ("--duration", a.duration.is_some()),
            ("--gamma", a.gamma.is_some()),
            ("--sigma-margin", a.sigma_margin.is_some()),
            ("--median-window", a.median_window.is_some()),
            ("--scheduled-contact-threshold", a.scheduled_contact_threshold.is_some()),
            // The table is the JK5's (docs/controller.md); other arms: naic sim --robot FILE --seeds 5,
            // or --held-out --robot FILE.
            ("--robot", a.robot.is_some() && !a.held_out),
            ("--tool-mass-error", a.tool_mass_error.is_some()),
            ("--tool-com-offset", a.tool_com_offset.is_some()),
            ("--tool-file", a.tool_file.is_some()),
            ("--velocity-noise", a.velocity_noise.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, g)| *g) {
            return Err(CliError::usage(format!("{what} runs its own scenarios, controllers and delays with the default settings: drop {flag}")));
        }
        if a.table && a.held_out {
            return Err(CliError::usage("--table and --held-out are two protocols: give one"));
        }
        if a.held_out {
            if a.seeds.is_some() {
                return Err(CliError::usage("--held-out runs its own seeds (6–10): drop --seeds"));
            }
            let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("{}-held-out", utc_stamp())));
            let choice = plant_choice(a.plant.as_deref(), a.mjcf.clone())?;
            let sensor = SensorOpts::from_args(a.inertial_wrench, a.tare.as_deref())?;
            let parts = derived_parts(a.ablate.as_deref())?;
            if parts != DerivedParts::ALL && !matches!(a.controller.as_deref(), Some("derived")) {
                return Err(CliError::usage("--held-out --ablate changes the derived law only: add --controller derived"));
            }
            if a.robot.is_some() {
                let robot = load_robot(a.robot.as_deref())?;
                if !robot.is_paper_jk5() {
                    let other = [("--plant", a.plant.is_some() && !matches!(choice, PlantChoice::Own)), ("--urdf", a.urdf.is_some()), ("--friction", a.friction.is_some()), ("--no-friction", a.no_friction), ("--inertial-wrench", a.inertial_wrench), ("--tare", a.tare.is_some())];
                    if let Some((flag, _)) = other.iter().find(|(_, g)| *g) {
                        return Err(CliError::usage(format!("--held-out --robot {}: runs on the own plant with the robot file's friction, tool and sensor: drop {flag}", robot.file.display())));
                    }
                    return super::sim_heldout::run_robot(&out, &robot, a.controller.as_deref(), parts);
                }
            }
            return super::sim_heldout::run(&out, a.urdf.as_deref(), a.friction.as_deref(), a.no_friction, &choice, sensor, a.controller.as_deref(), parts);
        }
        let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("{}-table", utc_stamp())));
        let choice = plant_choice(a.plant.as_deref(), a.mjcf.clone())?;
        let sensor = SensorOpts::from_args(a.inertial_wrench, a.tare.as_deref())?;
        let parts = derived_parts(a.ablate.as_deref())?;
        return super::sim_table::run(&out, a.seeds.unwrap_or(5), a.urdf.as_deref(), a.friction.as_deref(), a.no_friction, &choice, sensor, parts);
    }
    let name = a.scenario.clone().unwrap_or_else(|| "flat".into());
    if !SCENARIOS.contains(&name.as_str()) {
        return Err(CliError::usage(format!("--scenario '{name}': use one of {}", SCENARIOS.join(", "))));
    }
    let which = a.controller.clone().unwrap_or_else(|| "all".into());
    let modes: Vec<&str> = if which == "all" {
        vec!["naic", "aic", "fixed", "scheduled"]
    } else {
        match CONTROLLERS.iter().find(|c| **c == which.trim().to_ascii_lowercase()) {
            Some(c) => vec![*c],
            None => return Err(CliError::usage(format!("--controller '{which}': use one of {} or all", CONTROLLERS.join(", ")))),
        }
    };
    let robot = load_robot(a.robot.as_deref())?;
    let choice = plant_choice(a.plant.as_deref(), a.mjcf.clone())?;
    // --urdf replaces the robot file's URDF (a JK5 variant: the paper's placements).
    let paper_jk5 = a.urdf.is_some() || robot.is_paper_jk5();
    if a.urdf.is_some() && a.robot.is_some() {
        return Err(CliError::usage("--urdf and --robot: give the URDF in the robot file (its `urdf` field), or drop --robot"));
    }
    let model = if a.urdf.is_some() { load_model(a.urdf.as_deref())? } else { robot.model.clone() };
    if a.stiffness_report {
        return stiffness_report(&choice, &model, a.urdf.as_deref());
    }
    // The robot file's friction, unless --friction / --no-friction say otherwise.
    let friction = match (&a.friction, a.no_friction, &a.urdf) {
        (None, false, None) => robot.friction.as_ref().map(|f| f.1.clone()),
        _ => friction_for(a.friction.as_deref(), a.no_friction)?,
    };
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::usage(format!("--duration {d}: must be a positive number of seconds")));
        }
    }
    // The paper's JK5: its placements (another arm's scenario is placed in run_robot).
    let mut s = if paper_jk5 { Some(scenario::preset(&name, &model).map_err(|e| CliError::usage(format!("--urdf: {e}")))?) } else { None };
    if let Some(s) = &mut s {
        if let Some(seed) = a.seed {
            s.seed = seed;
        }
        if let Some(k) = a.stiffness {
            *s = s.with_stiffness(k).map_err(|e| CliError::usage(format!("--stiffness: {e}")))?;
        }
        if let Some(d) = a.duration {
            s.task.duration = d;
        }
    }
    let sensor = SensorOpts::from_args(a.inertial_wrench, a.tare.as_deref())?;
    let derived_parts = derived_parts(a.ablate.as_deref())?;
    if derived_parts != DerivedParts::ALL && !modes.iter().all(|m| m.starts_with("derived")) {
        return Err(CliError::usage("--ablate changes the derived law only: give --controller derived or derived_oracle"));
    }
    let mut settings = LoopSettings { tare_at_rest: sensor.tare_at_rest, sensor_reads_tool_inertia: sensor.sensor_reads_tool_inertia(&choice), derived_parts, ..LoopSettings::default() };
    if let Some(g) = a.gamma {
        if !(g >= 0.0 && g.is_finite()) {
            return Err(CliError::usage(format!("--gamma {g}: must be a finite number >= 0")));
        }
        settings.gamma = g;
    }
    if let Some(m) = a.sigma_margin {
        if m.is_nan() || m <= 0.0 {
            return Err(CliError::usage(format!("--sigma-margin {m}: must be > 0 (inf for the law as written)")));
        }
        settings.sigma_margin = m;
    }
    if let Some(w) = a.median_window {
        if w == 0 || w > naic_core::pipeline::sense::MAX_MEDIAN_WINDOW {
            return Err(CliError::usage(format!(
                "--median-window {w}: must be in 1..={}",
                naic_core::pipeline::sense::MAX_MEDIAN_WINDOW
            )));
        }
        settings.median_window = w;
    }
    if let Some(d) = a.delay_cycles {
        if d > MAX_DELAY_CYCLES {
            return Err(CliError::usage(format!("--delay-cycles {d}: must be in 0..={MAX_DELAY_CYCLES}")));
        }
        settings.delay_cycles = d;
    }
    if let Some(f) = a.model_mass_error {
        if !(f > 0.0 && f.is_finite()) {
            return Err(CliError::usage(format!("--model-mass-error {f}: must be a positive factor (1 = exact model)")));
        }
        settings.model_mass_error = f;
    }
    if let Some(t) = a.scheduled_contact_threshold {
        if !(t >= settings.contact_exit_n && t < settings.force_limit_n && t.is_finite()) {
            return Err(CliError::usage(format!(
                "--scheduled-contact-threshold {t}: must be in [{}, {}) N (the exit force to the force limit)",
                settings.contact_exit_n, settings.force_limit_n
            )));
        }
        settings.scheduled_contact_enter_n = t;
    }
    let Some(s) = s else {
        let n = robot.model.nv();
        return naic_core::with_joints!(n, N => run_robot::<N>(&a, &name, &robot, &choice, friction, &modes, &settings))
            .map_err(|e| CliError::usage(format!("--robot {}: {e}", robot.file.display())))?;
    };
    let tool = match &a.urdf {
        Some(urdf_path) => naic_sim::sensor::tool_from_urdf(urdf_path).map_err(|e| CliError::usage(format!("--urdf: {e}")))?,
        None => robot.tool_tuple(),
    };
    let build = |p: &PlantParams, q0: &JointVec, seed: u64| choice.build(p, q0, seed);
    run_seeds(&a, s, &build, &model, friction, tool, &modes, &settings, &robot)
}

/// `naic sim --robot FILE` for an arm that is not the paper's JK5: the scenario placed
/// relative to the robot file's start joints, on the own plant, `N` joints.
#[allow(clippy::too_many_arguments)]
fn run_robot<const N: usize>(
    a: &SimArgs,
    name: &str,
    robot: &naic_core::robot_file::Robot,
    choice: &PlantChoice,
    friction: Option<FrictionModel>,
    modes: &[&str],
    settings: &LoopSettings,
) -> CliResult {
    let Some(q) = &robot.start_q else {
        return Err(CliError::usage(format!(
            "--robot {}: the scenarios start at the robot file's `start_q`, and it has none: add start_q (joints [rad], the tool pointing along a base axis)",
            robot.file.display()
        )));
    };
    let q0: JointVec<N> = std::array::from_fn(|i| q[i]);
    let mut s = scenario::preset_relative::<N>(name, &robot.model, q0).map_err(|e| CliError::usage(format!("--robot {}: {e}", robot.file.display())))?;
    if let Some(seed) = a.seed {
        s.seed = seed;
    }
    if let Some(k) = a.stiffness {
        s = s.with_stiffness(k).map_err(|e| CliError::usage(format!("--stiffness: {e}")))?;
    }
    if let Some(d) = a.duration {
        s.task.duration = d;
    }
    let build = |p: &PlantParams<N>, q0: &JointVec<N>, seed: u64| choice.build_n::<N>(p, q0, seed);
    run_seeds(a, s, &build, &robot.model, friction, robot.tool_tuple(), modes, settings, robot)
}

/// Run `s` for `--seeds` seeds with every controller of `modes`, write the outputs and print
/// the summary (any joint count).
#[allow(clippy::too_many_arguments)]
fn run_seeds<const N: usize>(
    a: &SimArgs,
    s: Scenario<N>,
    build: BuildPlant<'_, N>,
    model: &Model,
    friction: Option<FrictionModel>,
    tool: (f64, Vector3<f64>),
    modes: &[&str],
    settings: &LoopSettings,
    robot: &naic_core::robot_file::Robot,
) -> CliResult {
    // The plant's (true) tool: the controller's, changed by --tool-mass-error / --tool-com-offset;
    // the controller's own: the robot file's (or --urdf's), or --tool-file's (issue 39).
    let urdf_path = a.urdf.clone().unwrap_or_else(|| robot.urdf.clone());
    let tool_i = tool_inertia(&urdf_path)?;
    let true_tool = true_tool(tool, a.tool_mass_error, a.tool_com_offset.as_deref())?;
    let tool = match &a.tool_file {
        Some(f) => tool_file(f)?,
        None => tool,
    };
    if true_tool != tool || a.tool_file.is_some() {
        eprintln!(
            "naic sim: true tool {:.4} kg at {:?} m; the controller's {:.4} kg at {:?} m",
            true_tool.0,
            true_tool.1.as_slice(),
            tool.0,
            tool.1.as_slice()
        );
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("{}-{}", utc_stamp(), s.task.name)));
    let show = std::io::stderr().is_terminal();
    let n_seeds = a.seeds.unwrap_or(1);
    if n_seeds == 0 {
        return Err(CliError::usage("--seeds 0: give at least 1"));
    }
    let first_seed = s.seed;
    let mut files = Vec::new();
    let mut rms: BTreeMap<String, Vec<Option<f64>>> = BTreeMap::new();
    for k in 0..n_seeds {
        let mut s = s.clone();
        s.seed = first_seed + u64::from(k);
        let dir = if a.seeds.is_some() { out.join(format!("seed-{}", s.seed)) } else { out.clone() };
        let mut plant = scenario_plant(&s, model.clone(), friction.clone(), true_tool, &tool_i)?;
        scenario::apply_sensor_spec(&mut plant, &robot.sensor);
        if a.inertial_wrench {
            plant.ft.inertial = true;
        }
        if let Some(v) = a.velocity_noise {
            if !(v.is_finite() && v >= 0.0) {
                return Err(CliError::usage(format!("--velocity-noise {v}: must be a finite number >= 0 rad/s (the encoders' velocity noise, 1 sigma; default 0.002)")));
            }
            plant.encoders.velocity_noise_sigma = v;
        }
        eprintln!(
            "naic sim: {} plant, {}, scenario '{}' seed {} ({:.1} s, {} sub-step(s) of {:.2} ms) -> {}",
            a.plant.as_deref().unwrap_or("own"),
            robot.file.display(),
            s.task.name,
            s.seed,
            s.task.duration,
            plant.substeps,
            plant.h() * 1e3,
            dir.display()
        );
        let mut runs = run_scenario(&s, build, &plant, model, friction.as_ref(), tool, modes, settings, show)?;
        // The honest metrics (naic_sim::metrics::Honest; docs/controller.md) into metrics.json.
        for r in &mut runs {
            r.metrics.honest = runner::honest_of(&s, &r.records, &r.metrics, settings.delay_cycles, runner::force_noise_sigma());
        }
        write_outputs(&dir, &s, &runs, &robot.joints)?;
        for r in &runs {
            if r.limit_violation {
                eprintln!("naic sim: warning: {} left the joint position limits", r.controller);
            }
            rms.entry(r.controller.clone()).or_default().push(runner::contact_rms(&r.records));
        }
        if a.seeds.is_none() {
            println!("{}", summary_table(&s, &runs));
            println!("{}", honest_table(&runs));
        }
        let mut controllers = BTreeMap::new();
        for r in &runs {
            controllers.insert(r.controller.clone(), r.metrics.clone());
        }
        files.push(MetricsFile { scenario: s.task.name.clone(), controllers });
    }
    if a.seeds.is_some() {
        let mut md = format!(
            "Scenario '{}', seeds {}–{}: median [min–max]\n\n{}\nRMS of f_ext − f_d from first contact to the end:",
            s.task.name,
            first_seed,
            first_seed + u64::from(n_seeds) - 1,
            naic_sim::metrics::spread_table(&files, true)
        );
        for (name, v) in &rms {
            md.push_str(&format!(" {name} {},", naic_sim::metrics::fmt_spread(v, 3)));
        }
        md.pop();
        md.push_str(" N\n");
        let p = out.join("summary.md");
        std::fs::write(&p, &md).map_err(|e| CliError::failure(format!("cannot write {}: {e}", p.display())))?;
        println!("{md}");
    }
    println!("wrote {}", out.display());
    Ok(())
}

/// `naic bench sim`: closed-loop steps per second.
#[derive(clap::Args, Debug)]
pub struct SimBenchArgs {
    /// Print one JSON object (the default output is the same JSON, pretty).
    #[arg(long)]
    pub json: bool,
    /// Timed control periods per repeat.
    #[arg(long, default_value_t = 20_000)]
    pub steps: usize,
    /// Repeats (the median is reported).
    #[arg(long, default_value_t = 7)]
    pub repeats: usize,
    /// Skip the MuJoCo reference (bench/reference/mujoco_step_bench.py).
    #[arg(long)]
    pub no_reference: bool,
}

/// Python for the reference benchmarks: $NAIC_PYTHON, $NAIC_VENV/bin/python, python3.
pub(super) fn python() -> String {
    if let Ok(p) = std::env::var("NAIC_PYTHON") {
        return p;
    }
    if let Ok(v) = std::env::var("NAIC_VENV") {
        return format!("{v}/bin/python");
    }
    "python3".into()
}

/// Closed loop (plant + sensor + NAIC pipeline + friction feedforward, 1 ms,
/// flat scenario in contact from t = 2.5 s) and MuJoCo's `mj_step` measured in
/// the same run: on the authors' MJCF (the closed loop's reference) and on its
/// variant with joint `frictionloss`/`damping` from the same friction file
/// (`bench/reference/jk5_friction_mjcf.py`; the plant-with-friction's reference).
pub fn bench(a: SimBenchArgs) -> CliResult {
    if a.steps == 0 || a.repeats == 0 {
        return Err(CliError::usage("--steps and --repeats must be at least 1"));
    }
    let model = load_model(None)?;
    let friction = load_friction(None)?;
    let s = scenario::preset("flat", &model).map_err(CliError::failure)?;
    let urdf_path = default_path("urdf/jk5.urdf");
    let tool = naic_sim::sensor::tool_from_urdf(&urdf_path).map_err(|e| CliError::failure(e.to_string()))?;
    let tool_i = tool_inertia(&urdf_path)?;
    let plant = scenario_plant(&s, model.clone(), Some(friction.clone()), tool, &tool_i)?;
    let c = PipelineController::new(Mode::Naic, &s, &model, Some(friction), tool.0, tool.1, &LoopSettings::default())
        .map_err(CliError::failure)?;
    let t_start = 2.5;
    let max_steps = ((s.task.duration - t_start) / s.task.dt) as usize;
    let steps = a.steps.min(max_steps.max(1));
    let (rate, last) = runner::bench_closed_loop(&s, &plant, &c, t_start, steps, a.repeats);
    // the same without joint friction (as MuJoCo's model): plant Euler-like, no feedforward
    let plant_nf = scenario_plant(&s, model.clone(), None, tool, &tool_i)?;
    let c_nf = PipelineController::new(Mode::Naic, &s, &model, None, tool.0, tool.1, &LoopSettings::default())
        .map_err(CliError::failure)?;
    let (rate_nf, _) = runner::bench_closed_loop(&s, &plant_nf, &c_nf, t_start, steps, a.repeats);
    let load_start = load_average();
    let mut out = serde_json::json!({
        "steps_per_s": rate.closed_loop.round(),
        "frictionless_steps_per_s": rate_nf.closed_loop.round(),
        "frictionless_plant_only_steps_per_s": rate_nf.plant_only.round(),
        "plant_only_steps_per_s": rate.plant_only.round(),
        "controller_only_steps_per_s": rate.controller_only.round(),
        "what": "closed loop: plant (CRBA + RNEA, implicit friction, contact) + encoders + mini45 + NAIC pipeline + friction feedforward + actuation, 1 ms period, flat scenario in contact",
        "in_contact_at_end": last.truth.contact.in_contact,
        "substeps": plant.substeps,
        "timed_steps": steps,
        "repeats": a.repeats,
    });
    if !a.no_reference {
        let script = default_path("bench/reference/mujoco_step_bench.py");
        let friction_file = default_path("params/friction_jk5.yaml");
        let py = python();
        match std::process::Command::new(&py).arg(&script).arg("--friction").arg(&friction_file).output() {
            Ok(o) if o.status.success() => {
                let text = String::from_utf8_lossy(&o.stdout);
                match serde_json::from_str::<serde_json::Value>(text.lines().last().unwrap_or("")) {
                    Ok(v) => {
                        if let Some(mj) = v.get("mj_step_per_s").and_then(|x| x.as_f64()) {
                            out["mujoco_mj_step_per_s"] = serde_json::json!(mj);
                            out["ratio_vs_mj_step"] = serde_json::json!((rate.closed_loop / mj * 100.0).round() / 100.0);
                            out["plant_only_ratio_vs_mj_step"] = serde_json::json!((rate.plant_only / mj * 100.0).round() / 100.0);
                            out["frictionless_plant_only_ratio_vs_mj_step"] =
                                serde_json::json!((rate_nf.plant_only / mj * 100.0).round() / 100.0);
                        }
                        if let Some(mjf) = v.get("mj_step_friction_per_s").and_then(|x| x.as_f64()) {
                            out["mujoco_mj_step_friction_per_s"] = serde_json::json!(mjf);
                            out["plant_only_ratio_vs_mj_step_friction"] =
                                serde_json::json!((rate.plant_only / mjf * 100.0).round() / 100.0);
                        }
                        out["mujoco_reference"] = v;
                    }
                    Err(e) => eprintln!("naic bench sim: cannot parse the output of {}: {e}", script.display()),
                }
            }
            Ok(o) => eprintln!(
                "naic bench sim: {} {} failed: {}",
                py,
                script.display(),
                String::from_utf8_lossy(&o.stderr).trim()
            ),
            Err(e) => eprintln!("naic bench sim: cannot run {py} (set NAIC_PYTHON or NAIC_VENV): {e}"),
        }
    }
    out["load_average_1min"] = serde_json::json!([load_start, load_average()]);
    if a.json {
        println!("{out}");
    } else {
        println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    }
    Ok(())
}

/// The 1-minute load average (`/proc/loadavg`), to say how busy the machine was.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--ablate` turns off the parts it names and refuses a name that is not a part, or
    /// none, naming the parts there are.
    #[test]
    fn ablate_names_the_derived_laws_parts() {
        assert_eq!(derived_parts(None).unwrap(), DerivedParts::ALL);
        let p = derived_parts(Some("stiction-hold, contact-loss")).unwrap();
        assert_eq!(p.off(), vec!["stiction-hold", "contact-loss"]);
        for bad in ["gravity", "", ","] {
            let e = derived_parts(Some(bad)).unwrap_err().to_string();
            assert!(e.contains("--ablate") && e.contains("reference-band"), "{bad}: {e}");
        }
    }
}
