//! MuJoCo as the plant (cargo feature `mujoco`): the MJCF (default: the paper
//! authors' JK5, `../shared/reference/jk5/jk5_table.nomesh.mjcf.xml`) stepped in
//! process through `mujoco-rs`, behind [`crate::plants::Plant`].
//!
//! What the plant does to the file, in memory only (the file is never written):
//! * comments are dropped, and a force and a torque sensor are added at the site
//!   `nft_sensor` (the authors' F/T sensor, commented out in their file);
//! * the body `table` (if any) is replaced by box geoms that model the scenario's
//!   surface: top face on naic's surface moved down by the radius of the tip's sphere
//!   geom (naic's contact is at the tip origin, MuJoCo's at the sphere's surface, so
//!   both touch at the same tip position), `condim="1"` (frictionless, as every naic
//!   material), `solref="-k_e -b"` (the direct form: the scenario's k_e as MuJoCo's
//!   stiffness, `b = max(b_e, 0.1)`, the authors' own mapping of the paper's 2000 N/m in
//!   their file) and the authors' `solimp="0.1 0.3 0.001 0.5 2"`, with a `priority` one above
//!   the highest of the MJCF's geoms so that a contact takes these as they are (MuJoCo would
//!   otherwise mix them with the tip sphere's defaults: the mean `solimp` and the larger
//!   `condim`, 3 with friction 1; with unequal priorities MuJoCo takes the higher one's
//!   `condim`, `friction`, `solref` and `solimp`, its "Contact parameters";
//!   [`MujocoPlant::table_contacts`] reads them back). MuJoCo's contact is
//!   a soft constraint, not a spring: the static stiffness this gives is not k_e and is
//!   measured by [`static_stiffness`] (`naic sim --plant mujoco --stiffness-report`);
//! * the table meets the tip's geoms alone (naic's contact is at the tip): the table geoms
//!   have `contype 0` and the `conaffinity` bit [`TIP_ONLY`], which only the body `tip`'s
//!   geoms have in their `contype` (an MJCF whose `tip` has no geom is refused). MuJoCo's
//!   contact sinks the tip sphere past its radius on flat and foam, where the authors' tool
//!   stick (a cylinder ending at the sphere's centre) would otherwise reach the table;
//! * the time step is the control period over the own plant's sub-step count;
//! * the constraint solver is warm-started (the file's `<flag warmstart="disable"/>` is
//!   turned off): MuJoCo's Newton solver then starts from the previous step's accelerations
//!   and converges to the same solution within its tolerance in about half the iterations
//!   and a third of the line-search evaluations (the joint friction's six constraint rows
//!   are in every step). [`MujocoPlant::solution_gap`] measures the difference against the
//!   file's cold start (`tests/mujoco_friction.rs`).
//!
//! Torque enters through `qfrc_applied` (saturated at the URDF effort limits like the
//! own plant; the MJCF motors' ±100 N·m ctrlrange is not used), held over the period.
//! Joint friction (the MJCF has none): when `PlantParams::friction` holds the robot's model
//! (the JK5's Table 1, eq 5 per direction), MuJoCo computes it ([`MujocoJointFriction`]):
//! the law's Coulomb/Stribeck level at the joint's speed and direction is the DOF's
//! `frictionloss` (an implicit constraint: it holds a joint at rest and never pushes), its
//! viscous coefficient in that direction the DOF's `damping` (implicit in MuJoCo's Euler),
//! both written on the model before each MuJoCo step from the velocity then. Nothing of it
//! is explicit. Without a model the joints are
//! frictionless. After each period `mj_forward`
//! evaluates the sensors at the new state under the held torque, so the F/T reading
//! includes the tool's weight and inertial wrench as a real sensor does. The naic
//! convention (the wrench the tool exerts on the sensor) is the negative of MuJoCo's
//! force/torque sensor (the wrench the parent exerts on the child subtree); the
//! reading then goes through the mini45 model's bias, noise, range and resolution
//! ([`crate::sensor::Mini45::read`]).

use crate::environment::{Contact, Environment, Material, MaterialMap};
use crate::plant::{Observation, PlantError, PlantParams, RawMeasurements, Truth};
use crate::rng::Rng;
use crate::sensor::{Encoders, Mini45};
use mujoco_rs::mujoco_c as ffi;
use mujoco_rs::prelude::{MjData, MjModel};
use naic_core::{JointVec, N_JOINTS};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::ffi::CString;
use std::path::Path;

/// The authors' table `solimp` (their `jk5_table.xml`).
pub const AUTHORS_SOLIMP: [f64; 5] = [0.1, 0.3, 0.001, 0.5, 2.0];
/// The authors' table damping in `solref`'s direct form.
pub const AUTHORS_DAMPING: f64 = 0.1;
/// Half extent of a table box along its surface [m], and half thickness [m].
const TABLE_HALF: f64 = 1.0;
/// Thick enough that a tip sphere pushed deep (15 N on foam sinks about 30 mm; an approach at
/// 0.8 m/s sank 52 mm) never passes the box's middle, past which MuJoCo pushes it out through
/// the bottom face.
const TABLE_HALF_THICK: f64 = 0.5;
/// The collision bit of the table: its `conaffinity` and its only `contype` partner, the
/// tip body's geoms (the table geoms' own `contype` is 0).
const TIP_ONLY: i32 = 1 << 30;

/// MuJoCo's `solref` (direct form) for a naic material.
pub fn solref_for(m: &Material) -> [f64; 2] {
    [-m.k_e, -m.b_e.max(AUTHORS_DAMPING)]
}

struct TableGeom {
    id: usize,
    /// A point on the surface over the geom (material lookup).
    surface_point: Vector3<f64>,
    solref: [f64; 2],
}

/// [`MujocoPlant::solution_gap`]: the largest differences between two constraint solutions of
/// one state, joint accelerations [rad/s²], constraint torques [N·m], and the table's normal
/// contact force on the tip [N]; NaN if MuJoCo could not allocate the copy.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolutionGap {
    pub qacc: f64,
    pub qfrc_constraint: f64,
    pub contact_normal: f64,
}

