//! Contact data: the per-axis residual of the F/T sensor against the nominal contact
//! model (issue 6, item 4).
//!
//! The nominal model is the project's simulator (`naic_sim`): a horizontal surface
//! (normal `n` = base +z) of unknown height `h` acting as a linear spring on the `tip`
//! frame origin (`naic_sim::environment`, F_n = k·δ, δ = h − z_tip), seen by the
//! ATI mini45 model (`naic_sim::sensor::Mini45::true_wrench`): the sensor reports, in
//! the `ft_sensor` frame, the tool's weight (mass and centre of mass of the URDF's
//! `ft_sensor` link, 0.424 kg for the JK5) plus the contact force and its moment about
//! the sensor origin. Its free parameters, the stiffness k and the surface height h, are
//! calibrated per axis on the training folds (h by a grid scan with refinement, k by
//! least squares), so what is found is structure.
//!
//! Kinematics per analysis instant come from the Savitzky–Golay-smoothed joint positions
//! and velocities ([`crate::prepare`]) by forward kinematics (`naic_core::dynamics`,
//! frames `ft_sensor` and `tip`); the wrench itself is used **raw** at the analysis
//! instants (no smoothing across the contact kink; its noise is white, so one sample is
//! one observation for the information criterion). Each axis `fx, fy, fz, mx, my, mz` is
//! a target of the same held-out scheme (the joints' time blocks), significance rule and
//! forward selection as the joints ([`crate::analysis`]).
//!
//! For the joint analysis of the same data, the contact wrench the sensor measured
//! (smoothed like the torques, nominal tool weight and the sensor errors found here —
//! `ft_bias`, `tool_gravity` — removed) is turned into joint torques `J_ftᵀ W` and taken
//! out of the joint residual ([`external_torques`]).

use crate::analysis::{Col, JointResult, JointSamples};
use crate::catalogue::lin_grid;
use crate::prepare::Prepared;
use crate::ExplainError;
use nalgebra::{DVector, Rotation3, Vector3};
use naic_core::dynamics::{forward_kinematics, frame_jacobian};
use naic_core::model::{Data, FrameId, Model};

/// Target numbers of the sensor axes are `AXIS_BASE + 1 ..= AXIS_BASE + 6` (joints are 1..).
pub const AXIS_BASE: usize = 100;
/// Names of the sensor axes (force then moment, `ft_sensor` frame).
pub const AXES: [&str; 6] = ["fx", "fy", "fz", "mx", "my", "mz"];

/// Whether a target number is a sensor axis.
pub fn is_axis(target: usize) -> bool {
    target > AXIS_BASE
}

/// The report key of a target: `joint3`, or `fz` for a sensor axis.
pub fn target_key(target: usize) -> String {
    if is_axis(target) {
        AXES.get(target - AXIS_BASE - 1).copied().unwrap_or("axis?").to_string()
    } else {
        format!("joint{target}")
    }
}

/// Unit of a target's residual.
pub fn target_unit(target: usize) -> &'static str {
    if is_axis(target) && target - AXIS_BASE <= 3 {
        "N"
    } else {
        "N·m"
    }
}

/// Names of the two tool-gravity parameters of each axis (forces: Δm only).
pub fn gravity_param_names(axis: usize) -> [&'static str; 2] {
    match axis {
        0..=2 => ["delta_mass_kg", ""],
        3 => ["delta_mc_y_kgm", "delta_mc_z_kgm"],
        4 => ["delta_mc_z_kgm", "delta_mc_x_kgm"],
        _ => ["delta_mc_x_kgm", "delta_mc_y_kgm"],
    }
}

/// The nominal tool: mass [kg] and centre of mass in the sensor frame [m].
#[derive(Clone, Copy, Debug)]
pub struct Tool {
    pub mass: f64,
    pub com: Vector3<f64>,
}

/// Points of the surface-height grid over the tip's height range (then refined by
/// halving; a coarse grid can leave the refinement in the wrong basin on axes that see
/// the contact force only through a small lever or tilt).
pub const H_GRID_POINTS: usize = 201;

/// Gravity in the base frame [m/s²] (as `naic_sim::sensor`).
pub const GRAVITY: Vector3<f64> = Vector3::new(0.0, 0.0, -9.81);

