//! The fit recovers known parameters from generated noisy data, reports active bounds,
//! and rejects bad data with a message that names the row/column and the fix.
//!
//! Tolerance: the true value must lie inside the fit's own 95 % confidence interval.
//! Over 10 seeds a correctly calibrated interval misses in 10 × 5 % = 0.5 seeds on
//! average; P(≥ 4 misses of 10 | p = 0.05) ≈ 1e-3, so each parameter must be covered in at
//! least 7 of 10 seeds, and all parameters together in ≥ 85 % of the cases. The seeds are
//! fixed, so the outcome is deterministic; the thresholds come from the binomial tail, not
//! from the outcome.

use naic_core::friction::{JointFriction, StribeckParams};
use naic_ident::lm::{lm_box, LeastSquares, LmOptions};
use naic_ident::stats::{student_t_cdf, student_t_quantile};
use naic_ident::{fit, residual_stats, Ci95, Direction, FitForm, FitOptions, FrictionData};
use naic_core::rng::Rng;
use nalgebra::{DMatrix, DVector};

/// Seeds per coverage test, and the fewest of them whose 95 % interval must contain the true
/// value: with nominal coverage the count is Binomial(40, 0.95), below 33 with probability
/// 7·10⁻⁴. (10 seeds with "at least 7" was used before: it passed on the generator's former
/// stream and failed on naic_core::rng's, at coverages of 93–98 % measured over 100 seeds,
/// so the 10-seed check was a matter of which seeds were drawn.)
const SEEDS: u64 = 40;
const MIN_COVERED: usize = 33;

/// Speeds like the JK5 wrist-joint experiment: 3..10 mrad/s, 15..50 mrad/s, 60..520 mrad/s, both ways.
fn speeds() -> Vec<f64> {
    let mut v = Vec::new();
    for k in 3..=10 {
        v.push(k as f64 * 1e-3);
    }
    for k in 3..=10 {
        v.push(k as f64 * 5e-3);
    }
    for k in 0..24 {
        v.push(0.06 + k as f64 * 0.02);
    }
    let neg: Vec<f64> = v.iter().map(|x| -x).collect();
    v.extend(neg);
    v
}

fn generate(joints: &[(usize, JointFriction)], sigma: f64, seed: u64) -> FrictionData {
    let mut rng = Rng::seed(seed);
    let mut pts = Vec::new();
    for &(j, law) in joints {
        for v in speeds() {
            // Velocity noise as well (segment means of a measured velocity).
            let v_meas = v * (1.0 + 0.002 * rng.gaussian());
            pts.push((j, v_meas, law.tau_f(v) + sigma * rng.gaussian()));
        }
    }
    FrictionData::from_points("generated", &pts).unwrap()
}

/// Joint-6-like and joint-4-like per-direction parameters (Table 1 magnitudes).
const J6P: StribeckParams = StribeckParams { f_a: 1.97, f_b: 2.431, q_s: 0.0170, f_v: 3.846 };
const J6N: StribeckParams = StribeckParams { f_a: 1.86, f_b: 2.429, q_s: 0.018, f_v: 4.009 };
const J4P: StribeckParams = StribeckParams { f_a: 2.254, f_b: 2.923, q_s: 0.0660, f_v: 3.208 };
const J4N: StribeckParams = StribeckParams { f_a: 3.111, f_b: 3.916, q_s: 0.036, f_v: 2.984 };

fn vals(p: &StribeckParams) -> [f64; 4] {
    [p.f_a, p.f_b, p.q_s, p.f_v]
}

