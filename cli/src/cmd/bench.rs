//! `naic bench …`: speed benchmarks that print JSON (`dynamics` here, `chain` in `bench_chain.rs`).
//!
//! `naic bench dynamics [--json] [--urdf PATH]`: median nanoseconds per call of
//! RNEA, CRBA, ABA and the `tip` frame Jacobian (including the forward
//! kinematics it needs), over 1000 pre-generated random states per batch and
//! the median over the batches; the same method as the Pinocchio reference
//! (`bench/reference/README.md`): q uniform in the joint range (±π where
//! unlimited), q̇ in ± the velocity limit, q̈ in ±10, τ in ± the effort limit,
//! 20 warm-up batches, 200 timed batches by default. A 6-joint URDF runs the stack 6-DOF path
//! (`Data<U6>`), any other the dynamic-size path. `controller_step_ns` is one
//! NAIC cycle of `naic_core::pipeline::controller::step` (see [`controller_step`]).
use super::{CliError, CliResult};
use naic_core::dynamics;
use naic_core::rng::Rng;
use naic_core::model::{Data, FrameId, Model};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, Dyn, OVector, U6};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Subcommand)]
pub enum BenchCmd {
    /// Median ns per call of the dynamics algorithms and of one NAIC controller step.
    Dynamics(DynamicsArgs),
    /// Simulator steps per second (closed loop, plant alone, with and without joint friction) vs MuJoCo mj_step (with and without joint frictionloss).
    Sim(super::sim::SimBenchArgs),
    /// Bag read+decode messages/s (1 kHz, 4 topics, 60 s) against Python mcap_ros2, same file.
    Bag {
        #[arg(long)]
        json: bool,
        /// Length of the generated bag [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
    },
    /// Latency of the 1 kHz DDS chain across the three node processes, Rust vs rclpy.
    Chain(super::bench_chain::ChainArgs),
    /// Record 4 topics at 1 kHz over DDS (naic replay -> naic record): drops and timing.
    Record {
        #[arg(long)]
        json: bool,
        /// Length of the replayed bag [s].
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
    },
}

#[derive(clap::Args)]
pub struct DynamicsArgs {
    /// Print one JSON line instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Robot description to benchmark.
    #[arg(long, default_value = "urdf/jk5.urdf", conflicts_with = "robot")]
    pub urdf: PathBuf,
    /// A robot file (docs/robots.md) instead of --urdf: its model (the chain to its tip frame,
    /// the tool's mass) on the compiled path of its joint count, and the controller cycle at its
    /// start_q with its tool.
    #[arg(long)]
    pub robot: Option<PathBuf>,
    /// Frame whose Jacobian is timed.
    #[arg(long, default_value = "tip")]
    pub frame: String,
    /// Number of timed batches of 1000 calls (at least 50).
    #[arg(long, default_value_t = 200)]
    pub batches: usize,
}

pub fn run(c: BenchCmd) -> CliResult {
    match c {
        BenchCmd::Dynamics(a) => run_dynamics(a),
        BenchCmd::Sim(a) => super::sim::bench(a),
        BenchCmd::Chain(a) => super::bench_chain::run(a),
        BenchCmd::Bag { json, seconds } => super::bag::bench(json, seconds),
        BenchCmd::Record { json, seconds } => super::record::bench_record(json, seconds),
    }
}

const STATES: usize = 1000;

struct Timings {
    rnea: f64,
    crba: f64,
    aba: f64,
    jac: f64,
}

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(|a, b| a.total_cmp(b));
    let n = xs.len();
    if n % 2 == 1 { xs[n / 2] } else { 0.5 * (xs[n / 2 - 1] + xs[n / 2]) }
}

/// Median over `batches` of the mean ns per call of `f` over all states.
fn time_batches(batches: usize, mut f: impl FnMut(usize)) -> f64 {
    for k in 0..STATES * 20 {
        f(k % STATES); // 20 warm-up batches
    }
    let per_batch: Vec<f64> = (0..batches)
        .map(|_| {
            let t = Instant::now();
            for k in 0..STATES {
                f(k);
            }
            t.elapsed().as_nanos() as f64 / STATES as f64
        })
        .collect();
    median(per_batch)
}

