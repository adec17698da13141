//! `inertial_parameters`: the link inertials of the URDF are wrong.
//!
//! The rigid-body torque is linear in the base parameters, `τ_rb = Y_B(q, q̇, q̈) β`
//! (`naic_core::dynamics::regressor`), so an error of the URDF's inertials is a correction
//! `δβ` **shared by every joint**. It cannot be one more per-joint column; it is scored in
//! an all-joint stage after the per-joint catalogue has run:
//!
//! 1. One least-squares fit on all joints together: the shared `Y_B δβ` plus, per joint,
//!    that joint's nominal friction columns (Coulomb with its calibrated width, viscous) and
//!    the first pass's `rotor_inertia` / `payload` columns when it found them (specific
//!    rigid-body-like effects, kept first where they suffice), against the same per-joint
//!    columns without `Y_B`. (Each joint's whole first-pass model was used before: effects such
//!    as `stribeck`, `position_torque` or `torque_offset` had already absorbed part of a
//!    rigid-body error and biased δβ.) Held out on the same
//!    time-block folds. The stage is significant when the mean over joints of the held-out
//!    gain is ≥ `min_gain`, the normalised held-out sum is lower in ≥ `min_fold_wins` folds,
//!    and BIC with one noise level per joint, `Σ_j n_eff,j ln(SSR_j'/SSR_j) + r ln(Σ n_eff)`,
//!    counts every one of the r base parameters. The per-joint columns include a constant
//!    where it earns its place beside `Y_B`, and `Y_B` must also pass the same rule against
//!    a constant on every joint ([`decide`]): where the data cannot tell the two apart, the
//!    constants have fewer parameters.
//! 2. When significant, the first pass's `rotor_inertia` columns are tested again beside
//!    `Y_B` (backward elimination by the per-joint rule, [`backward_beside_base`]): one that
//!    no longer earns its place was a stand-in for a link's inertia (on joint 1 it is the
//!    column of `link1.Izz`; on joint 2 it is the `q̈₂` part of what a heavier link 2 adds)
//!    and is left to δβ, which is refitted without it. A payload stays (see there).
//! 3. Then each joint gets the column `Y_B,j δβ₋f`, where `δβ₋f` is fitted without the
//!    sample's fold f (cross-fitting: the held-out samples of a fold never informed their
//!    own correction; the training samples' corrections saw other folds, a small leak the
//!    README states), and the per-joint forward selection runs again with
//!    `inertial_parameters` as a candidate beside the others. It is named on the joints where
//!    it passes the usual per-joint rule (its one column counts 1 there: the base parameters
//!    were counted in the stage's BIC). When the forward selection chooses among significant
//!    candidates, the column counts as the joint's share of the shared base parameters,
//!    ⌈r / N⌉, so that it is compared with a 1-parameter offset or a 3-parameter
//!    `position_torque` by what each explanation costs.
//!
//! The reported δβ is refitted in the same way on the second pass's final models (the
//! effects selected beside `inertial_parameters`, without its column): a first-pass model
//! may hold spurious columns (a `rotor_inertia` absorbing part of a link's inertia) that
//! the second pass drops.
//!
//! The corrected base parameters are `K π_URDF + δβ` (`regressor::base_map`). A URDF needs
//! every link's 10 parameters, which base parameters do not determine; [`corrected_links`]
//! takes the completion closest to the URDF (weighted minimum-norm `δπ` with `K δπ = δβ`)
//! and checks it is physically consistent (mass > 0, inertia about the centre of mass
//! positive definite and satisfying the triangle inequality). Only then is a URDF written.

use crate::analysis::{heldout, solve, AnalysisOptions, Col, JointResult, JointSamples, NominalShape, VALIDATION_FOLD};
use crate::catalogue::Effect;
use crate::prepare::Prepared;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, SymmetricEigen, Vector3};
use naic_core::dynamics::regressor::{
    base_map, base_parameters, dynamic_parameters, inertia_from_parameters, joint_torque_regressor, model_parameters, RegressorData,
    PARAMS_PER_BODY,
};
use naic_core::dynamics::spatial::Inertia;
use naic_core::model::Model;
use std::path::Path;

/// Result of the all-joint stage.
#[derive(Clone, Debug)]
pub struct InertialFit {
    /// Indices into π of the base columns, and their names (`link3.Izz`).
    pub base_columns: Vec<usize>,
    pub names: Vec<String>,
    /// Base parameters of the URDF (`K π`), and the whole-data correction δβ.
    pub urdf_beta: Vec<f64>,
    pub delta: Vec<f64>,
    /// Per joint: held-out relative gain of adding `Y_B δβ` to the joint's final model.
    pub joint_gain: Vec<f64>,
    /// Mean of `joint_gain`, folds won, ΔBIC, and the verdict.
    pub gain: f64,
    pub fold_wins: usize,
    pub folds: usize,
    pub delta_bic: f64,
    pub significant: bool,
    /// The stage's test of `Y_B` against a constant on every joint ([`decide`], step 1; `None`
    /// when the stage was fitted on the joints' final models): the verdict needs it to pass too.
    pub versus_constants: Option<StageTest>,
    /// The first pass's findings (1-based joint, `rotor_inertia`) that the correction was
    /// fitted without: beside `Y_B` they no longer passed the per-joint rule
    /// ([`backward_beside_base`]).
    pub set_aside: Vec<(usize, Effect)>,
    /// The joints (1-based) whose constant torque was fitted beside `Y_B δβ`: there it passed
    /// the per-joint rule beside the base columns ([`backward_beside_base`]). Not handed to
    /// the joints (`torque_offset` still has to pass its own test there).
    pub constants: Vec<usize>,
    /// Per joint, per sample (JointSamples order): `Y_B,j δβ` of the fit without the sample's fold.
    pub corrections: Vec<Vec<f64>>,
}

impl InertialFit {
    /// Corrected base parameters `K π_URDF + δβ`.
    pub fn corrected(&self) -> Vec<f64> {
        self.urdf_beta.iter().zip(&self.delta).map(|(a, b)| a + b).collect()
    }
}

