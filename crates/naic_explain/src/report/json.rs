//! The `report.json` model (schema of issue 6).

use super::findings::{direction_rmse, direction_rmse_insample, effect_params, jkey, map_of, Finding};
use crate::analysis::{Col, JointResult};
use crate::catalogue::Effect;
use crate::Explained;
use serde_json::{json, Map, Value};

/// The `report.json` value.
pub fn report_json(ex: &Explained, fs: &[Finding], params_file: &str) -> Value {
    let nominal: Vec<(usize, f64)> = ex.results.iter().map(|r| (r.joint, r.nominal.heldout_rmse())).collect();
    let extended: Vec<(usize, f64)> = ex.results.iter().map(|r| (r.joint, r.final_eval.heldout_rmse())).collect();
    let findings: Vec<Value> = fs
        .iter()
        .map(|f| {
            let mut params = Map::new();
            for (j, ps) in &f.params {
                let mut m = Map::new();
                for (k, v) in ps {
                    m.insert(k.clone(), json!(v));
                }
                params.insert(jkey(*j), Value::Object(m));
            }
            if f.effect == Effect::Payload && f.significant && !f.params.is_empty() {
                // combined estimate: median over the target joints
                let mut ms: Vec<f64> = f.params.iter().filter_map(|(_, p)| p.first().map(|x| x.1)).collect();
                ms.sort_by(f64::total_cmp);
                params.insert("mass_kg_median".into(), json!(ms[ms.len() / 2]));
            }
            json!({
                "effect": f.effect.name(),
                "targets": f.targets.iter().map(|&j| jkey(j)).collect::<Vec<_>>(),
                "significant": f.significant,
                "params": Value::Object(params),
                "heldout_rmse_before": map_of(&f.rmse_before),
                "heldout_rmse_after": map_of(&f.rmse_after),
                "gain": f.gain,
                "step_gain": f.step_gain,
                "share_of_joint_residual": map_of(&f.share),
                "share_left": map_of(&f.left),
                "small": f.is_small(),
                "sub_sample_delay": super::findings::sub_sample_delay(f, ex).is_some(),
                // the step's held-out gain per target, block-bootstrap interval: the significance
                // test (significant when its low end, a one-sided bound, is above zero), and per
                // target its two-sided level (≤ the Bonferroni level 1 − 2·α/comparisons: the
                // level balanced over the joint's candidates, analysis::family_test)
                "gain_interval": f.gain_ci.iter().map(|&(j, (lo, hi), _)| (jkey(j), json!([lo, hi]))).collect::<Map<_, _>>(),
                "interval_level": f.gain_ci.iter().map(|&(j, _, lv)| (jkey(j), json!(lv))).collect::<Map<_, _>>(),
                "bonferroni_interval_level": super::bootstrap::interval_level(f.family_alpha, f.comparisons),
                // friction points: the test that decided, per target the likelihood ratio T and its
                // bootstrap p-value (significant at p ≤ family_wise_alpha / comparisons); empty for
                // time series, where gain_interval is the test
                "lr_test": f.lr_test.iter().map(|&(j, (t, p))| (jkey(j), json!({"statistic": t, "p_value": p}))).collect::<Map<_, _>>(),
                "comparisons": f.comparisons,
                // decided by the pooled test over every joint's time blocks (gain_interval is its interval)
                "pooled_test": f.pooled,
                "family_wise_alpha": f.family_alpha,
                // per target: the significant candidates the data could not tell from this one
                "confounded_with": f.confounded.iter().map(|(j, es)| (jkey(*j), json!(es.iter().map(|e| e.name()).collect::<Vec<_>>()))).collect::<Map<_, _>>(),
                "evidence": f.evidence,
            })
        })
        .collect();
    let mut per_dir = Map::new();
    let mut contact = Map::new();
    for ((r, js), sh) in ex.results.iter().zip(&ex.joints).zip(ex.joints.iter().map(|js| ex.shapes.get(js.joint - 1).copied().unwrap_or_default())) {
        if js.contact {
            let st = &r.final_eval.full_structure;
            let mut m = Map::new();
            m.insert("nominal".into(), json!({"k_n_per_m": r.nominal.coef(Col::Spring), "surface_height_m": r.nominal.full_structure.h}));
            let mut ext = Map::new();
            ext.insert("model".into(), json!(st.effects.iter().map(|e| e.name()).collect::<Vec<_>>()));
            ext.insert("k".into(), json!(r.final_eval.coef(Col::Spring)));
            ext.insert("n".into(), json!(st.n_exp));
            ext.insert("surface_height_m".into(), json!(st.h));
            for e in &st.effects {
                for (k, v) in effect_params(*e, &r.final_eval, js) {
                    ext.insert(k, json!(v));
                }
            }
            m.insert("extended".into(), Value::Object(ext));
            contact.insert(jkey(r.joint), Value::Object(m));
            continue;
        }
        let (np, nn) = direction_rmse(js, &r.nominal, &sh);
        let (ep, en) = direction_rmse(js, &r.final_eval, &sh);
        let (ip, inn) = direction_rmse_insample(js, &r.final_eval, &sh);
        per_dir.insert(
            jkey(r.joint),
            json!({"nominal": {"positive": np, "negative": nn}, "extended": {"positive": ep, "negative": en},
                   "extended_insample": {"positive": ip, "negative": inn},
                   "model": r.final_eval.full_structure.effects.iter().map(|e| e.name()).collect::<Vec<_>>()}),
        );
    }
    let joints: Vec<&JointResult> = ex.results.iter().filter(|r| !crate::contact::is_axis(r.joint)).collect();
    let validation: Map<String, Value> = joints
        .iter()
        .filter_map(|r| {
            Some((jkey(r.joint), json!({"samples": r.final_eval.val_n, "nominal_rmse": r.nominal.validation_rmse()?,
                "extended_rmse": r.final_eval.validation_rmse()?})))
        })
        .collect();
    json!({
        "data": {"path": ex.path, "kind": ex.kind.name(), "samples": ex.samples},
        "explained": explained_json(&joints),
        "baseline": baseline_json(ex),
        "validation": if validation.is_empty() { Value::Null } else { Value::Object(validation) },
        "nominal": {"heldout_rmse": map_of(&nominal), "model": ex.nominal_source},
        // per joint, the torque noise after the filter (time series; `Prepared::noise_floor`)
        "noise_floor": map_of(&noise_floor_pairs(ex)),
        "verdict": if fs.iter().any(|f| f.significant) { "findings" } else { NO_EFFECT },
        "findings": findings,
        "extended": {"heldout_rmse": map_of(&extended), "params_file": params_file, "heldout_rmse_by_direction": Value::Object(per_dir)},
        "contact_model": Value::Object(contact),
        "outliers": ex.outliers.iter().map(|o| json!({"joint": jkey(o.joint), "line": o.line, "velocity_rad_s": o.velocity,
            "torque_nm": o.torque, "residual_nm": o.residual, "robust_sigma_nm": o.sigma})).collect::<Vec<_>>(),
        "extended_before_outlier_removal": ex.first_pass.iter().map(|&(j, a, p, n)| (jkey(j), json!({"heldout_rmse": a, "positive": p, "negative": n}))).collect::<Map<_, _>>(),
        "method": ex.method.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<Map<_, _>>(),
        "notes": ex.notes,
        "lack_of_fit": lack_of_fit_json(ex),
        "inertial_parameters": inertial_json(ex),
    })
}

