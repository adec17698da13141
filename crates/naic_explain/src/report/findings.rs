//! The ranked findings and the numbers they are read from: the physical parameters of an
//! effect, the evidence line, per-direction RMSEs.

use crate::analysis::{residuals, Candidate, Col, Dir, Eval, JointSamples, NominalShape};
use crate::catalogue::{Effect, ALL_EFFECTS};
use crate::Explained;
use serde_json::{json, Map, Value};

/// One finding (an effect, possibly on several joints).
#[derive(Clone, Debug)]
pub struct Finding {
    pub effect: Effect,
    pub targets: Vec<usize>,
    pub significant: bool,
    /// Per target joint: parameter name → value.
    pub params: Vec<(usize, Vec<(String, f64)>)>,
    pub rmse_before: Vec<(usize, f64)>,
    pub rmse_after: Vec<(usize, f64)>,
    pub gain: f64,
    /// Mean over the target joints of the relative held-out reduction when the effect was added.
    pub step_gain: f64,
    /// Per target: the share of that joint's nominal held-out mean-square residual this effect
    /// removed (significant findings).
    pub share: Vec<(usize, f64)>,
    /// Per target: the share of that joint's nominal held-out mean square the final model leaves.
    pub left: Vec<(usize, f64)>,
    /// Per target: the block-bootstrap interval of the step's held-out gain and its two-sided
    /// level 1 − 2a (a: the one-sided per-test level of the step's test, α/m or above it where
    /// the joint's candidates move together, [`crate::analysis::family_test`]): the
    /// significance test (significant findings; [`super::bootstrap`]).
    pub gain_ci: Vec<(usize, (f64, f64), f64)>,
    /// Friction points, per target: the test that decided, (T, p) of the likelihood ratio
    /// against the model before ([`crate::analysis::points_test`]); `gain_ci` is then reported
    /// but did not decide.
    pub lr_test: Vec<(usize, (f64, f64))>,
    /// Candidates × joints tried (m of the family of the test).
    pub comparisons: usize,
    /// The family-wise error rate of the test.
    pub family_alpha: f64,
    /// Per target: the other significant candidates the data could not tell from this one
    /// when it was taken (neither better than the other by the test).
    pub confounded: Vec<(usize, Vec<Effect>)>,
    /// Decided by the pooled test over every joint's time blocks (`inertial_parameters`, one
    /// correction of the whole arm; `gain_ci` is that test's interval on every target).
    pub pooled: bool,
    pub evidence: String,
}

/// A significant finding that removes less than this share of its joint's nominal held-out
/// mean square on every target is reported as "small" (next to the share left).
pub const SMALL_SHARE: f64 = 0.05;

impl Finding {
    /// Significant, but below [`SMALL_SHARE`] of the residual on every target.
    pub fn is_small(&self) -> bool {
        self.significant && !self.share.is_empty() && self.share.iter().all(|&(_, s)| s < SMALL_SHARE)
    }

    /// "small: 3.1 % of joint 6's residual explained, 22 % of it left" (empty when not small).
    pub fn small_note(&self) -> String {
        if !self.is_small() {
            return String::new();
        }
        let parts: Vec<String> = self
            .share
            .iter()
            .zip(&self.left)
            .map(|(&(j, s), &(_, l))| {
                let name = if crate::contact::is_axis(j) { jkey(j) } else { format!("joint {j}") };
                format!("{:.1} % of {name}'s residual explained, {:.0} % of it left", 100.0 * s, 100.0 * l)
            })
            .collect();
        format!("small: {}", parts.join("; "))
    }
}

pub(super) fn jkey(j: usize) -> String {
    crate::contact::target_key(j)
}