/// Every analysis instant in [`crate::joint_samples_from_series`] order (fit instants, then
/// validation instants); joint j's samples are those with `keep[i][j]`, in this order.
fn all_instants<'p>(fit: &'p Prepared, val: Option<&'p Prepared>) -> impl Iterator<Item = (&'p Prepared, usize)> + 'p {
    let one = move |p: &'p Prepared| (0..p.len()).map(move |i| (p, i));
    one(fit).chain(val.into_iter().flat_map(one))
}

/// Least squares with the base block regularised: θ. Weakly excited combinations of
/// base parameters are held at the URDF's value instead of fitting noise.
/// `f(j, Y)` for every kept (instant, joint) of the fit and validation samples, in their
/// order, with the joint-torque regressor `Y` of the instant (built once per instant for all
/// joints; row `j` is joint `j`'s).
fn for_each_kept(model: &Model, rd: &mut RegressorData, fit: &Prepared, val: Option<&Prepared>, mut f: impl FnMut(usize, &DMatrix<f64>)) {
    for (p, i) in all_instants(fit, val) {
        if !p.keep[i].iter().any(|&k| k) {
            continue;
        }
        let y = joint_torque_regressor(model, rd, &p.q[i], &p.v[i], &p.a[i]);
        for (j, &kept) in p.keep[i].iter().enumerate() {
            if kept {
                f(j, y);
            }
        }
    }
}

fn solve_reg(g: &DMatrix<f64>, p: usize, r: usize) -> Vec<f64> {
    let mut g2 = g.clone();
    for k in 0..r {
        g2[(k, k)] *= 1.0 + BASE_RIDGE;
    }
    solve(&g2, p).0
}

/// Relative ridge on the diagonal of the base-parameter block (scaled columns).
const BASE_RIDGE: f64 = 1e-6;

/// The all-joint stage (see the module docs). `joints` and `results` are the per-joint
/// samples and final models of the first pass, in joint order.
pub fn fit(
    model: &Model,
    fit: &Prepared,
    val: Option<&Prepared>,
    joints: &[JointSamples],
    results: &[JointResult],
    shapes: &[NominalShape],
    o: &AnalysisOptions,
    nominal_only: bool,
) -> InertialFit {
    let nj = model.nv();
    let base = base_parameters(model, 30 * nj);
    let k_map = base_map(model, &base, 30 * nj);
    let cols = base.columns.clone();
    let r = cols.len();
    let kf = o.folds;
    let urdf_beta: Vec<f64> = (&k_map * DVector::from_vec(model_parameters(model))).iter().copied().collect();
    let names: Vec<String> = cols.iter().map(|&c| crate::baseline::Baseline::column_name(model, c)).collect();
    let mut rd = RegressorData::new(model);
    // local layout per joint: [base (r), own columns (p_j), y]
    use crate::analysis::{Dir, Structure};
    let nominal_cols = vec![Col::Coul(Dir::Both), Col::Visc(Dir::Both)];
    let own: Vec<Vec<Col>> = results
        .iter()
        .map(|res| {
            if nominal_only {
                // the nominal friction, a constant (kept only where it earns its place beside
                // Y_B: [`constants_beside_base`]), and the first pass's own rigid-body-like
                // findings (a rotor inertia, a payload: specific, and kept first where they suffice)
                let mut c = nominal_cols.clone();
                c.push(Col::Offset);
                c.extend(res.final_eval.columns.iter().copied().filter(|c| matches!(c, Col::Rotor | Col::Payload)));
                c
            } else {
                res.final_eval.columns.iter().copied().filter(|c| *c != Col::Inertial).collect()
            }
        })
        .collect();
    let nominal_st = Structure::nominal();
    let mut grams: Vec<Vec<DMatrix<f64>>> = own.iter().map(|c| vec![DMatrix::zeros(r + c.len() + 1, r + c.len() + 1); kf + 1]).collect();
    // one pass over the instants: the regressor (all joints' rows) once per instant, each
    // joint's row into that joint's Gram when the instant is one of its samples (k[j]
    // counts them in JointSamples order)
    let mut xs: Vec<Vec<f64>> = own.iter().map(|c| vec![0.0; r + c.len() + 1]).collect();
    let mut ks = vec![0usize; nj];
    let sts: Vec<_> = results.iter().map(|res| if nominal_only { &nominal_st } else { &res.final_eval.full_structure }).collect();
    let shs: Vec<NominalShape> = (0..nj).map(|j| shapes.get(j).copied().unwrap_or_default()).collect();
    for_each_kept(model, &mut rd, fit, val, |j, y| {
        let (js, x) = (&joints[j], &mut xs[j]);
        let k = ks[j];
        ks[j] += 1;
        let pj = own[j].len();
        for (a, &c) in cols.iter().enumerate() {
            x[a] = y[(j, c)];
        }
        for (a, c) in own[j].iter().enumerate() {
            x[r + a] = js.col(*c, sts[j], &shs[j], k);
        }
        x[r + pj] = js.target(sts[j], k);
        let f = if js.fold[k] == VALIDATION_FOLD { kf } else { js.fold[k] as usize };
        let g = &mut grams[j][f];
        for a in 0..x.len() {
            if x[a] == 0.0 {
                continue;
            }
            for b in a..x.len() {
                g[(a, b)] += x[a] * x[b];
            }
        }
    });
    for j in 0..nj {
        for g in &mut grams[j] {
            for a in 0..g.nrows() {
                for b in 0..a {
                    g[(a, b)] = g[(b, a)];
                }
            }
        }
    }
    let n_eff: Vec<f64> = (0..nj).map(|j| (results[j].final_eval.n as f64 / joints[j].corr_len.max(1.0)).max(2.0)).collect();
    let Decision { used, active, set_aside, test, versus_constants, significant } = decide(&grams, r, &own, &n_eff, o, nominal_only);
    let constants: Vec<usize> = (0..nj).filter(|&j| active[j].iter().any(|&a| own[j][a] == Col::Offset)).map(|j| joints[j].joint).collect();
    let StageTest { joint_gain, gain, fold_wins, delta_bic: bic } = test;
    let set_aside = set_aside.into_iter().map(|(j, _)| (joints[j].joint, Effect::RotorInertia)).collect();
    // cross-fitted corrections per sample
    let mut corrections = vec![Vec::new(); nj];
    if significant {
        for j in 0..nj {
            corrections[j].reserve(joints[j].len());
        }
        for_each_kept(model, &mut rd, fit, val, |j, y| {
            let js = &joints[j];
            let k = corrections[j].len();
            let d = if js.fold[k] == VALIDATION_FOLD { &used.delta } else { &used.fold_delta[js.fold[k] as usize] };
            corrections[j].push(cols.iter().zip(d).map(|(&c, dv)| y[(j, c)] * dv).sum());
        });
    }
    InertialFit {
        base_columns: cols,
        names,
        urdf_beta,
        delta: used.delta,
        joint_gain,
        gain,
        fold_wins,
        folds: kf,
        delta_bic: bic,
        significant,
        versus_constants,
        set_aside,
        constants,
        corrections,
    }
}