/// The verdict when nothing is significant (report.json `verdict`, report.md, the CLI).
pub const NO_EFFECT: &str = "no effect beyond noise";

/// (joint, noise floor) of the time series' joints (none for friction points).
pub fn noise_floor_pairs(ex: &Explained) -> Vec<(usize, f64)> {
    ex.noise_floor.iter().enumerate().map(|(j, &x)| (j + 1, x)).collect()
}

/// The corrected link inertials (completion closest to the URDF), when the stage is significant.
pub fn inertial_links(ex: &Explained) -> Option<Result<Vec<crate::inertial::LinkChange>, crate::inertial::InertialError>> {
    let fit = ex.inertial.as_ref().filter(|f| f.significant)?;
    let model = naic_core::model::Model::from_urdf_file(&ex.urdf).map_err(crate::inertial::InertialError::from);
    Some(model.and_then(|m| crate::inertial::corrected_links(&m, &ex.urdf, fit)))
}

/// `report.json`'s `inertial_parameters`: the all-joint stage, the corrected base
/// parameters next to the URDF's, and per link the corrected completion (`null` when the
/// stage did not run).
pub(super) fn inertial_json(ex: &Explained) -> Value {
    let Some(fit) = &ex.inertial else { return Value::Null };
    let base: Map<String, Value> = fit
        .names
        .iter()
        .zip(fit.urdf_beta.iter().zip(fit.corrected()))
        .map(|(n, (u, c))| (n.clone(), json!({"urdf": u, "identified": c})))
        .collect();
    let inertia = |y: &naic_core::dynamics::spatial::Inertia| {
        let i = &y.inertia;
        json!({"mass_kg": y.mass, "com_m": [y.com.x, y.com.y, y.com.z],
               "inertia_about_com_kgm2": {"ixx": i[(0, 0)], "iyy": i[(1, 1)], "izz": i[(2, 2)], "ixy": i[(0, 1)], "ixz": i[(0, 2)], "iyz": i[(1, 2)]}})
    };
    let links = match inertial_links(ex) {
        None => Value::Null,
        Some(Err(e)) => json!({"error": e.to_string()}),
        Some(Ok(ls)) => Value::Object(
            ls.iter()
                .map(|l| (l.link.clone(), json!({"urdf": inertia(&l.urdf), "corrected": inertia(&l.corrected), "physically_consistent": l.inconsistent.is_none(), "problem": l.inconsistent})))
                .collect(),
        ),
    };
    json!({
        "method": "all joints together: Y_B δβ (base parameters of the robot model's regressor) + each joint's nominal friction \
                   (Coulomb, viscous), a constant where it passes the per-joint rule beside Y_B, and first-pass rotor_inertia / \
                   payload, held out on the same folds, against the same columns without Y_B; BIC counts every base parameter. \
                   Significant only when Y_B also beats a constant on every joint by the same rule (versus_a_constant_on_every_joint: \
                   where the data cannot tell the base parameters from per-joint constants, the constants have fewer parameters). \
                   When significant, a first-pass rotor_inertia that no longer passes \
                   the per-joint rule beside Y_B is set aside and δβ refitted without it. Corrected base \
                   parameters = K π_URDF + δβ. Links: the completion of δβ closest to the URDF (weighted minimum norm), one of many — \
                   base parameters do not fix the link inertials one by one",
        "significant": fit.significant,
        "mean_heldout_gain": fit.gain,
        "heldout_gain_per_joint": fit.joint_gain.iter().enumerate().map(|(j, g)| (jkey(j + 1), json!(g))).collect::<Map<_, _>>(),
        "folds_won": fit.fold_wins,
        "folds": fit.folds,
        "delta_bic": fit.delta_bic,
        "versus_a_constant_on_every_joint": fit.versus_constants.as_ref().map(|t| json!({
            "mean_heldout_gain": t.gain,
            "heldout_gain_per_joint": t.joint_gain.iter().enumerate().map(|(j, g)| (jkey(j + 1), json!(g))).collect::<Map<_, _>>(),
            "folds_won": t.fold_wins,
            "delta_bic": t.delta_bic,
        })),
        "constant_beside_base": fit.constants.iter().map(|j| jkey(*j)).collect::<Vec<_>>(),
        "first_pass_effects_set_aside": fit.set_aside.iter().map(|(j, e)| json!({"target": jkey(*j), "effect": e.name()})).collect::<Vec<_>>(),
        "base_parameters": Value::Object(base),
        "links": links,
    })
}

