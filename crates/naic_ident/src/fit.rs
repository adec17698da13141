//! Identification of equation 4/5 parameters from steady-state data.
//!
//! Each branch (all data for the symmetric forms; the q̇ > 0 and q̇ < 0 halves separately
//! for the per-direction form, as in Table 1) is fitted by bounded nonlinear least squares
//! ([`crate::lm::lm_box`]) on the residuals `τ̂(q̇_i; θ) − τ_i`, with
//! `τ̂ = sgn(q̇)·g(q̇) + f_v·q̇` and the physical bounds
//! `f_a, f_b, f_c, f_v ≥ 0`, `q_s ∈ [q_s_min, q_s_max]` (default [1e-4, 2] rad/s).
//!
//! * q_s is badly conditioned (the cost is flat in q_s wherever f_a ≈ f_b, and nearly flat
//!   once q_s is below the slowest or above the fastest speed), so the Stribeck fit runs
//!   from `n_starts` values of q_s spread log-uniformly over the bounds; for each, f_a, f_b
//!   and f_v start at the linear least-squares solution for that fixed q_s (the model is
//!   linear in them), clipped to ≥ 0. The best end point wins; the report says how many
//!   starts reached the same cost (within 1e-6 relative).
//! * Active bounds: a parameter that ends on a bound stays there (it is the constrained
//!   optimum, e.g. f_v = 0 when the data would prefer negative viscous friction); it is
//!   reported "at bound" with no interval, and the intervals of the others are computed
//!   with it held fixed (degrees of freedom n − p_free).
//! * 95 % intervals: θ̂_i ± t_{0.975, n−p}·σ·√[(J_FᵀJ_F)⁻¹]_ii with σ² = SSR/(n − p), J_F the
//!   Jacobian columns of the free parameters at the optimum (linearisation; intervals may
//!   reach past a bound). A parameter in the numerical null space of J_F (e.g. q_s when
//!   f_a = f_b) is reported "unidentifiable".
//! * RMSE per branch is √(SSR/n); `rmse_dfe` = σ = √(SSR/(n − p)) is MATLAB `fit`'s
//!   `gof.rmse`, the statistic printed in the paper's Table 1.

use crate::data::FrictionData;
use crate::lm::{lm_box, LeastSquares, LmOptions};
use crate::stats::student_t_quantile;
use naic_core::friction::{BranchStats, FrictionError, FrictionParams, JointFriction, JointParams, JointStats, StribeckParams};
use nalgebra::{DMatrix, DVector};
use std::time::{Duration, Instant};

/// Which model to fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitForm {
    /// Equation 4, one (f_c, f_v) per joint.
    CoulombViscous,
    /// Equation 5, one (f_a, f_b, q_s, f_v) per joint.
    Symmetric,
    /// Equation 5 per direction (Table 1), two parameter sets per joint.
    PerDirection,
}

impl FitForm {
    /// The CLI spelling.
    pub fn name(self) -> &'static str {
        match self {
            Self::CoulombViscous => "coulomb-viscous",
            Self::Symmetric => "symmetric",
            Self::PerDirection => "per-direction",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "coulomb-viscous" => Some(Self::CoulombViscous),
            "symmetric" => Some(Self::Symmetric),
            "per-direction" => Some(Self::PerDirection),
            _ => None,
        }
    }

    fn param_names(self) -> &'static [&'static str] {
        match self {
            Self::CoulombViscous => &["f_c", "f_v"],
            _ => &["f_a", "f_b", "q_s", "f_v"],
        }
    }
}

/// Fit settings.
#[derive(Clone, Debug)]
pub struct FitOptions {
    pub form: FitForm,
    /// Joints to fit (1-based); `None` = every joint in the data.
    pub joints: Option<Vec<usize>>,
    /// Bounds on q_s, rad/s.
    pub q_s_min: f64,
    pub q_s_max: f64,
    /// Number of q_s starting points (Stribeck forms).
    pub n_starts: usize,
    /// Confidence level of the intervals.
    pub confidence: f64,
    /// Samples with |q̇| below this (rad/s) are left out; samples with q̇ = 0 always are
    /// (they belong to neither direction and eq. 5 gives 0 there).
    pub min_speed: f64,
    pub lm: LmOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            form: FitForm::PerDirection,
            joints: None,
            q_s_min: 1e-4,
            q_s_max: 2.0,
            n_starts: 12,
            confidence: 0.95,
            min_speed: 0.0,
            lm: LmOptions::default(),
        }
    }
}