/// Kinematics of the sensor and the tip at every analysis instant.
#[derive(Clone, Debug, Default)]
pub struct ContactKinematics {
    /// Orientation of the sensor frame in the base frame.
    pub r_ws: Vec<Rotation3<f64>>,
    /// Tip origin minus sensor origin, base frame [m].
    pub r_tip: Vec<Vector3<f64>>,
    /// Tip height [m] and vertical tip velocity [m/s].
    pub z_tip: Vec<f64>,
    pub zdot_tip: Vec<f64>,
}

/// Forward kinematics of `sensor` and `tip` at the analysis instants.
pub fn kinematics(p: &Prepared, model: &Model, sensor: FrameId, tip: FrameId) -> Result<ContactKinematics, ExplainError> {
    let mut data = Data::new(model);
    let mut k = ContactKinematics::default();
    let nj = model.nv();
    let (mut q, mut v) = (DVector::zeros(nj), DVector::zeros(nj));
    for i in 0..p.len() {
        q.copy_from_slice(&p.q[i]);
        v.copy_from_slice(&p.v[i]);
        forward_kinematics(model, &mut data, &q);
        let ps = data.frame_placement(sensor);
        let pt = data.frame_placement(tip);
        let jt = frame_jacobian(model, &mut data, &q, tip);
        let vt = jt.fixed_rows::<3>(0) * &v;
        k.r_ws.push(ps.rotation.to_rotation_matrix());
        k.r_tip.push(pt.translation.vector - ps.translation.vector);
        k.z_tip.push(pt.translation.vector.z);
        k.zdot_tip.push(vt.z);
    }
    Ok(k)
}

/// The nominal tool's wrench on the sensor, sensor frame (static weight, as `Mini45::true_wrench`).
pub fn tool_wrench(tool: &Tool, r_ws: &Rotation3<f64>) -> [f64; 6] {
    let g_s = r_ws.inverse_transform_vector(&GRAVITY);
    let f = g_s * tool.mass;
    let t = tool.com.cross(&f);
    [f.x, f.y, f.z, t.x, t.y, t.z]
}

/// Per-axis analysis samples (targets `AXIS_BASE + 1..=6`). `wrench` is the raw wrench
/// (one row per raw sample); `fold_of` gives the held-out fold of an analysis instant.
pub fn axis_samples(
    p: &Prepared,
    wrench: &[[f64; 6]],
    ck: &ContactKinematics,
    tool: &Tool,
    fold_of: &dyn Fn(f64) -> u8,
) -> Vec<JointSamples> {
    let m = p.len();
    let t0 = p.t.first().copied().unwrap_or(0.0);
    let dur = (p.t.last().copied().unwrap_or(1.0) - t0).max(1e-9);
    let zmin = ck.z_tip.iter().copied().fold(f64::INFINITY, f64::min);
    let zmax = ck.z_tip.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let h_grid = if zmax > zmin { lin_grid(zmin - 1e-3, zmax, H_GRID_POINTS) } else { vec![zmin] };
    let n = Vector3::z();
    // Coupling of each axis to the contact force: mean square of u (moments divided by
    // the tip lever so both are dimensionless) over the lowest 10 % of the tip heights
    // (where a surface the tip touches must be; the free-space motion elsewhere does not
    // count). Axes that do not see it at all (below 10⁻¹² of the largest: the sensor's own
    // z moment always, fx, fy, mx, my with the tool pointing exactly down) get no contact
    // columns. Every other axis keeps them, however weak: the surface height comes from
    // the dominant axis (see `crate::explain_series`), so a weak axis only adds its scale.
    let mut zs = ck.z_tip.clone();
    zs.sort_by(f64::total_cmp);
    let z_low = zs.get(m / 10).copied().unwrap_or(f64::INFINITY);
    let mut coupling = [0.0f64; 6];
    for i in (0..m).filter(|&i| ck.z_tip[i] <= z_low) {
        let r = &ck.r_ws[i];
        let lever = ck.r_tip[i].norm().max(1e-6);
        let uf = r.inverse_transform_vector(&n);
        let um = r.inverse_transform_vector(&ck.r_tip[i].cross(&n)) / lever;
        for a in 0..3 {
            coupling[a] += uf[a] * uf[a];
            coupling[a + 3] += um[a] * um[a];
        }
    }
    let cmax = coupling.iter().copied().fold(0.0, f64::max);
    (0..6)
        .map(|a| {
            let coupled = coupling[a] >= 1e-12 * cmax && cmax > 0.0;
            let mut js = JointSamples {
                joint: AXIS_BASE + a + 1,
                corr_len: 1.0,
                time_series: true,
                contact: true,
                h_grid: if coupled { h_grid.clone() } else { vec![] },
                coupled,
                ..Default::default()
            };
            for i in 0..m {
                let r = &ck.r_ws[i];
                let g_s = r.inverse_transform_vector(&GRAVITY);
                let u = if a < 3 { r.inverse_transform_vector(&n) } else { r.inverse_transform_vector(&ck.r_tip[i].cross(&n)) };
                let (g0, g1) = match a {
                    0..=2 => (g_s[a], 0.0),
                    3 => (g_s.z, -g_s.y),
                    4 => (g_s.x, -g_s.z),
                    _ => (g_s.y, -g_s.x),
                };
                js.y.push(wrench[p.raw_index[i]][a] - tool_wrench(tool, r)[a]);
                js.cu.push(if coupled { u[a % 3] } else { 0.0 });
                js.cz.push(ck.z_tip[i]);
                js.crate_.push(-ck.zdot_tip[i]);
                js.cg0.push(g0);
                js.cg1.push(g1);
                js.t.push(p.t[i]);
                js.tn.push((p.t[i] - t0) / dur - 0.5);
                js.fold.push(fold_of(p.t[i]));
            }
            let z = vec![0.0; m];
            js.v = z.clone();
            js.s = z.clone();
            js.q = z.clone();
            js.a = z.clone();
            js.dtau = z.clone();
            js.payload = z;
            js
        })
        .collect()
}

