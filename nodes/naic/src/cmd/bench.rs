//! `naic bench …`: speed benchmarks that print JSON.
//!
//! `naic bench dynamics [--json] [--urdf PATH]`: median nanoseconds per call of
//! RNEA, CRBA, ABA and the `tip` frame Jacobian (including the forward
//! kinematics it needs), over 1000 pre-generated random states per batch and
//! the median over the batches. A 6-joint URDF runs the stack 6-DOF path
//! (`Data<U6>`), any other the dynamic-size path.
use super::{CliError, CliResult};
use naic_core::dynamics;
use naic_core::model::{Data, FrameId, Model};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, Dyn, OVector, U6};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Subcommand)]
pub enum BenchCmd {
    /// Median ns per call of the dynamics algorithms (and of one NAIC controller step, when available).
    Dynamics(DynamicsArgs),
}

#[derive(clap::Args)]
pub struct DynamicsArgs {
    /// Print one JSON line instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Robot description to benchmark.
    #[arg(long, default_value = "urdf/jk5.urdf")]
    pub urdf: PathBuf,
    /// Frame whose Jacobian is timed.
    #[arg(long, default_value = "tip")]
    pub frame: String,
    /// Number of timed batches of 1000 calls (at least 50).
    #[arg(long, default_value_t = 100)]
    pub batches: usize,
}

pub fn run(c: BenchCmd) -> CliResult {
    match c {
        BenchCmd::Dynamics(a) => run_dynamics(a),
    }
}

const STATES: usize = 1000;

/// Deterministic xorshift64* random numbers in [lo, hi) (no extra dependency).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        lo + (hi - lo) * (x as f64 / (1u64 << 53) as f64)
    }
}

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
    for k in 0..STATES * 5 {
        f(k % STATES); // warm-up
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
    let n = model.nv();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let lower = model.lower_limits();
    let upper = model.upper_limits();
    let gen = |f: &mut dyn FnMut(usize) -> f64| -> Vec<OVector<f64, D>> {
        (0..STATES).map(|_| OVector::<f64, D>::from_fn_generic(dim, nalgebra::U1, |i, _| f(i))).collect()
    };
    let qs = gen(&mut |i| {
        let lo = if lower[i].is_finite() { lower[i] } else { -std::f64::consts::PI };
        let hi = if upper[i].is_finite() { upper[i] } else { std::f64::consts::PI };
        rng.uniform(lo, hi)
    });
    let vs = gen(&mut |_| rng.uniform(-2.0, 2.0));
    let as_ = gen(&mut |_| rng.uniform(-5.0, 5.0));
    let taus = gen(&mut |_| rng.uniform(-20.0, 20.0));
    let _ = n;
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

fn run_dynamics(a: DynamicsArgs) -> CliResult {
    if a.batches < 50 {
        return Err(CliError::usage(format!("--batches {} is too few; use at least 50", a.batches)));
    }
    let model = Model::from_urdf_file(&a.urdf).map_err(|e| CliError::usage(format!("--urdf: {e}")))?;
    let frame = model.frame_id(&a.frame).ok_or_else(|| {
        let names: Vec<&str> = model.frames().iter().map(|f| f.name.as_str()).collect();
        CliError::usage(format!(
            "--frame: no frame '{}' in {}; frames are: {}",
            a.frame,
            a.urdf.display(),
            names.join(", ")
        ))
    })?;
    let (t, path) = if model.nv() == 6 {
        let data = Data::<U6>::try_new(&model).map_err(|e| CliError::failure(e.to_string()))?;
        (bench(&model, data, frame, a.batches, nalgebra::Const::<6>), "static6")
    } else {
        (bench(&model, Data::new(&model), frame, a.batches, Dyn(model.nv())), "dynamic")
    };
    // TODO(lead): time one NAIC cycle here once `naic_core::pipeline` exposes a controller step;
    // until then controller_step_ns is null.
    let controller_step_ns: Option<f64> = None;
    if a.json {
        let line = serde_json::json!({
            "rnea_ns": t.rnea,
            "crba_ns": t.crba,
            "aba_ns": t.aba,
            "frame_jacobian_ns": t.jac,
            "controller_step_ns": controller_step_ns,
            "nv": model.nv(),
            "path": path,
            "batches": a.batches,
            "calls_per_batch": STATES,
        });
        println!("{line}");
    } else {
        println!("naic bench dynamics: {} ({} joints, {path} path), median ns/call over {} batches of {STATES}", a.urdf.display(), model.nv(), a.batches);
        println!("  rnea            {:8.1}", t.rnea);
        println!("  crba            {:8.1}", t.crba);
        println!("  aba             {:8.1}", t.aba);
        println!("  frame_jacobian  {:8.1}  ({})", t.jac, a.frame);
        println!("  controller_step      n/a  (no controller step in naic_core::pipeline yet)");
    }
    Ok(())
}
