//! Compliant contact environments for the `tip` frame.
//!
//! The environment is a plane (point + outward unit normal) whose material
//! (stiffness `k_e`, damping `b_e`, optional Coulomb friction `mu`) may depend
//! on where the tip is (two materials side by side) or on time (the stiffness
//! schedule of the paper's equation 22). Contact is unilateral: with
//! penetration `d = n·(p0 − p_tip) > 0` and penetration rate `ḋ = −n·v_tip`,
//! the normal force on the robot is `F_n = max(0, k_e d + b_e ḋ)` along `n`;
//! the environment never pulls. Optional tangential friction opposes the
//! sliding velocity with magnitude `mu F_n tanh(|v_t| / v_slip)`. Two materials
//! side by side are two blocks: the stiffer one's side face pushes a tip that
//! meets it below its top out along x ([`Environment::contact`]).
//!
//! The tip is a point: the authors' MJCF tip sphere has radius 0.01 m and
//! their table top is at z = 0.07 m, so the tip *centre* touches at 0.08 m —
//! the surface height of the paper's §4.1. Our surfaces are given as the
//! height of the tip centre at first touch.

use nalgebra::{Unit, Vector3};

/// Contact material: normal stiffness [N/m], normal damping [N·s/m],
/// Coulomb friction coefficient (0 = frictionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub k_e: f64,
    pub b_e: f64,
    pub mu: f64,
}

/// Which material is under the tip.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialMap {
    /// One material everywhere, always.
    Uniform(Material),
    /// Equation 22: `k_e` switches at the given times (seconds, ascending);
    /// before the first switch `base.k_e` applies. Damping and friction stay.
    StiffnessSchedule { base: Material, switches: Vec<(f64, f64)> },
    /// Two materials split by the plane `x = x_boundary` (base frame):
    /// `high_x` where tip x ≥ boundary, `low_x` below it.
    SplitX { x_boundary: f64, high_x: Material, low_x: Material },
}

impl MaterialMap {
    /// The material in effect at time `t` at tip position `p`.
    pub fn at(&self, t: f64, p: &Vector3<f64>) -> Material {
        match self {
            MaterialMap::Uniform(m) => *m,
            MaterialMap::StiffnessSchedule { base, switches } => {
                let mut m = *base;
                for &(t_switch, k) in switches {
                    if t >= t_switch {
                        m.k_e = k;
                    }
                }
                m
            }
            MaterialMap::SplitX { x_boundary, high_x, low_x } => {
                if p.x >= *x_boundary {
                    *high_x
                } else {
                    *low_x
                }
            }
        }
    }

    /// Largest stiffness this map can present (for choosing sub-steps).
    pub fn max_stiffness(&self) -> f64 {
        match self {
            MaterialMap::Uniform(m) => m.k_e,
            MaterialMap::StiffnessSchedule { base, switches } => {
                switches.iter().map(|s| s.1).fold(base.k_e, f64::max)
            }
            MaterialMap::SplitX { high_x, low_x, .. } => high_x.k_e.max(low_x.k_e),
        }
    }
}

/// A plane surface with a material map. `enabled = false` turns contact off.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// A point on the surface (where the tip centre first touches), base frame.
    pub point: Vector3<f64>,
    /// Outward unit normal (pointing from the material into free space).
    pub normal: Unit<Vector3<f64>>,
    pub material: MaterialMap,
    /// Speed below which tangential friction is scaled down (tanh), m/s.
    pub v_slip: f64,
    pub enabled: bool,
}

/// The contact state for one tip position/velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Contact {
    /// Penetration depth along the normal [m] (negative: tip above the surface).
    pub penetration: f64,
    /// Normal force magnitude the environment applies to the robot [N] (≥ 0).
    pub normal_force: f64,
    /// Force of the environment on the robot at the tip origin, base frame [N].
    pub force: Vector3<f64>,
    /// Stiffness in effect [N/m].
    pub k_e: f64,
    pub in_contact: bool,
    /// The contact is with the stiffer block's side face (two materials,
    /// [`Environment::contact`]), not with a top.
    pub on_side: bool,
}

impl Environment {
    /// A horizontal plane at height `z` with upward normal.
    pub fn horizontal(z: f64, material: MaterialMap) -> Self {
        Self {
            point: Vector3::new(0.0, 0.0, z),
            normal: Vector3::z_axis(),
            material,
            v_slip: 1e-3,
            enabled: true,
        }
    }