/// The axis that sees the contact force most (largest Σ u², the spring column's scale);
/// `None` when no axis is coupled.
pub fn dominant_axis(axes: &[JointSamples]) -> Option<usize> {
    axes.iter()
        .enumerate()
        .filter(|(_, js)| js.coupled)
        .map(|(a, js)| (a, js.cu.iter().map(|u| u * u).sum::<f64>()))
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(a, _)| a)
}

/// The sensor error (`ft_bias`) of an axis in its final model. A `tool_gravity` finding
/// is not an error of the sensor: the tool really weighs that, the joints carry it too,
/// so the measured wrench is kept for the joints.
fn sensor_error(r: &JointResult) -> f64 {
    r.final_eval.coef(Col::Offset).unwrap_or(0.0)
}

/// Joint torques `J_ftᵀ W` of the wrench the sensor measured beyond the URDF's tool
/// (smoothed wrench minus the nominal tool weight, which the rigid-body model already
/// carries, minus the sensor bias the axis analysis found), per analysis instant. `axes`/`results` are the axis samples and their analysis.
pub fn external_torques(
    p: &Prepared,
    model: &Model,
    sensor: FrameId,
    ck: &ContactKinematics,
    tool: &Tool,
    results: &[JointResult],
) -> Result<crate::input::Rows, ExplainError> {
    let mut data = Data::new(model);
    let nj = model.nv();
    let mut out = crate::input::Rows::with_capacity(nj, p.len());
    let mut q = DVector::zeros(nj);
    for i in 0..p.len() {
        let r = &ck.r_ws[i];
        let tw = tool_wrench(tool, r);
        let mut w = [0.0; 6];
        for a in 0..6 {
            w[a] = p.wrench[i][a] - tw[a];
            if let Some(res) = results.get(a) {
                w[a] -= sensor_error(res);
            }
        }
        let f = r * Vector3::new(w[0], w[1], w[2]);
        let t = r * Vector3::new(w[3], w[4], w[5]);
        q.copy_from_slice(&p.q[i]);
        let j = frame_jacobian(model, &mut data, &q, sensor);
        let mut wv = nalgebra::Vector6::zeros();
        wv.fixed_rows_mut::<3>(0).copy_from(&f);
        wv.fixed_rows_mut::<3>(3).copy_from(&t);
        out.push((j.transpose() * wv).as_slice());
    }
    Ok(out)
}
