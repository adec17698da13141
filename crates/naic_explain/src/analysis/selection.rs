//! Forward selection on one joint: add the significant candidate with the lowest held-out
//! BIC until none is significant; a richer candidate is taken over a significant simpler one
//! only when it is better than it by the test, and candidates the data cannot tell apart are
//! named as confounded.

use super::{assess, bootstrap, decide, evaluate, family_test, residuals, points_test, AnalysisOptions, Candidate, Eval, JointSamples, NominalShape, Structure};
use crate::catalogue::Effect;

/// `a` is better than `b` by the significance test: held-out gain of `a` over `b` ≥
/// `min_gain` and its block-bootstrap interval (same level and blocks as the rule) above zero.
fn better(js: &JointSamples, ra: &[f64], rb: &[f64], ssr_a: f64, ssr_b: f64, alpha: f64, o: &AnalysisOptions, seed: u64) -> bool {
    let gain = if ssr_b > 0.0 { 1.0 - ssr_a / ssr_b } else { 0.0 };
    if gain < o.min_gain {
        return false;
    }
    let blocks = bootstrap::blocks_of(js, rb, ra);
    bootstrap::gain_interval(&blocks, 2.0 * alpha, bootstrap::REPLICATES, seed).0 > 0.0
}

/// Which significant candidate to add (index into `cands`), and the ones confounded with it;
/// `alpha`: the per-test level of the step's test ([`family_test`]).
///
/// The lowest held-out BIC first; then a candidate counting fewer parameters replaces it when
/// the richer one is not better than it by the test (a constant offset on the JK5's joint 2,
/// moving one joint at a time, is matched within 0.03 % of the residual by the base-parameter
/// correction through the gravity columns cos(q₂ + φ) over a joint-2 range of ±0.3 rad, and
/// the correction's 35 other directions took 4 % of what the filter's estimation mismatch
/// left: the held-out BIC then preferred it). Every other significant candidate that is not
/// better than the one taken, and than which the one taken is not better, is named
/// confounded with it.
fn pick(js: &JointSamples, sh: &NominalShape, cands: &[Candidate], o: &AnalysisOptions, alpha: f64) -> Option<(usize, Vec<Effect>)> {
    let mut sig: Vec<usize> = (0..cands.len()).filter(|&i| cands[i].significant).collect();
    if sig.is_empty() {
        return None;
    }
    sig.sort_by(|&a, &b| cands[a].heldout_bic.total_cmp(&cands[b].heldout_bic));
    if sig.len() == 1 {
        return Some((sig[0], Vec::new()));
    }
    let res: Vec<Vec<f64>> = cands.iter().map(|c| if c.significant { residuals(js, &c.eval, sh).0 } else { Vec::new() }).collect();
    let ssr = |i: usize| cands[i].eval.heldout_ssr;
    let seed = |a: usize, b: usize| bootstrap::seed(js.joint, cands[a].effect) ^ (bootstrap::seed(js.joint, cands[b].effect) << 20);
    // Friction points: a is better than b when its held-out gain over b reaches the effect
    // size and, in the model that has both (b's model with a's effect added), a's effect is
    // significant by the points' test ([`super::points_test`]): the artificial nesting of two
    // non-nested models (Davidson & MacKinnon 1981), since the likelihood ratio of nested
    // fits cannot compare them directly. Time series: the block bootstrap of the held-out
    // residuals ([`better`]).
    let points = !js.time_series && !js.contact;
    let beats = |a: usize, b: usize| {
        if !points {
            return better(js, &res[a], &res[b], ssr(a), ssr(b), alpha, o, seed(a, b));
        }
        let gain = if ssr(b) > 0.0 { 1.0 - ssr(a) / ssr(b) } else { 0.0 };
        if gain < o.min_gain {
            return false;
        }
        let (st, scan) = cands[b].eval.full_structure.with(cands[a].effect);
        points_test::lr_test(js, &cands[b].eval, &st, &scan, sh, o.folds, seed(a, b)).p_value <= alpha
    };
    let mut chosen = sig[0];
    for &c in &sig[1..] {
        if cands[c].pick_params < cands[chosen].pick_params && !beats(chosen, c) {
            chosen = c;
        }
    }
    let confounded = sig.iter().copied().filter(|&c| c != chosen && !beats(c, chosen) && !beats(chosen, c)).map(|c| cands[c].effect).collect();
    Some((chosen, confounded))
}

/// The selection history of one joint.
#[derive(Clone, Debug)]
pub struct JointResult {
    pub joint: usize,
    pub n: usize,
    pub nominal: Eval,
    /// Selected candidates in order.
    pub steps: Vec<Candidate>,
    /// Final model.
    pub final_eval: Eval,
    /// Every candidate scored against the final model (none of them significant).
    pub rejected: Vec<Candidate>,
}

/// Forward selection on one joint.
pub fn analyse_joint(js: &JointSamples, sh: &NominalShape, o: &AnalysisOptions) -> JointResult {
    let (st0, scan0) = Structure::nominal_for(js);
    let nominal = evaluate(js, &st0, &scan0, sh, o.folds);
    let mut cur = nominal.clone();
    let mut steps = Vec::new();
    let rejected;
    loop {
        let mut cands: Vec<Candidate> = o
            .effects
            .iter()
            .copied()
            .filter(|e| js.applicable(*e) && !cur.full_structure.has(*e))
            .map(|e| assess(js, &cur, e, sh, o))
            .collect();
        // the test of this step, calibrated over the candidates still outside the model
        let (level, ivs) = family_test(js, &cur, &cands, sh, o);
        for (c, iv) in cands.iter_mut().zip(ivs) {
            decide(js, &cur, c, sh, o, level, iv);
        }
        cands.sort_by(|a, b| b.gain.total_cmp(&a.gain));
        // Of the significant candidates the one with the lowest held-out BIC is added (held-out
        // gain, with ln(n_eff) per parameter): where two explain the same residual about
        // equally (a Stribeck curve whose q_s lies beyond the data mimics s·q̇²; a slow
        // sin(k'q + φ) over a joint's range mimics an offset; a delay found on the other joints
        // is a negative rotor inertia on a wrist joint), the one with fewer parameters is
        // taken, not the one whose extra freedom fits the noise a little better held out.
        match pick(js, sh, &cands, o, level) {
            Some((i, confounded)) if steps.len() < o.max_steps => {
                let mut c = cands.swap_remove(i);
                c.confounded = confounded;
                cur = c.eval.clone();
                steps.push(c);
            }
            _ => {
                rejected = cands;
                break;
            }
        }
    }
    JointResult { joint: js.joint, n: nominal.n, nominal, steps, final_eval: cur, rejected }
}