/// The stage's test of `Y_B` beside each joint's `active` own columns: per-joint held-out gain
/// of the all-joint fit `with` over each joint alone on the same columns, their mean, the folds
/// whose normalised held-out sum is lower, and BIC counting the r base parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct StageTest {
    pub joint_gain: Vec<f64>,
    pub gain: f64,
    pub fold_wins: usize,
    pub delta_bic: f64,
}

impl StageTest {
    /// The stage's rule: mean held-out gain ≥ `min_gain`, ≥ `min_fold_wins` folds, BIC lower.
    pub fn passes(&self, o: &AnalysisOptions) -> bool {
        self.gain >= o.min_gain && self.fold_wins >= o.min_fold_wins && self.delta_bic < 0.0
    }
}

fn stage_test(grams: &[Vec<DMatrix<f64>>], r: usize, active: &[Vec<usize>], with: &JointFit, n_eff: &[f64], kf: usize) -> StageTest {
    let nj = grams.len();
    // without the base columns: each joint alone on its own (active) columns
    let sub = |g: &DMatrix<f64>, j: usize| -> DMatrix<f64> {
        let ix: Vec<usize> = active[j].iter().map(|&a| r + a).chain([g.nrows() - 1]).collect();
        g.select_rows(&ix).select_columns(&ix)
    };
    let totals: Vec<DMatrix<f64>> = grams.iter().map(|g| fold_sum(&g[..kf])).collect();
    let mut ho_without = vec![vec![0.0; kf]; nj];
    for f in 0..kf {
        for j in 0..nj {
            let (tw, _) = solve(&sub(&(&totals[j] - &grams[j][f]), j), active[j].len());
            ho_without[j][f] = heldout(&sub(&grams[j][f], j), &tw);
        }
    }
    let sum = |v: &[f64]| v.iter().sum::<f64>();
    let joint_gain: Vec<f64> =
        (0..nj).map(|j| if sum(&ho_without[j]) > 0.0 { 1.0 - sum(&with.heldout[j]) / sum(&ho_without[j]) } else { 0.0 }).collect();
    let gain = joint_gain.iter().sum::<f64>() / nj.max(1) as f64;
    let fold_wins = (0..kf)
        .filter(|&f| {
            let norm = |v: &[Vec<f64>]| (0..nj).map(|j| v[j][f] / sum(&ho_without[j]).max(1e-300)).sum::<f64>();
            norm(&with.heldout) < norm(&ho_without)
        })
        .count();
    let mut bic = 0.0;
    for j in 0..nj {
        let (_, without) = solve(&sub(&totals[j], j), active[j].len());
        if with.whole[j] > 0.0 && without > 0.0 {
            bic += n_eff[j] * (with.whole[j] / without).ln();
        }
    }
    bic += r as f64 * n_eff.iter().sum::<f64>().max(2.0).ln();
    StageTest { joint_gain, gain, fold_wins, delta_bic: bic }
}

/// What the stage decided ([`decide`]).
struct Decision {
    /// The fit whose δβ is handed to the joints (after the rotor set-aside).
    used: JointFit,
    /// Each joint's own columns (indices into `own`) the verdict was made beside.
    active: Vec<Vec<usize>>,
    /// First-pass rotor inertias set aside (joint index, column).
    set_aside: Vec<(usize, Col)>,
    /// `Y_B` beside the `active` columns (the verdict's numbers).
    test: StageTest,
    /// `Y_B` beside every joint's own columns with a constant on every joint (`nominal_only`).
    versus_constants: Option<StageTest>,
    significant: bool,
}

/// The stage's verdict from each joint's per-fold Grams of `[base (r), own columns, y]`.
///
/// With the nominal friction only (`nominal_only`, `own` holding a `Col::Offset` per joint):
/// 1. `Y_B` must beat a constant on every joint: the stage's rule ([`StageTest::passes`]) for
///    `Y_B` beside all the own columns, every joint's constant among them. A constant is one
///    parameter on one joint; `Y_B` is r, and on a joint that moves through a small part of
///    its range its gravity columns (sin, cos of that joint's angle and the angles outboard)
///    make a constant too (the trapezoid generator's joint 2 over 0.7–1.3 rad: `Y_B` alone
///    reproduces a 0.45 N·m offset held out to the noise, whether the joint moves or holds).
///    Where the data cannot tell them apart, the one with fewer parameters is named, as in the
///    per-joint selection; `Y_B` is kept only for what the constants cannot explain.
/// 2. Then the constants are eliminated beside `Y_B` ([`backward_beside_base`]) and the verdict
///    is `Y_B` beside the constants left (significant only when 1 passed as well); when
///    significant, the first pass's rotor inertias are tested beside `Y_B` the same way.
fn decide(grams: &[Vec<DMatrix<f64>>], r: usize, own: &[Vec<Col>], n_eff: &[f64], o: &AnalysisOptions, nominal_only: bool) -> Decision {
    let kf = o.folds;
    let all_own: Vec<Vec<usize>> = own.iter().map(|c| (0..c.len()).collect()).collect();
    let with = joint_fit(grams, r, &all_own, kf);
    let versus_constants = nominal_only.then(|| stage_test(grams, r, &all_own, &with, n_eff, kf));
    // a joint's constant only where it earns its place beside Y_B
    let (with, active, _) =
        if nominal_only { backward_beside_base(grams, r, own, all_own, n_eff, o, with, Col::Offset) } else { (with, all_own, vec![]) };
    let test = stage_test(grams, r, &active, &with, n_eff, kf);
    let significant = test.passes(o) && versus_constants.as_ref().is_none_or(|t| t.passes(o));
    // The correction handed to the joints is fitted beside only those first-pass rotor
    // inertias that still earn their place beside Y_B: one that the first pass took as a
    // stand-in for a link's inertia is left to δβ.
    let (used, set_aside) = if significant && nominal_only {
        let (fit, _, set_aside) = backward_beside_base(grams, r, own, active.clone(), n_eff, o, with, Col::Rotor);
        (fit, set_aside)
    } else {
        (with, vec![])
    };
    Decision { used, active, set_aside, test, versus_constants, significant }
}