/// `report.json`'s `baseline` (see [`crate::baseline`]; `null` when it was not fitted).
pub(super) fn baseline_json(ex: &Explained) -> Value {
    let Some(b) = &ex.baseline else { return Value::Null };
    let mut per = Map::new();
    for j in 0..b.nj {
        let (fv, fc, fo) = b.friction(j);
        per.insert(
            jkey(j + 1),
            json!({"heldout_rmse": b.heldout_rmse[j], "validation_rmse": b.validation_rmse.get(j),
                   "urdf_rigid_body_rmse": b.urdf_rmse[j], "f_v": fv, "f_c": fc, "f_o": fo}),
        );
    }
    let base: Map<String, Value> = ex.baseline_names.iter().zip(&b.theta).map(|(n, v)| (n.clone(), json!(v))).collect();
    json!({
        "model": "base parameters of the rigid body (least squares on the joint-torque regressor, pivoted-QR column selection) + per joint f_v q̇ + f_c sgn(q̇) + f_o; same samples, folds and validation runs as the extended model",
        "base_parameters": base,
        "joints": Value::Object(per),
    })
}

/// Below this share of the nominal held-out mean square explained (over all joints),
/// the report says that most of the residual is left.
pub const MOSTLY_LEFT: f64 = 0.5;

/// `report.json`'s `explained`: per joint and over all joints, the share of the nominal
/// model's held-out mean-square residual that the extended model removes.
pub(super) fn explained_json(joints: &[&JointResult]) -> Value {
    let mut m = Map::new();
    let (mut nom, mut ext) = (0.0, 0.0);
    for r in joints {
        let (a, b) = (r.nominal.heldout_ssr / r.nominal.n.max(1) as f64, r.final_eval.heldout_ssr / r.final_eval.n.max(1) as f64);
        nom += a;
        ext += b;
        m.insert(jkey(r.joint), json!(if a > 0.0 { 1.0 - b / a } else { 0.0 }));
    }
    let total = if nom > 0.0 { 1.0 - ext / nom } else { 0.0 };
    m.insert("all_joints".into(), json!(total));
    m.insert("method".into(), json!("1 − (extended held-out mean square)/(nominal held-out mean square); all_joints sums the mean squares over the joints"));
    Value::Object(m)
}