fn bench<D: Dim>(model: &Model, mut data: Data<D>, frame: FrameId, batches: usize, dim: D) -> Timings
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    let mut rng = Rng::seed(0x9E37_79B9_7F4A_7C15);
    let lower = model.lower_limits();
    let upper = model.upper_limits();
    let gen = |f: &mut dyn FnMut(usize) -> f64| -> Vec<OVector<f64, D>> {
        (0..STATES).map(|_| OVector::<f64, D>::from_fn_generic(dim, nalgebra::U1, |i, _| f(i))).collect()
    };
    let qs = gen(&mut |i| {
        let lo = if lower[i].is_finite() { lower[i] } else { -std::f64::consts::PI };
        let hi = if upper[i].is_finite() { upper[i] } else { std::f64::consts::PI };
        rng.range(lo, hi)
    });
    let (vel, eff) = (model.velocity_limits(), model.effort_limits());
    let finite_or = |x: f64, d: f64| if x.is_finite() && x > 0.0 { x } else { d };
    let vs = gen(&mut |i| {
        let l = finite_or(vel[i], std::f64::consts::PI);
        rng.range(-l, l)
    });
    let as_ = gen(&mut |_| rng.range(-10.0, 10.0));
    let taus = gen(&mut |i| {
        let l = finite_or(eff[i], 100.0);
        rng.range(-l, l)
    });
    let rnea = time_batches(batches, |k| {
        black_box(dynamics::rnea(model, &mut data, black_box(&qs[k]), &vs[k], &as_[k]));
    });
    let crba = time_batches(batches, |k| {
        black_box(dynamics::crba(model, &mut data, black_box(&qs[k])));
    });
    let aba = time_batches(batches, |k| {
        black_box(dynamics::aba(model, &mut data, black_box(&qs[k]), &vs[k], &taus[k]));
    });
    let jac = time_batches(batches, |k| {
        black_box(dynamics::frame_jacobian(model, &mut data, black_box(&qs[k]), frame));
    });
    Timings { rnea, crba, aba, jac }
}

/// Median ns of one NAIC controller cycle (`naic_core::pipeline::controller::update`, the
/// in-place form of `step` the simulator runs,
/// paper defaults, γ = 1e-6) in contact near the paper's start pose: 1000
/// pre-generated measurements (q within ±0.2 rad of (0, −30°, 120°, 0, −90°, 0),
/// q̇ within ±0.3 rad/s, the tool weight plus a 10 N push at the tip in the
/// F/T reading), after the F/T tare; the state carries over between calls.
/// With a robot file (`robot`): any joint count, near its `start_q`, with its tool.
fn controller_step<const N: usize>(model: &Model, batches: usize, robot: Option<&naic_core::robot_file::Robot>) -> Result<f64, CliError> {
    use naic_core::pipeline::control::force_law::Mode;
    use naic_core::pipeline::controller::{self, Controller, ControllerParams, Reference};
    use naic_core::pipeline::estimate;
    use naic_core::pipeline::sense::RawMeasurements;
    use naic_core::JointVec;
    use nalgebra::{Rotation3, SVector, UnitQuaternion, Vector3, Vector6};
    let mut params = ControllerParams::<N>::paper_defaults(model, Mode::Naic, 1e-6);
    if let Some(r) = robot.filter(|r| !r.is_paper_jk5()) {
        (params.tool.mass, params.tool.com) = (r.tool.mass, r.tool.com);
        if let Some(tip) = r.tip_in_sensor() {
            params.tool.tip = tip;
        }
    }
    let ctl = Controller::new(model.clone(), params)
        .map_err(|e| CliError::usage(format!("--urdf: the controller cannot run on this model: {e}")))?;
    let (tip, sensor) = match (model.frame_id("tip"), model.frame_id("ft_sensor")) {
        (Some(t), Some(s)) => (t, s),
        _ => return Err(CliError::usage("--urdf: the controller needs frames 'tip' and 'ft_sensor'")),
    };
    let mut data = naic_core::model::DataN::<N>::try_new(model).map_err(|e| CliError::failure(e.to_string()))?;
    let d = std::f64::consts::PI / 180.0;
    let jk5 = [0.0, -30.0 * d, 120.0 * d, 0.0, -90.0 * d, 0.0];
    let q0: JointVec<N> = match robot.filter(|r| !r.is_paper_jk5()) {
        Some(r) => {
            let q = r.start_q.as_ref().filter(|q| q.len() == N).ok_or_else(|| {
                CliError::usage(format!("--robot {}: the controller cycle is timed near start_q, and it has none: add start_q", r.file.display()))
            })?;
            std::array::from_fn(|i| q[i])
        }
        None => std::array::from_fn(|i| jk5.get(i).copied().unwrap_or(0.0)),
    };
    let tool = ctl.params().tool;
    let reading = |data: &mut naic_core::model::DataN<N>, q: &JointVec<N>, push: f64| -> [f64; 6] {
        dynamics::forward_kinematics(model, data, &SVector::<f64, N>::from(*q));
        let r = data.frame_se3(sensor).rot;
        let weight = estimate::tool_weight_wrench(&tool, &r);
        let f = r.transpose() * Vector3::new(0.0, 0.0, push);
        let m = tool.tip.cross(&f);
        (weight + Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)).into()
    };
    let mut rng = Rng::seed(0xD1B5_4A32_D192_ED03);
    let inputs: Vec<(JointVec<N>, JointVec<N>, [f64; 6])> = (0..STATES)
        .map(|_| {
            let q: JointVec<N> = std::array::from_fn(|i| q0[i] + rng.range(-0.2, 0.2));
            let dq: JointVec<N> = std::array::from_fn(|_| rng.range(-0.3, 0.3));
            (q, dq, reading(&mut data, &q, 10.0))
        })
        .collect();
    dynamics::forward_kinematics(model, &mut data, &SVector::<f64, N>::from(q0));
    let start = *data.frame_se3(tip);
    let reference = Reference {
        p_d: start.trans - Vector3::new(0.0, 0.0, 0.01),
        r_d: UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(start.rot)),
        v_d: Vector6::zeros(),
        a_d: Vector6::zeros(),
        f_d: 10.0,
    };
    let mut ws = ctl.workspace();
    let mut s = ctl.initial_state();
    let mut t = 0.0;
    let free = reading(&mut data, &q0, 0.0);
    for _ in 0..=ctl.params().tare_samples {
        t += 1e-3;
        let m = RawMeasurements { t, q: q0, dq: [0.0; N], joints_stamp: t, wrench: free, wrench_stamp: t };
        s = controller::step(&ctl, &s, &m, &reference, &mut ws).0;
    }
    let mut faults = 0usize;
    let mut calls = 0usize;
    let ns = time_batches(batches, |k| {
        t += 1e-3;
        let (q, dq, wrench) = inputs[k];
        let m = RawMeasurements { t, q, dq, joints_stamp: t, wrench, wrench_stamp: t };
        let out = controller::update(&ctl, &mut s, black_box(&m), &reference, &mut ws);
        faults += out.status.fault.is_some() as usize;
        calls += 1;
        black_box(&mut s);
    });
    if faults * 100 > calls {
        return Err(CliError::failure(format!(
            "controller benchmark: {faults} of {calls} cycles were rejected by the sense stage, so the timing would be of the safe hold"
        )));
    }
    Ok(ns)
}