    /// Height of the surface above (x, y) along base z (for plots); NaN for a
    /// vertical plane.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let n = self.normal.as_ref();
        if n.z.abs() < 1e-12 {
            return f64::NAN;
        }
        self.point.z - (n.x * (x - self.point.x) + n.y * (y - self.point.y)) / n.z
    }

    /// Contact force on the tip at time `t` (allocation-free).
    ///
    /// On two materials ([`MaterialMap::SplitX`]) the stiffer one is a block whose side face
    /// (the plane `x = x_boundary`) stands above the softer one's surface wherever the softer
    /// one is pressed down: a tip inside the stiffer block that is nearer its side face than
    /// its top ([`Environment::side_face`]) is pushed out through the side, along x, as a box
    /// contact pushes out through its nearest face (MuJoCo's two table boxes do the same). Without
    /// it a tip pressed into the foam that moved back across the boundary would be read as
    /// that depth below the acrylic's top: a vertical spring force of `k_acrylic` times the
    /// foam's depth (50 000 N/m × 2 mm = 100 N) that no real edge gives.
    pub fn contact(&self, t: f64, p_tip: &Vector3<f64>, v_tip: &Vector3<f64>) -> Contact {
        let n = self.normal.as_ref();
        let penetration = n.dot(&(self.point - p_tip));
        let mat = self.material.at(t, p_tip);
        if !self.enabled || penetration <= 0.0 {
            return Contact { penetration, k_e: mat.k_e, ..Default::default() };
        }
        if let Some((side, depth)) = self.side_face(&mat, p_tip, penetration) {
            let force = self.face_force(&side, depth, &mat, v_tip);
            return Contact { penetration: depth, normal_force: n.dot(&force).max(0.0), force, k_e: mat.k_e, in_contact: true, on_side: true };
        }
        let force = self.face_force(n, penetration, &mat, v_tip);
        Contact { penetration, normal_force: n.dot(&force).max(0.0), force, k_e: mat.k_e, in_contact: true, on_side: false }
    }

    /// The force of one face (outward unit normal `n`, penetration `depth` > 0) of `mat` on
    /// the tip: `max(0, k_e d + b_e ḋ)` along `n`, and Coulomb friction against the sliding.
    fn face_force(&self, n: &Vector3<f64>, depth: f64, mat: &Material, v_tip: &Vector3<f64>) -> Vector3<f64> {
        let rate = -n.dot(v_tip);
        let normal_force = (mat.k_e * depth + mat.b_e * rate).max(0.0);
        let mut force = n * normal_force;
        if mat.mu > 0.0 && normal_force > 0.0 {
            let v_t = v_tip - n * n.dot(v_tip);
            let speed = v_t.norm();
            if speed > 1e-12 {
                force -= v_t * (mat.mu * normal_force * (speed / self.v_slip).tanh() / speed);
            }
        }
        force
    }

    /// On two materials: the stiffer block's side face when the tip (`penetration` > 0 below
    /// the top) is inside that block and nearer its side than its top — `(outward normal of
    /// the side, depth through it)`; else `None`. Equal stiffnesses have no exposed side.
    /// `mat`: the material the map gives at the tip ([`MaterialMap::at`]); the tip is inside the
    /// stiffer block exactly when that is the stiffer material (the map's boundary convention,
    /// kept in one place).
    fn side_face(&self, mat: &Material, p_tip: &Vector3<f64>, penetration: f64) -> Option<(Vector3<f64>, f64)> {
        let MaterialMap::SplitX { x_boundary, high_x, low_x } = &self.material else { return None };
        if high_x.k_e == low_x.k_e || mat.k_e != high_x.k_e.max(low_x.k_e) {
            return None;
        }
        // outward from the stiffer block: −x when it is the high-x one
        let outward = if high_x.k_e > low_x.k_e { -1.0 } else { 1.0 };
        let inside = outward * (x_boundary - p_tip.x);
        (inside < penetration).then(|| (Vector3::new(outward, 0.0, 0.0), inside))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const M: Material = Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 };

    #[test]
    fn static_force_is_stiffness_times_penetration_and_never_pulls() {
        let env = Environment::horizontal(0.08, MaterialMap::Uniform(M));
        let c = env.contact(0.0, &Vector3::new(-0.4, 0.1, 0.075), &Vector3::zeros());
        assert!(c.in_contact);
        assert!((c.penetration - 0.005).abs() < 1e-15);
        assert!((c.force.z - 10.0).abs() < 1e-9 && c.force.x == 0.0 && c.force.y == 0.0);
        // above the surface: nothing
        let c = env.contact(0.0, &Vector3::new(0.0, 0.0, 0.081), &Vector3::zeros());
        assert!(!c.in_contact && c.force == Vector3::zeros());
        // leaving fast with damping: force clipped at zero, not negative (no pulling)
        let env = Environment::horizontal(0.08, MaterialMap::Uniform(Material { b_e: 100.0, ..M }));
        let c = env.contact(0.0, &Vector3::new(0.0, 0.0, 0.079), &Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(c.normal_force, 0.0);
        assert!(c.force.z >= 0.0);
    }

    #[test]
    fn stiffness_schedule_switches_exactly_at_the_stated_times() {
        let env = Environment::horizontal(
            0.08,
            MaterialMap::StiffnessSchedule { base: M, switches: vec![(2.0, 5000.0), (4.0, 2000.0)] },
        );
        let p = Vector3::new(0.0, 0.0, 0.07);
        let k = |t: f64| env.contact(t, &p, &Vector3::zeros()).k_e;
        assert_eq!(k(0.0), 2000.0);
        assert_eq!(k(1.999_999), 2000.0);
        assert_eq!(k(2.0), 5000.0);
        assert_eq!(k(3.999_999), 5000.0);
        assert_eq!(k(4.0), 2000.0);
        assert!((env.contact(2.5, &p, &Vector3::zeros()).force.z - 50.0).abs() < 1e-9);
    }

    #[test]
    fn tilted_plane_height_and_normal_force_direction() {
        let theta: f64 = 0.2;
        let env = Environment {
            point: Vector3::new(-0.3, 0.0, 0.1),
            normal: Unit::new_normalize(Vector3::new(theta.sin(), 0.0, theta.cos())),
            material: MaterialMap::Uniform(M),
            v_slip: 1e-3,
            enabled: true,
        };
        // surface rises towards -x: height = 0.1 + tan(theta) (−0.3 − x)
        let h = env.height_at(-0.5, 0.0);
        assert!((h - (0.1 + theta.tan() * 0.2)).abs() < 1e-12);
        let p = Vector3::new(-0.5, 0.0, h - 0.01); // 1 cm below along z
        let c = env.contact(0.0, &p, &Vector3::zeros());
        assert!((c.penetration - 0.01 * theta.cos()).abs() < 1e-12);
        assert!((c.force.normalize() - env.normal.into_inner()).norm() < 1e-12);
    }

    #[test]
    fn tangential_friction_opposes_sliding_and_is_bounded_by_mu_fn() {
        let env = Environment::horizontal(0.0, MaterialMap::Uniform(Material { mu: 0.3, ..M }));
        let c = env.contact(0.0, &Vector3::new(0.0, 0.0, -0.01), &Vector3::new(0.5, 0.0, 0.0));
        assert!((c.force.z - 20.0).abs() < 1e-9);
        assert!(c.force.x < 0.0 && (c.force.x + 0.3 * 20.0).abs() < 1e-6);
    }

    #[test]
    fn split_materials_by_x() {
        let acrylic = Material { k_e: 50_000.0, b_e: 50.0, mu: 0.0 };
        let foam = Material { k_e: 1000.0, b_e: 10.0, mu: 0.0 };
        let map = MaterialMap::SplitX { x_boundary: -0.45, high_x: acrylic, low_x: foam };
        assert_eq!(map.at(0.0, &Vector3::new(-0.40, 0.0, 0.0)), acrylic);
        assert_eq!(map.at(0.0, &Vector3::new(-0.50, 0.0, 0.0)), foam);
        assert_eq!(map.max_stiffness(), 50_000.0);
    }

    /// A tip pressed 2 mm into the foam that moves 0.1 mm back across the boundary meets the
    /// acrylic's side face: 5 N along x, none along the surface normal (it was read as 2 mm
    /// below the acrylic's top: 100 N up). On the acrylic's top, away from the edge, the
    /// contact is the top's; the foam has no exposed side.
    #[test]
    fn the_stiffer_block_pushes_out_through_its_side_face() {
        let acrylic = Material { k_e: 50_000.0, b_e: 0.0, mu: 0.0 };
        let foam = Material { k_e: 1000.0, b_e: 0.0, mu: 0.0 };
        let env = Environment::horizontal(0.0, MaterialMap::SplitX { x_boundary: -0.45, high_x: acrylic, low_x: foam });
        let still = Vector3::zeros();
        let side = env.contact(0.0, &Vector3::new(-0.4499, 0.0, -2e-3), &still);
        assert!((side.force - Vector3::new(-5.0, 0.0, 0.0)).norm() < 1e-6, "{:?}", side.force);
        assert_eq!(side.normal_force, 0.0);
        assert!((side.penetration - 1e-4).abs() < 1e-12 && side.in_contact && side.on_side);
        let top = env.contact(0.0, &Vector3::new(-0.44, 0.0, -6e-5), &still);
        assert!((top.force - Vector3::new(0.0, 0.0, 3.0)).norm() < 1e-6 && !top.on_side, "{:?}", top.force);
        let in_foam = env.contact(0.0, &Vector3::new(-0.4501, 0.0, -2e-3), &still);
        assert!((in_foam.force - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-6, "{:?}", in_foam.force);
        // the other way round (the stiffer block on the low-x side): its side faces +x
        let env = Environment::horizontal(0.0, MaterialMap::SplitX { x_boundary: -0.45, high_x: foam, low_x: acrylic });
        let side = env.contact(0.0, &Vector3::new(-0.4501, 0.0, -2e-3), &still);
        assert!((side.force - Vector3::new(5.0, 0.0, 0.0)).norm() < 1e-6, "{:?}", side.force);
    }
}