/// `report.json`'s `lack_of_fit`: per joint and direction, the data's noise floor against
/// the extended model's held-out residual (friction points only; `null` otherwise).
pub(super) fn lack_of_fit_json(ex: &Explained) -> Value {
    use crate::lack_of_fit::{lack_of_fit, DirectionFit, LACK_OF_FIT_MIN_POINTS, LACK_OF_FIT_MS_RATIO};
    let rows = lack_of_fit(ex);
    if rows.is_empty() {
        return Value::Null;
    }
    let dir = |d: &Option<DirectionFit>| match d {
        Some(d) => json!({"points": d.points, "floor_rmse": d.floor_rmse, "heldout_rmse": d.heldout_rmse,
                          "ms_ratio": d.ms_ratio, "lack_of_fit": d.lack_of_fit, "reference_rmse_dfe": d.reference_rmse_dfe}),
        None => Value::Null,
    };
    let mut m = Map::new();
    m.insert(
        "method".into(),
        json!(format!(
            "floor_rmse = noise σ of the points from neighbour differences of the extended model's whole-data residual along \
             speed (Gasser, Sroka & Jennen-Steinmetz 1986; the differences remove any smooth function of speed); lack_of_fit when the extended model's held-out mean square ≥ \
             {LACK_OF_FIT_MS_RATIO} × floor² on ≥ {LACK_OF_FIT_MIN_POINTS} points: structure is left that no catalogue effect names"
        )),
    );
    if let Some((path, _)) = &ex.reference {
        m.insert("reference".into(), json!(path));
    }
    for r in &rows {
        m.insert(jkey(r.joint), json!({"positive": dir(&r.positive), "negative": dir(&r.negative)}));
    }
    Value::Object(m)
}
