//! Properties of the friction laws (eq. 4, eq. 5, eq. 5 per direction, tanh variant)
//! and of the n-joint FrictionModel.

use naic_core::friction::{FrictionError, FrictionModel, JointFriction, Smoothing, StribeckParams, DEFAULT_V_S};

const POS: StribeckParams = StribeckParams { f_a: 2.254, f_b: 2.923, q_s: 0.066, f_v: 3.208 };
const NEG: StribeckParams = StribeckParams { f_a: 3.111, f_b: 3.916, q_s: 0.036, f_v: 2.984 };

fn speeds() -> Vec<f64> {
    // 0, then ±1e-6 .. ±1 rad/s, log-spaced.
    let mut v = vec![0.0];
    for k in 0..=120 {
        let x = 10f64.powf(-6.0 + 6.0 * k as f64 / 120.0);
        v.push(x);
        v.push(-x);
    }
    v
}

fn laws() -> Vec<JointFriction> {
    vec![
        JointFriction::CoulombViscous { f_c: 1.5, f_v: 2.0 },
        JointFriction::Stribeck(POS),
        JointFriction::StribeckPerDirection { positive: POS, negative: NEG },
    ]
}

#[test]
fn symmetric_laws_are_odd_exact_and_smooth() {
    for law in [JointFriction::CoulombViscous { f_c: 1.5, f_v: 2.0 }, JointFriction::Stribeck(POS)] {
        for &v in &speeds() {
            assert_eq!(law.tau_f(-v), -law.tau_f(v), "{law:?} at {v}");
            let (a, b) = (law.tau_f_smooth(-v, DEFAULT_V_S), law.tau_f_smooth(v, DEFAULT_V_S));
            assert!((a + b).abs() <= 1e-12 * b.abs().max(1.0), "{law:?} smooth at {v}: {a} vs {b}");
        }
    }
}

#[test]
fn equation_4_and_5_values() {
    let cv = JointFriction::CoulombViscous { f_c: 1.5, f_v: 2.0 };
    assert_eq!(cv.tau_f(0.5), 1.5 + 1.0);
    assert_eq!(cv.tau_f(-0.5), -1.5 - 1.0);
    let s = JointFriction::Stribeck(POS);
    // At q̇ = q_s the Stribeck term has decayed to e^{-1}.
    let want = POS.f_a + (POS.f_b - POS.f_a) * (-1f64).exp() + POS.f_v * POS.q_s;
    assert!((s.tau_f(POS.q_s) - want).abs() < 1e-12);
    // Low speed → breakaway level f_b; high speed → Coulomb level f_a plus viscous.
    assert!((s.tau_f(1e-9) - POS.f_b).abs() < 1e-6);
    assert!((s.tau_f(1.0) - (POS.f_a + POS.f_v)).abs() < 1e-9);
    for law in laws() {
        assert_eq!(law.tau_f(0.0), 0.0, "sgn(0) = 0 for {law:?}");
    }
}

#[test]
fn per_direction_branches_use_their_own_parameters_and_signs() {
    let law = JointFriction::StribeckPerDirection { positive: POS, negative: NEG };
    for &v in speeds().iter().filter(|v| **v != 0.0) {
        let t = law.tau_f(v);
        if v > 0.0 {
            // q̇ > 0: +[f_a⁺ + (f_b⁺ − f_a⁺) e^{−(q̇/q_s⁺)²}] + f_v⁺ q̇
            assert!((t - (POS.magnitude(v) + POS.f_v * v)).abs() < 1e-12);
            assert!(t > 0.0);
        } else {
            // q̇ < 0: −[f_a⁻ + (f_b⁻ − f_a⁻) e^{−(q̇/q_s⁻)²}] + f_v⁻ q̇
            assert!((t - (-NEG.magnitude(v) + NEG.f_v * v)).abs() < 1e-12);
            assert!(t < 0.0);
        }
    }
    // Changing the negative set leaves q̇ > 0 alone, and vice versa.
    let other = JointFriction::StribeckPerDirection { positive: POS, negative: POS };
    assert_eq!(law.tau_f(0.2), other.tau_f(0.2));
    assert_ne!(law.tau_f(-0.2), other.tau_f(-0.2));
    // Same set both ways = the symmetric eq. 5.
    for &v in &speeds() {
        assert_eq!(other.tau_f(v), JointFriction::Stribeck(POS).tau_f(v));
    }
    // Table 1 magnitudes at −0.2 rad/s: −[3.111 + 0.805 e^{−(0.2/0.036)²}] − 0.5968.
    assert!((law.tau_f(-0.2) - (-3.111 - 0.805 * (-(0.2f64 / 0.036).powi(2)).exp() - 2.984 * 0.2)).abs() < 1e-12);
}