/// The parameters MuJoCo used for one contact of the tip with the table (read from
/// `mjData.contact` after collision detection).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams {
    /// `dim`: 1 frictionless, 3 sliding friction, 4 and 6 with torsional and rolling.
    pub dim: i32,
    pub friction: [f64; 5],
    pub solref: [f64; 2],
    pub solimp: [f64; 5],
    /// Normal force [N] and the tangential force [N] (norm of the friction rows) of the contact.
    pub normal_n: f64,
    pub tangential_n: f64,
}

/// MuJoCo stepping an MJCF, as a [`crate::plants::Plant`].
pub struct MujocoPlant {
    data: MjData<Box<MjModel>>,
    dt: f64,
    substeps: u32,
    effort: JointVec,
    lower: JointVec,
    upper: JointVec,
    env: Environment,
    ft: Mini45,
    encoders: Encoders,
    rng: Rng,
    k: u64,
    q: JointVec,
    dq: JointVec,
    obs: Observation,
    force_adr: usize,
    torque_adr: usize,
    site_ee: i32,
    table: Vec<TableGeom>,
    qadr: [usize; N_JOINTS],
    vadr: [usize; N_JOINTS],
    /// The robot's joint friction as MuJoCo computes it (`None`: frictionless joints).
    friction: Option<[MujocoJointFriction; N_JOINTS]>,
    /// Constraint solves so far, with the solver's iterations and line-search cost evaluations
    /// over them ([`Self::solver_work`]); counting allocates nothing.
    work: SolverWork,
}

/// The constraint solver's work over a run: constraint solves (each MuJoCo step's and each
/// observation's `mj_forward`), solver iterations, line-search cost evaluations
/// (`mjData.solver_niter`, `mjSolverStat.neval`, summed over islands).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolverWork {
    pub solves: u64,
    pub iterations: u64,
    pub evaluations: u64,
}

/// One joint's friction law (eq 4 or 5) as MuJoCo computes it: `τ_f(q̇) = g(q̇)·sgn(q̇) + f_v·q̇`
/// with the level `g` (eq 5's `f_a + (f_b − f_a)e^{−(q̇/q_s)²}` of the direction of motion)
/// as the DOF's `frictionloss` and the direction's `f_v` as its `damping`, set from the
/// velocity before each MuJoCo step (one step of lag in the level; both act implicitly, so
/// a light joint needs no smoothing: the JK5's joint 6 has 0.0004 kg·m² in the MJCF, and
/// an explicit Stribeck term of 0.57 N·m would need `tanh(q̇/1.5 rad/s)` to be stable at
/// 1 ms). Within `v_s` of rest (the model's smoothing velocity) the level is the smaller
/// breakaway level `min(f_b⁺, f_b⁻)` and the damping the smaller `f_v`: the constraint
/// holds the joint against up to that torque in either direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MujocoJointFriction {
    pub law: naic_core::friction::JointFriction,
    /// [rad/s]
    pub v_s: f64,
}

impl MujocoJointFriction {
    /// `(frictionloss [N·m], damping [N·m·s/rad])` at joint velocity `qdot`.
    #[inline]
    pub fn level_and_damping(&self, qdot: f64) -> (f64, f64) {
        use naic_core::friction::JointFriction as L;
        let moving = qdot.abs() > self.v_s;
        match &self.law {
            L::CoulombViscous { f_c, f_v } => (*f_c, *f_v),
            L::Stribeck(p) => (if moving { p.magnitude(qdot) } else { p.f_b }, p.f_v),
            L::StribeckPerDirection { positive, negative } => {
                if !moving {
                    (positive.f_b.min(negative.f_b), positive.f_v.min(negative.f_v))
                } else if qdot > 0.0 {
                    (positive.magnitude(qdot), positive.f_v)
                } else {
                    (negative.magnitude(qdot), negative.f_v)
                }
            }
        }
    }
}

fn mjcf_err(path: &Path, problem: impl Into<String>) -> PlantError {
    PlantError::Mjcf { path: path.display().to_string(), problem: problem.into() }
}

/// `xml` without `<!-- -->` comments.
fn strip_comments(xml: &str) -> String {
    let mut out = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(i) = rest.find("<!--") {
        out.push_str(&rest[..i]);
        match rest[i..].find("-->") {
            Some(j) => rest = &rest[i + j + 3..],
            None => return out,
        }
    }
    out.push_str(rest);
    out
}

/// `xml` without the element `<body name="table" ...>...</body>` (nesting counted).
fn without_body(xml: &str, name: &str) -> String {
    let open = format!("<body name=\"{name}\"");
    let Some(start) = xml.find(&open) else { return xml.to_string() };
    let mut depth = 0i32;
    let mut i = start;
    while i < xml.len() {
        let r = &xml[i..];
        if r.starts_with("<body") {
            let end = r.find('>').map_or(r.len(), |e| e + 1);
            if !r[..end].ends_with("/>") {
                depth += 1;
            } else if depth == 0 {
                return format!("{}{}", &xml[..start], &xml[i + end..]);
            }
            i += end;
        } else if r.starts_with("</body>") {
            depth -= 1;
            i += 7;
            if depth == 0 {
                return format!("{}{}", &xml[..start], &xml[i..]);
            }
        } else {
            i += r.chars().next().map_or(1, char::len_utf8);
        }
    }
    xml.to_string()
}

const SENSORS: &str = "<force name=\"naic_ft_force\" site=\"nft_sensor\"/><torque name=\"naic_ft_torque\" site=\"nft_sensor\"/>";

fn with_sensors(xml: &str) -> String {
    if let Some(i) = xml.rfind("</sensor>") {
        format!("{}{SENSORS}{}", &xml[..i], &xml[i..])
    } else if let Some(i) = xml.rfind("</mujoco>") {
        format!("{}<sensor>{SENSORS}</sensor>{}", &xml[..i], &xml[i..])
    } else {
        xml.to_string()
    }
}

fn load(path: &Path, xml: &str) -> Result<MjModel, PlantError> {
    MjModel::from_xml_string(xml).map_err(|e| mjcf_err(path, format!("MuJoCo cannot load it: {e}")))
}

fn id(m: &MjModel, obj: ffi::mjtObj, name: &str) -> Option<i32> {
    let c = CString::new(name).ok()?;
    let i = unsafe { ffi::mj_name2id(m.ffi(), obj as i32, c.as_ptr()) };
    (i >= 0).then_some(i)
}

/// One box geom of the table: center, orientation, material.
struct Region {
    center: Vector3<f64>,
    surface_point: Vector3<f64>,
    rot: UnitQuaternion<f64>,
    half: [f64; 3],
    material: Material,
}

