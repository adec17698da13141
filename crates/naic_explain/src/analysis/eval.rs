//! The fit of one structure ([`Eval`]) and what is read off it: residuals and the friction part.

use super::{Col, JointSamples, NominalShape, Structure};

/// Fit of one structure: per-fold and whole-data results.
#[derive(Clone, Debug)]
pub struct Eval {
    pub structure: Structure,
    pub columns: Vec<Col>,
    /// Whole-data fit (shape values chosen on all data).
    pub full_structure: Structure,
    pub full_theta: Vec<f64>,
    pub full_ssr: f64,
    /// Per fold: the structure chosen on its training part, its amplitudes and held-out SSR.
    pub fold_structure: Vec<Structure>,
    pub fold_theta: Vec<Vec<f64>>,
    pub fold_ssr: Vec<f64>,
    pub heldout_ssr: f64,
    /// Samples fitted and held out (validation samples not counted).
    pub n: usize,
    pub n_params: usize,
    /// SSR of the whole-data fit on the validation samples, and their number (0: none).
    pub val_ssr: f64,
    pub val_n: usize,
}

impl Eval {
    pub fn heldout_rmse(&self) -> f64 {
        (self.heldout_ssr / self.n.max(1) as f64).sqrt()
    }
    /// RMSE on the validation runs (`None` without them).
    pub fn validation_rmse(&self) -> Option<f64> {
        (self.val_n > 0).then(|| (self.val_ssr / self.val_n as f64).sqrt())
    }
    /// Whole-data coefficient of a column.
    pub fn coef(&self, c: Col) -> Option<f64> {
        self.columns.iter().position(|&x| x == c).map(|i| self.full_theta[i])
    }
}

/// The friction part (Coulomb, viscous, Stribeck, s·q̇² columns) of a whole-data fit at
/// velocity `v`, with sgn(v) exact.
pub fn friction_part(ev: &Eval, sh: &NominalShape, v: f64) -> f64 {
    let js = JointSamples {
        y: vec![0.0],
        v: vec![v],
        s: vec![v.signum()],
        q: vec![0.0],
        t: vec![0.0],
        tn: vec![0.0],
        a: vec![0.0],
        dtau: vec![0.0],
        payload: vec![0.0],
        fold: vec![0],
        ..Default::default()
    };
    ev.columns
        .iter()
        .zip(&ev.full_theta)
        .filter(|(c, _)| matches!(c, Col::Coul(_) | Col::Visc(_) | Col::Strib(_) | Col::Visc2(_)))
        .map(|(c, th)| th * js.col(*c, &ev.full_structure, sh, 0))
        .sum()
}

/// Out-of-fold residuals (y − prediction of the model trained without the sample's fold),
/// and whole-data residuals.
pub fn residuals(js: &JointSamples, ev: &Eval, sh: &NominalShape) -> (Vec<f64>, Vec<f64>) {
    let mut oof = Vec::with_capacity(js.len());
    let mut ins = Vec::with_capacity(js.len());
    for i in 0..js.len() {
        let f = js.fold[i] as usize;
        // validation samples: the whole-data fit (they were never trained on either)
        let (sf, tf) = if js.is_validation(i) { (&ev.full_structure, &ev.full_theta) } else { (&ev.fold_structure[f], &ev.fold_theta[f]) };
        let mut pf = 0.0;
        let mut pa = 0.0;
        for (k, &c) in ev.columns.iter().enumerate() {
            pf += tf[k] * js.col(c, sf, sh, i);
            pa += ev.full_theta[k] * js.col(c, &ev.full_structure, sh, i);
        }
        oof.push(js.target(sf, i) - pf);
        ins.push(js.target(&ev.full_structure, i) - pa);
    }
    (oof, ins)
}