/// A confidence interval, or why there is none: defined with the parameter file that
/// stores it (`naic_core::friction::params`), re-exported here for the fit's API.
pub use naic_core::friction::Ci95;

/// One fitted parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamEstimate {
    pub name: &'static str,
    pub value: f64,
    pub ci95: Ci95,
}

/// Which samples a branch covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Both,
    Positive,
    Negative,
}

impl Direction {
    pub fn label(self) -> &'static str {
        match self {
            Self::Both => "±",
            Self::Positive => "+",
            Self::Negative => "−",
        }
    }
}

/// The fit of one branch (one parameter set).
#[derive(Clone, Debug)]
pub struct BranchFit {
    pub direction: Direction,
    pub params: Vec<ParamEstimate>,
    pub n_points: usize,
    /// √(SSR/n), N·m.
    pub rmse: f64,
    /// √(SSR/(n − p_free)), N·m (MATLAB's gof.rmse; Table 1's RMSE).
    pub rmse_dfe: f64,
    /// Starting points tried and how many reached the best cost.
    pub n_starts: usize,
    pub starts_agreeing: usize,
    pub iterations: usize,
    pub converged: bool,
}

impl BranchFit {
    pub fn param(&self, name: &str) -> Option<&ParamEstimate> {
        self.params.iter().find(|p| p.name == name)
    }
}

/// The fit of one joint.
#[derive(Clone, Debug)]
pub struct JointFit {
    /// 1-based joint number.
    pub joint: usize,
    pub friction: JointFriction,
    /// One branch (symmetric forms) or two (+ then −).
    pub branches: Vec<BranchFit>,
    /// RMSE √(SSR/n) of the fitted law on the q̇ > 0 and q̇ < 0 samples (None if there are none).
    pub rmse_positive: Option<f64>,
    pub rmse_negative: Option<f64>,
    pub n_positive: usize,
    pub n_negative: usize,
    /// Samples left out for |q̇| = 0 or below `min_speed`.
    pub n_dropped: usize,
}

/// The result of [`fit`].
#[derive(Clone, Debug)]
pub struct FitReport {
    pub form: FitForm,
    pub data_name: String,
    pub options: FitOptions,
    pub joints: Vec<JointFit>,
    pub elapsed: Duration,
}

/// The model of one branch, as a least-squares problem.
struct Branch<'a> {
    qdot: &'a [f64],
    tau: &'a [f64],
    form: FitForm,
}

impl LeastSquares for Branch<'_> {
    fn n_params(&self) -> usize {
        self.form.param_names().len()
    }
    fn n_residuals(&self) -> usize {
        self.qdot.len()
    }
    fn eval(&self, th: &[f64], r: &mut DVector<f64>, mut jac: Option<&mut DMatrix<f64>>) {
        for (i, (&v, &t)) in self.qdot.iter().zip(self.tau).enumerate() {
            let s = v.signum();
            match self.form {
                FitForm::CoulombViscous => {
                    r[i] = th[0] * s + th[1] * v - t;
                    if let Some(j) = jac.as_deref_mut() {
                        j[(i, 0)] = s;
                        j[(i, 1)] = v;
                    }
                }
                _ => {
                    let (f_a, f_b, q_s, f_v) = (th[0], th[1], th[2], th[3]);
                    let x = v / q_s;
                    let e = (-x * x).exp();
                    r[i] = s * (f_a + (f_b - f_a) * e) + f_v * v - t;
                    if let Some(j) = jac.as_deref_mut() {
                        j[(i, 0)] = s * (1.0 - e);
                        j[(i, 1)] = s * e;
                        j[(i, 2)] = s * (f_b - f_a) * e * 2.0 * x * x / q_s;
                        j[(i, 3)] = v;
                    }
                }
            }
        }
    }
}