/// Sum of Gram matrices (not empty).
fn fold_sum(g: &[DMatrix<f64>]) -> DMatrix<f64> {
    g.iter().skip(1).fold(g[0].clone(), |a, b| a + b)
}

/// The all-joint least squares of `Y_B δβ` plus each joint's `active` own columns (indices
/// into the joint's own columns), held out on the folds.
struct JointFit {
    /// Per joint, per fold: held-out SSR of the fit without that fold.
    heldout: Vec<Vec<f64>>,
    /// Per joint: SSR of the whole-data fit.
    whole: Vec<f64>,
    /// Per fold: δβ fitted without it; and δβ of the whole data.
    fold_delta: Vec<Vec<f64>>,
    delta: Vec<f64>,
}

/// [`JointFit`] from each joint's per-fold Grams of `[base (r), own columns, y]`.
fn joint_fit(grams: &[Vec<DMatrix<f64>>], r: usize, active: &[Vec<usize>], kf: usize) -> JointFit {
    let nj = grams.len();
    // each joint's Grams on [base, its active columns, y]
    let grams: Vec<Vec<DMatrix<f64>>> = grams
        .iter()
        .zip(active)
        .map(|(g, a)| {
            let y = g[0].nrows() - 1;
            let ix: Vec<usize> = (0..r).chain(a.iter().map(|&k| r + k)).chain([y]).collect();
            g.iter().map(|m| m.select_rows(&ix).select_columns(&ix)).collect()
        })
        .collect();
    // global layout: [base, joint 1's columns, …, joint N's, y]
    let offs: Vec<usize> = active
        .iter()
        .scan(r, |acc, a| {
            let o = *acc;
            *acc += a.len();
            Some(o)
        })
        .collect();
    let np = r + active.iter().map(Vec::len).sum::<usize>();
    let index = |j: usize| -> Vec<usize> { (0..r).chain(offs[j]..offs[j] + active[j].len()).chain([np]).collect() };
    let embed = |into: &mut DMatrix<f64>, j: usize, g: &DMatrix<f64>, sign: f64| {
        let ix = index(j);
        for (a, &ga) in ix.iter().enumerate() {
            for (b, &gb) in ix.iter().enumerate() {
                into[(ga, gb)] += sign * g[(a, b)];
            }
        }
    };
    let totals: Vec<DMatrix<f64>> = grams.iter().map(|g| fold_sum(&g[..kf])).collect();
    let mut total = DMatrix::zeros(np + 1, np + 1);
    for j in 0..nj {
        embed(&mut total, j, &totals[j], 1.0);
    }
    let local = |th: &[f64], j: usize| -> Vec<f64> { (0..r).map(|k| th[k]).chain((0..active[j].len()).map(|k| th[offs[j] + k])).collect() };
    let mut heldout_ssr = vec![vec![0.0; kf]; nj];
    let mut fold_delta = Vec::with_capacity(kf);
    for f in 0..kf {
        let mut train = total.clone();
        for j in 0..nj {
            embed(&mut train, j, &grams[j][f], -1.0);
        }
        let th = solve_reg(&train, np, r);
        for j in 0..nj {
            heldout_ssr[j][f] = heldout(&grams[j][f], &local(&th, j));
        }
        fold_delta.push(th[..r].to_vec());
    }
    let th_all = solve_reg(&total, np, r);
    let whole = (0..nj).map(|j| heldout(&totals[j], &local(&th_all, j))).collect();
    JointFit { heldout: heldout_ssr, whole, fold_delta, delta: th_all[..r].to_vec() }
}

/// Backward elimination of the `tested` columns beside `Y_B` (among each joint's `active`
/// own columns): each is tested by the per-joint rule (held-out gain ≥ `min_gain` on its
/// joint, better in ≥ `min_fold_wins` folds, BIC lower with its one parameter) against the
/// all-joint fit without it; the weakest that fails is dropped and the rest tested again.
/// Returns each joint's kept own columns and the dropped (joint index, column). Used for two
/// columns:
///
/// A constant per joint (`Col::Offset`, the classical identification's f_o), before the
/// stage's verdict. Without it the all-joint least squares took a joint's real constant
/// torque into gravity columns (on the real Panda joints 1, 2 and 6: f_o −0.16, −0.18,
/// +0.08 N·m), and every joint's correction carried that compromise. Fitted on every joint
/// unconditionally, it took what is δβ's where a joint's rigid-body error is itself constant
/// for long stretches (a holding joint's gravity error while another joint moves, the
/// trapezoid generator): δβ then left that joint's part of the link change out. Beside `Y_B`
/// such a constant does not earn its place (δβ explains the same samples, and on held-out
/// blocks where the joint moved better), a sensor offset does — unless that joint's gravity
/// columns make a constant too over the range it visits; then neither earns its place beside
/// the other, and [`decide`] keeps the constant by testing `Y_B` against a constant on every
/// joint first.
///
/// A rotor inertia is a per-joint column, and on its own joint a link's inertia looks like
/// one (on joint 1 it is the column of `link1.Izz`; on joint 2 it is the `q̈₂` of what a
/// heavier link 2 adds there, while the same link also changes joint 1's torque, which a
/// rotor column cannot follow). Found before `Y_B` was tried, it took that part of the
/// link's error, and δβ fitted beside it left it out of every joint's correction (on the
/// independent generator's heavier link 2: 0.31 N·m of joint 2's residual, which
/// `position_torque` + `rotor_inertia` then explained instead, in 7 of 20 seeds). A payload
/// is not tested: one point mass at the tool is itself a rigid-body change (a direction of
/// δβ on every joint), so it could never earn a place beside `Y_B`; found first (one
/// parameter, agreed by ≥ 2 joints), it stays, and δβ takes what is beyond it.
/// `all` is the fit with the `active` columns; returns the fit with the columns that
/// are left, those columns (indices into `own`) and the ones set aside.
#[allow(clippy::too_many_arguments)]
fn backward_beside_base(
    grams: &[Vec<DMatrix<f64>>],
    r: usize,
    own: &[Vec<Col>],
    active: Vec<Vec<usize>>,
    n_eff: &[f64],
    o: &AnalysisOptions,
    all: JointFit,
    tested: Col,
) -> (JointFit, Vec<Vec<usize>>, Vec<(usize, Col)>) {
    let kf = o.folds;
    let mut active = active;
    let mut dropped = Vec::new();
    let mut cur = all;
    loop {
        // (gain, joint, position in active) of the weakest column that fails the rule
        let mut weakest: Option<(f64, usize, usize)> = None;
        for j in 0..active.len() {
            for (pos, &a) in active[j].iter().enumerate() {
                if own[j][a] != tested {
                    continue;
                }
                let mut less = active.clone();
                less[j].remove(pos);
                let w = joint_fit(grams, r, &less, kf);
                let (with_ho, without_ho): (f64, f64) = (cur.heldout[j].iter().sum(), w.heldout[j].iter().sum());
                let gain = if without_ho > 0.0 { 1.0 - with_ho / without_ho } else { 0.0 };
                let wins = cur.heldout[j].iter().zip(&w.heldout[j]).filter(|(a, b)| a < b).count();
                let bic = if cur.whole[j] > 0.0 && w.whole[j] > 0.0 { n_eff[j] * (cur.whole[j] / w.whole[j]).ln() + n_eff[j].ln() } else { 0.0 };
                let earns = gain >= o.min_gain && wins >= o.min_fold_wins && bic < 0.0;
                if !earns && weakest.is_none_or(|(g, _, _)| gain < g) {
                    weakest = Some((gain, j, pos));
                }
            }
        }
        let Some((_, j, pos)) = weakest else { return (cur, active, dropped) };
        dropped.push((j, own[j][active[j][pos]]));
        active[j].remove(pos);
        cur = joint_fit(grams, r, &active, kf);
    }
}