/// Runs `seeds` fits and returns (per-parameter coverage counts, total covered, total).
fn coverage(
    joints: &[(usize, JointFriction)],
    form: FitForm,
    truth: &[(usize, usize, [f64; 4])], // (joint, branch index, true values) — CV uses the first 2
    sigma: f64,
    seeds: u64,
    calibrate: &[usize], // indices into `truth` whose interval widths are checked against the seed spread
) -> (Vec<usize>, usize, usize) {
    let n_par = if form == FitForm::CoulombViscous { 2 } else { 4 };
    let mut counts = vec![0; truth.len() * n_par];
    let (mut hit, mut all) = (0, 0);
    let mut pooled = (0.0, 0.0);
    // Per parameter: estimates and interval half-widths over the seeds.
    let mut est: Vec<Vec<(f64, f64)>> = vec![Vec::new(); truth.len() * n_par];
    for seed in 0..seeds {
        let data = generate(joints, sigma, 1000 + seed);
        let rep = fit(&data, &FitOptions { form, ..FitOptions::default() }).unwrap();
        for (t, &(joint, branch, ref true_vals)) in truth.iter().enumerate() {
            let jf = rep.joints.iter().find(|j| j.joint == joint).unwrap();
            let b = &jf.branches[branch];
            assert!(b.converged, "seed {seed} joint {joint} branch {branch} did not converge");
            // A least-squares optimum explains the data at least as well as the true parameters.
            let law = joints.iter().find(|(j, _)| *j == joint).unwrap().1;
            let rs = residual_stats(&law, &data, joint, 0.0);
            let ssr_true = match b.direction {
                Direction::Positive => rs.ssr_positive,
                Direction::Negative => rs.ssr_negative,
                Direction::Both => rs.ssr_positive + rs.ssr_negative,
            };
            let ssr_fit = b.rmse.powi(2) * b.n_points as f64;
            assert!(ssr_fit <= ssr_true * (1.0 + 1e-9), "seed {seed} joint {joint}: SSR {ssr_fit} > SSR at truth {ssr_true}");
            // RMSE_dfe estimates the noise level: ~70 points → s/σ within ±25 % (≈ 3 sd).
            // RMSE_dfe estimates the noise level. With n − p ≈ 36 (per direction) or 76 (symmetric),
            // s/σ lies in [0.55, 1.5] with probability > 1 − 1e-4 (χ² quantiles); pooled below.
            let ratio = b.rmse_dfe / sigma;
            assert!((0.55..1.5).contains(&ratio), "seed {seed} joint {joint}: rmse_dfe {} vs σ {sigma}", b.rmse_dfe);
            pooled.0 += ratio * ratio;
            pooled.1 += 1.0;
            for k in 0..n_par {
                if let Ci95::Interval { lo, hi } = b.params[k].ci95 {
                    est[t * n_par + k].push((b.params[k].value, 0.5 * (hi - lo)));
                }
                all += 1;
                if b.params[k].ci95.contains(true_vals[k]) {
                    hit += 1;
                    counts[t * n_par + k] += 1;
                }
            }
        }
    }
    // Not too wide either: the mean half-width should be ≈ 1.96 × the spread of the
    // estimates over the seeds (40 seeds: the sample sd is within 0.67–1.36 of the true
    // one with probability 0.998; allow × 2).
    for (i, e) in est.iter().enumerate() {
        if !calibrate.contains(&(i / n_par)) {
            continue;
        }
        let m = e.len() as f64;
        assert!(m >= 7.0, "parameter {i}: only {m} intervals");
        let mean = e.iter().map(|x| x.0).sum::<f64>() / m;
        let sd = (e.iter().map(|x| (x.0 - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let half = e.iter().map(|x| x.1).sum::<f64>() / m;
        let ratio = half / (1.96 * sd);
        assert!((0.5..2.0).contains(&ratio), "parameter {i}: mean half-width {half} vs 1.96·sd {}", 1.96 * sd);
    }
    // Pooled over ≥ 10 fits (≥ 360 degrees of freedom) s²/σ² has sd ≤ 0.075: allow ±0.25.
    let pooled = pooled.0 / pooled.1;
    assert!((pooled - 1.0).abs() < 0.25, "pooled rmse_dfe²/σ² = {pooled}");
    (counts, hit, all)
}

#[test]
fn per_direction_fit_recovers_parameters_within_their_95_percent_intervals() {
    let joints = [
        (4, JointFriction::StribeckPerDirection { positive: J4P, negative: J4N }),
        (6, JointFriction::StribeckPerDirection { positive: J6P, negative: J6N }),
    ];
    let truth = [(4, 0, vals(&J4P)), (4, 1, vals(&J4N)), (6, 0, vals(&J6P)), (6, 1, vals(&J6N))];
    let (counts, hit, all) = coverage(&joints, FitForm::PerDirection, &truth, 0.05, SEEDS, &[0, 1, 2, 3]);
    for (i, c) in counts.iter().enumerate() {
        assert!(*c >= MIN_COVERED, "parameter {} of branch {} covered in only {c}/{SEEDS} seeds (counts {counts:?})", i % 4, i / 4);
    }
    assert!(hit as f64 >= 0.85 * all as f64, "overall coverage {hit}/{all}");
}

#[test]
fn symmetric_fit_recovers_parameters_within_their_95_percent_intervals() {
    let p = StribeckParams { f_a: 2.0, f_b: 2.6, q_s: 0.02, f_v: 3.5 };
    let q = StribeckParams { f_a: 0.55, f_b: 0.70, q_s: 0.05, f_v: 3.7 };
    let joints = [(1, JointFriction::Stribeck(p)), (2, JointFriction::Stribeck(q))];
    let truth = [(1, 0, vals(&p)), (2, 0, vals(&q))];
    // Joint 2's Stribeck hump (f_b − f_a = 0.15 N·m = 3σ) is weak: in about a fifth of the
    // seeds the best fit is a different minimum (f_a ≈ 1.8, large q_s, smaller f_v) with a
    // lower SSR than the truth, so its estimates are bimodal. Only joint 1's interval widths
    // are checked against the seed spread, and joint 2's coverage is held to what that allows:
    // 75–83 % measured over 100 seeds on its f_a, q_s and f_v; Binomial(40, 0.75) is below 21
    // with probability 6·10⁻⁴.
    let (counts, hit, all) = coverage(&joints, FitForm::Symmetric, &truth, 0.05, SEEDS, &[0]);
    for (i, c) in counts.iter().enumerate() {
        let min = if i < 4 { MIN_COVERED } else { 21 };
        assert!(*c >= min, "parameter {} of joint {} covered in only {c}/{SEEDS} seeds", i % 4, i / 4 + 1);
    }
    assert!(hit as f64 >= 0.85 * all as f64, "overall coverage {hit}/{all}");
}

#[test]
fn coulomb_viscous_fit_recovers_parameters_within_their_95_percent_intervals() {
    let joints = [(3, JointFriction::CoulombViscous { f_c: 1.2, f_v: 3.4 })];
    let truth = [(3, 0, [1.2, 3.4, 0.0, 0.0])];
    let (counts, hit, all) = coverage(&joints, FitForm::CoulombViscous, &truth, 0.05, SEEDS, &[0]);
    assert!(counts.iter().all(|c| *c >= MIN_COVERED), "{counts:?}");
    assert!(hit as f64 >= 0.85 * all as f64);
}

#[test]
fn noise_free_data_is_fitted_exactly() {
    let joints = [(6, JointFriction::StribeckPerDirection { positive: J6P, negative: J6N })];
    let mut pts = Vec::new();
    for v in speeds() {
        pts.push((6, v, joints[0].1.tau_f(v)));
    }
    let data = FrictionData::from_points("exact", &pts).unwrap();
    let rep = fit(&data, &FitOptions::default()).unwrap();
    let j = &rep.joints[0];
    for (b, truth) in j.branches.iter().zip([vals(&J6P), vals(&J6N)]) {
        assert!(b.rmse < 1e-9, "rmse {}", b.rmse);
        for k in 0..4 {
            assert!((b.params[k].value - truth[k]).abs() <= 1e-6 * truth[k], "{:?} vs {}", b.params[k], truth[k]);
        }
    }
}

#[test]
fn active_bound_is_reported_and_excluded_from_the_intervals() {
    // Torque that falls with speed (negative viscous slope, like the J1+ row of the
    // authors' own fit): the constrained optimum has f_v on its bound 0.
    let law = |v: f64| v.signum() * (3.0 + 0.5 * (-(v / 0.05).powi(2)).exp()) - 1.0 * v;
    let mut rng = Rng::seed(7);
    let pts: Vec<(usize, f64, f64)> = speeds().into_iter().map(|v| (2, v, law(v) + 0.02 * rng.gaussian())).collect();
    let data = FrictionData::from_points("falling", &pts).unwrap();
    let rep = fit(&data, &FitOptions { form: FitForm::Symmetric, ..FitOptions::default() }).unwrap();
    let b = &rep.joints[0].branches[0];
    let f_v = b.param("f_v").unwrap();
    assert_eq!(f_v.value, 0.0);
    assert_eq!(f_v.ci95, Ci95::AtBound);
    for name in ["f_a", "f_b", "q_s"] {
        assert!(matches!(b.param(name).unwrap().ci95, Ci95::Interval { .. }), "{name}: {:?}", b.param(name));
    }
    // One free parameter fewer: σ² = SSR/(n − 3).
    let n = b.n_points as f64;
    assert!((b.rmse_dfe.powi(2) * (n - 3.0) - b.rmse.powi(2) * n).abs() < 1e-9);
}

#[test]
fn fit_is_never_worse_than_the_best_of_a_q_s_scan() {
    // Independent of the LM: a dense q_s scan with non-negative least squares for the
    // linear parameters (brute force). The LM optimum must not be worse.
    let mut rng = Rng::seed(99);
    let law = JointFriction::Stribeck(StribeckParams { f_a: 1.18, f_b: 1.38, q_s: 0.004, f_v: 3.47 });
    let pts: Vec<(usize, f64, f64)> = speeds().into_iter().map(|v| (3, v, law.tau_f(v) + 0.05 * rng.gaussian())).collect();
    let data = FrictionData::from_points("small q_s", &pts).unwrap();
    let rep = fit(&data, &FitOptions { form: FitForm::Symmetric, ..FitOptions::default() }).unwrap();
    let b = &rep.joints[0].branches[0];
    let ssr_fit = b.rmse.powi(2) * b.n_points as f64;
    let (q, t): (Vec<f64>, Vec<f64>) = pts.iter().map(|p| (p.1, p.2)).unzip();
    let mut best = f64::INFINITY;
    for k in 0..=2000 {
        let q_s = (1e-4f64.ln() + (2f64.ln() - 1e-4f64.ln()) * k as f64 / 2000.0).exp();
        best = best.min(nnls3_ssr(&q, &t, q_s));
    }
    assert!(ssr_fit <= best * (1.0 + 1e-6), "LM {ssr_fit} vs scan {best}");
}

/// SSR of the best (f_a, f_b, f_v) ≥ 0 at fixed q_s: every subset of active constraints.
fn nnls3_ssr(q: &[f64], t: &[f64], q_s: f64) -> f64 {
    let cols = |k: usize, v: f64| {
        let e = (-(v / q_s).powi(2)).exp();
        [v.signum() * (1.0 - e), v.signum() * e, v][k]
    };
    let mut best = t.iter().map(|x| x * x).sum::<f64>();
    for mask in 1u8..8 {
        let idx: Vec<usize> = (0..3).filter(|k| mask & (1 << k) != 0).collect();
        let a = DMatrix::from_fn(q.len(), idx.len(), |i, c| cols(idx[c], q[i]));
        let b = DVector::from_column_slice(t);
        let Ok(x) = a.clone().svd(true, true).solve(&b, 1e-14) else { continue };
        if x.iter().any(|v| *v < 0.0) {
            continue;
        }
        best = best.min((a * x - b).norm_squared());
    }
    best
}

#[test]
fn student_t_quantiles_match_tables() {
    // Two-sided 95 % values from standard tables.
    for (dof, want) in [(1.0, 12.706_204_7), (2.0, 4.302_652_7), (10.0, 2.228_138_9), (30.0, 2.042_272_5), (68.0, 1.995_468_9), (1000.0, 1.962_339_1)] {
        let got = student_t_quantile(0.975, dof);
        assert!((got - want).abs() < 1e-6, "dof {dof}: {got} vs {want}");
        assert!((student_t_cdf(got, dof) - 0.975).abs() < 1e-12);
    }
    assert!(student_t_quantile(1.5, 3.0).is_nan());
}

#[test]
fn lm_box_solves_a_bounded_linear_problem() {
    // y = a + b·x with data falling in x: unconstrained b < 0; with b ≥ 0 the optimum is
    // b = 0, a = mean(y).
    struct Line(Vec<f64>, Vec<f64>);
    impl LeastSquares for Line {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            self.0.len()
        }
        fn eval(&self, th: &[f64], r: &mut DVector<f64>, jac: Option<&mut DMatrix<f64>>) {
            for i in 0..self.0.len() {
                r[i] = th[0] + th[1] * self.0[i] - self.1[i];
            }
            if let Some(j) = jac {
                for i in 0..self.0.len() {
                    j[(i, 0)] = 1.0;
                    j[(i, 1)] = self.0[i];
                }
            }
        }
    }
    let x: Vec<f64> = (0..10).map(|i| i as f64).collect();
    let y: Vec<f64> = x.iter().map(|x| 5.0 - 0.3 * x).collect();
    let mean = y.iter().sum::<f64>() / 10.0;
    let r = lm_box(&Line(x, y), &[1.0, 1.0], &[f64::NEG_INFINITY, 0.0], &[f64::INFINITY; 2], &LmOptions::default());
    assert!(r.converged);
    assert!((r.theta[0] - mean).abs() < 1e-9 && r.theta[1] == 0.0, "{:?}", r.theta);
    assert_eq!(r.at_bound, vec![false, true]);
}

// ---- bad data -------------------------------------------------------------------

fn csv_err(text: &str) -> String {
    FrictionData::from_csv_str("t.csv", text).unwrap_err().to_string()
}

#[test]
fn csv_with_nan_or_inf_names_line_and_column() {
    let e = csv_err("joint,velocity_rad_s,torque_nm\n1,0.1,2.0\n1,NaN,2.0\n");
    assert!(e.contains("t.csv: line 3, column `velocity_rad_s`") && e.contains("not finite"), "{e}");
    let e = csv_err("joint,velocity_rad_s,torque_nm\n1,0.1,inf\n");
    assert!(e.contains("line 2, column `torque_nm`") && e.contains("not finite"), "{e}");
    let e = csv_err("joint,velocity_rad_s,torque_nm\n1,0.1,abc\n");
    assert!(e.contains("line 2, column `torque_nm`: `abc` is not a number"), "{e}");
}

#[test]
fn csv_empty_or_without_rows_says_what_is_needed() {
    let e = csv_err("");
    assert!(e.contains("the file is empty") && e.contains("joint,velocity_rad_s,torque_nm"), "{e}");
    let e = csv_err("\n\n# only a comment\n");
    assert!(e.contains("the file is empty"), "{e}");
    let e = csv_err("joint,velocity_rad_s,torque_nm\n");
    assert!(e.contains("no data rows"), "{e}");
}

#[test]
fn csv_with_wrong_or_missing_columns_names_the_expected_header() {
    let e = csv_err("joint,velocity,torque\n1,0.1,2\n");
    assert!(e.contains("missing column `velocity_rad_s`") && e.contains("expected header is `joint,velocity_rad_s,torque_nm`"), "{e}");
    let e = csv_err("1,0.1,2\n1,0.2,3\n");
    assert!(e.contains("line 1 is data, not a header"), "{e}");
    let e = csv_err("joint,velocity_rad_s,torque_nm\n1,0.1\n");
    assert!(e.contains("line 2: expected 3 fields"), "{e}");
    let e = csv_err("joint,velocity_rad_s,torque_nm\n0,0.1,2\n");
    assert!(e.contains("line 2, column `joint`") && e.contains("integer ≥ 1"), "{e}");
    // Columns in another order and extra columns are fine.
    let d = FrictionData::from_csv_str("t", "torque_nm,note,joint,velocity_rad_s\n2.5,x,3,-0.1\n").unwrap();
    assert_eq!((d.samples[0].joint, d.samples[0].qdot, d.samples[0].tau), (3, -0.1, 2.5));
}

#[test]
fn per_direction_fit_with_one_direction_only_says_so() {
    let text: String = std::iter::once("joint,velocity_rad_s,torque_nm\n".to_string())
        .chain((1..=20).map(|k| format!("2,{},{}\n", k as f64 * 0.01, 1.0 + k as f64 * 0.01)))
        .collect();
    let data = FrictionData::from_csv_str("pos.csv", &text).unwrap();
    let e = fit(&data, &FitOptions::default()).unwrap_err().to_string();
    assert!(e.contains("pos.csv, joint 2: no samples with velocity < 0 (negative direction)"), "{e}");
    assert!(e.contains("--model symmetric"), "{e}");
    // The symmetric fit works on the same data.
    assert!(fit(&data, &FitOptions { form: FitForm::Symmetric, ..FitOptions::default() }).is_ok());
}

#[test]
fn too_few_points_and_unknown_joints_are_rejected() {
    let data = FrictionData::from_points("few", &[(1, 0.1, 1.0), (1, 0.2, 1.1), (1, 0.3, 1.2), (1, -0.1, -1.0), (1, -0.2, -1.1)])
        .unwrap();
    let e = fit(&data, &FitOptions::default()).unwrap_err().to_string();
    assert!(e.contains("joint 1, positive direction: 3 data points for 4 parameters"), "{e}");
    assert!(e.contains("at least 5 points"), "{e}");
    let e = fit(&data, &FitOptions { joints: Some(vec![7]), ..FitOptions::default() }).unwrap_err().to_string();
    assert!(e.contains("joint 7 is not in few (it has joints 1)"), "{e}");
    let e = FrictionData::from_points("p", &[(1, f64::NAN, 1.0)]).unwrap_err().to_string();
    assert!(e.contains("velocity NaN is not finite"), "{e}");
}

#[test]
fn csv_quoting_blank_lines_and_comments() {
    let d = FrictionData::from_csv_str("q.csv", "# a comment\n\"joint\",\"velocity_rad_s\",\"torque_nm\"\n\n\"2\", -0.25 ,\"1.5\"\n   \n# another\n2,0.25,1.75\n")
        .unwrap();
    assert_eq!(d.samples.len(), 2);
    assert_eq!((d.samples[0].joint, d.samples[0].qdot, d.samples[0].tau, d.samples[0].line), (2, -0.25, 1.5, 4));
    assert_eq!(d.samples[1].line, 7);
}
