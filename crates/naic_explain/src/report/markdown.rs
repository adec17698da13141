//! `report.md`: the text report written from `report.json`'s values.

use super::findings::{jkey, Finding};
use super::json::MOSTLY_LEFT;
use crate::analysis::Col;
use crate::Explained;
use serde_json::Value;
use std::fmt::Write;

pub(super) fn report_md(ex: &Explained, fs: &[Finding], v: &Value, plots: &[(String, String)]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# naic explain: {}\n", ex.path);
    let rb = if ex.kind == crate::input::Kind::FrictionPoints { "" } else { "rigid body of the robot model (see Method) + " };
    let _ = writeln!(s, "Kind: **{}**, {} samples. Nominal model: {rb}{}.\n", ex.kind.name(), ex.samples, ex.nominal_source);
    let any_sig = fs.iter().any(|f| f.significant);
    if let Some(total) = v["explained"]["all_joints"].as_f64().filter(|_| any_sig) {
        if total < MOSTLY_LEFT {
            let _ = writeln!(
                s,
                "**Most of the residual is left**: the findings explain {:.0} % of the nominal model's held-out mean-square residual \
                 (over all joints); {:.0} % is not explained by anything in the catalogue. See \"Held-out RMSE per joint\".\n",
                100.0 * total,
                100.0 * (1.0 - total)
            );
        } else {
            let _ = writeln!(s, "The findings explain {:.0} % of the nominal model's held-out mean-square residual (over all joints).\n", 100.0 * total);
        }
    }
    let _ = writeln!(s, "## Method\n");
    for (k, m) in &ex.method {
        let _ = writeln!(s, "- {k}: {m}");
    }
    if ex.kind == crate::input::Kind::FrictionPoints {
        let alpha = fs.first().map_or(crate::analysis::bootstrap::FAMILY_ALPHA, |f| f.family_alpha);
        let _ = writeln!(
            s,
            "- significance: held-out gain ≥ 2 % of the joint's mean-square residual, BIC lower, and the test: the likelihood ratio of the whole-data fits (the larger of the two directions') with a bootstrap p-value ≤ {} %/(candidates × joints); candidates added greedily per joint\n",
            100.0 * alpha
        );
    } else {
        let alpha = fs.first().map_or(crate::analysis::bootstrap::FAMILY_ALPHA, |f| f.family_alpha);
        let _ = writeln!(
            s,
            "- significance: held-out gain ≥ 2 % of the joint's mean-square residual, BIC (effective sample count) lower, and the test: the block-bootstrap interval of the held-out gain above zero at a family-wise {} % over candidates × targets (each target's share, balanced over its candidates); candidates added greedily per joint\n",
            100.0 * alpha
        );
    }
    for n in &ex.notes {
        let _ = writeln!(s, "> {n}\n");
    }
    let sig: Vec<&Finding> = fs.iter().filter(|f| f.significant).collect();
    let _ = writeln!(s, "## Findings\n");
    if sig.is_empty() {
        let _ = writeln!(
            s,
            "**Nothing significant: {}.** No candidate extension improved the held-out fit by the rule above.\n",
            super::json::NO_EFFECT
        );
        let floor = super::json::noise_floor_pairs(ex);
        if !floor.is_empty() {
            let _ = writeln!(
                s,
                "Per joint, the torque noise floor after the filter (a robust σ of what the filter removes, scaled to its output) \
                 next to the nominal model's held-out RMSE [N·m]:\n\n| joint | noise floor | held-out RMSE |\n| --- | --- | --- |"
            );
            for (j, x) in floor {
                let r = ex.results.iter().find(|r| r.joint == j).map_or(f64::NAN, |r| r.nominal.heldout_rmse());
                let flag = if r > 2.0 * x { " (above twice the floor: structure no candidate names)" } else { "" };
                let _ = writeln!(s, "| {j} | {x:.4} | {r:.4}{flag} |");
            }
            let _ = writeln!(s);
        }
    } else {
        let _ = writeln!(s, "`gain` = share of the nominal held-out mean-square residual the effect removed (averaged over the joints, or over the sensor axes for contact effects); `step gain` = relative held-out reduction on its targets when it was added.\n");
        let _ = writeln!(s, "| rank | effect | targets | gain | step gain | parameters |\n| --- | --- | --- | --- | --- | --- |");
        for (i, f) in sig.iter().enumerate() {
            let ps: Vec<String> = f
                .params
                .iter()
                .map(|(j, p)| format!("{}: {}", if crate::contact::is_axis(*j) { jkey(*j) } else { format!("J{j}") }, p.iter().map(|(k, v)| format!("{k} {v:.4}")).collect::<Vec<_>>().join(", ")))
                .collect();
            let _ = writeln!(
                s,
                "| {} | `{}`{} | {} | {:.4} | {:.3} | {} |",
                i + 1,
                f.effect.name(),
                if f.is_small() { format!(" ({})", f.small_note()) } else { String::new() },
                f.targets.iter().map(|&j| if crate::contact::is_axis(j) { jkey(j) } else { j.to_string() }).collect::<Vec<_>>().join(", "),
                f.gain,
                f.step_gain,
                ps.join("; ")
            );
        }
        let _ = writeln!(s);
        for f in &sig {
            let _ = writeln!(s, "- **{}**: {}", f.effect.name(), f.evidence);
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(s, "### Checked, not significant\n");
    for f in fs.iter().filter(|f| !f.significant) {
        let _ = writeln!(s, "- `{}`: {}", f.effect.name(), f.evidence);
    }
    let _ = writeln!(s, "\n## Held-out RMSE per joint [N·m]\n");
    let _ = writeln!(s, "| joint | nominal | extended | explained | extended + | extended − | model |\n| --- | --- | --- | --- | --- | --- | --- |");
    for r in ex.results.iter().filter(|r| !crate::contact::is_axis(r.joint)) {
        let k = jkey(r.joint);
        let d = &v["extended"]["heldout_rmse_by_direction"][&k];
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4} | {:.0} % | {:.4} | {:.4} | {} |",
            r.joint,
            r.nominal.heldout_rmse(),
            r.final_eval.heldout_rmse(),
            100.0 * v["explained"][&k].as_f64().unwrap_or(f64::NAN),
            d["extended"]["positive"].as_f64().unwrap_or(f64::NAN),
            d["extended"]["negative"].as_f64().unwrap_or(f64::NAN),
            r.final_eval.full_structure.effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
        );
    }
    if let Some(val) = v["validation"].as_object() {
        let _ = writeln!(s, "\n## RMSE on the validation runs [N·m]\n\nModels fitted on all of the fit runs, scored on the whole validation runs.\n");
        let _ = writeln!(s, "| joint | samples | nominal | extended | baseline (classical) |\n| --- | --- | --- | --- | --- |");
        for (k, d) in val {
            let _ = writeln!(
                s,
                "| {} | {} | {:.4} | {:.4} | {:.4} |",
                k.trim_start_matches("joint"),
                d["samples"],
                d["nominal_rmse"].as_f64().unwrap_or(f64::NAN),
                d["extended_rmse"].as_f64().unwrap_or(f64::NAN),
                v["baseline"]["joints"][k]["validation_rmse"].as_f64().unwrap_or(f64::NAN)
            );
        }
    }
    if let Some(b) = v["baseline"]["joints"].as_object() {
        let _ = writeln!(
            s,
            "\n## Baseline: classical identification on the same samples [N·m]\n\n{} base parameters of the rigid body by least squares + per-joint \
             viscous, Coulomb and offset friction, fitted from nothing (the URDF's inertials are not used); held-out on the same time blocks. \
             `URDF, no friction` is τ − RNEA of the robot model, nothing fitted.\n",
            v["baseline"]["base_parameters"].as_object().map_or(0, |m| m.len())
        );
        let _ = writeln!(s, "| joint | URDF, no friction | nominal | extended | baseline | baseline f_v | f_c | f_o |\n| --- | --- | --- | --- | --- | --- | --- | --- |");
        for r in ex.results.iter().filter(|r| !crate::contact::is_axis(r.joint)) {
            let d = &b[&jkey(r.joint)];
            let g = |k: &str| d[k].as_f64().unwrap_or(f64::NAN);
            let _ = writeln!(
                s,
                "| {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
                r.joint,
                g("urdf_rigid_body_rmse"),
                r.nominal.heldout_rmse(),
                r.final_eval.heldout_rmse(),
                g("heldout_rmse"),
                g("f_v"),
                g("f_c"),
                g("f_o")
            );
        }
    }
    inertial_md(v, &mut s);
    if ex.results.iter().any(|r| crate::contact::is_axis(r.joint)) {
        let _ = writeln!(s, "\n## Held-out RMSE per sensor axis [N, N·m]\n");
        let _ = writeln!(s, "| axis | nominal | extended | nominal k [N/m], h [m] | model |\n| --- | --- | --- | --- | --- |");
        for r in ex.results.iter().filter(|r| crate::contact::is_axis(r.joint)) {
            let _ = writeln!(
                s,
                "| {} | {:.4} | {:.4} | {:.1}, {:.5} | {} |",
                jkey(r.joint),
                r.nominal.heldout_rmse(),
                r.final_eval.heldout_rmse(),
                r.nominal.coef(Col::Spring).unwrap_or(f64::NAN),
                r.nominal.full_structure.h,
                r.final_eval.full_structure.effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
            );
        }
    }
    lack_of_fit_md(ex, v, &mut s);
    let _ = writeln!(s, "\nExtended parameters: `extended_params.yaml` (loads with the project's friction loader).\n");
    let _ = writeln!(s, "## Plots\n");
    for (name, _) in plots {
        let _ = writeln!(s, "![{name}]({name})\n");
    }
    s
}

