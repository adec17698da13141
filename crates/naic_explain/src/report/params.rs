//! `extended_params.yaml`: the extended friction law of every joint in the friction schema.

use super::findings::{jkey, Finding};
use crate::analysis::{Col, Dir, JointResult, JointSamples, NominalShape};
use crate::catalogue::Effect;
use crate::Explained;
use naic_core::friction::{FrictionParams, JointFriction, JointParams, JointStats, StribeckParams};
use naic_ident::{fit, FitForm, FitOptions, FrictionData};
use std::fmt::Write;

pub(super) fn nonneg(x: f64) -> f64 {
    if x.is_finite() && x > 0.0 {
        x
    } else {
        0.0
    }
}

/// The extended friction law of one joint in the friction schema (eq. 5, per direction when
/// asymmetric). When the final model has terms the schema cannot hold (s·q̇²) or a level
/// came out negative, the model's friction part is evaluated at 200 speeds per direction
/// spanning the data and eq. 5 is fitted to it with the project's bounded fitter
/// (`naic_ident::fit`); the note gives the largest deviation.
pub fn extended_friction(r: &JointResult, js: &JointSamples, sh: &NominalShape, notes: &mut Vec<String>) -> JointFriction {
    let mut direct_notes = Vec::new();
    let direct = extended_friction_direct(r, sh, &mut direct_notes);
    let st = &r.final_eval.full_structure;
    if !st.has(Effect::ViscousNonlinearity) && direct_notes.is_empty() {
        return direct;
    }
    // speeds: quantiles of |v| per direction
    let mut pts = Vec::new();
    for dir in [1.0, -1.0] {
        let mut sp: Vec<f64> = (0..js.len()).filter(|&i| js.s[i] * dir > 0.0).map(|i| js.v[i].abs()).collect();
        if sp.is_empty() {
            continue;
        }
        sp.sort_by(f64::total_cmp);
        for k in 0..200 {
            let v = dir * sp[(k * (sp.len() - 1)) / 199];
            pts.push((1usize, v, crate::analysis::friction_part(&r.final_eval, sh, v)));
        }
    }
    let form = if st.has(Effect::FrictionAsymmetry) { FitForm::PerDirection } else { FitForm::Symmetric };
    let fitted = FrictionData::from_points("extended model", &pts)
        .ok()
        .and_then(|d| fit(&d, &FitOptions { form, ..Default::default() }).ok())
        .and_then(|rep| rep.joints.first().map(|j| j.friction));
    match fitted {
        Some(f) => {
            let dev = pts.iter().map(|&(_, v, t)| (f.tau_f(v) - t).abs()).fold(0.0, f64::max);
            notes.push(format!(
                "joint {}: the extended law ({}) is outside the eq. 5 schema; written as the eq. 5 {} fit to it at {} speeds (largest deviation {dev:.4} N·m).",
                r.joint,
                st.effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + "),
                form.name(),
                pts.len()
            ));
            f
        }
        None => {
            notes.extend(direct_notes);
            direct
        }
    }
}

pub(super) fn extended_friction_direct(r: &JointResult, sh: &NominalShape, notes: &mut Vec<String>) -> JointFriction {
    let ev = &r.final_eval;
    let st = &ev.full_structure;
    let strib = st.has(Effect::Stribeck);
    let branch = |d: Dir, q_s: f64, notes: &mut Vec<String>| -> StribeckParams {
        let f_a_raw = ev.coef(Col::Coul(d)).unwrap_or(0.0);
        let f_v_raw = ev.coef(Col::Visc(d)).unwrap_or(0.0);
        let (f_b_raw, q_s) = if strib {
            (f_a_raw + ev.coef(Col::Strib(d)).unwrap_or(0.0), q_s)
        } else {
            (f_a_raw * (1.0 + sh.r0), sh.q_s0)
        };
        let p = StribeckParams { f_a: nonneg(f_a_raw), f_b: nonneg(f_b_raw), q_s, f_v: nonneg(f_v_raw) };
        for (name, raw, v) in [("f_a", f_a_raw, p.f_a), ("f_b", f_b_raw, p.f_b), ("f_v", f_v_raw, p.f_v)] {
            if raw != v {
                notes.push(format!(
                    "joint {} ({:?}): fitted {name} = {raw:.4} is negative; written as 0 (the friction loader requires ≥ 0)",
                    r.joint, d
                ));
            }
        }
        p
    };
    if st.has(Effect::FrictionAsymmetry) {
        JointFriction::StribeckPerDirection {
            positive: branch(Dir::Pos, st.q_s_pos, notes),
            negative: branch(Dir::Neg, st.q_s_neg, notes),
        }
    } else {
        JointFriction::Stribeck(branch(Dir::Both, st.q_s_pos, notes))
    }
}

/// The extended parameter file (loadable by `FrictionParams::from_yaml_file`).
pub fn extended_params(ex: &Explained, fs: &[Finding]) -> FrictionParams {
    let mut notes = Vec::new();
    let mut joints = Vec::new();
    for (r, js) in ex.results.iter().zip(&ex.joints).filter(|(_, js)| !js.contact) {
        let sh = ex.shapes.get(r.joint - 1).copied().unwrap_or_default();
        joints.push(JointParams { joint: r.joint, friction: extended_friction(r, js, &sh, &mut notes), stats: JointStats::default() });
    }
    let mut extra = Vec::new();
    for f in fs.iter().filter(|f| f.significant) {
        if matches!(f.effect, Effect::FrictionAsymmetry | Effect::Stribeck | Effect::ViscousNonlinearity) {
            continue;
        }
        for (j, ps) in &f.params {
            let s: Vec<String> = ps.iter().map(|(k, v)| format!("{k} = {v:.5}")).collect();
            let name = if crate::contact::is_axis(*j) { format!("sensor axis {}", jkey(*j)) } else { format!("joint {j}") };
            extra.push(format!("{name}: {} ({})", f.effect.name(), s.join(", ")));
        }
    }
    let mut text = String::new();
    if !extra.is_empty() {
        let _ = write!(
            text,
            "Findings that are not part of the friction law (the friction schema cannot hold them; apply them separately): {}. ",
            extra.join("; ")
        );
    }
    if !notes.is_empty() {
        let _ = write!(text, "{}", notes.join(" "));
    }
    FrictionParams {
        source: format!(
            "naic explain on {} ({}): nominal eq. 5 symmetric + significant findings, fitted on all data (amplitudes by least squares, shapes by grid scan)",
            ex.path,
            ex.kind.name()
        ),
        notes: if text.is_empty() { None } else { Some(text) },
        smoothing_v_s: None,
        joints,
    }
}
