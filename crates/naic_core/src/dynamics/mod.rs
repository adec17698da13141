//! Rigid-body dynamics of a serial chain: plain functions over `(&Model, &mut Data)`.
//!
//! # Algorithms and where they come from
//!
//! | function | computes | algorithm |
//! | --- | --- | --- |
//! | [`forward_kinematics`] | world pose of every joint and frame | recursive `oMi = oMλ(i) · λMi(q)` |
//! | [`frame_placement`] | world pose of one frame | the same recursion up to the frame's parent |
//! | [`frame_jacobian`] | `J(q)` of a frame, 6×nv | geometric columns `[ωⱼ × (p − pⱼ); ωⱼ]` (Pinocchio `getFrameJacobian`) |
//! | [`frame_jdot_qdot`] | `J̇ q̇` of a frame | classical acceleration at `q̈ = 0`, no gravity (Pinocchio `getFrameClassicalAcceleration`) |
//! | [`rnea`] | `τ = M q̈ + C q̇ + G` | Recursive Newton–Euler (Featherstone 2008, §5.3, table 5.1) |
//! | [`bias_torques`] / [`gravity_torques`] | `C q̇ + G` / `G` | RNEA with `q̈ = 0` / `q̇ = q̈ = 0` |
//! | [`crba`] | `M(q)`, full symmetric | Composite Rigid Body Algorithm (Featherstone §6.2, table 6.2) |
//! | [`aba`] | `q̈ = M⁻¹(τ − C q̇ − G)` | Articulated Body Algorithm (Featherstone §7.3, table 7.1) |
//! | [`cartesian_terms`] | `D`, `h` of the paper's eq. 3 | from `M`, `C q̇ + G`, `J`, `J̇ q̇` with a (damped) SVD inverse of `J` |
//! | [`regressor::joint_torque_regressor`] | `Y(q, q̇, q̈)` with `τ = Y π`, 10 inertial parameters per body | RNEA's wrenches written linearly in π (Atkeson et al. 1986; Pinocchio `computeJointTorqueRegressor`) |
//! | [`solve_damped`] | `J x = b` for a 6×6 `J` | the same damping rule ([`Damping`]); LU fast path away from singularities |
//!
//! All of them work in *local* joint frames like Pinocchio's default
//! convention: body velocities, accelerations and forces are expressed in the
//! body's joint frame and moved between frames with [`spatial::Se3`] actions
//! (rotation + cross product, never a 6×6 product). Gravity enters, as in
//! Featherstone and Pinocchio, as a fictitious base acceleration `a₀ = −g`.
//!
//! # Conventions
//!
//! * Base frame = the URDF root link frame (= MJCF world frame for the JK5;
//!   REP-103: x forward, y left, z up). Gravity `model.gravity = (0, 0, −9.81)` m/s².
//! * Spatial vectors are ordered **(linear, angular)**, like Pinocchio.
//! * Jacobians ([`frame_jacobian`]) are Pinocchio's `LOCAL_WORLD_ALIGNED`:
//!   the velocity of the frame *origin* and the angular velocity, both in
//!   base-frame axes: `[ṗ; ω] = J q̇`, rows 0–2 linear, rows 3–5 angular.
//! * [`frame_jdot_qdot`] is in the same convention: the classical
//!   acceleration `[p̈; ω̇]` of the frame at `q̈ = 0`, so `[p̈; ω̇] = J q̈ + J̇ q̇`.
//! * Joint `i` is DOF `i`, in chain order from the base (see [`crate::model`]).
//!
//! # Sizes and allocation
//!
//! Every function is generic over the DOF dimension `D` of the [`Data`]:
//! `Data<U6>` ([`crate::model::Data6`]) is the 6-DOF fast path with stack
//! joint-space results, `Data<Dyn>` serves any chain, and both run the same
//! code. Results live in `data` (`data.tau`, `data.m`, `data.ddq`,
//! `data.j`) and are returned by reference, so no call allocates. Joint
//! vectors are any nalgebra vector of matching dimension (`SVector<f64, 6>`,
//! `DVector`, or `DVectorView::from_slice(&q, n)` for a slice).
//!
//! # Panics
//!
//! Only on programming errors: a joint vector whose length differs from
//! `model.nv()`, a `data` made for another model, or a `FrameId` from another
//! model. Model input errors are caught at load time ([`crate::model::ModelError`]).

pub mod regressor;
pub mod spatial;

mod cartesian;
mod damped;
pub mod task_inverse;

pub use cartesian::{cartesian_terms, CartesianError, CartesianTerms, Damping};
pub use damped::solve_damped;
pub use task_inverse::{consistent_inverse, TaskInverse};