/// Fits `opts.form` to every requested joint of `data`.
pub fn fit(data: &FrictionData, opts: &FitOptions) -> Result<FitReport, FrictionError> {
    let start = Instant::now();
    check_options(opts)?;
    let present = data.joints();
    let joints = match &opts.joints {
        None => present.clone(),
        Some(js) => {
            if js.is_empty() {
                return Err(FrictionError::Fit("the joint list is empty; name at least one joint, e.g. 1,2,3".into()));
            }
            for &j in js {
                if !present.contains(&j) {
                    return Err(FrictionError::Fit(format!(
                        "joint {j} is not in {} (it has joints {}); choose joints from that list",
                        data.name,
                        list(&present)
                    )));
                }
            }
            js.clone()
        }
    };
    let mut out = Vec::with_capacity(joints.len());
    for j in joints {
        out.push(fit_joint(data, j, opts)?);
    }
    Ok(FitReport {
        form: opts.form,
        data_name: data.name.clone(),
        options: opts.clone(),
        joints: out,
        elapsed: start.elapsed(),
    })
}

fn list(v: &[usize]) -> String {
    v.iter().map(|j| j.to_string()).collect::<Vec<_>>().join(", ")
}

fn check_options(o: &FitOptions) -> Result<(), FrictionError> {
    if !(o.q_s_min > 0.0 && o.q_s_min < o.q_s_max && o.q_s_max.is_finite()) {
        return Err(FrictionError::Fit(format!(
            "q_s bounds [{}, {}] are invalid; need 0 < q_s_min < q_s_max < ∞ (default [1e-4, 2] rad/s)",
            o.q_s_min, o.q_s_max
        )));
    }
    if o.n_starts == 0 {
        return Err(FrictionError::Fit("n_starts = 0; use at least 1 starting point for q_s (default 12)".into()));
    }
    if !(o.confidence > 0.0 && o.confidence < 1.0) {
        return Err(FrictionError::Fit(format!("confidence {} is not in (0, 1); use e.g. 0.95", o.confidence)));
    }
    if !(o.min_speed >= 0.0 && o.min_speed.is_finite()) {
        return Err(FrictionError::Fit(format!("min_speed {} is invalid; give a finite speed ≥ 0 in rad/s", o.min_speed)));
    }
    Ok(())
}

fn fit_joint(data: &FrictionData, joint: usize, opts: &FitOptions) -> Result<JointFit, FrictionError> {
    let mut pos = (Vec::new(), Vec::new());
    let mut neg = (Vec::new(), Vec::new());
    let mut n_dropped = 0;
    for s in data.joint_samples(joint) {
        if s.qdot == 0.0 || s.qdot.abs() < opts.min_speed {
            n_dropped += 1;
        } else if s.qdot > 0.0 {
            pos.0.push(s.qdot);
            pos.1.push(s.tau);
        } else {
            neg.0.push(s.qdot);
            neg.1.push(s.tau);
        }
    }
    let what = format!("{}, joint {joint}", data.name);
    let (friction, branches) = match opts.form {
        FitForm::PerDirection => {
            for (half, dir, sign) in [(&pos, "positive", ">"), (&neg, "negative", "<")] {
                if half.0.is_empty() {
                    return Err(FrictionError::Fit(format!(
                        "{what}: no samples with velocity {sign} 0 ({dir} direction){}; a per-direction fit needs data in \
                         both directions — add {dir}-velocity segments or use --model symmetric",
                        if n_dropped > 0 { format!(" after leaving out {n_dropped} below the minimum speed") } else { String::new() }
                    )));
                }
            }
            let bp = fit_branch(&pos.0, &pos.1, opts, Direction::Positive, &what)?;
            let bn = fit_branch(&neg.0, &neg.1, opts, Direction::Negative, &what)?;
            let friction = JointFriction::StribeckPerDirection { positive: stribeck(&bp), negative: stribeck(&bn) };
            (friction, vec![bp, bn])
        }
        FitForm::Symmetric | FitForm::CoulombViscous => {
            let qdot: Vec<f64> = pos.0.iter().chain(&neg.0).copied().collect();
            let tau: Vec<f64> = pos.1.iter().chain(&neg.1).copied().collect();
            let b = fit_branch(&qdot, &tau, opts, Direction::Both, &what)?;
            let friction = if opts.form == FitForm::Symmetric {
                JointFriction::Stribeck(stribeck(&b))
            } else {
                JointFriction::CoulombViscous { f_c: b.params[0].value, f_v: b.params[1].value }
            };
            (friction, vec![b])
        }
    };
    let rmse_of = |q: &[f64], t: &[f64]| -> Option<f64> {
        (!q.is_empty()).then(|| {
            (q.iter().zip(t).map(|(&v, &tt)| (friction.tau_f(v) - tt).powi(2)).sum::<f64>() / q.len() as f64).sqrt()
        })
    };
    Ok(JointFit {
        joint,
        friction,
        rmse_positive: rmse_of(&pos.0, &pos.1),
        rmse_negative: rmse_of(&neg.0, &neg.1),
        n_positive: pos.0.len(),
        n_negative: neg.0.len(),
        n_dropped,
        branches,
    })
}