fn regions(env: &Environment, at: Vector3<f64>, r_tip: f64) -> Vec<Region> {
    if !env.enabled {
        return Vec::new();
    }
    let n = env.normal.into_inner();
    let rot = UnitQuaternion::rotation_between(&Vector3::z(), &n).unwrap_or_else(UnitQuaternion::identity);
    let make = |x: f64, y: f64, half_x: f64, material: Material| {
        let surface_point = Vector3::new(x, y, env.height_at(x, y));
        Region {
            center: surface_point - n * (r_tip + TABLE_HALF_THICK),
            surface_point,
            rot,
            half: [half_x, TABLE_HALF, TABLE_HALF_THICK],
            material,
        }
    };
    match &env.material {
        MaterialMap::Uniform(m) => vec![make(at.x, at.y, TABLE_HALF, *m)],
        MaterialMap::StiffnessSchedule { base, .. } => vec![make(at.x, at.y, TABLE_HALF, *base)],
        MaterialMap::SplitX { x_boundary, high_x, low_x } => vec![
            make(x_boundary + TABLE_HALF / 2.0, at.y, TABLE_HALF / 2.0, *high_x),
            make(x_boundary - TABLE_HALF, at.y, TABLE_HALF, *low_x),
        ],
    }
}

/// The table geoms; `priority` above every geom of the MJCF (module docs).
fn table_xml(regions: &[Region], priority: i32) -> String {
    let mut s = String::new();
    for (i, r) in regions.iter().enumerate() {
        let q = r.rot.quaternion();
        let sr = solref_for(&r.material);
        let si = AUTHORS_SOLIMP;
        s.push_str(&format!(
            "<geom name=\"naic_table_{i}\" type=\"box\" size=\"{} {} {}\" pos=\"{} {} {}\" quat=\"{} {} {} {}\" condim=\"1\" contype=\"0\" conaffinity=\"{TIP_ONLY}\" priority=\"{priority}\" solref=\"{} {}\" solimp=\"{} {} {} {} {}\"/>",
            r.half[0], r.half[1], r.half[2], r.center.x, r.center.y, r.center.z, q.w, q.i, q.j, q.k, sr[0], sr[1], si[0], si[1], si[2], si[3], si[4]
        ));
    }
    s
}