/// One link's inertials: the URDF's next to the corrected completion.
#[derive(Clone, Debug)]
pub struct LinkChange {
    pub link: String,
    pub urdf: Inertia,
    pub corrected: Inertia,
    /// `None`: physically consistent; else what fails.
    pub inconsistent: Option<String>,
}

/// Why an inertia is not physical (mass, moments about the centre of mass), or `None`.
fn physical(y: &Inertia, p: &[f64]) -> Option<String> {
    if !(p[0] > 0.0) {
        return Some(format!("mass {:.4} kg ≤ 0", p[0]));
    }
    let ic: Matrix3<f64> = y.inertia;
    let mut e: Vec<f64> = SymmetricEigen::new(ic).eigenvalues.iter().copied().collect();
    e.sort_by(f64::total_cmp);
    if e[0] <= 0.0 {
        return Some(format!("principal moments about the centre of mass {:.3e}, {:.3e}, {:.3e} kg·m²: not positive definite", e[0], e[1], e[2]));
    }
    if e[0] + e[1] < e[2] * (1.0 - 1e-9) {
        return Some(format!("principal moments {:.3e} + {:.3e} < {:.3e} kg·m²: triangle inequality violated", e[0], e[1], e[2]));
    }
    None
}

/// Pseudo-inertia `J = [[½ tr(I_o) 1 − I_o, h], [hᵀ, m]]` of 10 dynamic parameters (about
/// the frame origin): the parameters are physically consistent (m > 0, inertia about the
/// centre of mass positive definite with the triangle inequality) iff `J ≻ 0`
/// (Wensing, Kim & Slotine 2017).
fn pseudo_inertia(p: &[f64]) -> nalgebra::Matrix4<f64> {
    let io = Matrix3::new(p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9]);
    let sigma = Matrix3::identity() * (0.5 * io.trace()) - io;
    let mut j = nalgebra::Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    for k in 0..3 {
        j[(k, 3)] = p[1 + k];
        j[(3, k)] = p[1 + k];
    }
    j[(3, 3)] = p[0];
    j
}

/// Inverse of [`pseudo_inertia`] (I_o = tr(Σ) 1 − Σ).
fn from_pseudo_inertia(j: &nalgebra::Matrix4<f64>) -> [f64; PARAMS_PER_BODY] {
    let sigma: Matrix3<f64> = j.fixed_view::<3, 3>(0, 0).into_owned();
    let io = Matrix3::identity() * sigma.trace() - sigma;
    [j[(3, 3)], j[(0, 3)], j[(1, 3)], j[(2, 3)], io[(0, 0)], io[(0, 1)], io[(1, 1)], io[(0, 2)], io[(1, 2)], io[(2, 2)]]
}

/// Why no corrected links ([`corrected_links`]) or no corrected URDF ([`write_urdf`]):
/// each variant names the file or the link and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum InertialError {
    /// The robot model does not load (the model's own error names the file and field).
    #[error(transparent)]
    Model(#[from] naic_core::model::ModelError),
    /// The URDF does not parse as a URDF (`problem`: the parser's words).
    #[error("{path}: {problem}")]
    Urdf { path: String, problem: String },
    /// A joint's child link of the model is missing from the URDF.
    #[error("{path}: no link `{link}`")]
    NoLink { path: String, link: String },
    /// The pseudo-inertia metric or the base-parameter map cannot be inverted.
    #[error("the corrected links cannot be computed: {what}")]
    Singular { what: String },
    /// A corrected link is not physically consistent (`problem`: which condition fails).
    #[error(
        "no corrected URDF: the completion closest to the URDF of the identified base parameters gives link `{link}` {problem} (base \
         parameters fix only combinations of the link inertials; the corrected base parameters are in report.json `inertial_parameters`)"
    )]
    Inconsistent { link: String, problem: String },
    /// Serialising, writing or re-reading the corrected URDF failed.
    #[error("{action} the corrected URDF {path}: {problem}")]
    Write { action: &'static str, path: String, problem: String },
}