fn stribeck(b: &BranchFit) -> StribeckParams {
    StribeckParams { f_a: b.params[0].value, f_b: b.params[1].value, q_s: b.params[2].value, f_v: b.params[3].value }
}

/// Linear least squares for (f_a, f_b, f_v) at a fixed q_s, clipped to ≥ 0.
fn linear_start(qdot: &[f64], tau: &[f64], q_s: f64) -> [f64; 3] {
    let m = qdot.len();
    let a = DMatrix::from_fn(m, 3, |i, k| {
        let v = qdot[i];
        let s = v.signum();
        let e = (-(v / q_s).powi(2)).exp();
        match k {
            0 => s * (1.0 - e),
            1 => s * e,
            _ => v,
        }
    });
    let b = DVector::from_column_slice(tau);
    let sol = a.svd(true, true).solve(&b, 1e-12).unwrap_or_else(|_| DVector::zeros(3));
    [sol[0].max(0.0), sol[1].max(0.0), sol[2].max(0.0)]
}

fn fit_branch(
    qdot: &[f64],
    tau: &[f64],
    opts: &FitOptions,
    direction: Direction,
    what: &str,
) -> Result<BranchFit, FrictionError> {
    let form = opts.form;
    let names = form.param_names();
    let p = names.len();
    let n = qdot.len();
    if n <= p {
        let dir = match direction {
            Direction::Both => String::new(),
            Direction::Positive => ", positive direction".into(),
            Direction::Negative => ", negative direction".into(),
        };
        return Err(FrictionError::Fit(format!(
            "{what}{dir}: {n} data points for {p} parameters; the {} fit needs at least {} points (one more than \
             the parameters, for an error estimate) — add segments at more speeds{}",
            form.name(),
            p + 1,
            if form != FitForm::CoulombViscous { " or use --model coulomb-viscous (2 parameters)" } else { "" }
        )));
    }
    let problem = Branch { qdot, tau, form };
    let (lower, upper): (Vec<f64>, Vec<f64>) = match form {
        FitForm::CoulombViscous => (vec![0.0, 0.0], vec![f64::INFINITY; 2]),
        _ => (vec![0.0, 0.0, opts.q_s_min, 0.0], vec![f64::INFINITY, f64::INFINITY, opts.q_s_max, f64::INFINITY]),
    };
    let starts: Vec<Vec<f64>> = match form {
        FitForm::CoulombViscous => vec![vec![0.0, 0.0]],
        _ => {
            let k = opts.n_starts;
            (0..k)
                .map(|i| {
                    let t = if k == 1 { 0.5 } else { i as f64 / (k - 1) as f64 };
                    let q_s = (opts.q_s_min.ln() + t * (opts.q_s_max.ln() - opts.q_s_min.ln())).exp();
                    let [f_a, f_b, f_v] = linear_start(qdot, tau, q_s);
                    vec![f_a, f_b, q_s, f_v]
                })
                .collect()
        }
    };
    let results: Vec<_> = starts.iter().map(|s| lm_box(&problem, s, &lower, &upper, &opts.lm)).collect();
    let best = results
        .iter()
        .min_by(|a, b| a.ssr.total_cmp(&b.ssr))
        .ok_or_else(|| FrictionError::Fit(format!("{what}: no starting point")))?;
    if !best.ssr.is_finite() {
        return Err(FrictionError::Fit(format!(
            "{what}: the fit diverged (non-finite residuals); check the data for extreme values"
        )));
    }
    let starts_agreeing = results.iter().filter(|r| r.ssr - best.ssr <= 1e-6 * best.ssr + 1e-300).count();

    // Confidence intervals from the Jacobian of the free parameters at the optimum.
    let theta = &best.theta;
    let mut r = DVector::zeros(n);
    let mut jac = DMatrix::zeros(n, p);
    problem.eval(theta, &mut r, Some(&mut jac));
    let free: Vec<usize> = (0..p).filter(|&i| !best.at_bound[i]).collect();
    let dof = n - free.len();
    let sigma2 = best.ssr / dof as f64;
    let tq = student_t_quantile(0.5 + 0.5 * opts.confidence, dof as f64);
    let mut ci = vec![Ci95::AtBound; p];
    if !free.is_empty() {
        let jf = jac.select_columns(&free);
        let svd = jf.svd(false, true);
        let v_t = svd.v_t.as_ref().expect("SVD computed with V");
        let s_max = svd.singular_values.max();
        let tol = s_max * 1e-9;
        let mut null_mask = vec![false; free.len()];
        for (k, &s) in svd.singular_values.iter().enumerate() {
            if s <= tol {
                for c in 0..free.len() {
                    if v_t[(k, c)].abs() > 1e-3 {
                        null_mask[c] = true;
                    }
                }
            }
        }
        for (c, &i) in free.iter().enumerate() {
            if null_mask[c] || s_max == 0.0 {
                ci[i] = Ci95::Unidentifiable;
                continue;
            }
            let var: f64 = svd
                .singular_values
                .iter()
                .enumerate()
                .filter(|(_, &s)| s > tol)
                .map(|(k, &s)| (v_t[(k, c)] / s).powi(2))
                .sum::<f64>()
                * sigma2;
            let half = tq * var.sqrt();
            ci[i] = Ci95::Interval { lo: theta[i] - half, hi: theta[i] + half };
        }
    }
    let params = (0..p).map(|i| ParamEstimate { name: names[i], value: theta[i], ci95: ci[i] }).collect();
    Ok(BranchFit {
        direction,
        params,
        n_points: n,
        rmse: (best.ssr / n as f64).sqrt(),
        rmse_dfe: sigma2.sqrt(),
        n_starts: starts.len(),
        starts_agreeing,
        iterations: results.iter().map(|r| r.iterations).sum(),
        converged: best.converged,
    })
}

fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e4).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

fn fmt_est(p: &ParamEstimate) -> String {
    match p.ci95 {
        Ci95::Interval { lo, hi } => format!("{} [{}, {}]", fmt_num(p.value), fmt_num(lo), fmt_num(hi)),
        Ci95::AtBound => format!("{} (at bound)", fmt_num(p.value)),
        Ci95::Unidentifiable => format!("{} (unidentifiable)", fmt_num(p.value)),
    }
}

impl FitReport {
    /// The parameter file (`naic_core::friction::FrictionParams`) of this fit: the fitted
    /// laws with their statistics (RMSE, n, 95 % intervals per branch; RMSE per direction
    /// for the symmetric forms). Was `FrictionParams::from_fit` before the fit left naic_core.
    pub fn to_params(&self, source: &str) -> FrictionParams {
        let stats_of = |b: &BranchFit| BranchStats {
            rmse: Some(b.rmse),
            rmse_dfe: Some(b.rmse_dfe),
            n_points: Some(b.n_points),
            ci95: b.params.iter().map(|p| (p.name.to_string(), p.ci95)).collect(),
        };
        let joints = self
            .joints
            .iter()
            .map(|j| {
                let mut stats = JointStats::default();
                for b in &j.branches {
                    match b.direction {
                        Direction::Both => {
                            stats.all = stats_of(b);
                            stats.positive = BranchStats {
                                rmse: j.rmse_positive,
                                n_points: Some(j.n_positive),
                                ..Default::default()
                            };
                            stats.negative = BranchStats {
                                rmse: j.rmse_negative,
                                n_points: Some(j.n_negative),
                                ..Default::default()
                            };
                        }
                        Direction::Positive => stats.positive = stats_of(b),
                        Direction::Negative => stats.negative = stats_of(b),
                    }
                }
                JointParams { joint: j.joint, friction: j.friction, stats }
            })
            .collect();
        FrictionParams { source: source.to_string(), notes: None, smoothing_v_s: None, joints }
    }

