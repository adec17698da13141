//! The joint-torque regressor: RNEA is linear in the inertial parameters,
//! `τ = Y(q, q̇, q̈) π`, with 10 parameters per body (Pinocchio's
//! `computeJointTorqueRegressor`, Atkeson, An & Hollerbach 1986):
//!
//! `π_i = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]`, the rotational
//! inertia **about the joint-frame origin** (not the centre of mass), body axes; the
//! order is Pinocchio's `Inertia::toDynamicParameters`.
//!
//! Body i's wrench `f_i = I_i a_i + v_i ×* I_i v_i` is linear in `π_i`: with `h = m c` and
//! `I_o` the inertia about the origin, `f = m a_l − h×α + ω×(m v_l − h×ω)` and
//! `n = I_o α + h×a_l + ω×(I_o ω + h×v_l) + v_l×(m v_l − h×ω)`, so each of the 10 parameters
//! gives one wrench column `A_i(v_i, a_i)`. Joint j carries every body i ≥ j:
//! `Y[j, 10 i + k] = S_jᵀ X*_{j←i} A_i[:, k]`.
//!
//! [`base_parameters`] finds the identifiable combinations (QR with column pivoting on
//! the stacked regressor of random states).

use super::spatial::{Force, Inertia, Motion, Se3};
use crate::model::Model;
use nalgebra::{DMatrix, Matrix3, Vector3};

/// Parameters per body.
pub const PARAMS_PER_BODY: usize = 10;

/// Names of the 10 parameters of a body, in order.
pub const PARAM_NAMES: [&str; PARAMS_PER_BODY] = ["m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"];

/// The 10 dynamic parameters of a body inertia (about the frame origin, see module docs).
pub fn dynamic_parameters(y: &Inertia) -> [f64; PARAMS_PER_BODY] {
    let h = y.com * y.mass;
    let c = y.com;
    // I_o = I_c + m (|c|² 1 − c cᵀ)
    let io = y.inertia + (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * y.mass;
    [y.mass, h.x, h.y, h.z, io[(0, 0)], io[(0, 1)], io[(1, 1)], io[(0, 2)], io[(1, 2)], io[(2, 2)]]
}

/// The body inertia of 10 dynamic parameters (inverse of [`dynamic_parameters`]; `m > 0`).
pub fn inertia_from_parameters(p: &[f64]) -> Inertia {
    let m = p[0];
    let c = if m > 0.0 { Vector3::new(p[1], p[2], p[3]) / m } else { Vector3::zeros() };
    let io = Matrix3::new(p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9]);
    Inertia { mass: m, com: c, inertia: io - (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * m }
}

/// The model's parameter vector π (10 per joint body, chain order).
pub fn model_parameters(model: &Model) -> Vec<f64> {
    model.joints.iter().flat_map(|j| dynamic_parameters(&j.inertia)).collect()
}

/// Workspace of [`joint_torque_regressor`] (allocated once per model).
#[derive(Clone, Debug)]
pub struct RegressorData {
    li: Vec<Se3>,
    v: Vec<Motion>,
    a: Vec<Motion>,
    cols: Vec<[Force; PARAMS_PER_BODY]>,
    /// The regressor of the last call, nv × 10·nv.
    pub y: DMatrix<f64>,
}

impl RegressorData {
    pub fn new(model: &Model) -> Self {
        let n = model.nv();
        Self {
            li: vec![Se3::identity(); n],
            v: vec![Motion::zero(); n],
            a: vec![Motion::zero(); n],
            cols: vec![[Force::zero(); PARAMS_PER_BODY]; n],
            y: DMatrix::zeros(n, PARAMS_PER_BODY * n),
        }
    }
}

/// Wrench columns of one body moving with `v`, accelerating with `a` (gravity included in `a`).
fn body_columns(v: &Motion, a: &Motion) -> [Force; PARAMS_PER_BODY] {
    let (vl, w, al, al_w) = (v.v, v.w, a.v, a.w);
    let mut out = [Force::zero(); PARAMS_PER_BODY];
    out[0] = Force { f: al + w.cross(&vl), n: Vector3::zeros() };
    for k in 0..3 {
        let e = Vector3::ith(k, 1.0);
        out[1 + k] = Force { f: -e.cross(&al_w) - w.cross(&e.cross(&w)), n: e.cross(&al) + w.cross(&e.cross(&vl)) - vl.cross(&e.cross(&w)) };
    }
    // symmetric basis in the order xx, xy, yy, xz, yz, zz
    let idx = [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)];
    for (k, &(r, c)) in idx.iter().enumerate() {
        let mut e = Matrix3::zeros();
        e[(r, c)] = 1.0;
        e[(c, r)] = 1.0;
        out[4 + k] = Force { f: Vector3::zeros(), n: e * al_w + w.cross(&(e * w)) };
    }
    out
}

