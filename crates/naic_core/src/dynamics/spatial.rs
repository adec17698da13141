//! Spatial algebra on stack types, in Pinocchio's layout.
//!
//! * [`Se3`]: a rigid transform `aMb` (rotation `rot`, translation `trans`)
//!   that maps coordinates in frame `b` to frame `a`: `p_a = rot * p_b + trans`.
//! * [`Motion`]: a spatial velocity/acceleration `(v, w)` = (linear, angular),
//!   the linear part being the velocity of the point at the frame origin.
//! * [`Force`]: a spatial force `(f, n)` = (force, moment about the origin).
//! * [`Inertia`]: a rigid-body inertia `(mass, com, inertia about the com)`.
//! * [`ArticulatedInertia`]: a symmetric 6×6 operator kept as 3×3 blocks, for ABA.
//!
//! Every operation is written with 3-vectors and cross products; no 6×6
//! matrix product appears anywhere (Featherstone, *Rigid Body Dynamics
//! Algorithms*, 2008, ch. 2; Pinocchio's `SE3`, `Motion`, `Force`, `Inertia`).

use nalgebra::{Matrix3, Vector3};

/// Skew-symmetric matrix `[a]×` such that `[a]× b = a × b`.
#[inline(always)]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// `R S Rᵀ` for a symmetric `S` (computes the upper triangle only).
#[inline(always)]
pub fn rotate_symmetric(r: &Matrix3<f64>, s: &Matrix3<f64>) -> Matrix3<f64> {
    let a = r * s;
    let e = |i: usize, j: usize| a[(i, 0)] * r[(j, 0)] + a[(i, 1)] * r[(j, 1)] + a[(i, 2)] * r[(j, 2)];
    let (xx, xy, xz, yy, yz, zz) = (e(0, 0), e(0, 1), e(0, 2), e(1, 1), e(1, 2), e(2, 2));
    Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
}

/// Rigid transform `aMb`: `p_a = rot * p_b + trans`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3 {
    pub rot: Matrix3<f64>,
    pub trans: Vector3<f64>,
}

impl Default for Se3 {
    fn default() -> Self {
        Self::identity()
    }
}

impl Se3 {
    #[inline(always)]
    pub fn identity() -> Self {
        Self { rot: Matrix3::identity(), trans: Vector3::zeros() }
    }

    #[inline(always)]
    pub fn new(rot: Matrix3<f64>, trans: Vector3<f64>) -> Self {
        Self { rot, trans }
    }

    /// `aMc = aMb * bMc`.
    #[inline(always)]
    pub fn compose(&self, other: &Se3) -> Se3 {
        Se3 { rot: self.rot * other.rot, trans: self.rot * other.trans + self.trans }
    }

    /// `bMa` from `aMb`.
    #[inline(always)]
    pub fn inverse(&self) -> Se3 {
        let rt = self.rot.transpose();
        Se3 { rot: rt, trans: -(rt * self.trans) }
    }

    /// Transform a point from frame b to frame a.
    #[inline(always)]
    pub fn act_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rot * p + self.trans
    }

    /// Motion expressed in b → the same motion expressed in a.
    #[inline(always)]
    pub fn act_motion(&self, m: &Motion) -> Motion {
        let w = self.rot * m.w;
        Motion { v: self.rot * m.v + self.trans.cross(&w), w }
    }

    /// Motion expressed in a → the same motion expressed in b.
    #[inline(always)]
    pub fn act_inv_motion(&self, m: &Motion) -> Motion {
        let rt = self.rot.transpose();
        Motion { v: rt * (m.v - self.trans.cross(&m.w)), w: rt * m.w }
    }

    /// Force expressed in b → the same force expressed in a.
    #[inline(always)]
    pub fn act_force(&self, f: &Force) -> Force {
        let ff = self.rot * f.f;
        Force { f: ff, n: self.rot * f.n + self.trans.cross(&ff) }
    }

    /// Inertia expressed in b → the same inertia expressed in a.
    #[inline(always)]
    pub fn act_inertia(&self, y: &Inertia) -> Inertia {
        Inertia {
            mass: y.mass,
            com: self.act_point(&y.com),
            inertia: rotate_symmetric(&self.rot, &y.inertia),
        }
    }

    /// Articulated inertia expressed in b → expressed in a (`aX*_b · I · bX_a`).
    ///
    /// With `I = [A B; Bᵀ C]` (force = I · motion, both (linear, angular)),
    /// rotation R and translation P = `[p]×`: A' = R A Rᵀ, B' = R B Rᵀ, C' = R C Rᵀ, then
    /// A'' = A', B'' = B' − A' P, C'' = C' − B'ᵀ P + P B' − P A' P.
    #[inline(always)]
    pub fn act_articulated(&self, ia: &ArticulatedInertia) -> ArticulatedInertia {
        let r = &self.rot;
        let rt = r.transpose();
        let a = rotate_symmetric(r, &ia.a);
        let b = r * ia.b * rt;
        let c = rotate_symmetric(r, &ia.c);
        let p = skew(&self.trans);
        let ap = a * p;
        let btp = b.transpose() * p;
        // P B' − B'ᵀ P = P B' + (P B')ᵀ ... since (P B')ᵀ = B'ᵀ Pᵀ = −B'ᵀ P.
        let pb = p * b;
        let c2 = c - btp + pb - p * ap;
        ArticulatedInertia { a, b: b - ap, c: c2 }
    }

    /// As a nalgebra isometry (for callers).
    pub fn to_isometry(&self) -> nalgebra::Isometry3<f64> {
        let rot = nalgebra::Rotation3::from_matrix_unchecked(self.rot);
        nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::from(self.trans),
            nalgebra::UnitQuaternion::from_rotation_matrix(&rot),
        )
    }
}