/// Physical parameters of `effect` read from a fitted model.
pub fn effect_params(effect: Effect, ev: &Eval, js: &JointSamples) -> Vec<(String, f64)> {
    let c = |col: Col| ev.coef(col).unwrap_or(0.0);
    let st = &ev.full_structure;
    let mut out: Vec<(String, f64)> = Vec::new();
    let mut push = |k: &str, v: f64| out.push((k.to_string(), v));
    match effect {
        Effect::FrictionAsymmetry => {
            let (p, n) = (c(Col::Coul(Dir::Pos)), c(Col::Coul(Dir::Neg)));
            push("f_c_pos", p);
            push("f_c_neg", n);
            push("f_c_difference", p - n);
            push("f_v_pos", c(Col::Visc(Dir::Pos)));
            push("f_v_neg", c(Col::Visc(Dir::Neg)));
        }
        Effect::Stribeck => {
            if st.has(Effect::FrictionAsymmetry) {
                push("f_s_pos", c(Col::Strib(Dir::Pos)));
                push("q_s_pos", st.q_s_pos);
                push("f_s_neg", c(Col::Strib(Dir::Neg)));
                push("q_s_neg", st.q_s_neg);
            } else {
                push("f_s", c(Col::Strib(Dir::Both)));
                push("q_s", st.q_s_pos);
            }
        }
        Effect::PositionRipple => {
            let (a, b) = (c(Col::RipSin), c(Col::RipCos));
            push("amplitude_nm", a.hypot(b));
            push("k_per_rad", st.k);
            push("phase_rad", b.atan2(a));
        }
        Effect::PositionTorque => {
            let (a, b) = (c(Col::PosSin), c(Col::PosCos));
            push("amplitude_nm", a.hypot(b));
            push("k_per_rad", st.k_pos);
            push("phase_rad", b.atan2(a));
        }
        Effect::Payload => push("mass_kg", c(Col::Payload)),
        Effect::TorqueOffset => push("offset_nm", c(Col::Offset)),
        Effect::Delay => push("delay_s", st.delay),
        Effect::Drift => {
            push("delta_f_c_nm", c(Col::Drift));
            let dur = js.t.last().copied().unwrap_or(0.0) - js.t.first().copied().unwrap_or(0.0);
            if js.time_series && dur > 0.0 {
                push("rate_nm_per_hour", c(Col::Drift) / dur * 3600.0);
            }
        }
        Effect::RotorInertia => push("inertia_kgm2", c(Col::Rotor)),
        Effect::ViscousNonlinearity => {
            if ev.columns.contains(&Col::Visc2(Dir::Pos)) {
                push("f_v2_pos", c(Col::Visc2(Dir::Pos)));
                push("f_v2_neg", c(Col::Visc2(Dir::Neg)));
            } else {
                push("f_v2", c(Col::Visc2(Dir::Both)));
            }
        }
        // measured = k·model: the rigid-body column's coefficient is k − 1
        Effect::TorqueScale => push("scale", 1.0 + c(Col::Scale)),
        // the shared correction is in report.json `inertial_parameters`; per joint, the scale
        // the joint's fit gives its cross-fitted column (≈ 1 when the correction fits it)
        Effect::InertialParameters => push("correction_scale", c(Col::Inertial)),
        Effect::ContactNonlinearity => {
            push("n", st.n_exp);
            push("k_n", c(Col::Spring));
            push("surface_height_m", st.h);
        }
        Effect::ContactDamping => push("c_ns_per_m", c(Col::CDamp)),
        Effect::FtBias => push("bias", c(Col::Offset)),
        Effect::ToolGravity => {
            let names = crate::contact::gravity_param_names(js.joint.saturating_sub(crate::contact::AXIS_BASE + 1));
            push(names[0], c(Col::Grav0));
            if !names[1].is_empty() {
                push(names[1], c(Col::Grav1));
            }
        }
    }
    out
}

pub(super) fn rmse(ssr: f64, n: usize) -> f64 {
    (ssr / n.max(1) as f64).sqrt()
}

pub(super) fn evidence_line(j: usize, c: &Candidate, n: usize) -> String {
    let b = rmse(c.before_ssr, n);
    let a = c.eval.heldout_rmse();
    let name = if crate::contact::is_axis(j) { jkey(j) } else { format!("joint {j}") };
    format!(
        "{name}: held-out RMSE {b:.4} → {a:.4} {} ({:+.1} % mean square), better in {}/{} folds, ΔBIC {:.1}",
        crate::contact::target_unit(j),
        -100.0 * c.gain,
        c.fold_wins,
        c.eval.fold_ssr.len(),
        c.delta_bic
    )
}

/// A significant `delay` shorter than one raw sample period: that period [s].
pub fn sub_sample_delay(f: &Finding, ex: &Explained) -> Option<f64> {
    if f.effect != Effect::Delay || !f.significant {
        return None;
    }
    let dt = ex.joints.iter().map(|js| js.sample_period).fold(0.0, f64::max);
    let d = f.params.iter().flat_map(|(_, p)| p.iter()).find(|(k, _)| k == "delay_s").map(|(_, v)| v.abs())?;
    (dt > 0.0 && d < dt).then_some(dt)
}