    /// A Table-1-like text table: parameters with 95 % intervals, RMSE per joint and direction.
    pub fn table(&self) -> String {
        let names = self.form.param_names();
        let mut rows: Vec<Vec<String>> = Vec::new();
        let mut head = vec!["joint".to_string(), "dir".into(), "n".into()];
        head.extend(names.iter().map(|n| {
            let unit = match *n {
                "q_s" => "rad/s",
                "f_v" => "N·m·s/rad",
                _ => "N·m",
            };
            format!("{n} [{unit}] (95% CI)")
        }));
        head.extend(["RMSE [N·m]".into(), "RMSE_dfe".into(), "RMSE+".into(), "RMSE−".into(), "starts".into()]);
        rows.push(head);
        for j in &self.joints {
            for b in &j.branches {
                let mut row = vec![j.joint.to_string(), b.direction.label().into(), b.n_points.to_string()];
                row.extend(b.params.iter().map(fmt_est));
                row.push(fmt_num(b.rmse));
                row.push(fmt_num(b.rmse_dfe));
                let opt = |x: Option<f64>| x.map(fmt_num).unwrap_or_else(|| "-".into());
                match b.direction {
                    Direction::Both => {
                        row.push(opt(j.rmse_positive));
                        row.push(opt(j.rmse_negative));
                    }
                    Direction::Positive => {
                        row.push(opt(j.rmse_positive));
                        row.push("".into());
                    }
                    Direction::Negative => {
                        row.push("".into());
                        row.push(opt(j.rmse_negative));
                    }
                }
                row.push(format!(
                    "{}/{}{}",
                    b.starts_agreeing,
                    b.n_starts,
                    if b.converged { "" } else { " (not converged)" }
                ));
                rows.push(row);
            }
        }
        let ncol = rows[0].len();
        let width: Vec<usize> =
            (0..ncol).map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0)).collect();
        let mut s = String::new();
        for (k, r) in rows.iter().enumerate() {
            let line: Vec<String> =
                r.iter().zip(&width).map(|(c, w)| format!("{c}{}", " ".repeat(w - c.chars().count()))).collect();
            s.push_str(line.join("  ").trim_end());
            s.push('\n');
            if k == 0 {
                s.push_str(&width.iter().map(|w| "-".repeat(*w)).collect::<Vec<_>>().join("  "));
                s.push('\n');
            }
        }
        s
    }
}

/// Residual sums of a given law on one joint's data, per direction (q̇ = 0 samples are skipped).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResidualStats {
    pub n_positive: usize,
    pub ssr_positive: f64,
    pub n_negative: usize,
    pub ssr_negative: f64,
}

impl ResidualStats {
    /// √(SSR/n) of the q̇ > 0 samples (None if there are none).
    pub fn rmse_positive(&self) -> Option<f64> {
        (self.n_positive > 0).then(|| (self.ssr_positive / self.n_positive as f64).sqrt())
    }
    pub fn rmse_negative(&self) -> Option<f64> {
        (self.n_negative > 0).then(|| (self.ssr_negative / self.n_negative as f64).sqrt())
    }
    /// √(SSR/(n − p)) of the q̇ > 0 samples for a branch with `p` parameters.
    pub fn rmse_dfe_positive(&self, p: usize) -> Option<f64> {
        (self.n_positive > p).then(|| (self.ssr_positive / (self.n_positive - p) as f64).sqrt())
    }
    pub fn rmse_dfe_negative(&self, p: usize) -> Option<f64> {
        (self.n_negative > p).then(|| (self.ssr_negative / (self.n_negative - p) as f64).sqrt())
    }
}

/// How well `friction` (exact law) explains the samples of `joint` (1-based) in `data`,
/// leaving out samples with |q̇| < `min_speed` (as [`FitOptions::min_speed`] does).
pub fn residual_stats(friction: &JointFriction, data: &FrictionData, joint: usize, min_speed: f64) -> ResidualStats {
    let mut s = ResidualStats::default();
    for p in data.joint_samples(joint).filter(|p| p.qdot.abs() >= min_speed) {
        let e2 = (friction.tau_f(p.qdot) - p.tau).powi(2);
        if p.qdot > 0.0 {
            s.n_positive += 1;
            s.ssr_positive += e2;
        } else if p.qdot < 0.0 {
            s.n_negative += 1;
            s.ssr_negative += e2;
        }
    }
    s
}