use crate::model::{Data, FrameId, Model};
use nalgebra::allocator::Allocator;
use nalgebra::storage::Storage;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, Vector, Vector6, U6};
use spatial::{Force, Motion};

#[inline(always)]
fn check<D: Dim, S: Storage<f64, D>>(model: &Model, data: &Data<D>, x: &Vector<f64, D, S>, what: &str)
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    assert!(
        data.li_m_i.len() == model.nv() && data.o_m_f.len() == model.frames.len(),
        "naic_core::dynamics: this Data was made for another model (Data::new(&model) for this one)"
    );
    assert!(x.nrows() == model.nv(), "naic_core::dynamics: {what} has {} entries, the model has {} joints", x.nrows(), model.nv());
}

/// Joint transforms `λMi(q)` of joints `0..=last` into `data.li_m_i`, reusing
/// those already computed for a bit-identical `q` (see `Data::placed_q`).
#[inline(always)]
fn joint_transforms<D: Dim, S: Storage<f64, D>>(model: &Model, data: &mut Data<D>, q: &Vector<f64, D, S>, last: usize)
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    let n = data.nv();
    if (0..n).any(|i| data.placed_q[i].to_bits() != q[i].to_bits()) {
        for i in 0..n {
            data.placed_q[i] = q[i];
        }
        data.li_valid = 0;
        data.o_valid = 0;
    }
    for i in data.li_valid..=last {
        data.li_m_i[i] = model.joints[i].transform(q[i]);
    }
    data.li_valid = data.li_valid.max(last + 1);
}

/// Joint placements `λMi(q)` and `oMi(q)` of joints `0..=last` (reused as in [`joint_transforms`]).
#[inline(always)]
fn joint_placements<D: Dim, S: Storage<f64, D>>(model: &Model, data: &mut Data<D>, q: &Vector<f64, D, S>, last: usize)
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    joint_transforms(model, data, q, last);
    for i in data.o_valid..=last {
        let li = data.li_m_i[i];
        data.o_m_i[i] = if i == 0 { li } else { data.o_m_i[i - 1].compose(&li) };
    }
    data.o_valid = data.o_valid.max(last + 1);
}

/// Forward kinematics: world pose of every joint and every frame
/// (read them with [`Data::frame_placement`]).
pub fn forward_kinematics<D: Dim, S: Storage<f64, D>>(model: &Model, data: &mut Data<D>, q: &Vector<f64, D, S>)
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    joint_placements(model, data, q, model.nv() - 1);
    for (k, fr) in model.frames.iter().enumerate() {
        data.o_m_f[k] = match fr.parent {
            None => fr.placement,
            Some(p) => data.o_m_i[p].compose(&fr.placement),
        };
    }
}

/// World pose of one frame: the joint placements up to its parent and the frame's own, the
/// same numbers [`forward_kinematics`] gives it, without placing the model's other frames
/// (a URDF such as the Panda's has many). Also in `data` ([`Data::frame_se3`]).
pub fn frame_placement<'d, D: Dim, S: Storage<f64, D>>(model: &Model, data: &'d mut Data<D>, q: &Vector<f64, D, S>, frame: FrameId) -> &'d spatial::Se3
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    let fr = &model.frames[frame.0];
    data.o_m_f[frame.0] = match fr.parent {
        None => fr.placement,
        Some(p) => {
            joint_placements(model, data, q, p);
            data.o_m_i[p].compose(&fr.placement)
        }
    };
    &data.o_m_f[frame.0]
}

/// Jacobian of `frame` (6×nv, rows `[linear; angular]`, world-aligned at the
/// frame origin = Pinocchio `LOCAL_WORLD_ALIGNED`), including the forward
/// kinematics it needs. Also updates the frame's pose in `data`.
pub fn frame_jacobian<'d, D: Dim, S: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S>,
    frame: FrameId,
) -> &'d OMatrix<f64, U6, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    let fr = &model.frames[frame.0];
    data.j.fill(0.0);
    let Some(p) = fr.parent else {
        data.o_m_f[frame.0] = fr.placement;
        return &data.j;
    };
    joint_placements(model, data, q, p);
    let o_m_f = data.o_m_i[p].compose(&fr.placement);
    data.o_m_f[frame.0] = o_m_f;
    for i in 0..=p {
        let jm = &model.joints[i];
        let o = &data.o_m_i[i];
        let axis = o.rot * jm.axis;
        let (lin, ang) = if jm.is_revolute() {
            (axis.cross(&(o_m_f.trans - o.trans)), axis)
        } else {
            (axis, nalgebra::Vector3::zeros())
        };
        let mut col = data.j.column_mut(i);
        col[0] = lin.x;
        col[1] = lin.y;
        col[2] = lin.z;
        col[3] = ang.x;
        col[4] = ang.y;
        col[5] = ang.z;
    }
    &data.j
}