/// Builds the ranked list of findings.
pub fn findings(ex: &Explained) -> Vec<Finding> {
    // gains are averaged over the targets of the effect's kind (joints, or sensor axes)
    let n_axes = ex.results.iter().filter(|r| crate::contact::is_axis(r.joint)).count();
    let n_joints = ex.results.len() - n_axes;
    let mut out = Vec::new();
    // every candidate the catalogue could try on every target: the family of the intervals
    let comparisons = ex
        .results
        .iter()
        .flat_map(|r| r.steps.iter().chain(&r.rejected))
        .map(|c| c.comparisons)
        .max()
        .unwrap_or_else(|| super::bootstrap::comparisons(&ex.joints));
    let family_alpha = ex
        .results
        .iter()
        .flat_map(|r| r.steps.iter().chain(&r.rejected))
        .map(|c| c.family_alpha)
        .next()
        .unwrap_or(super::bootstrap::FAMILY_ALPHA);
    let level = super::bootstrap::interval_level(family_alpha, comparisons);
    for e in ALL_EFFECTS {
        let nj = (if e.is_contact() { n_axes } else { n_joints }).max(1) as f64;
        let mut f = Finding {
            effect: e,
            targets: vec![],
            significant: false,
            params: vec![],
            rmse_before: vec![],
            rmse_after: vec![],
            gain: 0.0,
            step_gain: 0.0,
            share: vec![],
            left: vec![],
            gain_ci: vec![],
            lr_test: vec![],
            comparisons,
            family_alpha,
            confounded: vec![],
            pooled: false,
            evidence: String::new(),
        };
        let mut ev_lines = Vec::new();
        for (r, js) in ex.results.iter().zip(&ex.joints) {
            if let Some(c) = r.steps.iter().find(|c| c.effect == e) {
                f.significant = true;
                f.targets.push(r.joint);
                f.params.push((r.joint, effect_params(e, &r.final_eval, js)));
                f.rmse_before.push((r.joint, rmse(c.before_ssr, r.n)));
                f.rmse_after.push((r.joint, c.eval.heldout_rmse()));
                f.gain += (c.before_ssr - c.eval.heldout_ssr) / r.nominal.heldout_ssr.max(1e-300) / nj;
                f.step_gain += c.gain;
                let nom = r.nominal.heldout_ssr.max(1e-300);
                f.share.push((r.joint, ((c.before_ssr - c.eval.heldout_ssr) / nom).clamp(0.0, 1.0)));
                f.left.push((r.joint, (r.final_eval.heldout_ssr / nom).clamp(0.0, 1.0)));
                // the test's own interval (computed when the candidate was scored)
                f.gain_ci.push((r.joint, c.gain_interval.unwrap_or((f64::NAN, f64::NAN)), 1.0 - 2.0 * c.test_level));
                if let Some(t) = c.lr_test {
                    f.lr_test.push((r.joint, (t.statistic, t.p_value)));
                }
                f.pooled |= c.pooled;
                if !c.confounded.is_empty() {
                    f.confounded.push((r.joint, c.confounded.clone()));
                }
                ev_lines.push(evidence_line(r.joint, c, r.n));
            }
        }
        if !f.significant {
            // best non-significant attempt
            let best = ex
                .results
                .iter()
                .zip(&ex.joints)
                .filter_map(|(r, js)| r.rejected.iter().find(|c| c.effect == e).map(|c| (r, js, c)))
                .max_by(|a, b| a.2.gain.total_cmp(&b.2.gain));
            let Some((r, js, c)) = best else { continue };
            f.targets.push(r.joint);
            f.params.push((r.joint, effect_params(e, &c.eval, js)));
            f.rmse_before.push((r.joint, rmse(c.before_ssr, r.n)));
            f.rmse_after.push((r.joint, c.eval.heldout_rmse()));
            f.gain = ((c.before_ssr - c.eval.heldout_ssr) / r.nominal.heldout_ssr.max(1e-300) / nj).max(0.0);
            f.step_gain = c.gain;
            ev_lines.push(format!("not significant; best: {}", evidence_line(r.joint, c, r.n)));
        }
        f.gain = f.gain.clamp(0.0, 1.0);
        if f.significant {
            f.step_gain /= f.targets.len() as f64;
        }
        f.evidence = format!("{}. {}", e.meaning(), ev_lines.join("; "));
        if let Some(dt) = sub_sample_delay(&f, ex) {
            f.evidence = format!(
                "{} (shorter than one sample period of the data, {:.3} ms: the data cannot tell it from its own sampling \
                 convention, e.g. a torque computed with q̈ taken as a one-sided difference of q̇, which lags by about half a sample)",
                f.evidence,
                dt * 1e3
            );
        }
        if f.is_small() {
            f.evidence = format!("{} ({})", f.evidence, f.small_note());
        }
        if !f.confounded.is_empty() {
            let cs: Vec<String> = f
                .confounded
                .iter()
                .map(|(j, es)| {
                    let names: Vec<&str> = es.iter().map(|e| e.name()).collect();
                    format!("{} on {}", names.join(" or "), if crate::contact::is_axis(*j) { jkey(*j) } else { format!("joint {j}") })
                })
                .collect();
            f.evidence = format!(
                "{}. Confounded: the data cannot tell it from {} (neither is better than the other by the test; the one with fewer parameters is named)",
                f.evidence.trim_end_matches('.'),
                cs.join(", ")
            );
        }
        if !f.lr_test.is_empty() {
            // friction points: the likelihood-ratio test decided; the block interval is reported
            let ps: Vec<String> = f.lr_test.iter().map(|&(j, (t, p))| format!("J{j} T {t:.3}, p {p:.4}")).collect();
            let cis: Vec<String> = f.gain_ci.iter().map(|&(j, (lo, hi), _)| format!("J{j} [{lo:+.4}, {hi:+.4}]")).collect();
            f.evidence = format!(
                "{}. The test (friction points): likelihood ratio of the whole-data fits against the model before, the larger of the two directions' ln(SSR before / SSR after), its law from {} residual-bootstrap replicates within each direction; significant at p ≤ {} %/{} (Bonferroni over candidates × targets): {}. Held-out gain interval at {:.4} % (block bootstrap, reported, not the test here): {}",
                f.evidence.trim_end_matches('.'),
                crate::analysis::points_test::REPLICATES,
                100.0 * family_alpha,
                comparisons,
                ps.join(", "),
                100.0 * level,
                cis.join(", ")
            );
        } else if !f.gain_ci.is_empty() {
            let cis: Vec<String> = f
                .gain_ci
                .iter()
                .map(|&(j, (lo, hi), lv)| format!("{} [{lo:+.4}, {hi:+.4}] at {:.4} %", if crate::contact::is_axis(j) { jkey(j) } else { format!("J{j}") }, 100.0 * lv))
                .collect();
            f.evidence = format!(
                "{}. Held-out gain interval (the test, its low end above zero: block bootstrap over time blocks{}, one-sided, family-wise {} % over {} candidates × targets: {}): {}",
                f.evidence.trim_end_matches('.'),
                if f.pooled { " of every joint together (one correction of the whole arm: the pooled test, the mean of the joints' gains, the same interval on every joint)" } else { "" },
                100.0 * family_alpha,
                comparisons,
                if f.pooled { "its level α/m" } else { "each joint's share α·m_j/m, its level balanced over the joint's candidates, never below α/m" },
                cis.join(", ")
            );
        }
        out.push(f);
    }
    out.sort_by(|a, b| b.significant.cmp(&a.significant).then(b.gain.total_cmp(&a.gain)));
    out
}