impl MujocoPlant {
    /// MuJoCo on `mjcf` in the world of `p` (its environment, sensor and encoder
    /// models, control period, sub-steps and effort limits), at rest at `q0`.
    pub fn new(mjcf: &Path, p: &PlantParams, q0: &[f64], seed: u64) -> Result<Self, PlantError> {
        let text = std::fs::read_to_string(mjcf).map_err(|e| {
            mjcf_err(mjcf, format!("cannot read it ({e}); give the MuJoCo model with --mjcf FILE (default: the authors' JK5 in ../shared/reference/jk5/)"))
        })?;
        if q0.len() != N_JOINTS {
            return Err(PlantError::Config(format!("q0 has {} joints; the arm has {N_JOINTS}", q0.len())));
        }
        let base = with_sensors(&without_body(&strip_comments(&text), "table"));
        // first load: the tip sphere radius and checks
        let m0 = load(mjcf, &base)?;
        let need = |obj, name: &str, what: &str| {
            id(&m0, obj, name).ok_or_else(|| mjcf_err(mjcf, format!("no {what} '{name}' (the plant needs it: add it to the model)")))
        };
        let site_ee = need(ffi::mjtObj::mjOBJ_SITE, "ee", "site")?;
        need(ffi::mjtObj::mjOBJ_SITE, "nft_sensor", "site")?;
        let tip_body = need(ffi::mjtObj::mjOBJ_BODY, "tip", "body")?;
        let mf = m0.ffi();
        if mf.nv as usize != N_JOINTS || mf.nq as usize != N_JOINTS {
            return Err(mjcf_err(mjcf, format!("the model has nq = {}, nv = {}; the plant needs a {N_JOINTS}-joint arm of hinges", mf.nq, mf.nv)));
        }
        let r_tip = (0..mf.ngeom as usize)
            .find(|&g| unsafe { *mf.geom_bodyid.add(g) } == tip_body)
            .map(|g| unsafe { *mf.geom_size.add(3 * g) })
            .ok_or_else(|| {
                mjcf_err(mjcf, "its body 'tip' has no geom; the table meets the tip's geoms only (naic's contact is at the tip): give 'tip' a sphere geom")
            })?;
        // the tip's start position in naic's model (same kinematics; checked below)
        let mut q0a = [0.0; N_JOINTS];
        q0a.copy_from_slice(q0);
        let (tip0, _) = naic_core::task::tip_pose(&p.model, &q0a);
        let regs = regions(&p.env, tip0, r_tip);
        let priority = 1 + (0..mf.ngeom as usize).map(|g| unsafe { *mf.geom_priority.add(g) }).max().unwrap_or(0);
        let xml = match base.rfind("</worldbody>") {
            Some(i) => format!("{}{}{}", &base[..i], table_xml(&regs, priority), &base[i..]),
            None => return Err(mjcf_err(mjcf, "no </worldbody>")),
        };
        let model = load(mjcf, &xml)?;
        let force_sensor = id(&model, ffi::mjtObj::mjOBJ_SENSOR, "naic_ft_force").ok_or_else(|| mjcf_err(mjcf, "no <sensor> block could be added"))?;
        let torque_sensor = id(&model, ffi::mjtObj::mjOBJ_SENSOR, "naic_ft_torque").ok_or_else(|| mjcf_err(mjcf, "no <sensor> block could be added"))?;
        let mut table = Vec::with_capacity(regs.len());
        for (i, r) in regs.iter().enumerate() {
            let g = id(&model, ffi::mjtObj::mjOBJ_GEOM, &format!("naic_table_{i}")).ok_or_else(|| mjcf_err(mjcf, "table geom lost"))?;
            table.push(TableGeom { id: g as usize, surface_point: r.surface_point, solref: solref_for(&r.material) });
        }
        let mf = model.ffi();
        let (force_adr, torque_adr) =
            unsafe { (*mf.sensor_adr.add(force_sensor as usize) as usize, *mf.sensor_adr.add(torque_sensor as usize) as usize) };
        let mut qadr = [0; N_JOINTS];
        let mut vadr = [0; N_JOINTS];
        for j in 0..N_JOINTS {
            unsafe {
                if *mf.jnt_type.add(j) != ffi::mjtJoint::mjJNT_HINGE as i32 {
                    return Err(mjcf_err(mjcf, format!("joint {j} is not a hinge")));
                }
                qadr[j] = *mf.jnt_qposadr.add(j) as usize;
                vadr[j] = *mf.jnt_dofadr.add(j) as usize;
            }
        }
        let mut lower = [0.0; N_JOINTS];
        let mut upper = [0.0; N_JOINTS];
        for (i, j) in p.model.joints().iter().enumerate().take(N_JOINTS) {
            lower[i] = j.limits.lower;
            upper[i] = j.limits.upper;
        }
        let mut model = Box::new(model);
        unsafe {
            model.ffi_mut().opt.timestep = p.dt / p.substeps as f64;
            // The solver starts from the previous step's accelerations (module docs: the
            // authors' file disables warmstart; the solution is the same within MuJoCo's
            // tolerance, [`Self::solution_gap`]).
            model.ffi_mut().opt.disableflags &= !(ffi::mjtDisableBit::mjDSBL_WARMSTART as i32);
            // The table meets the tip's geoms only (module docs): the table's `conaffinity`
            // bit is in the tip's geoms' `contype` and in no other geom's.
            let tip_body = id(&model, ffi::mjtObj::mjOBJ_BODY, "tip").ok_or_else(|| mjcf_err(mjcf, "body 'tip' lost"))?;
            let m = model.ffi_mut();
            for g in 0..m.ngeom as usize {
                let ct = &mut *m.geom_contype.add(g);
                *ct = if *m.geom_bodyid.add(g) == tip_body { *ct | TIP_ONLY } else { *ct & !TIP_ONLY };
            }
        }
        let data = MjData::new(model);
        let mut plant = Self {
            data,
            dt: p.dt,
            substeps: p.substeps,
            effort: p.effort_limit,
            lower,
            upper,
            env: p.env.clone(),
            ft: p.ft.clone(),
            encoders: p.encoders,
            rng: Rng::seed(seed),
            k: 0,
            q: q0a,
            dq: [0.0; N_JOINTS],
            obs: Observation {
                meas: RawMeasurements { t: 0.0, q: q0a, dq: [0.0; N_JOINTS], joints_stamp: 0.0, wrench: [0.0; 6], wrench_stamp: 0.0 },
                truth: Truth {
                    tip: Isometry3::identity(),
                    tip_velocity: Vector3::zeros(),
                    contact: Contact::default(),
                    tau_applied: [0.0; N_JOINTS],
                    tau_friction: [0.0; N_JOINTS],
                    saturated: false,
                    limit_violation: false,
                    wrench_true: [0.0; 6],
                },
            },
            force_adr,
            torque_adr,
            site_ee,
            table,
            qadr,
            vadr,
            friction: None,
            work: SolverWork::default(),
        };
        {
            let qp = plant.data.qpos_mut();
            for j in 0..N_JOINTS {
                qp[qadr[j]] = q0a[j];
            }
        }
        plant.data.qvel_mut().fill(0.0);
        plant.data.qfrc_applied_mut().fill(0.0);
        plant.data.forward();
        // At rest means held at rest (as the own plant's static sensor model assumes):
        // the first reading is taken under the torque that holds the arm, q̈ = 0.
        let mut hold = [0.0; N_JOINTS];
        for j in 0..N_JOINTS {
            hold[j] = plant.data.qfrc_bias()[vadr[j]];
        }
        {
            let f = plant.data.qfrc_applied_mut();
            for j in 0..N_JOINTS {
                f[vadr[j]] = hold[j];
            }
        }
        plant.data.forward();
        // same kinematics as naic's model: the tips agree at q0
        let p_mj = plant.site_pos();
        if (p_mj - tip0).norm() > 1e-6 {
            return Err(mjcf_err(
                mjcf,
                format!("its site 'ee' at q0 is at {p_mj:?}, naic's URDF tip at {tip0:?}: the MJCF and --urdf must describe the same arm"),
            ));
        }
        if let Some(f) = &p.friction {
            plant.set_joint_friction(f)?;
        }
        plant.observe(hold, false);
        Ok(plant)
    }

    /// Give the DOFs the robot's joint friction (module docs, [`MujocoJointFriction`]): the
    /// friction constraint's `solref`/`solimp` (time constant two steps, impedance 0.9999,
    /// MuJoCo's largest: a joint held by it creeps at about `1e-4·(τ/I)/(1000/s)`, against
    /// `0.1·(τ/I)/(100/s)` with MuJoCo's defaults) on the model, and the laws kept for
    /// [`Self::set_friction_at`]. At start-up only.
    fn set_joint_friction(&mut self, f: &naic_core::friction::FrictionModel) -> Result<(), PlantError> {
        if f.n_joints() != N_JOINTS {
            return Err(PlantError::FrictionJoints { friction: f.n_joints(), arm: N_JOINTS });
        }
        let v_s = match f.smoothing() {
            naic_core::friction::Smoothing::Tanh { v_s } => v_s,
            naic_core::friction::Smoothing::Exact => naic_core::friction::DEFAULT_V_S,
        };
        let h = self.dt / self.substeps as f64;
        let mut laws = [MujocoJointFriction { law: naic_core::friction::JointFriction::CoulombViscous { f_c: 0.0, f_v: 0.0 }, v_s }; N_JOINTS];
        for (j, law) in f.joints().iter().enumerate() {
            laws[j].law = *law;
            let dof = self.vadr[j];
            unsafe {
                let m = self.data.model_mut().ffi_mut();
                *m.dof_solref.add(2 * dof) = 2.0 * h;
                *m.dof_solref.add(2 * dof + 1) = 1.0;
                for (k, v) in [0.9999, 0.9999, 0.001, 0.5, 2.0].into_iter().enumerate() {
                    *m.dof_solimp.add(5 * dof + k) = v;
                }
            }
        }
        self.friction = Some(laws);
        self.set_friction_at();
        Ok(())
    }

