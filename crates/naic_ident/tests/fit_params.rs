//! Parameter files written from a fit: every form's report becomes a `FrictionParams`
//! (`FitReport::to_params`) that round-trips through YAML unchanged, and
//! params/friction_jk5_refit.yaml is reproduced by the fit on the JK5 data.

use naic_core::friction::{Ci95, FrictionParams};
use naic_ident::{fit, FitForm, FitOptions, FrictionData};
use std::path::PathBuf;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn fitted_params_of_every_form_round_trip() {
    let data = {
        let mut pts = Vec::new();
        for k in 1..=30 {
            let v = k as f64 * 0.01;
            pts.push((1, v, 1.0 + 0.5 * v + 0.01 * ((k * 7 % 5) as f64 - 2.0)));
            pts.push((1, -v, -1.2 + 0.6 * -v + 0.01 * ((k * 3 % 5) as f64 - 2.0)));
        }
        FrictionData::from_points("g", &pts).unwrap()
    };
    let mut q = FrictionParams { source: "fit round trip".into(), notes: None, smoothing_v_s: None, joints: vec![] };
    for (joint, form) in [(1, FitForm::PerDirection), (2, FitForm::Symmetric), (3, FitForm::CoulombViscous)] {
        let rep = fit(&data, &FitOptions { form, ..FitOptions::default() }).unwrap();
        let mut jp = rep.to_params("x").joints.remove(0);
        jp.joint = joint;
        q.joints.push(jp);
    }
    let text = q.to_yaml_string();
    let back = FrictionParams::from_yaml_str("rt", &text).unwrap();
    assert_eq!(q, back, "{text}");
    assert_eq!(back.to_model().unwrap().n_joints(), 3);
}

fn jk5_data_dir() -> PathBuf {
    let mut cands = vec![repo().join("../shared/data/jk5-friction")];
    if let Ok(s) = std::env::var("NAIC_SHARED") {
        cands.push(PathBuf::from(s).join("data/jk5-friction"));
    }
    cands.into_iter().find(|d| d.is_dir()).unwrap_or_else(|| {
        panic!("jk5-friction data not found: expected ../shared/data/jk5-friction beside the repo (or set NAIC_SHARED)")
    })
}

#[test]
fn refit_params_file_is_reproduced_by_the_fit() {
    // params/friction_jk5_refit.yaml = `naic friction fit --data …gravity_removed.csv --min-speed 0.0005`.
    let saved = FrictionParams::from_yaml_file(repo().join("params/friction_jk5_refit.yaml")).unwrap();
    assert_eq!(saved.to_model().unwrap().n_joints(), 6);
    let data = FrictionData::from_csv_file(jk5_data_dir().join("segment_means_gravity_removed.csv")).unwrap();
    let rep = fit(&data, &FitOptions { min_speed: 0.0005, ..FitOptions::default() }).unwrap();
    let now = rep.to_params("now");
    for (a, b) in saved.joints.iter().zip(&now.joints) {
        assert_eq!(a.joint, b.joint);
        for (sa, sb) in [(&a.stats.positive, &b.stats.positive), (&a.stats.negative, &b.stats.negative)] {
            // Same optimum: every parameter within 1e-3 of its interval half-width.
            for ((name, ca), (_, cb)) in sa.ci95.iter().zip(&sb.ci95) {
                if let (Ci95::Interval { lo, hi }, Ci95::Interval { lo: lo2, hi: hi2 }) = (ca, cb) {
                    let tol = 1e-3 * 0.5 * (hi - lo);
                    assert!(((lo + hi) - (lo2 + hi2)).abs() * 0.5 <= tol, "joint {} {name}", a.joint);
                } else {
                    assert_eq!(ca, cb, "joint {} {name}", a.joint);
                }
            }
            let (ra, rb) = (sa.rmse.unwrap(), sb.rmse.unwrap());
            assert!((ra - rb).abs() <= 1e-6 * ra, "joint {}: rmse {ra} vs {rb}", a.joint);
        }
    }
}