pub(super) fn map_of(pairs: &[(usize, f64)]) -> Value {
    let mut m = Map::new();
    for &(j, v) in pairs {
        m.insert(jkey(j), json!(v));
    }
    Value::Object(m)
}

/// Per-direction held-out RMSE (out-of-fold residuals) of an Eval.
pub fn direction_rmse(js: &JointSamples, ev: &Eval, sh: &NominalShape) -> (f64, f64) {
    let (oof, _) = residuals(js, ev, sh);
    split_rmse(js, &oof)
}

/// Per-direction in-sample RMSE √(SSR/n) of the whole-data fit.
pub fn direction_rmse_insample(js: &JointSamples, ev: &Eval, sh: &NominalShape) -> (f64, f64) {
    let (_, ins) = residuals(js, ev, sh);
    split_rmse(js, &ins)
}

pub(super) fn split_rmse(js: &JointSamples, oof: &[f64]) -> (f64, f64) {
    let (mut sp, mut np, mut sn, mut nn) = (0.0, 0usize, 0.0, 0usize);
    for (i, r) in oof.iter().enumerate() {
        if js.is_validation(i) {
            continue;
        }
        if js.s[i] > 0.0 {
            sp += r * r;
            np += 1;
        } else if js.s[i] < 0.0 {
            sn += r * r;
            nn += 1;
        }
    }
    (rmse(sp, np), rmse(sn, nn))
}