    /// One MuJoCo step as `mj_step` takes it (the state checks, `mj_forward`, the integrator)
    /// but with `mj_forwardSkip(…, skipsensor = 1)`: the sensors (the F/T pair's
    /// `mj_rnePostConstraint`) are evaluated once per period by the observation's `mj_forward`,
    /// the only place they are read. The state it advances to is bit-identical to `mj_step`'s
    /// (sensors feed nothing back). RK4 and `fwdinv` take `mj_step` itself.
    fn step_without_sensors(&mut self) {
        let m: *const ffi::mjModel = self.data.model().ffi();
        let d = unsafe { self.data.ffi_mut() };
        unsafe {
            let integrator = (*m).opt.integrator;
            let fwdinv = (*m).opt.enableflags & ffi::mjtEnableBit::mjENBL_FWDINV as i32 != 0;
            let euler = integrator == ffi::mjtIntegrator::mjINT_EULER as i32;
            let implicit =
                integrator == ffi::mjtIntegrator::mjINT_IMPLICIT as i32 || integrator == ffi::mjtIntegrator::mjINT_IMPLICITFAST as i32;
            if fwdinv || !(euler || implicit) {
                ffi::mj_step(m, d);
            } else {
                ffi::mj_checkPos(m, d);
                ffi::mj_checkVel(m, d);
                ffi::mj_forwardSkip(m, d, ffi::mjtStage::mjSTAGE_NONE as i32, 1);
                ffi::mj_checkAcc(m, d);
                if euler {
                    ffi::mj_Euler(m, d);
                } else {
                    ffi::mj_implicit(m, d);
                }
            }
        }
        self.count_solver_work();
    }

    fn count_solver_work(&mut self) {
        let d = self.data.ffi();
        self.work.solves += 1;
        for island in 0..(d.nisland.max(1) as usize).min(d.solver_niter.len()) {
            let n = d.solver_niter[island].max(0) as usize;
            self.work.iterations += n as u64;
            let base = island * ffi::mjNSOLVER as usize;
            for it in 0..n.min(ffi::mjNSOLVER as usize) {
                self.work.evaluations += d.solver[base + it].neval.max(0) as u64;
            }
        }
    }

    /// The constraint solver's work since the plant was built ([`SolverWork`]); the solves of
    /// the start-up `mj_forward`s are not counted.
    pub fn solver_work(&self) -> SolverWork {
        self.work
    }

    /// The constraint solution at the state now under other solver options: `mj_forward` on a
    /// copy of the data with the model's `opt` changed by `set` (restored after), against the
    /// data now (the observation's `mj_forward` under the plant's own options). For the
    /// solver settings' check (tests, reports; allocates).
    pub fn solution_gap(&mut self, set: impl FnOnce(&mut ffi::mjOption)) -> SolutionGap {
        let saved = self.data.model().ffi().opt.clone();
        unsafe {
            set(&mut self.data.model_mut().ffi_mut().opt);
        }
        let m: *const ffi::mjModel = self.data.model().ffi();
        // MuJoCo could not allocate the copy: NaN, which no bound accepts.
        let mut gap = SolutionGap { qacc: f64::NAN, qfrc_constraint: f64::NAN, contact_normal: f64::NAN };
        unsafe {
            let other = ffi::mj_makeData(m);
            if !other.is_null() {
                ffi::mj_copyData(other, m, self.data.ffi());
                ffi::mj_forward(m, other);
                gap = SolutionGap::default();
                let d = self.data.ffi();
                let nv = (*m).nv as usize;
                for i in 0..nv {
                    gap.qacc = gap.qacc.max((*d.qacc.add(i) - *(*other).qacc.add(i)).abs());
                    gap.qfrc_constraint = gap.qfrc_constraint.max((*d.qfrc_constraint.add(i) - *(*other).qfrc_constraint.add(i)).abs());
                }
                let normal = |dd: *const ffi::mjData| {
                    let mut sum = 0.0;
                    for c in 0..(*dd).ncon as usize {
                        let con = &*(*dd).contact.add(c);
                        let t1 = self.table.iter().any(|g| g.id as i32 == con.geom1);
                        let t2 = self.table.iter().any(|g| g.id as i32 == con.geom2);
                        if t1 != t2 {
                            let mut f = [0.0; 6];
                            ffi::mj_contactForce(m, dd, c as i32, &mut f);
                            sum += f[0];
                        }
                    }
                    sum
                };
                gap.contact_normal = (normal(d) - normal(other)).abs();
                ffi::mj_deleteData(other);
            }
            self.data.model_mut().ffi_mut().opt = saved;
        }
        gap
    }

    /// Each DOF's `frictionloss` and `damping` from its law at the velocity now.
    fn set_friction_at(&mut self) {
        let Some(laws) = self.friction else { return };
        let mut lv = [(0.0, 0.0); N_JOINTS];
        {
            let qv = self.data.qvel();
            for j in 0..N_JOINTS {
                lv[j] = laws[j].level_and_damping(qv[self.vadr[j]]);
            }
        }
        let m = unsafe { self.data.model_mut().ffi_mut() };
        for j in 0..N_JOINTS {
            unsafe {
                *m.dof_frictionloss.add(self.vadr[j]) = lv[j].0;
                *m.dof_damping.add(self.vadr[j]) = lv[j].1;
            }
        }
    }

    /// The joint friction torques now [N·m] (opposing the motion, as the own plant's
    /// `tau_friction`): MuJoCo's `frictionloss` constraint force and its damping.
    fn friction_torques(&self) -> JointVec {
        let mut out = [0.0; N_JOINTS];
        if self.friction.is_none() {
            return out;
        }
        let d = self.data.ffi();
        let m = self.data.model().ffi();
        let qv = self.data.qvel();
        for j in 0..N_JOINTS {
            out[j] = unsafe { *m.dof_damping.add(self.vadr[j]) } * qv[self.vadr[j]];
        }
        for i in 0..d.nefc as usize {
            let (ty, id, f) = unsafe { (*d.efc_type.add(i), *d.efc_id.add(i), *d.efc_force.add(i)) };
            if ty == ffi::mjtConstraint::mjCNSTR_FRICTION_DOF as i32 {
                if let Some(j) = self.vadr.iter().position(|&a| a as i32 == id) {
                    out[j] -= f;
                }
            }
        }
        out
    }