/// `Y(q, q̇, q̈)` with `τ = Y π` ([`model_parameters`]); slices of length `model.nv()`.
/// Result in `data.y` (nv × 10·nv). Panics on a length mismatch (a programming error).
pub fn joint_torque_regressor<'d>(model: &Model, data: &'d mut RegressorData, q: &[f64], v: &[f64], a: &[f64]) -> &'d DMatrix<f64> {
    let n = model.nv();
    assert!(q.len() == n && v.len() == n && a.len() == n, "joint_torque_regressor: vectors must have {n} entries");
    let a0 = Motion::new(-model.gravity, Vector3::zeros());
    for i in 0..n {
        let jm = &model.joints[i];
        let li = jm.transform(q[i]);
        let vj = jm.s_mul(v[i]);
        let (vi, ai) = if i == 0 {
            (vj, li.act_inv_motion(&a0).add(&jm.s_mul(a[i])))
        } else {
            let vi = li.act_inv_motion(&data.v[i - 1]).add(&vj);
            (vi, li.act_inv_motion(&data.a[i - 1]).add(&jm.s_mul(a[i])).add(&vi.cross_motion(&vj)))
        };
        data.li[i] = li;
        data.v[i] = vi;
        data.a[i] = ai;
        data.cols[i] = body_columns(&vi, &ai);
    }
    data.y.fill(0.0);
    for i in 0..n {
        let mut f = data.cols[i];
        for j in (0..=i).rev() {
            for (k, fk) in f.iter_mut().enumerate() {
                data.y[(j, PARAMS_PER_BODY * i + k)] = model.joints[j].s_t_force(fk);
                if j > 0 {
                    *fk = data.li[j].act_force(fk);
                }
            }
        }
    }
    &data.y
}

/// The identifiable (base) parameters of a model: the columns of `Y` that are linearly
/// independent over the state space, found by QR with column pivoting of `Y` stacked over
/// `samples` pseudo-random states (positions inside the joint limits, velocities and
/// accelerations in ±2). `columns` are indices into π (chain order, 10 per body), in
/// π order; the other columns are combinations of them (or do not act at all).
#[derive(Clone, Debug)]
pub struct BaseParameters {
    pub columns: Vec<usize>,
    /// Total parameters (10·nv).
    pub total: usize,
    /// |R_kk| of the first dropped pivot over the last kept one (≪ 1: a clear rank).
    pub gap: f64,
}

/// `Y` stacked over `samples` pseudo-random states (positions inside the joint limits,
/// velocities and accelerations in ±2; a fixed sequence): `samples·nv × 10·nv`.
pub fn stacked_regressor(model: &Model, samples: usize) -> DMatrix<f64> {
    let n = model.nv();
    let p = PARAMS_PER_BODY * n;
    let mut rd = RegressorData::new(model);
    let mut w = DMatrix::zeros(samples * n, p);
    let mut rng = crate::rng::Rng::seed(0x9E37_79B9_7F4A_7C15);
    let mut rnd = move || rng.uniform();
    let (lo, hi) = (model.lower_limits(), model.upper_limits());
    let (mut q, mut v, mut a) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for s in 0..samples {
        for j in 0..n {
            let (l, h) = if lo[j].is_finite() && hi[j].is_finite() && hi[j] > lo[j] { (lo[j], hi[j]) } else { (-std::f64::consts::PI, std::f64::consts::PI) };
            q[j] = l + (h - l) * rnd();
            v[j] = 4.0 * rnd() - 2.0;
            a[j] = 4.0 * rnd() - 2.0;
        }
        let y = joint_torque_regressor(model, &mut rd, &q, &v, &a);
        w.view_mut((s * n, 0), (n, p)).copy_from(y);
    }
    w
}