#[test]
fn smooth_variant_is_continuous_through_zero() {
    for law in laws() {
        let v_s = DEFAULT_V_S;
        assert_eq!(law.tau_f_smooth(0.0, v_s), 0.0);
        // Lipschitz on a fine grid across 0: no jump bigger than the steepest slope allows.
        let slope = law.max_slope(v_s);
        let h = 1e-7;
        let mut prev = law.tau_f_smooth(-0.02, v_s);
        let mut v = -0.02 + h;
        let mut max_step: f64 = 0.0;
        while v <= 0.02 {
            let t = law.tau_f_smooth(v, v_s);
            max_step = max_step.max((t - prev).abs());
            prev = t;
            v += h;
        }
        assert!(max_step <= 1.01 * slope * h, "{law:?}: step {max_step} > slope {slope} · h");
        // The slope at 0 is (f_b⁺ + f_b⁻)/(2 v_s) + (f_v⁺ + f_v⁻)/2 (f_c for eq. 4), and max_slope is not below it.
        let d = 1e-9;
        let fd = (law.tau_f_smooth(d, v_s) - law.tau_f_smooth(-d, v_s)) / (2.0 * d);
        let at_zero = match law {
            JointFriction::CoulombViscous { f_c, f_v } => f_c / v_s + f_v,
            JointFriction::Stribeck(p) => p.f_b / v_s + p.f_v,
            JointFriction::StribeckPerDirection { positive: p, negative: n } => {
                0.5 * (p.f_b + n.f_b) / v_s + 0.5 * (p.f_v + n.f_v)
            }
        };
        assert!((fd - at_zero).abs() <= 1e-4 * at_zero, "{law:?}: slope at 0 {fd} vs {at_zero}");
        assert!(slope >= at_zero * (1.0 - 1e-6), "{law:?}: max_slope {slope} < slope at 0 {at_zero}");
    }
}

#[test]
fn smooth_variant_matches_exact_law_beyond_three_v_s() {
    // tanh(3) = 0.99505: the Coulomb/Stribeck term is within 0.5 % for |q̇| ≥ 3 v_s.
    for law in laws() {
        for &v in speeds().iter().filter(|v| v.abs() >= 3.0 * DEFAULT_V_S) {
            let (e, s) = (law.tau_f(v), law.tau_f_smooth(v, DEFAULT_V_S));
            assert!((e - s).abs() <= 0.005 * e.abs(), "{law:?} at {v}: exact {e}, smooth {s}");
        }
    }
}

#[test]
fn model_vector_form_matches_per_joint_and_checks_lengths() {
    let m = FrictionModel::new(laws()).unwrap();
    let qdot = [0.1, -0.05, -0.3];
    let mut out = [0.0; 3];
    m.tau_f_into(&qdot, &mut out).unwrap();
    for j in 0..3 {
        assert_eq!(out[j], m.tau_f(j, qdot[j]));
        assert_eq!(out[j], laws()[j].tau_f(qdot[j]));
    }
    let ms = m.clone().with_smoothing(Smoothing::Tanh { v_s: 0.01 }).unwrap();
    ms.tau_f_into(&qdot, &mut out).unwrap();
    for j in 0..3 {
        assert_eq!(out[j], laws()[j].tau_f_smooth(qdot[j], 0.01));
    }
    let e = m.tau_f_into(&qdot[..2], &mut out).unwrap_err();
    assert!(matches!(e, FrictionError::Length { what: "qdot", expected: 3, found: 2 }), "{e}");
    let e = m.tau_f_into(&qdot, &mut out[..1]).unwrap_err();
    assert!(e.to_string().contains("tau_f has length 1"), "{e}");
}