/// `report.md`'s section on the link inertials (`inertial_parameters`).
pub(super) fn inertial_md(v: &Value, s: &mut String) {
    let ip = &v["inertial_parameters"];
    if ip.is_null() {
        return;
    }
    let f = |k: &str| ip[k].as_f64().unwrap_or(f64::NAN);
    let _ = writeln!(
        s,
        "\n## Link inertials (`inertial_parameters`)\n\nAll joints together, the {} base parameters of the robot model refitted on top of each \
         joint's final model: mean held-out gain {:.3}, better in {}/{} folds, ΔBIC {:.1}: **{}**.\n",
        ip["base_parameters"].as_object().map_or(0, |m| m.len()),
        f("mean_heldout_gain"),
        ip["folds_won"],
        ip["folds"],
        f("delta_bic"),
        if ip["significant"].as_bool() == Some(true) { "significant" } else { "not significant" }
    );
    let vc = &ip["versus_a_constant_on_every_joint"];
    if !vc.is_null() {
        let _ = writeln!(
            s,
            "Against a constant torque on every joint (fewer parameters; the base parameters must beat them as well): mean held-out \
             gain {:.3}, better in {}/{} folds, ΔBIC {:.1}.\n",
            vc["mean_heldout_gain"].as_f64().unwrap_or(f64::NAN),
            vc["folds_won"],
            ip["folds"],
            vc["delta_bic"].as_f64().unwrap_or(f64::NAN)
        );
    }
    if ip["significant"].as_bool() != Some(true) {
        return;
    }
    if let Some(a) = ip["first_pass_effects_set_aside"].as_array().filter(|a| !a.is_empty()) {
        let list: Vec<String> = a.iter().map(|x| format!("`{}` on {}", x["effect"].as_str().unwrap_or("?"), x["target"].as_str().unwrap_or("?"))).collect();
        let _ = writeln!(
            s,
            "Set aside beside the base parameters (found by the per-joint catalogue first, no longer significant beside them: \
             a stand-in for the link inertials): {}.\n",
            list.join(", ")
        );
    }
    let _ = writeln!(s, "| base parameter | URDF | identified |\n| --- | --- | --- |");
    if let Some(b) = ip["base_parameters"].as_object() {
        for (n, d) in b {
            let _ = writeln!(s, "| `{n}` | {:.5} | {:.5} |", d["urdf"].as_f64().unwrap_or(f64::NAN), d["identified"].as_f64().unwrap_or(f64::NAN));
        }
    }
    match ip["links"].as_object() {
        Some(ls) if !ls.contains_key("error") => {
            let _ = writeln!(
                s,
                "\nPer link, the completion closest to the URDF (one of many: the base parameters fix combinations only):\n\n\
                 | link | mass URDF → corrected [kg] | centre of mass URDF → corrected [m] | physically consistent |\n| --- | --- | --- | --- |"
            );
            for (n, d) in ls {
                let com = |x: &Value| x.as_array().map(|a| a.iter().map(|c| format!("{:.4}", c.as_f64().unwrap_or(f64::NAN))).collect::<Vec<_>>().join(", ")).unwrap_or_default();
                let _ = writeln!(
                    s,
                    "| {n} | {:.3} → {:.3} | ({}) → ({}) | {} |",
                    d["urdf"]["mass_kg"].as_f64().unwrap_or(f64::NAN),
                    d["corrected"]["mass_kg"].as_f64().unwrap_or(f64::NAN),
                    com(&d["urdf"]["com_m"]),
                    com(&d["corrected"]["com_m"]),
                    d["problem"].as_str().map_or("yes".to_string(), |p| format!("no: {p}"))
                );
            }
        }
        _ => {
            let _ = writeln!(s, "\nPer-link completion: {}", ip["links"]["error"].as_str().unwrap_or("not available"));
        }
    }
}