/// The map `K` (base × all) with `Y = Y_B K` over the state space: the base parameters of
/// a parameter vector π are `K π` (each base column's parameter plus the combination of
/// dependent ones the regressor cannot tell from it). Least squares on [`stacked_regressor`].
pub fn base_map(model: &Model, base: &BaseParameters, samples: usize) -> DMatrix<f64> {
    let w = stacked_regressor(model, samples);
    let wb = w.select_columns(&base.columns);
    let svd = wb.svd(true, true);
    svd.solve(&w, 1e-12).unwrap_or_else(|_| DMatrix::zeros(base.columns.len(), w.ncols()))
}

/// See [`BaseParameters`]. Deterministic (fixed pseudo-random sequence).
pub fn base_parameters(model: &Model, samples: usize) -> BaseParameters {
    let p = PARAMS_PER_BODY * model.nv();
    let mut w = stacked_regressor(model, samples);
    // scale columns to unit norm so the rank tolerance is relative per column; columns
    // below 1e-9 of the largest are rounding noise of a parameter that does not act (the
    // ±π/2 rotations of a URDF leave 6e-17 entries) and are zeroed, not scaled up
    let mut norms: Vec<f64> = (0..p).map(|c| w.column(c).norm()).collect();
    let nmax = norms.iter().copied().fold(0.0, f64::max);
    for c in 0..p {
        if norms[c] < 1e-9 * nmax {
            norms[c] = 0.0;
            w.column_mut(c).fill(0.0);
        } else {
            w.column_mut(c).scale_mut(1.0 / norms[c]);
        }
    }
    let qr = w.col_piv_qr();
    let perm = qr.p().clone();
    let r = qr.unpack_r();
    // the pivot order: the permutation applied to a row of column indices
    let mut idx = DMatrix::from_fn(1, p, |_, c| c as f64);
    perm.permute_columns(&mut idx);
    let order: Vec<usize> = (0..p).map(|c| idx[(0, c)] as usize).collect();
    let r00 = r[(0, 0)].abs();
    let diag: Vec<f64> = (0..r.nrows().min(p)).map(|k| r[(k, k)].abs() / r00).collect();
    let rank = (0..diag.len()).take_while(|&k| diag[k] > 1e-8 && norms[order[k]] > 0.0).count();
    let mut columns: Vec<usize> = order[..rank].to_vec();
    columns.sort_unstable();
    let gap = diag.get(rank).map_or(0.0, |&d| d / diag[rank.max(1) - 1]);
    BaseParameters { columns, total: p, gap }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::rnea;
    use crate::model::Data;
    use nalgebra::DVector;

    fn urdf(name: &str) -> Model {
        Model::from_urdf_file(format!("{}/../../urdf/{name}", env!("CARGO_MANIFEST_DIR"))).expect("urdf loads")
    }

    fn states(n: usize, k: usize) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        (0..k)
            .map(|s| {
                let f = |j: usize, o: f64| ((s * 7 + j * 3) as f64 * 0.37 + o).sin() * 1.5;
                ((0..n).map(|j| f(j, 0.1)).collect(), (0..n).map(|j| f(j, 1.3)).collect(), (0..n).map(|j| f(j, 2.9)).collect())
            })
            .collect()
    }

    #[test]
    fn parameters_round_trip() {
        for m in [urdf("jk5.urdf"), urdf("panda.urdf")] {
            for j in m.joints() {
                let back = inertia_from_parameters(&dynamic_parameters(&j.inertia));
                assert!((back.mass - j.inertia.mass).abs() < 1e-12);
                assert!((back.com - j.inertia.com).norm() < 1e-12);
                assert!((back.inertia - j.inertia.inertia).norm() < 1e-12);
            }
        }
    }

    /// Y π = RNEA, and every column is the change of RNEA when that one parameter changes
    /// (τ is linear in π, so τ(π + δ e_k) − τ(π) = δ Y e_k exactly, up to rounding).
    #[test]
    fn regressor_equals_rnea_column_by_column() {
        for model in [urdf("jk5.urdf"), urdf("panda.urdf")] {
            let n = model.nv();
            let pi = model_parameters(&model);
            let mut rd = RegressorData::new(&model);
            let mut data = Data::new(&model);
            for (q, v, a) in states(n, 20) {
                let (qv, vv, av) = (DVector::from_vec(q.clone()), DVector::from_vec(v.clone()), DVector::from_vec(a.clone()));
                let y = joint_torque_regressor(&model, &mut rd, &q, &v, &a).clone();
                let tau = rnea(&model, &mut data, &qv, &vv, &av).clone();
                let yp = &y * DVector::from_vec(pi.clone());
                assert!((&yp - &tau).amax() < 1e-10 * (1.0 + tau.amax()), "Yπ {yp} vs RNEA {tau}");
                for k in 0..pi.len() {
                    let mut m2 = model.clone();
                    let mut p = dynamic_parameters(&m2.joints[k / 10].inertia);
                    p[k % 10] += 0.01;
                    m2.joints[k / 10].inertia = inertia_from_parameters(&p);
                    let mut d2 = Data::new(&m2);
                    let t2 = rnea(&m2, &mut d2, &qv, &vv, &av).clone();
                    let col = y.column(k) * 0.01;
                    let diff = &t2 - &tau;
                    assert!((&diff - &col).amax() < 1e-9, "column {k}: {diff} vs {col}");
                }
            }
        }
    }

    /// The rank is clear-cut (dropped pivots ~1e-15 of the kept ones), and the first body,
    /// turning about the fixed vertical axis, contributes only its I_zz (column 9), as in
    /// Gaz et al.'s first coefficient J2yy + J1zz. The Panda has 43, Gaz et al.'s count of
    /// dynamic coefficients; the count is also checked against the rank of Pinocchio's
    /// regressor in tests/python/test_explain_baseline.py.
    #[test]
    fn base_parameters_have_a_clear_rank() {
        for (name, nj) in [("panda.urdf", 7), ("jk5.urdf", 6)] {
            let b = base_parameters(&urdf(name), 200);
            assert_eq!(b.total, 10 * nj);
            assert!(b.gap < 1e-10, "{name}: rank gap {}", b.gap);
            assert_eq!(b.columns.iter().filter(|&&c| c < 10).copied().collect::<Vec<_>>(), vec![9], "{name}: {:?}", b.columns);
            // every later body has ≥ 1 identifiable parameter and at most 10
            assert!(b.columns.len() > nj && b.columns.len() < 10 * nj);
            if nj == 7 {
                assert_eq!(b.columns.len(), 43);
            }
        }
    }

    /// `Y_B K = Y` at states the map was not built on, so `K π` are the base parameters of π.
    #[test]
    fn base_map_reproduces_the_full_regressor() {
        for model in [urdf("jk5.urdf"), urdf("panda.urdf")] {
            let n = model.nv();
            let b = base_parameters(&model, 30 * n);
            let k = base_map(&model, &b, 30 * n);
            let pi = DVector::from_vec(model_parameters(&model));
            let beta = &k * &pi;
            let mut rd = RegressorData::new(&model);
            for (q, v, a) in states(n, 10) {
                let y = joint_torque_regressor(&model, &mut rd, &q, &v, &a).clone();
                let full = &y * &pi;
                let base = y.select_columns(&b.columns) * &beta;
                assert!((&full - &base).amax() < 1e-9 * (1.0 + full.amax()), "{full} vs {base}");
            }
        }
    }
}