#[test]
fn model_rejects_unphysical_parameters_naming_joint_and_field() {
    let bad = StribeckParams { q_s: -0.01, ..POS };
    let e = FrictionModel::new(vec![JointFriction::Stribeck(POS), JointFriction::Stribeck(bad)]).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("joint 2") && msg.contains("q_s"), "{msg}");
    let nan = StribeckParams { f_b: f64::NAN, ..POS };
    let e = FrictionModel::new(vec![JointFriction::StribeckPerDirection { positive: POS, negative: nan }]).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("joint 1, negative direction") && msg.contains("f_b"), "{msg}");
    let e = FrictionModel::new(vec![JointFriction::CoulombViscous { f_c: 1.0, f_v: -2.0 }]).unwrap_err();
    assert!(e.to_string().contains("f_v = -2"), "{e}");
    assert!(FrictionModel::new(vec![]).is_err());
    let m = FrictionModel::new(laws()).unwrap();
    for v_s in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = m.clone().with_smoothing(Smoothing::Tanh { v_s }).unwrap_err();
        assert!(e.to_string().contains("v_s"), "{e}");
    }
}

#[test]
fn analytic_slope_matches_finite_differences_and_torque_is_bit_identical() {
    for v_s in [DEFAULT_V_S, 0.02] {
        for law in laws() {
            let mut checked = 0;
            for v in speeds() {
                let (tau, slope) = law.tau_f_smooth_and_slope(v, v_s);
                assert_eq!(tau.to_bits(), law.tau_f_smooth(v, v_s).to_bits(), "{law:?} at {v}: torque differs from tau_f_smooth");
                // central difference with a step well inside the smallest velocity scale
                let d = 1e-6 * v_s.min(0.036).max(v.abs() * 1e-3);
                let fd = (law.tau_f_smooth(v + d, v_s) - law.tau_f_smooth(v - d, v_s)) / (2.0 * d);
                assert!((slope - fd).abs() <= 1e-5 * (slope.abs() + 1.0), "{law:?} at {v}, v_s {v_s}: slope {slope} vs fd {fd}");
                checked += 1;
            }
            assert!(checked > 200);
        }
    }
    // the model-level entry point: the same torque as tau_f, the analytic slope with tanh,
    // the central difference with the exact law
    let per_dir = JointFriction::StribeckPerDirection { positive: POS, negative: NEG };
    let m = FrictionModel::new(vec![per_dir]).unwrap();
    let (t, s) = m.tau_f_and_slope(0, 0.05);
    assert_eq!((t, s), (m.tau_f(0, 0.05), (m.tau_f(0, 0.05 + 1e-7) - m.tau_f(0, 0.05 - 1e-7)) / 2e-7));
    let smooth = m.with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S }).unwrap();
    for v in [0.0, 2e-4, -3e-3, 0.05, -0.5] {
        let (t, s) = smooth.tau_f_and_slope(0, v);
        assert_eq!(t.to_bits(), smooth.tau_f(0, v).to_bits());
        assert_eq!(s, per_dir.tau_f_smooth_and_slope(v, DEFAULT_V_S).1);
    }
    // at rest the tanh slope dominates: ≈ f_b/v_s (both branches weigh ½ there)
    let (_, s0) = smooth.tau_f_and_slope(0, 0.0);
    assert!((s0 - (0.5 * (POS.f_b + NEG.f_b) / DEFAULT_V_S + 0.5 * (POS.f_v + NEG.f_v))).abs() < 1e-9 * s0);
}