    /// The contacts of the table with the robot now, with the parameters MuJoCo combined
    /// for them (`mjData.contact`) and their forces. For tests and reports (allocates).
    pub fn table_contacts(&self) -> Vec<ContactParams> {
        let d = self.data.ffi();
        let m = self.data.model().ffi();
        let mut out = Vec::new();
        for c in 0..d.ncon as usize {
            let con = unsafe { &*d.contact.add(c) };
            let t1 = self.table.iter().any(|g| g.id as i32 == con.geom1);
            let t2 = self.table.iter().any(|g| g.id as i32 == con.geom2);
            if t1 == t2 {
                continue;
            }
            let mut f = [0.0; 6];
            unsafe { ffi::mj_contactForce(m, d, c as i32, &mut f) };
            out.push(ContactParams {
                dim: con.dim,
                friction: con.friction,
                solref: con.solref,
                solimp: con.solimp,
                normal_n: f[0],
                tangential_n: (f[1] * f[1] + f[2] * f[2]).sqrt(),
            });
        }
        out
    }

    /// The tip's position [m] (MuJoCo's site `ee`).
    pub fn tip_position(&self) -> Vector3<f64> {
        self.site_pos()
    }

    fn site_pos(&self) -> Vector3<f64> {
        let x = self.data.site_xpos()[self.site_ee as usize];
        Vector3::new(x[0], x[1], x[2])
    }

