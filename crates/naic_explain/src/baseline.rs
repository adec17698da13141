//! The classical identification, as a baseline the extended model is compared with: the
//! rigid body's **base parameters** by least squares on the joint-torque regressor
//! (`naic_core::dynamics::regressor`, identifiable columns by QR with column pivoting),
//! plus per-joint **viscous + Coulomb + offset** friction `f_v q̇ + f_c sgn(q̇) + f_o`
//! (Gaz et al. 2019, Supp. §II), all joints in one fit (they share the body parameters).
//!
//! It uses the same samples as the catalogue analysis (the analysis instants, the same
//! Savitzky–Golay estimates and smoothed torque, samples near a direction change left
//! out per joint, sgn(q̇) = tanh(q̇/1 mrad/s) and 0 at rest), the same held-out time blocks,
//! and — with `--validate` — the same validation runs, so the numbers are side by side.
//! The URDF's parameters are not used: the fit starts from nothing.

use crate::analysis::solve;
use crate::prepare::Prepared;
use nalgebra::DMatrix;
use naic_core::dynamics::regressor::{base_parameters, joint_torque_regressor, model_parameters, RegressorData, PARAM_NAMES, PARAMS_PER_BODY};
use naic_core::friction::DEFAULT_V_S;
use naic_core::model::Model;

/// Result of the baseline fit.
#[derive(Clone, Debug)]
pub struct Baseline {
    /// Indices into π (10 per body) of the identified base columns.
    pub base_columns: Vec<usize>,
    /// Whole-fit-data estimate: base parameters then (f_v, f_c, f_o) per joint.
    pub theta: Vec<f64>,
    /// Per joint: held-out RMSE over the time-block folds [N·m].
    pub heldout_rmse: Vec<f64>,
    /// Per joint: RMSE on the validation runs (empty without them).
    pub validation_rmse: Vec<f64>,
    /// Per joint: the URDF's rigid body alone (no friction, nothing fitted) on the same
    /// held-out samples, for reference.
    pub urdf_rmse: Vec<f64>,
    pub nj: usize,
}

impl Baseline {
    /// Friction of joint j (0-based): (f_v, f_c, f_o).
    pub fn friction(&self, j: usize) -> (f64, f64, f64) {
        let r = self.base_columns.len();
        (self.theta[r + 3 * j], self.theta[r + 3 * j + 1], self.theta[r + 3 * j + 2])
    }
    /// The name of base column k, e.g. `link3.Izz` (each is that parameter plus the
    /// combination of dependent ones the regressor cannot tell from it).
    pub fn column_name(model: &Model, c: usize) -> String {
        let link = &model.joints()[c / PARAMS_PER_BODY].child_link;
        format!("{link}.{}", PARAM_NAMES[c % PARAMS_PER_BODY])
    }
}

/// One pass over the instants of `p`: per (joint, group) Gram matrices of `[X y]`.
fn grams(
    model: &Model,
    p: &Prepared,
    cols: &[usize],
    group_of: &dyn Fn(f64) -> usize,
    groups: usize,
    rd: &mut RegressorData,
    urdf_pi: &[f64],
    urdf_ss: &mut [f64],
) -> Vec<DMatrix<f64>> {
    let nj = model.nv();
    let r = cols.len();
    let np = r + 3 * nj;
    let mut g = vec![DMatrix::<f64>::zeros(np + 1, np + 1); nj * groups];
    let mut x = vec![0.0; np + 1];
    let mut nz: Vec<usize> = Vec::with_capacity(np + 1);
    for i in 0..p.len() {
        let y = joint_torque_regressor(model, rd, &p.q[i], &p.v[i], &p.a[i]);
        let grp = group_of(p.t[i]);
        for j in 0..nj {
            if !p.keep[i][j] {
                continue;
            }
            x.fill(0.0);
            nz.clear();
            for (k, &c) in cols.iter().enumerate() {
                let val = y[(j, c)];
                if val != 0.0 {
                    x[k] = val;
                    nz.push(k);
                }
            }
            let v = p.v[i][j];
            let s = if p.regime[i][j] == 0 { 0.0 } else { (v / DEFAULT_V_S).tanh() };
            x[r + 3 * j] = v;
            x[r + 3 * j + 1] = s;
            x[r + 3 * j + 2] = 1.0;
            x[np] = p.tau[i][j];
            nz.extend([r + 3 * j, r + 3 * j + 1, r + 3 * j + 2, np]);
            let gm = &mut g[j * groups + grp];
            for (ia, &a) in nz.iter().enumerate() {
                let xa = x[a];
                for &b in &nz[ia..] {
                    gm[(a, b)] += xa * x[b];
                }
            }
            let tu: f64 = (0..urdf_pi.len()).map(|c| y[(j, c)] * urdf_pi[c]).sum();
            urdf_ss[j * groups + grp] += (p.tau[i][j] - tu).powi(2);
        }
    }
    for gm in &mut g {
        for a in 0..=np {
            for b in 0..a {
                gm[(a, b)] = gm[(b, a)];
            }
        }
    }
    g
}