/// `report.md`'s section on what is left (friction points), from `report.json`'s `lack_of_fit`.
pub(super) fn lack_of_fit_md(ex: &Explained, v: &Value, s: &mut String) {
    use crate::lack_of_fit::LACK_OF_FIT_MS_RATIO;
    let Some(lof) = v["lack_of_fit"].as_object() else { return };
    let _ = writeln!(s, "\n## What is left: held-out residual against the data's noise floor [N·m]\n");
    let _ = writeln!(
        s,
        "The floor is the points' own scatter: neighbour differences along speed of the extended model's residual, which \
         remove any smooth function of speed, so no law of speed alone can do better held-out. **Structure left** = held-out \
         mean square ≥ {LACK_OF_FIT_MS_RATIO}× the floor's: the residual there is not noise, and no catalogue effect explains \
         it. Noise alone crosses 2 in about 1–4 % of directions (measured on generated data) and did not reach 3.\n"
    );
    let reference = lof.get("reference").and_then(Value::as_str);
    if let Some(p) = reference {
        let _ = writeln!(s, "Reference: `{p}` as given, on the same points, √(SSE/(n − p)) with p its parameters per direction (the RMSE of the paper's Table 1).\n");
    }
    let (ref_head, ref_rule) = if reference.is_some() { (" reference |", " --- |") } else { ("", "") };
    let _ = writeln!(s, "| joint | dir | points | floor | extended held-out | mean-square ratio | |{ref_head}\n| --- | --- | --- | --- | --- | --- | --- |{ref_rule}");
    for r in &ex.results {
        for (name, key) in [("+", "positive"), ("−", "negative")] {
            let d = &lof.get(&jkey(r.joint)).unwrap_or(&Value::Null)[key];
            let (Some(floor), Some(heldout), Some(ratio)) = (d["floor_rmse"].as_f64(), d["heldout_rmse"].as_f64(), d["ms_ratio"].as_f64()) else {
                continue;
            };
            let flag = if d["lack_of_fit"].as_bool() == Some(true) { "**structure left**" } else { "noise level" };
            let rf = match (reference, d["reference_rmse_dfe"].as_f64()) {
                (Some(_), Some(x)) => format!(" {x:.4} |"),
                (Some(_), None) => " – |".into(),
                _ => String::new(),
            };
            let _ = writeln!(s, "| {} | {name} | {} | {floor:.4} | {heldout:.4} | {ratio:.2} | {flag} |{rf}", r.joint, d["points"]);
        }
    }
}