    fn site_rot(&self) -> Matrix3<f64> {
        let m = self.data.site_xmat()[self.site_ee as usize];
        Matrix3::new(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8])
    }

    /// Apply the material in effect at time `t` to each table geom (stiffness schedule).
    fn update_materials(&mut self, t: f64) {
        for g in &mut self.table {
            let sr = solref_for(&self.env.material.at(t, &g.surface_point));
            if sr != g.solref {
                g.solref = sr;
                unsafe {
                    let m = self.data.model_mut().ffi_mut();
                    *m.geom_solref.add(2 * g.id) = sr[0];
                    *m.geom_solref.add(2 * g.id + 1) = sr[1];
                }
            }
        }
    }

    /// Contact of the table on the robot: total force at the tip, deepest penetration.
    fn contact(&self, t: f64, tip: &Vector3<f64>) -> Contact {
        let n_env = self.env.normal.into_inner();
        let mut force = Vector3::zeros();
        let mut pen = f64::NEG_INFINITY;
        let mut any = false;
        let d = self.data.ffi();
        let m = self.data.model().ffi();
        for c in 0..d.ncon as usize {
            let con = unsafe { &*d.contact.add(c) };
            let t1 = self.table.iter().any(|g| g.id as i32 == con.geom1);
            let t2 = self.table.iter().any(|g| g.id as i32 == con.geom2);
            if t1 == t2 {
                continue;
            }
            let mut f = [0.0; 6];
            unsafe { ffi::mj_contactForce(m, d, c as i32, &mut f) };
            let nrm = Vector3::new(con.frame[0], con.frame[1], con.frame[2]);
            // the normal points from geom1 to geom2; f[0] ≥ 0 pushes them apart
            let on_robot = if t1 { nrm * f[0] } else { -nrm * f[0] };
            force += on_robot;
            pen = pen.max(-con.dist);
            any = true;
        }
        let k_e = self.env.material.at(t, tip).k_e;
        if !any {
            let pen = n_env.dot(&(self.env.point - tip));
            return Contact { penetration: pen, k_e, ..Default::default() };
        }
        Contact { penetration: pen, normal_force: n_env.dot(&force).max(0.0), force, k_e, in_contact: true, on_side: false }
    }

    fn observe(&mut self, tau_applied: JointVec, saturated: bool) {
        let t = self.k as f64 * self.dt;
        {
            let qp = self.data.qpos();
            let qv = self.data.qvel();
            for j in 0..N_JOINTS {
                self.q[j] = qp[self.qadr[j]];
                self.dq[j] = qv[self.vadr[j]];
            }
        }
        let sd = self.data.sensordata();
        let (fa, ta) = (self.force_adr, self.torque_adr);
        let w_true = [-sd[fa], -sd[fa + 1], -sd[fa + 2], -sd[ta], -sd[ta + 1], -sd[ta + 2]];
        let wrench = self.ft.read(&w_true, &mut self.rng);
        let (qm, dqm) = self.encoders.measure(&self.q, &self.dq, &mut self.rng);
        let pos = self.site_pos();
        let rot = Rotation3::from_matrix_unchecked(self.site_rot());
        let mut v6 = [0.0; 6];
        unsafe {
            ffi::mj_objectVelocity(self.data.model().ffi(), self.data.ffi(), ffi::mjtObj::mjOBJ_SITE as i32, self.site_ee, &mut v6, 0);
        }
        let contact = self.contact(t, &pos);
        let mut limit_violation = false;
        for j in 0..N_JOINTS {
            limit_violation |= self.q[j] < self.lower[j] || self.q[j] > self.upper[j];
        }
        self.obs = Observation {
            meas: RawMeasurements { t, q: qm, dq: dqm, joints_stamp: t, wrench, wrench_stamp: t },
            truth: Truth {
                tip: Isometry3::from_parts(Translation3::from(pos), UnitQuaternion::from_rotation_matrix(&rot)),
                tip_velocity: Vector3::new(v6[3], v6[4], v6[5]),
                contact,
                tau_applied,
                tau_friction: self.friction_torques(),
                saturated,
                limit_violation,
                wrench_true: w_true,
            },
        };
    }

    /// [`Self::push_to`]'s mean contact normal force [N] and penetration [m].
    pub fn push_along(&mut self, f_n: f64, f_t: Option<Vector3<f64>>, seconds: f64) -> (f64, f64) {
        let r = self.push_to(f_n, f_t, seconds);
        (r.force, r.penetration)
    }

    /// The push's damping rate [1/s], about critical for the tip on the contact under it.
    /// MuJoCo's contact row moves about as `a = (1 − d)·a₀ + d·(−k·r − b·ṙ)` (impedance d, the
    /// direct `solref` (−k, −b), a₀ the free acceleration under the push; MuJoCo weights the
    /// two terms by its own estimate of the row's inertia), so a push that gives
    /// `a₀ = −D·ṙ` leaves the row `r̈ + ((1 − d)·D + d·b)·ṙ + d·k·r = …`, critical at
    /// `D = (2·sqrt(d·k) − d·b)/(1 − d)`; the pushed mass drops out, since the push damps
    /// through the mass matrix. d is `solimp`'s d_max, reached within its width (1 mm).
    /// MuJoCo's own damping is nearly none on flat (b 0.1). [`Push::settled`] is what the
    /// stiffness report relies on, not this rate being exactly critical.
    pub fn push_damping(&self) -> f64 {
        let t = self.k as f64 * self.dt;
        let sr = solref_for(&self.env.material.at(t, &self.site_pos()));
        let (k, b, d) = (-sr[0], -sr[1], AUTHORS_SOLIMP[1]);
        ((2.0 * (d * k).sqrt() - d * b) / (1.0 - d)).max(0.0)
    }

    /// Hold the tip on the surface with a push `f_n` [N] along −n for `seconds`, on MuJoCo's
    /// own Jacobian J, mass matrix M and bias forces: `τ = bias + Jᵀ·F + M·J⁻¹·a_c`, F the push
    /// (and `f_t`, if given, a constant tangential force [N] on the tip, its part along n
    /// dropped). `a_c` holds the orientation and, without `f_t`, the tangential position at
    /// their start as critically damped double poles at D/2 (`a_c = D²/4·e − D·ẋ`) and takes
    /// out the acceleration the push gives them (`J M⁻¹ Jᵀ F`, so that they keep no offset);
    /// along n it adds `−D·ẋ_n` alone, critical on the contact ([`Self::push_damping`]), so
    /// that the push settles on flat's nearly undamped contact. Every rate comes from the
    /// contact's k and impedance. [`Push`] has the means over the last 0.2 s and how settled
    /// they are.
    pub fn push_to(&mut self, f_n: f64, f_t: Option<Vector3<f64>>, seconds: f64) -> Push {
        use nalgebra::{Matrix6, Vector6};
        let nv = N_JOINTS;
        let n = self.env.normal.into_inner();
        let p0 = self.site_pos();
        let r0 = self.site_rot();
        let rate = self.push_damping();
        let stiff = rate * rate / 4.0;
        let steps = (seconds / self.dt).round() as usize;
        let tail = (0.2 / self.dt).round() as usize;
        let (mut f_sum, mut p_sum) = (0.0, 0.0);
        let (mut f_lo, mut f_hi, mut speed) = (f64::INFINITY, f64::NEG_INFINITY, 0.0_f64);
        let mut jp = vec![0.0; 3 * nv];
        let mut jr = vec![0.0; 3 * nv];
        let mut row = vec![0.0; nv];
        let mut x = vec![0.0; nv];
        let mut m_y = vec![0.0; nv];
        let hold_t = f_t.is_none();
        // projections of ẋ = (v, ω): the held directions and the damped ones
        let pn = n * n.transpose();
        let pt = Matrix3::identity() - pn;
        let mut q_held = Matrix6::identity();
        let mut p_damped = Matrix6::identity();
        q_held.fixed_view_mut::<3, 3>(0, 0).copy_from(&if hold_t { pt } else { Matrix3::zeros() });
        p_damped.fixed_view_mut::<3, 3>(0, 0).copy_from(&if hold_t { Matrix3::identity() } else { pn });
        let f_tan = f_t.map(|f| f - n * n.dot(&f)).unwrap_or_else(Vector3::zeros);
        let push = -n * f_n + f_tan;
        let f6 = Vector6::new(push.x, push.y, push.z, 0.0, 0.0, 0.0);
        for k in 0..steps {
            unsafe {
                ffi::mj_jacSite(self.data.model().ffi(), self.data.ffi(), jp.as_mut_ptr(), jr.as_mut_ptr(), self.site_ee);
            }
            let mut j6 = Matrix6::zeros();
            for j in 0..nv {
                for a in 0..3 {
                    j6[(a, j)] = jp[a * nv + self.vadr[j]];
                    j6[(a + 3, j)] = jr[a * nv + self.vadr[j]];
                }
            }
            // A = J M⁻¹ Jᵀ
            let mut a6 = Matrix6::zeros();
            for c in 0..6 {
                for j in 0..nv {
                    row[self.vadr[j]] = j6[(c, j)];
                }
                unsafe {
                    let m: *const ffi::mjModel = self.data.model().ffi();
                    ffi::mj_solveM(m, self.data.ffi_mut(), x.as_mut_ptr(), row.as_ptr(), 1);
                }
                for r in 0..6 {
                    a6[(r, c)] = (0..nv).map(|j| j6[(r, j)] * x[self.vadr[j]]).sum::<f64>();
                }
            }
            let p = self.site_pos();
            let r = self.site_rot();
            let mut v6 = [0.0; 6];
            unsafe {
                ffi::mj_objectVelocity(self.data.model().ffi(), self.data.ffi(), ffi::mjtObj::mjOBJ_SITE as i32, self.site_ee, &mut v6, 0);
            }
            let v = Vector3::new(v6[3], v6[4], v6[5]);
            let w = Vector3::new(v6[0], v6[1], v6[2]);
            let dp = p0 - p;
            let rot_err = Rotation3::from_matrix_unchecked(r0 * r.transpose()).scaled_axis();
            let e6 = Vector6::new(dp.x, dp.y, dp.z, rot_err.x, rot_err.y, rot_err.z);
            let xd6 = Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z);
            let a_c = q_held * (e6 * stiff - a6 * f6) - p_damped * xd6 * rate;
            let qdd = j6.lu().solve(&a_c).unwrap_or_else(Vector6::zeros);
            for j in 0..nv {
                x[self.vadr[j]] = qdd[j];
            }
            unsafe {
                ffi::mj_mulM(self.data.model().ffi(), self.data.ffi(), m_y.as_mut_ptr(), x.as_ptr());
            }
            let jt_f = j6.transpose() * f6;
            let mut tau = [0.0; N_JOINTS];
            for j in 0..nv {
                tau[j] = self.data.qfrc_bias()[self.vadr[j]] + jt_f[j] + m_y[self.vadr[j]];
            }
            crate::plants::Plant::step(self, &tau);
            if k + tail >= steps {
                let c = &self.obs.truth.contact;
                f_sum += c.normal_force;
                p_sum += c.penetration;
                f_lo = f_lo.min(c.normal_force);
                f_hi = f_hi.max(c.normal_force);
                speed = speed.max(n.dot(&self.obs.truth.tip_velocity).abs());
            }
        }
        Push { force: f_sum / tail as f64, penetration: p_sum / tail as f64, force_spread: f_hi - f_lo, speed, damping: rate }
    }

    /// Bring the tip onto the surface: [`Self::push_to`] `f_n` [N] in 0.1 s pieces until the
    /// tip touches, then 1 s more. An error if it has not touched after 20 s.
    pub fn approach(&mut self, f_n: f64) -> Result<Push, PlantError> {
        for _ in 0..200 {
            if self.obs.truth.contact.in_contact {
                return Ok(self.push_to(f_n, None, 1.0));
            }
            self.push_to(f_n, None, 0.1);
        }
        Err(PlantError::Config(format!(
            "pushing {f_n} N along the surface normal for 20 s, the tip did not reach the table ({:.1} mm away): the scenario's surface is not under the tip",
            -self.obs.truth.contact.penetration * 1e3
        )))
    }
}