/// `J̇ q̇` of `frame`: the classical acceleration `[p̈; ω̇]` of the frame origin
/// at `q̈ = 0` without gravity, world-aligned (same convention as
/// [`frame_jacobian`]; Pinocchio's `getFrameClassicalAcceleration` with
/// `LOCAL_WORLD_ALIGNED` after `forwardKinematics(q, v, 0)`).
pub fn frame_jdot_qdot<D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>>(
    model: &Model,
    data: &mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: &Vector<f64, D, S2>,
    frame: FrameId,
) -> Vector6<f64>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    check(model, data, v, "v");
    let fr = &model.frames[frame.0];
    let Some(p) = fr.parent else {
        data.o_m_f[frame.0] = fr.placement;
        return Vector6::zeros();
    };
    joint_placements(model, data, q, p);
    for i in 0..=p {
        let jm = &model.joints[i];
        let li = data.li_m_i[i];
        let vj = jm.s_mul(v[i]);
        if i == 0 {
            data.v[0] = vj;
            data.a[0] = Motion::zero();
        } else {
            let vi = li.act_inv_motion(&data.v[i - 1]).add(&vj);
            data.a[i] = li.act_inv_motion(&data.a[i - 1]).add(&vi.cross_motion(&vj));
            data.v[i] = vi;
        }
    }
    let o_m_f = data.o_m_i[p].compose(&fr.placement);
    data.o_m_f[frame.0] = o_m_f;
    let vf = fr.placement.act_inv_motion(&data.v[p]);
    let af = fr.placement.act_inv_motion(&data.a[p]);
    let lin = o_m_f.rot * (af.v + vf.w.cross(&vf.v));
    let ang = o_m_f.rot * af.w;
    Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)
}

/// One RNEA implementation for τ, bias and gravity torques (`None` = zero).
#[inline(always)]
fn rnea_impl<D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>, S3: Storage<f64, D>>(
    model: &Model,
    data: &mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: Option<&Vector<f64, D, S2>>,
    a: Option<&Vector<f64, D, S3>>,
) where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    let n = data.nv();
    let a0 = Motion::new(-model.gravity, nalgebra::Vector3::zeros());
    joint_transforms(model, data, q, n - 1);
    for i in 0..n {
        let jm = &model.joints[i];
        let li = data.li_m_i[i];
        let qd = v.map_or(0.0, |v| v[i]);
        let qdd = a.map_or(0.0, |a| a[i]);
        let vj = jm.s_mul(qd);
        let (vi, ai) = if i == 0 {
            (vj, li.act_inv_motion(&a0).add(&jm.s_mul(qdd)))
        } else {
            let vi = li.act_inv_motion(&data.v[i - 1]).add(&vj);
            let ai = li.act_inv_motion(&data.a[i - 1]).add(&jm.s_mul(qdd)).add(&vi.cross_motion(&vj));
            (vi, ai)
        };
        data.v[i] = vi;
        data.a[i] = ai;
        let y = &jm.inertia;
        data.f[i] = y.mul_motion(&ai).add(&vi.cross_force(&y.mul_motion(&vi)));
    }
    for i in (0..n).rev() {
        let fi = data.f[i];
        data.tau[i] = model.joints[i].s_t_force(&fi);
        if i > 0 {
            let fp = data.li_m_i[i].act_force(&fi);
            data.f[i - 1] = data.f[i - 1].add(&fp);
        }
    }
}

/// Inverse dynamics (RNEA): `τ = M(q) q̈ + C(q, q̇) q̇ + G(q)` (eq. 1 without
/// friction and external torque). Result also in `data.tau`.
pub fn rnea<'d, D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>, S3: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: &Vector<f64, D, S2>,
    a: &Vector<f64, D, S3>,
) -> &'d OVector<f64, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    check(model, data, v, "v");
    check(model, data, a, "a");
    rnea_impl(model, data, q, Some(v), Some(a));
    &data.tau
}

/// Bias torques `C(q, q̇) q̇ + G(q)` = RNEA(q, q̇, 0). Result also in `data.tau`.
pub fn bias_torques<'d, D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: &Vector<f64, D, S2>,
) -> &'d OVector<f64, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    check(model, data, v, "v");
    rnea_impl::<D, S1, S2, S2>(model, data, q, Some(v), None);
    &data.tau
}

/// Gravity torques `G(q)` = RNEA(q, 0, 0). Result also in `data.tau`.
pub fn gravity_torques<'d, D: Dim, S1: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S1>,
) -> &'d OVector<f64, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    rnea_impl::<D, S1, S1, S1>(model, data, q, None, None);
    &data.tau
}