/// The completion of the corrected base parameters closest to the URDF, per URDF child
/// link of each joint (its frame is the joint frame, so the 10 parameters add to the fixed
/// descendants' into the body's). Distances are Frobenius norms of the pseudo-inertia
/// change, one metric for kg, kg·m and kg·m². Start: the minimum-distance `δπ` with
/// `K δπ = δβ`; when a link is not physically consistent, alternating projections between
/// that affine set and the consistent set `J ⪰ ε` (both convex) look for a point in both.
pub fn corrected_links(model: &Model, urdf: &Path, fit: &InertialFit) -> Result<Vec<LinkChange>, InertialError> {
    let nj = model.nv();
    let np = PARAMS_PER_BODY * nj;
    let base = naic_core::dynamics::regressor::BaseParameters { columns: fit.base_columns.clone(), total: np, gap: 0.0 };
    let k = base_map(model, &base, 30 * nj);
    let robot = read_urdf(urdf)?;
    let mut links = Vec::with_capacity(nj);
    let mut x = DVector::zeros(np);
    let mut fixed = DVector::zeros(np);
    for (i, jm) in model.joints().iter().enumerate() {
        let link = robot.links.iter().find(|l| l.name == jm.child_link).ok_or_else(|| InertialError::NoLink { path: urdf.display().to_string(), link: jm.child_link.clone() })?;
        let old = link_inertia(link);
        let (pl, pb) = (dynamic_parameters(&old), dynamic_parameters(&jm.inertia));
        for kk in 0..PARAMS_PER_BODY {
            x[PARAMS_PER_BODY * i + kk] = pl[kk];
            fixed[PARAMS_PER_BODY * i + kk] = pb[kk] - pl[kk];
        }
        links.push((jm.child_link.clone(), old));
    }
    let target = DVector::from_vec(fit.corrected()) - &k * &fixed;
    // metric Q = Lᵀ L, L: π ↦ vec(J) per body (block diagonal)
    let mut l = DMatrix::zeros(16 * nj, np);
    for i in 0..nj {
        for kk in 0..PARAMS_PER_BODY {
            let mut e = [0.0; PARAMS_PER_BODY];
            e[kk] = 1.0;
            let j = pseudo_inertia(&e);
            for (r, v) in j.iter().enumerate() {
                l[(16 * i + r, PARAMS_PER_BODY * i + kk)] = *v;
            }
        }
    }
    let q = l.tr_mul(&l);
    let qinv = q.clone().try_inverse().ok_or_else(|| InertialError::Singular { what: "pseudo-inertia metric is singular".into() })?;
    let kq = &k * &qinv;
    let gram = (&kq * k.transpose()).pseudo_inverse(1e-12).map_err(|e| InertialError::Singular { what: format!("K Q⁻¹ Kᵀ has no pseudo-inverse ({e})") })?;
    let project_affine = |x: &DVector<f64>| -> DVector<f64> { x - kq.transpose() * (&gram * (&k * x - &target)) };
    // floor of the consistent set: a thousandth of each URDF link's smallest pseudo-inertia eigenvalue
    let floor: Vec<f64> = (0..nj)
        .map(|i| {
            let e = SymmetricEigen::new(pseudo_inertia(&x.as_slice()[PARAMS_PER_BODY * i..PARAMS_PER_BODY * (i + 1)])).eigenvalues;
            1e-3 * e.min().max(1e-9)
        })
        .collect();
    let consistent = |x: &DVector<f64>| (0..nj).all(|i| SymmetricEigen::new(pseudo_inertia(&x.as_slice()[PARAMS_PER_BODY * i..PARAMS_PER_BODY * (i + 1)])).eigenvalues.min() > 0.0);
    let mut y = project_affine(&x);
    for _ in 0..2000 {
        if consistent(&y) {
            break;
        }
        for i in 0..nj {
            let j = pseudo_inertia(&y.as_slice()[PARAMS_PER_BODY * i..PARAMS_PER_BODY * (i + 1)]);
            let mut e = SymmetricEigen::new(j);
            e.eigenvalues.iter_mut().for_each(|v| *v = v.max(2.0 * floor[i]));
            let p = from_pseudo_inertia(&e.recompose());
            y.as_mut_slice()[PARAMS_PER_BODY * i..PARAMS_PER_BODY * (i + 1)].copy_from_slice(&p);
        }
        y = project_affine(&y);
    }
    x = y;
    let mut out = Vec::new();
    for (i, (name, old)) in links.into_iter().enumerate() {
        let p = &x.as_slice()[PARAMS_PER_BODY * i..PARAMS_PER_BODY * (i + 1)];
        let new = inertia_from_parameters(p);
        out.push(LinkChange { link: name, urdf: old, corrected: new, inconsistent: physical(&new, p) });
    }
    Ok(out)
}

/// A URDF link's inertia in its own frame (URDF: origin rpy = R_z(y) R_y(p) R_x(r)).
fn link_inertia(l: &urdf_rs::Link) -> Inertia {
    let o = &l.inertial.origin;
    let rot = Rotation3::from_euler_angles(o.rpy[0], o.rpy[1], o.rpy[2]);
    let t = &l.inertial.inertia;
    let ic = Matrix3::new(t.ixx, t.ixy, t.ixz, t.ixy, t.iyy, t.iyz, t.ixz, t.iyz, t.izz);
    Inertia { mass: l.inertial.mass.value, com: Vector3::new(o.xyz[0], o.xyz[1], o.xyz[2]), inertia: rot.matrix() * ic * rot.matrix().transpose() }
}

/// Writes `urdf` with the corrected link inertials to `out` (inertial origin at the new
/// centre of mass, link axes). Refused when a link is not physically consistent.
pub fn write_urdf(urdf: &Path, links: &[LinkChange], out: &Path) -> Result<(), InertialError> {
    if let Some(l) = links.iter().find(|l| l.inconsistent.is_some()) {
        return Err(InertialError::Inconsistent { link: l.link.clone(), problem: l.inconsistent.clone().unwrap_or_default() });
    }
    let mut robot = read_urdf(urdf)?;
    for lc in links {
        if let Some(l) = robot.links.iter_mut().find(|l| l.name == lc.link) {
            let c = &lc.corrected;
            l.inertial.origin = urdf_rs::Pose { xyz: urdf_rs::Vec3([c.com.x, c.com.y, c.com.z]), rpy: urdf_rs::Vec3([0.0, 0.0, 0.0]) };
            l.inertial.mass.value = c.mass;
            let i = &c.inertia;
            l.inertial.inertia = urdf_rs::Inertia { ixx: i[(0, 0)], ixy: i[(0, 1)], ixz: i[(0, 2)], iyy: i[(1, 1)], iyz: i[(1, 2)], izz: i[(2, 2)] };
        }
    }
    let failed = |action: &'static str, problem: String| InertialError::Write { action, path: out.display().to_string(), problem };
    let text = urdf_rs::write_to_string(&robot).map_err(|e| failed("serialising", e.to_string()))?;
    let header = "<!-- written by naic explain (option write-urdf): the input URDF with the link inertials corrected by the \
                  inertial_parameters finding (the completion closest to the input of the identified base parameters) -->\n";
    let text = match text.find("?>") {
        Some(k) => format!("{}\n{header}{}", &text[..k + 2], text[k + 2..].trim_start()),
        None => format!("{header}{text}"),
    };
    std::fs::write(out, text).map_err(|e| failed("writing", e.to_string()))?;
    Model::from_urdf_file(out).map_err(|e| failed("loading back", e.to_string()))?;
    Ok(())
}

