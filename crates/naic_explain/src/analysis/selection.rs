//! Forward selection on one joint: add the significant candidate with the lowest held-out
//! BIC until none is significant.

use super::{evaluate, score, AnalysisOptions, Candidate, Eval, JointSamples, NominalShape, Structure};

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
            .map(|e| score(js, &cur, e, sh, o))
            .collect();
        cands.sort_by(|a, b| b.gain.total_cmp(&a.gain));
        // Of the significant candidates the one with the lowest held-out BIC is added (held-out
        // gain, with ln(n_eff) per parameter): where two explain the same residual about
        // equally (a Stribeck curve whose q_s lies beyond the data mimics s·q̇²; a slow
        // sin(k'q + φ) over a joint's range mimics an offset; a delay found on the other joints
        // is a negative rotor inertia on a wrist joint), the one with fewer parameters is
        // taken, not the one whose extra freedom fits the noise a little better held out.
        let pick = cands
            .iter()
            .enumerate()
            .filter(|(_, c)| c.significant)
            .min_by(|a, b| a.1.heldout_bic.total_cmp(&b.1.heldout_bic))
            .map(|(i, _)| i);
        match pick {
            Some(i) if steps.len() < o.max_steps => {
                let c = cands.swap_remove(i);
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