/// Spatial motion (twist or spatial acceleration): `v` linear, `w` angular.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
}

impl Motion {
    #[inline(always)]
    pub fn zero() -> Self {
        Self { v: Vector3::zeros(), w: Vector3::zeros() }
    }
    #[inline(always)]
    pub fn new(v: Vector3<f64>, w: Vector3<f64>) -> Self {
        Self { v, w }
    }
    /// Spatial cross product for motions: `self ×ₘ m`.
    #[inline(always)]
    pub fn cross_motion(&self, m: &Motion) -> Motion {
        Motion { v: self.w.cross(&m.v) + self.v.cross(&m.w), w: self.w.cross(&m.w) }
    }
    /// Spatial cross product for forces: `self ×* f`.
    #[inline(always)]
    pub fn cross_force(&self, f: &Force) -> Force {
        Force { f: self.w.cross(&f.f), n: self.w.cross(&f.n) + self.v.cross(&f.f) }
    }
    #[inline(always)]
    pub fn add(&self, o: &Motion) -> Motion {
        Motion { v: self.v + o.v, w: self.w + o.w }
    }
    #[inline(always)]
    pub fn dot_force(&self, f: &Force) -> f64 {
        self.v.dot(&f.f) + self.w.dot(&f.n)
    }
}

/// Spatial force (wrench): `f` force, `n` moment about the frame origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Force {
    pub f: Vector3<f64>,
    pub n: Vector3<f64>,
}

impl Force {
    #[inline(always)]
    pub fn zero() -> Self {
        Self { f: Vector3::zeros(), n: Vector3::zeros() }
    }
    #[inline(always)]
    pub fn add(&self, o: &Force) -> Force {
        Force { f: self.f + o.f, n: self.n + o.n }
    }
}

/// Rigid-body inertia: `mass`, centre of mass `com` (in the body frame) and
/// the rotational inertia `inertia` about the centre of mass (body axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia {
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
}

impl Default for Inertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl Inertia {
    pub fn zero() -> Self {
        Self { mass: 0.0, com: Vector3::zeros(), inertia: Matrix3::zeros() }
    }

    /// Momentum `I · m` of the body moving with spatial velocity `m`.
    #[inline(always)]
    pub fn mul_motion(&self, m: &Motion) -> Force {
        let f = self.mass * (m.v - self.com.cross(&m.w));
        Force { f, n: self.inertia * m.w + self.com.cross(&f) }
    }

    /// Sum of two inertias expressed in the same frame (parallel-axis theorem).
    #[inline(always)]
    pub fn add(&self, o: &Inertia) -> Inertia {
        let mass = self.mass + o.mass;
        if mass <= 0.0 {
            return Inertia { mass: 0.0, com: Vector3::zeros(), inertia: self.inertia + o.inertia };
        }
        let com = (self.com * self.mass + o.com * o.mass) / mass;
        let d = self.com - o.com;
        // m1 m2 / m · ([d]×ᵀ[d]×) = m1 m2 / m · (|d|² I − d dᵀ)
        let k = self.mass * o.mass / mass;
        let dd = d.norm_squared();
        let mut parallel = d * d.transpose() * (-k);
        parallel[(0, 0)] += k * dd;
        parallel[(1, 1)] += k * dd;
        parallel[(2, 2)] += k * dd;
        Inertia { mass, com, inertia: self.inertia + o.inertia + parallel }
    }