fn read_urdf(urdf: &Path) -> Result<urdf_rs::Robot, InertialError> {
    urdf_rs::read_file(urdf).map_err(|e| InertialError::Urdf { path: urdf.display().to_string(), problem: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn urdf(name: &str) -> std::path::PathBuf {
        std::path::PathBuf::from(format!("{}/../../urdf/{name}", env!("CARGO_MANIFEST_DIR")))
    }

    fn fit_for(model: &Model, delta: Vec<f64>) -> InertialFit {
        let nj = model.nv();
        let b = base_parameters(model, 30 * nj);
        let k = base_map(model, &b, 30 * nj);
        let urdf_beta = (&k * DVector::from_vec(model_parameters(model))).iter().copied().collect();
        let r = b.columns.len();
        let delta = if delta.is_empty() { vec![0.0; r] } else { delta };
        InertialFit {
            base_columns: b.columns,
            names: vec![],
            urdf_beta,
            delta,
            joint_gain: vec![],
            gain: 0.0,
            fold_wins: 0,
            folds: 10,
            delta_bic: 0.0,
            significant: true,
            versus_constants: None,
            set_aside: vec![],
            constants: vec![],
            corrections: vec![],
        }
    }

    /// Per joint, per fold Grams of `[base…, own…, y]` from rows `row(joint, i)` (1 000
    /// samples per joint in 10 time-block folds; `own[j]` own columns beside the r base columns).
    fn grams_of(own: &[usize], row: impl Fn(usize, usize) -> Vec<f64>) -> Vec<Vec<DMatrix<f64>>> {
        own.iter()
            .enumerate()
            .map(|(j, &p)| {
                let n = row(j, 0).len();
                assert!(n > p, "a row holds the base columns, the {p} own columns and y");
                let mut g = vec![DMatrix::zeros(n, n); 10];
                for i in 0..1000 {
                    let x = DVector::from_vec(row(j, i));
                    g[(i / 20) % 10] += &x * x.transpose();
                }
                g
            })
            .collect()
    }

    #[test]
    fn a_rotor_inertia_standing_in_for_a_base_parameter_is_set_aside() {
        // two joints sharing two base parameters; joint 1 has viscous + the first pass's rotor
        // inertia column, joint 2 viscous only. The residual is the base correction (0.5, 0.3)
        // on both joints plus friction; the rotor column is `stand_in`'s choice.
        let own = vec![vec![Col::Visc(crate::analysis::Dir::Both), Col::Rotor], vec![Col::Visc(crate::analysis::Dir::Both)]];
        let run = |stand_in: bool| {
            let mut rng = naic_core::rng::Rng::seed(7);
            let rows: Vec<Vec<Vec<f64>>> = (0..2)
                .map(|j| {
                    (0..1000)
                        .map(|_| {
                            let (b1, b2, v, n) = (rng.gaussian(), rng.gaussian(), rng.gaussian(), 0.01 * rng.gaussian());
                            let rotor = if stand_in { b1 } else { rng.gaussian() };
                            let y = 0.5 * b1 + 0.3 * b2 + 0.2 * v + n + if j == 0 && !stand_in { 0.4 * rotor } else { 0.0 };
                            if j == 0 {
                                vec![b1, b2, v, rotor, y]
                            } else {
                                vec![b1, b2, v, y]
                            }
                        })
                        .collect()
                })
                .collect();
            let grams = grams_of(&[2, 1], |j, i| rows[j][i].clone());
            let all = joint_fit(&grams, 2, &[vec![0, 1], vec![0]], AnalysisOptions::default().folds);
            let (_, active, dropped) =
                backward_beside_base(&grams, 2, &own, vec![vec![0, 1], vec![0]], &[200.0, 200.0], &AnalysisOptions::default(), all, Col::Rotor);
            (active, dropped)
        };
        // the rotor column is base column 1 on joint 1: nothing beside Y_B, set aside
        let (active, dropped) = run(true);
        assert_eq!(dropped, vec![(0, Col::Rotor)], "a rotor column equal to a base column must be set aside");
        assert_eq!(active, vec![vec![0], vec![0]]);
        // an independent rotor inertia (0.4 of a unit column) is kept
        let (active, dropped) = run(false);
        assert!(dropped.is_empty(), "a real rotor inertia was set aside: {dropped:?}");
        assert_eq!(active, vec![vec![0, 1], vec![0]]);
    }

    /// A constant torque on a joint whose gravity columns make a constant too is left to the
    /// constant. Two joints, three base columns: cos q and sin q appear on joint 1 only (its
    /// gravity, q in 1.0 ± 0.15 rad: over that range a·cos q + b·sin q ≈ 0.45 N·m to a few
    /// thousandths), the third on both. Joint 1 carries a 0.45 N·m offset. Beside `Y_B` the
    /// constant earns nothing and is eliminated, and `Y_B` beside the constants left (none)
    /// passes the stage's rule — the stage was significant on an offset (the trapezoid
    /// generator's joint 2). Beside a constant on every joint `Y_B` explains nothing, so the
    /// stage is not significant. A change of the third base parameter, which no constant can
    /// follow, still is.
    #[test]
    fn a_constant_that_gravity_columns_also_make_is_left_to_the_constant() {
        use crate::analysis::Dir;
        let own = vec![vec![Col::Visc(Dir::Both), Col::Offset], vec![Col::Visc(Dir::Both), Col::Offset]];
        let o = AnalysisOptions::default();
        let run = |offset: f64, shared: f64| {
            let mut rng = naic_core::rng::Rng::seed(11);
            let rows: Vec<Vec<Vec<f64>>> = (0..2)
                .map(|j| {
                    (0..1000)
                        .map(|i| {
                            let q = 1.0 + 0.15 * (2.0 * std::f64::consts::PI * i as f64 / 400.0).sin();
                            let (b3, v, n) = (rng.gaussian(), rng.gaussian(), 0.01 * rng.gaussian());
                            let (b1, b2) = if j == 0 { (q.cos(), q.sin()) } else { (0.0, 0.0) };
                            let y = 0.2 * v + shared * b3 + n + if j == 0 { offset } else { 0.0 };
                            vec![b1, b2, b3, v, 1.0, y]
                        })
                        .collect()
                })
                .collect();
            let grams = grams_of(&[2, 2], |j, i| rows[j][i].clone());
            decide(&grams, 3, &own, &[1000.0, 1000.0], &o, true)
        };
        let d = run(0.45, 0.0);
        // the mechanism: joint 1's constant does not earn its place beside Y_B, and Y_B beside
        // the constants left passes
        assert_eq!(d.active, vec![vec![0], vec![0]], "both constants (joint 2 has none) were expected to be eliminated beside Y_B");
        assert!(d.test.passes(&o), "Y_B beside the constants left: {:?}", d.test);
        // the rule: Y_B does not beat a constant on every joint
        let vc = d.versus_constants.clone().expect("nominal_only tests Y_B against the constants");
        assert!(!vc.passes(&o) && vc.joint_gain[0] < o.min_gain, "Y_B against the constants: {vc:?}");
        assert!(!d.significant, "an offset that gravity columns also make was taken as a rigid-body error: {:?}", d.test);
        // a base-parameter change no constant follows is still found
        let d = run(0.0, 0.3);
        assert!(d.significant && d.versus_constants.as_ref().is_some_and(|t| t.passes(&o)), "{:?} {:?}", d.test, d.versus_constants);
    }

    #[test]
    fn pseudo_inertia_round_trips() {
        let m = Model::from_urdf_file(urdf("panda.urdf")).expect("urdf");
        for j in m.joints() {
            let p = dynamic_parameters(&j.inertia);
            let back = from_pseudo_inertia(&pseudo_inertia(&p));
            assert!(p.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-12));
            // the URDF's links are physical: J ≻ 0
            assert!(SymmetricEigen::new(pseudo_inertia(&p)).eigenvalues.min() > 0.0, "{}", j.child_link);
        }
    }

    /// A known physical change (link 3 of the JK5 10 % heavier, every parameter scaled) gives
    /// δβ = K δπ; the completion is consistent, the written URDF loads, and its base
    /// parameters are the corrected ones. δβ = 0 gives the URDF's own links back.
    #[test]
    fn corrected_urdf_has_the_corrected_base_parameters() {
        let path = urdf("jk5.urdf");
        let model = Model::from_urdf_file(&path).expect("urdf");
        let same = corrected_links(&model, &path, &fit_for(&model, vec![])).expect("links");
        for l in &same {
            assert!(l.inconsistent.is_none(), "{}: {:?}", l.link, l.inconsistent);
            assert!((l.corrected.mass - l.urdf.mass).abs() < 1e-9 && (l.corrected.com - l.urdf.com).norm() < 1e-9, "{}", l.link);
        }
        let nj = model.nv();
        let mut dpi = vec![0.0; PARAMS_PER_BODY * nj];
        let p3 = dynamic_parameters(&model.joints()[2].inertia);
        for k in 0..PARAMS_PER_BODY {
            dpi[PARAMS_PER_BODY * 2 + k] = 0.1 * p3[k];
        }
        let b = base_parameters(&model, 30 * nj);
        let k = base_map(&model, &b, 30 * nj);
        let delta: Vec<f64> = (&k * DVector::from_vec(dpi)).iter().copied().collect();
        let fit = fit_for(&model, delta);
        let links = corrected_links(&model, &path, &fit).expect("links");
        assert!(links.iter().all(|l| l.inconsistent.is_none()), "{links:?}");
        let out = std::env::temp_dir().join(format!("naic_inertial_test_{}.urdf", std::process::id()));
        write_urdf(&path, &links, &out).expect("written");
        let m2 = Model::from_urdf_file(&out).expect("loads");
        let _ = std::fs::remove_file(&out);
        let beta2 = &k * DVector::from_vec(model_parameters(&m2));
        let want = fit.corrected();
        for (a, b) in beta2.iter().zip(&want) {
            assert!((a - b).abs() < 1e-6 * (1.0 + b.abs()), "base parameters of the written URDF {a} vs {b}");
        }
    }

    /// A link that is not physically consistent refuses the URDF, naming the link, what
    /// fails and where the corrected base parameters are; a missing URDF names its path.
    #[test]
    fn write_urdf_errors_name_the_link_or_the_file_and_the_way_out() {
        let link = |inconsistent: Option<&str>| LinkChange {
            link: "link3".into(),
            urdf: Inertia::default(),
            corrected: Inertia::default(),
            inconsistent: inconsistent.map(str::to_string),
        };
        let out = std::env::temp_dir().join(format!("naic_inertial_err_{}.urdf", std::process::id()));
        let e = write_urdf(&urdf("jk5.urdf"), &[link(None), link(Some("has mass -0.1 kg"))], &out).unwrap_err();
        assert!(matches!(&e, InertialError::Inconsistent { link, problem } if link == "link3" && problem == "has mass -0.1 kg"), "{e:?}");
        let m = e.to_string();
        assert!(m.contains("link `link3` has mass -0.1 kg") && m.contains("report.json `inertial_parameters`"), "{m}");
        assert!(!out.exists(), "a refused URDF must not be written");
        let missing = urdf("no_such_robot.urdf");
        let e = write_urdf(&missing, &[link(None)], &out).unwrap_err();
        assert!(matches!(&e, InertialError::Urdf { path, .. } if path.ends_with("no_such_robot.urdf")), "{e:?}");
        assert!(e.to_string().contains("no_such_robot.urdf"), "{e}");
    }
}