fn ssr(g: &DMatrix<f64>, th: &[f64]) -> f64 {
    let p = th.len();
    let t = nalgebra::DVector::from_column_slice(th);
    let b = g.view((0, p), (p, 1)).column(0).clone_owned();
    (g[(p, p)] - 2.0 * t.dot(&b) + (g.view((0, 0), (p, p)) * &t).dot(&t)).max(0.0)
}

/// Fits the baseline on `fit` (time-block folds by `fold_of`, `folds` of them) and scores
/// it on the held-out folds and on `val`.
pub fn fit(model: &Model, fit: &Prepared, val: Option<&Prepared>, fold_of: &dyn Fn(f64) -> u8, folds: usize) -> Baseline {
    let nj = model.nv();
    let base = base_parameters(model, 30 * nj);
    let cols = base.columns.clone();
    let np = cols.len() + 3 * nj;
    let mut rd = RegressorData::new(model);
    let pi = model_parameters(model);
    let mut urdf_ss = vec![0.0; nj * folds];
    let g = grams(model, fit, &cols, &|t| fold_of(t) as usize, folds, &mut rd, &pi, &mut urdf_ss);
    let count = |p: &Prepared, j: usize, pred: &dyn Fn(f64) -> bool| (0..p.len()).filter(|&i| p.keep[i][j] && pred(p.t[i])).count();
    let mut total = DMatrix::<f64>::zeros(np + 1, np + 1);
    for gm in &g {
        total += gm;
    }
    let (theta, _) = solve(&total, np);
    let mut heldout = vec![0.0; nj];
    for f in 0..folds {
        let mut fold_tot = DMatrix::<f64>::zeros(np + 1, np + 1);
        for j in 0..nj {
            fold_tot += &g[j * folds + f];
        }
        let (th, _) = solve(&(&total - &fold_tot), np);
        for j in 0..nj {
            heldout[j] += ssr(&g[j * folds + f], &th);
        }
    }
    let mut heldout_rmse = Vec::with_capacity(nj);
    let mut urdf_rmse = Vec::with_capacity(nj);
    for j in 0..nj {
        let n = count(fit, j, &|_| true).max(1) as f64;
        heldout_rmse.push((heldout[j] / n).sqrt());
        urdf_rmse.push((urdf_ss[j * folds..(j + 1) * folds].iter().sum::<f64>() / n).sqrt());
    }
    let validation_rmse = match val {
        Some(vp) => {
            let mut vss = vec![0.0; nj];
            let gv = grams(model, vp, &cols, &|_| 0, 1, &mut rd, &pi, &mut vss);
            (0..nj).map(|j| (ssr(&gv[j], &theta) / count(vp, j, &|_| true).max(1) as f64).sqrt()).collect()
        }
        None => vec![],
    };
    Baseline { base_columns: cols, theta, heldout_rmse, validation_rmse, urdf_rmse, nj }
}