fn run_dynamics(a: DynamicsArgs) -> CliResult {
    if a.batches < 50 {
        return Err(CliError::usage(format!("--batches {} is too few; use at least 50", a.batches)));
    }
    let robot = match &a.robot {
        Some(f) => Some(naic_core::robot_file::Robot::load(f).map_err(|e| CliError::usage(format!("--robot: {e}")))?),
        None => None,
    };
    let model = match &robot {
        Some(r) => r.model.clone(),
        None => Model::from_urdf_file(&a.urdf).map_err(|e| CliError::usage(format!("--urdf: {e}")))?,
    };
    let source = robot.as_ref().map_or_else(|| a.urdf.display().to_string(), |r| r.file.display().to_string());
    let frame = model.frame_id(&a.frame).ok_or_else(|| {
        let names: Vec<&str> = model.frames().iter().map(|f| f.name.as_str()).collect();
        CliError::usage(format!(
            "--frame: no frame '{}' in {}; frames are: {}",
            a.frame,
            source,
            names.join(", ")
        ))
    })?;
    let (t, path, controller_step_ns) = if let Some(r) = &robot {
        // A robot file: the compiled path of its joint count (the one the nodes run), and
        // the controller cycle on it.
        naic_core::with_joints!(model.nv(), N => {
            let data = naic_core::model::DataN::<N>::try_new(&model).map_err(|e| CliError::failure(e.to_string()))?;
            let t = bench(&model, data, frame, a.batches, nalgebra::Const::<N>);
            (t, "static", Some(controller_step::<N>(&model, a.batches, Some(r))?))
        })
        .map_err(|e| CliError::usage(format!("--robot: {e}")))?
    } else if model.nv() == 6 {
        let data = Data::<U6>::try_new(&model).map_err(|e| CliError::failure(e.to_string()))?;
        // One NAIC cycle of the lead's pure controller step (6-joint models only).
        (bench(&model, data, frame, a.batches, nalgebra::Const::<6>), "static6", Some(controller_step::<6>(&model, a.batches, None)?))
    } else {
        (bench(&model, Data::new(&model), frame, a.batches, Dyn(model.nv())), "dynamic", None)
    };
    if a.json {
        let line = serde_json::json!({
            "rnea_ns": t.rnea,
            "crba_ns": t.crba,
            "aba_ns": t.aba,
            "frame_jacobian_ns": t.jac,
            "controller_step_ns": controller_step_ns,
            "nv": model.nv(),
            "model": source,
            "path": path,
            "batches": a.batches,
            "calls_per_batch": STATES,
        });
        println!("{line}");
    } else {
        println!("naic bench dynamics: {source} ({} joints, {path} path), median ns/call over {} batches of {STATES}", model.nv(), a.batches);
        println!("  rnea            {:8.1}", t.rnea);
        println!("  crba            {:8.1}", t.crba);
        println!("  aba             {:8.1}", t.aba);
        println!("  frame_jacobian  {:8.1}  ({})", t.jac, a.frame);
        match controller_step_ns {
            Some(ns) => println!("  controller_step {ns:8.1}  (one NAIC cycle, naic_core::pipeline::controller::step)"),
            None => println!("  controller_step      n/a  (a 6-joint URDF or a robot file)"),
        }
    }
    Ok(())
}