/// Joint-space inertia matrix `M(q)` (CRBA), full and symmetric. Result also in `data.m`.
pub fn crba<'d, D: Dim, S1: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S1>,
) -> &'d OMatrix<f64, D, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    let n = data.nv();
    // M does not depend on the first joint's position (everything is relative
    // to body 0), so λM₀ is never needed: only joints 1.. are placed (unless
    // all placements for this q are already in `data`).
    let placed = data.li_valid == n && (0..n).all(|i| data.placed_q[i].to_bits() == q[i].to_bits());
    if !placed {
        data.li_valid = 0; // λM₀ stays stale: no placement is current for any q
        data.o_valid = 0;
        for i in 1..n {
            data.li_m_i[i] = model.joints[i].transform(q[i]);
        }
    }
    for i in 0..n {
        data.ycrb[i] = model.joints[i].inertia;
    }
    // Leaf to root: when body i is reached its composite inertia Ic_i is complete.
    // Column i: F = Ic_i S_i carried to every ancestor j, M[j,i] = S_jᵀ F; then Ic_i joins its parent.
    for i in (0..n).rev() {
        let jm = &model.joints[i];
        let yc = data.ycrb[i];
        let mut f = jm.inertia_s(&yc);
        data.m[(i, i)] = jm.s_t_force(&f);
        for j in (0..i).rev() {
            f = data.li_m_i[j + 1].act_force(&f);
            let mji = model.joints[j].s_t_force(&f);
            data.m[(j, i)] = mji;
            data.m[(i, j)] = mji;
        }
        if i > 0 {
            let yp = data.li_m_i[i].act_inertia(&yc);
            data.ycrb[i - 1] = data.ycrb[i - 1].add(&yp);
        }
    }
    &data.m
}

/// Forward dynamics (ABA): `q̈ = M⁻¹ (τ − C q̇ − G)`. Result also in `data.ddq`.
/// To apply an external wrench, add `Jᵀ F` to `tau` (eq. 2).
pub fn aba<'d, D: Dim, S1: Storage<f64, D>, S2: Storage<f64, D>, S3: Storage<f64, D>>(
    model: &Model,
    data: &'d mut Data<D>,
    q: &Vector<f64, D, S1>,
    v: &Vector<f64, D, S2>,
    tau: &Vector<f64, D, S3>,
) -> &'d OVector<f64, D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    check(model, data, q, "q");
    check(model, data, v, "v");
    check(model, data, tau, "tau");
    let n = data.nv();
    // Pass 1, root to leaf: velocities, bias accelerations, rigid inertias.
    joint_transforms(model, data, q, n - 1);
    for i in 0..n {
        let jm = &model.joints[i];
        let li = data.li_m_i[i];
        let vj = jm.s_mul(v[i]);
        let vi = if i == 0 { vj } else { li.act_inv_motion(&data.v[i - 1]).add(&vj) };
        data.v[i] = vi;
        data.c[i] = vi.cross_motion(&vj);
        let y = &jm.inertia;
        data.ia[i] = y.to_articulated();
        data.pa[i] = vi.cross_force(&y.mul_motion(&vi));
    }
    // Pass 2, leaf to root: articulated inertias and bias forces.
    for i in (0..n).rev() {
        let jm = &model.joints[i];
        let s = jm.s_mul(1.0);
        let u_f = data.ia[i].mul_motion(&s);
        let dinv = 1.0 / s.dot_force(&u_f);
        let u = tau[i] - jm.s_t_force(&data.pa[i]);
        data.u_f[i] = u_f;
        data.dinv[i] = dinv;
        data.u[i] = u;
        if i > 0 {
            let ia_a = data.ia[i].sub_rank1(&u_f, dinv);
            let k = u * dinv;
            let pa = data.pa[i].add(&ia_a.mul_motion(&data.c[i])).add(&Force { f: u_f.f * k, n: u_f.n * k });
            let li = data.li_m_i[i];
            let ia_p = li.act_articulated(&ia_a);
            data.ia[i - 1].add_assign(&ia_p);
            data.pa[i - 1] = data.pa[i - 1].add(&li.act_force(&pa));
        }
    }
    // Pass 3, root to leaf: accelerations.
    let a0 = Motion::new(-model.gravity, nalgebra::Vector3::zeros());
    for i in 0..n {
        let jm = &model.joints[i];
        let ap = if i == 0 { a0 } else { data.a[i - 1] };
        let ai = data.li_m_i[i].act_inv_motion(&ap).add(&data.c[i]);
        let qdd = (data.u[i] - ai.dot_force(&data.u_f[i])) * data.dinv[i];
        data.ddq[i] = qdd;
        data.a[i] = ai.add(&jm.s_mul(qdd));
    }
    &data.ddq
}