    /// As an articulated (6×6 block) inertia.
    #[inline(always)]
    pub fn to_articulated(&self) -> ArticulatedInertia {
        let cx = skew(&self.com);
        let m = self.mass;
        ArticulatedInertia {
            a: Matrix3::from_diagonal_element(m),
            b: -m * cx,
            c: self.inertia - m * cx * cx,
        }
    }
}

/// Symmetric 6×6 spatial inertia operator `[a b; bᵀ c]` (force = I · motion).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ArticulatedInertia {
    pub a: Matrix3<f64>,
    pub b: Matrix3<f64>,
    pub c: Matrix3<f64>,
}

impl ArticulatedInertia {
    #[inline(always)]
    pub fn mul_motion(&self, m: &Motion) -> Force {
        Force { f: self.a * m.v + self.b * m.w, n: self.b.tr_mul(&m.v) + self.c * m.w }
    }
    #[inline(always)]
    pub fn add_assign(&mut self, o: &ArticulatedInertia) {
        self.a += o.a;
        self.b += o.b;
        self.c += o.c;
    }
    /// `self − u uᵀ / d` for a spatial force vector `u`.
    #[inline(always)]
    pub fn sub_rank1(&self, u: &Force, dinv: f64) -> ArticulatedInertia {
        let uf = u.f * dinv;
        ArticulatedInertia {
            a: self.a - uf * u.f.transpose(),
            b: self.b - uf * u.n.transpose(),
            c: self.c - u.n * dinv * u.n.transpose(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix6, Rotation3, Vector6};

    fn m6(ia: &ArticulatedInertia) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&ia.a);
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&ia.b);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&ia.b.transpose());
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&ia.c);
        m
    }
    fn xm(t: &Se3) -> Matrix6<f64> {
        // motion b -> a
        let mut x = Matrix6::zeros();
        x.fixed_view_mut::<3, 3>(0, 0).copy_from(&t.rot);
        x.fixed_view_mut::<3, 3>(0, 3).copy_from(&(skew(&t.trans) * t.rot));
        x.fixed_view_mut::<3, 3>(3, 3).copy_from(&t.rot);
        x
    }

    #[test]
    fn articulated_transform_matches_6x6() {
        let t = Se3::new(
            *Rotation3::from_euler_angles(0.3, -0.7, 1.1).matrix(),
            Vector3::new(0.2, -0.5, 0.9),
        );
        let y = Inertia {
            mass: 2.5,
            com: Vector3::new(0.1, 0.2, -0.3),
            inertia: Matrix3::new(0.3, 0.01, 0.02, 0.01, 0.4, 0.03, 0.02, 0.03, 0.5),
        };
        let ia = y.to_articulated();
        let got = m6(&t.act_articulated(&ia));
        let x = xm(&t);
        let xinv = xm(&t.inverse());
        // force b->a is X_m(a<-b)^-T; I_a = X^-T I_b X^-1
        let want = xinv.transpose() * m6(&ia) * xinv;
        assert!((got - want).norm() < 1e-12, "{got}\n{want}");
        // and it equals the rigid-inertia transform
        assert!((m6(&t.act_inertia(&y).to_articulated()) - want).norm() < 1e-12);
        // motion action agrees with the 6x6 form
        let mv = Motion::new(Vector3::new(1.0, 2.0, 3.0), Vector3::new(-1.0, 0.5, 0.25));
        let am = t.act_motion(&mv);
        let v6 = x * Vector6::new(1.0, 2.0, 3.0, -1.0, 0.5, 0.25);
        assert!((Vector6::new(am.v.x, am.v.y, am.v.z, am.w.x, am.w.y, am.w.z) - v6).norm() < 1e-12);
    }

    #[test]
    fn inertia_add_is_parallel_axis() {
        let a = Inertia { mass: 1.0, com: Vector3::new(1.0, 0.0, 0.0), inertia: Matrix3::zeros() };
        let b = Inertia { mass: 1.0, com: Vector3::new(-1.0, 0.0, 0.0), inertia: Matrix3::zeros() };
        let s = a.add(&b);
        assert_eq!(s.mass, 2.0);
        assert!(s.com.norm() < 1e-15);
        assert!((s.inertia - Matrix3::from_diagonal(&Vector3::new(0.0, 2.0, 2.0))).norm() < 1e-15);
        // 6x6 forms add
        assert!((m6(&s.to_articulated()) - m6(&a.to_articulated()) - m6(&b.to_articulated())).norm() < 1e-12);
    }
}