/// One push of [`MujocoPlant::push_to`]: over its last 0.2 s, the mean contact normal force
/// [N] and penetration [m], the normal force's peak-to-peak [N] and the tip's fastest speed
/// along n [m/s]; and the push's damping rate [1/s].
#[derive(Clone, Copy, Debug)]
pub struct Push {
    pub force: f64,
    pub penetration: f64,
    pub force_spread: f64,
    pub speed: f64,
    pub damping: f64,
}

impl Push {
    /// Settled on the push `f_n`: over the last 0.2 s the contact force stays within ±1 % of
    /// `f_n` (its peak-to-peak and its mean's distance from `f_n`) and the tip moves along n
    /// slower than 1 mm/s.
    pub fn settled(&self, f_n: f64) -> bool {
        self.force_spread <= 0.02 * f_n && (self.force - f_n).abs() <= 0.01 * f_n && self.speed < 1e-3
    }
}

impl crate::plants::Plant for MujocoPlant {
    fn name(&self) -> &'static str {
        "mujoco"
    }
    fn dof(&self) -> usize {
        N_JOINTS
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn step(&mut self, tau_cmd: &[f64]) {
        let mut tau = [0.0; N_JOINTS];
        let mut sat = false;
        for j in 0..N_JOINTS {
            let v = tau_cmd.get(j).copied().unwrap_or(0.0);
            let v2 = if v.is_finite() { v } else { 0.0 };
            tau[j] = v2.clamp(-self.effort[j], self.effort[j]);
            sat |= tau[j] != v;
        }
        {
            let f = self.data.qfrc_applied_mut();
            for j in 0..N_JOINTS {
                f[self.vadr[j]] = tau[j];
            }
        }
        let h = self.dt / self.substeps as f64;
        for s in 0..self.substeps {
            self.update_materials(self.k as f64 * self.dt + s as f64 * h);
            self.set_friction_at();
            self.step_without_sensors();
        }
        self.k += 1;
        self.update_materials(self.k as f64 * self.dt);
        self.data.forward();
        self.count_solver_work();
        self.observe(tau, sat);
    }
    fn observation(&self) -> &Observation {
        &self.obs
    }
    fn q(&self) -> &[f64] {
        &self.q
    }
    fn dq(&self) -> &[f64] {
        &self.dq
    }
}

/// The static stiffness MuJoCo's contact gives for one material of a scenario.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StaticStiffness {
    /// The naic material's k_e [N/m] and the MuJoCo `solref` it maps to.
    pub k_e: f64,
    pub solref: [f64; 2],
    /// Normal force [N] and penetration [mm] at the two pushes.
    pub forces_n: [f64; 2],
    pub penetration_mm: [f64; 2],
    /// Secant stiffness between the two pushes [N/m].
    pub k_static: f64,
}

/// Measure the static stiffness of each material of `p.env` on MuJoCo: from `q0`, bring
/// the tip onto that material's surface at 15 N ([`MujocoPlant::approach`]), then push with
/// each of `pushes` [N] for 3 s ([`MujocoPlant::push_to`]; an error if a push has not
/// settled, [`Push::settled`]) and take the secant Δf/Δpenetration.
pub fn static_stiffness(mjcf: &Path, p: &PlantParams, q0: &[f64], pushes: [f64; 2]) -> Result<Vec<StaticStiffness>, PlantError> {
    let mats: Vec<Material> = match &p.env.material {
        MaterialMap::Uniform(m) => vec![*m],
        MaterialMap::StiffnessSchedule { base, switches } => {
            let mut v = vec![*base];
            for &(_, k) in switches {
                if !v.iter().any(|m| m.k_e == k) {
                    v.push(Material { k_e: k, ..*base });
                }
            }
            v
        }
        MaterialMap::SplitX { high_x, low_x, .. } => vec![*high_x, *low_x],
    };
    let mut out = Vec::new();
    for m in mats {
        let mut pp = p.clone();
        pp.env.material = MaterialMap::Uniform(m);
        let mut fp = [(0.0, 0.0); 2];
        for (i, f) in pushes.iter().enumerate() {
            let mut plant = MujocoPlant::new(mjcf, &pp, q0, 0)?;
            plant.approach(15.0)?;
            let r = plant.push_to(*f, None, 3.0);
            if !r.settled(*f) {
                return Err(PlantError::Config(format!(
                    "the static stiffness push of {f} N on k_e {} N/m did not settle (last 0.2 s: mean {:.3} N, peak-to-peak {:.3} N, tip speed {:.2e} m/s; \
                     settled: within ±1 % of the push, slower than 1 mm/s)",
                    m.k_e, r.force, r.force_spread, r.speed
                )));
            }
            fp[i] = (r.force, r.penetration);
        }
        let k_static = (fp[1].0 - fp[0].0) / (fp[1].1 - fp[0].1);
        out.push(StaticStiffness {
            k_e: m.k_e,
            solref: solref_for(&m),
            forces_n: [fp[0].0, fp[1].0],
            penetration_mm: [fp[0].1 * 1e3, fp[1].1 * 1e3],
            k_static,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_and_the_table_body_come_out() {
        let x = "<a><!-- <body name=\"table\"> --><body name=\"table\" pos=\"0 0 0\"><geom/><body name=\"in\"></body></body><b/></a>";
        let s = without_body(&strip_comments(x), "table");
        assert_eq!(s, "<a><b/></a>");
        assert!(with_sensors("<mujoco></mujoco>").contains("<sensor><force name=\"naic_ft_force\" site=\"nft_sensor\"/>"));
    }
}
