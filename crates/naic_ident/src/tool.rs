//! The tool on the F/T sensor from static poses: its mass, centre of mass and the
//! sensor's force and torque bias, by linear least squares (issue 39 item 2).
//!
//! At rest in pose `i` the sensor (frame `s`, orientation `R_i` in the base frame) reads
//! the tool's weight and its own bias:
//!
//! * `F_i = m R_iᵀ g + b_F`                       (4 unknowns: `m`, `b_F`)
//! * `τ_i = c × m R_iᵀ g + b_τ = −[R_iᵀ g]× p + b_τ`, with `p = m c` (6 unknowns: `p`, `b_τ`)
//!
//! Both are linear; they are solved one after the other (the force fit gives `m`, then
//! `c = p / m`). Each pose gives 3 equations to each fit. `m` is separable from `b_F` only
//! when gravity has at least 2 different directions in the sensor frame, and `p` from `b_τ`
//! only when the differences of those directions span a plane (at least 3 orientations
//! whose gravity directions are not all on one line; tool spun about the vertical only
//! gives one direction):
//! [`fit`] checks the rank of each design matrix (its smallest singular value against its
//! largest) and names what is missing. The standard error of each parameter is from the
//! residual variance and `(AᵀA)⁻¹` (ordinary least squares; `c`'s from `p`'s and `m`'s
//! by first-order propagation).

use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

/// One static pose: the sensor frame's orientation in the base frame and the mean reading
/// there (force [N], torque [N m], sensor frame).
#[derive(Clone, Debug, PartialEq)]
pub struct StaticPose {
    pub r_ws: Rotation3<f64>,
    pub force: Vector3<f64>,
    pub torque: Vector3<f64>,
    /// Samples averaged (reported only).
    pub samples: usize,
}

/// A parameter and its standard error (1 σ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub std_error: f64,
}

/// The identified tool and bias.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolFit {
    /// Tool mass beyond the measuring plane [kg].
    pub mass: Estimate,
    /// Centre of mass in the sensor frame [m].
    pub com: [Estimate; 3],
    /// Force bias [N], sensor frame.
    pub force_bias: [Estimate; 3],
    /// Torque bias [N m], sensor frame.
    pub torque_bias: [Estimate; 3],
    /// RMS of the force residuals [N] and of the torque residuals [N m].
    pub force_rms: f64,
    pub torque_rms: f64,
    pub poses: usize,
}

/// Why the tool could not be identified.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ToolIdError {
    #[error("{found} static pose(s): the fit needs at least 3 with gravity in different directions of the sensor frame (e.g. tool down, tilted about x, tilted about y; 6 or more for a confident fit)")]
    TooFewPoses { found: usize },
    #[error("the static poses do not separate the {what}: gravity does not point in enough different directions of the sensor frame (smallest/largest singular value {ratio:.1e}, below {RANK_TOLERANCE:.0e}); add poses rotated about a different axis")]
    RankDeficient { what: &'static str, ratio: f64 },
    #[error("a static pose has a non-finite reading or orientation")]
    NonFinite,
}

/// Smallest singular value over the largest below which a design matrix is rank-deficient.
pub const RANK_TOLERANCE: f64 = 1e-3;

fn skew(v: &Vector3<f64>) -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Ordinary least squares `A x ≈ b`: solution, standard errors and RSS; the rank check
/// names `what` when `A` is rank-deficient.
fn ols(a: &DMatrix<f64>, b: &DVector<f64>, what: &'static str) -> Result<(DVector<f64>, DVector<f64>, f64), ToolIdError> {
    let svd = a.clone().svd(true, true);
    let sv = &svd.singular_values;
    let (max, min) = (sv.max(), sv.min());
    let ratio = if max > 0.0 { min / max } else { 0.0 };
    if !(ratio > RANK_TOLERANCE) {
        return Err(ToolIdError::RankDeficient { what, ratio });
    }
    let x = svd.solve(b, 0.0).map_err(|_| ToolIdError::NonFinite)?;
    let r = b - a * &x;
    let rss = r.norm_squared();
    let dof = (a.nrows() as f64 - a.ncols() as f64).max(1.0);
    let s2 = rss / dof;
    let ata_inv = (a.transpose() * a).try_inverse().ok_or(ToolIdError::NonFinite)?;
    let se = DVector::from_iterator(x.len(), (0..x.len()).map(|k| (s2 * ata_inv[(k, k)]).max(0.0).sqrt()));
    Ok((x, se, rss))
}

/// Fit the tool (module docs) from static poses under gravity `g` (base frame, m/s²).
pub fn fit(poses: &[StaticPose], g: &Vector3<f64>) -> Result<ToolFit, ToolIdError> {
    let n = poses.len();
    if n < 3 {
        return Err(ToolIdError::TooFewPoses { found: n });
    }
    if poses.iter().any(|p| !(p.force.iter().chain(p.torque.iter()).chain(p.r_ws.matrix().iter()).all(|x| x.is_finite()))) {
        return Err(ToolIdError::NonFinite);
    }
    // Forces: [R_iᵀ g | I] (m, b_F).
    let mut a = DMatrix::zeros(3 * n, 4);
    let mut b = DVector::zeros(3 * n);
    for (i, p) in poses.iter().enumerate() {
        let gs = p.r_ws.inverse() * g;
        for k in 0..3 {
            a[(3 * i + k, 0)] = gs[k];
            a[(3 * i + k, 1 + k)] = 1.0;
            b[3 * i + k] = p.force[k];
        }
    }
    let (xf, sef, rss_f) = ols(&a, &b, "tool mass from the force bias")?;
    let m = xf[0];
    // Torques: [−[R_iᵀ g]× | I] (p = m c, b_τ).
    let mut a = DMatrix::zeros(3 * n, 6);
    let mut b = DVector::zeros(3 * n);
    for (i, p) in poses.iter().enumerate() {
        let gs = p.r_ws.inverse() * g;
        let s = -skew(&gs);
        for r in 0..3 {
            for c in 0..3 {
                a[(3 * i + r, c)] = s[(r, c)];
            }
            a[(3 * i + r, 3 + r)] = 1.0;
            b[3 * i + r] = p.torque[r];
        }
    }
    let (xt, set, rss_t) = ols(&a, &b, "centre of mass from the torque bias")?;
    let se_m = sef[0];
    let com = std::array::from_fn(|k| {
        let (pk, se_p) = (xt[k], set[k]);
        let c = pk / m;
        Estimate { value: c, std_error: ((se_p / m).powi(2) + (pk * se_m / (m * m)).powi(2)).sqrt() }
    });
    Ok(ToolFit {
        mass: Estimate { value: m, std_error: se_m },
        com,
        force_bias: std::array::from_fn(|k| Estimate { value: xf[1 + k], std_error: sef[1 + k] }),
        torque_bias: std::array::from_fn(|k| Estimate { value: xt[3 + k], std_error: set[3 + k] }),
        force_rms: (rss_f / (3 * n) as f64).sqrt(),
        torque_rms: (rss_t / (3 * n) as f64).sqrt(),
        poses: n,
    })
}

impl ToolFit {
    /// The tool section of a robot file, in its layout (mass in kg, centre of mass in m in
    /// the sensor frame).
    pub fn robot_file_section(&self) -> String {
        let c = &self.com;
        format!(
            "tool:\n  mass: {:.4}          # kg\n  com: [{:.4}, {:.4}, {:.4}]  # m, in the sensor frame\n",
            self.mass.value, c[0].value, c[1].value, c[2].value
        )
    }
}

/// Maximal runs of samples at rest: `still[k]` says whether sample `k` is at rest, `t[k]`
/// its time [s]; runs shorter than `min_duration` [s] are dropped. Returns index ranges.
pub fn static_segments(still: &[bool], t: &[f64], min_duration: f64) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for k in 0..=still.len() {
        let s = k < still.len() && still[k];
        match (s, start) {
            (true, None) => start = Some(k),
            (false, Some(a)) => {
                if t[k - 1] - t[a] >= min_duration {
                    out.push(a..k);
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poses(m: f64, c: Vector3<f64>, bf: Vector3<f64>, bt: Vector3<f64>, rots: &[Rotation3<f64>]) -> Vec<StaticPose> {
        let g = Vector3::new(0.0, 0.0, -9.81);
        rots.iter()
            .map(|r| {
                let gs = r.inverse() * g * m;
                StaticPose { r_ws: *r, force: gs + bf, torque: c.cross(&gs) + bt, samples: 1 }
            })
            .collect()
    }

    fn rots() -> Vec<Rotation3<f64>> {
        let down = Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
        vec![
            down,
            Rotation3::from_axis_angle(&Vector3::x_axis(), 0.6) * down,
            Rotation3::from_axis_angle(&Vector3::y_axis(), 0.6) * down,
            Rotation3::from_axis_angle(&Vector3::x_axis(), -0.8) * down,
        ]
    }

    #[test]
    fn exact_readings_give_the_tool_back_with_zero_residual() {
        let (m, c) = (0.5, Vector3::new(0.003, -0.002, 0.03));
        let (bf, bt) = (Vector3::new(0.4, -0.7, 0.2), Vector3::new(0.01, -0.02, 0.005));
        let f = fit(&poses(m, c, bf, bt, &rots()), &Vector3::new(0.0, 0.0, -9.81)).unwrap();
        assert!((f.mass.value - m).abs() < 1e-12, "{f:?}");
        for k in 0..3 {
            assert!((f.com[k].value - c[k]).abs() < 1e-12);
            assert!((f.force_bias[k].value - bf[k]).abs() < 1e-12);
            assert!((f.torque_bias[k].value - bt[k]).abs() < 1e-12);
        }
        assert!(f.force_rms < 1e-12 && f.torque_rms < 1e-12);
        let y = f.robot_file_section();
        assert_eq!(y, "tool:\n  mass: 0.5000          # kg\n  com: [0.0030, -0.0020, 0.0300]  # m, in the sensor frame\n");
    }

    #[test]
    fn too_few_or_degenerate_poses_are_refused_naming_what_is_missing() {
        let g = Vector3::new(0.0, 0.0, -9.81);
        let (m, c, z) = (0.5, Vector3::new(0.0, 0.0, 0.03), Vector3::zeros());
        let e = fit(&poses(m, c, z, z, &rots()[..2]), &g).unwrap_err();
        assert_eq!(e, ToolIdError::TooFewPoses { found: 2 });
        assert!(e.to_string().contains("at least 3"), "{e}");
        // The same orientation three times: the mass is not separable from the force bias.
        let r = rots()[0];
        let e = fit(&poses(m, c, z, z, &[r, r, r]), &g).unwrap_err();
        assert!(matches!(e, ToolIdError::RankDeficient { what, .. } if what.contains("mass")), "{e:?}");
        // Rotations about the gravity axis only (tool down, spun about its axis): gravity has
        // one direction in the sensor frame.
        let spun: Vec<_> = (0..4).map(|k| Rotation3::from_axis_angle(&Vector3::z_axis(), k as f64) * r).collect();
        let e = fit(&poses(m, c, z, z, &spun), &g).unwrap_err();
        assert!(e.to_string().contains("add poses rotated about a different axis"), "{e}");
        // Two orientations, each twice: the mass is separable (gravity in 2 directions), the
        // centre of mass along their difference is not.
        let two = [rots()[0], rots()[1], rots()[0], rots()[1]];
        let e = fit(&poses(m, c, z, z, &two), &g).unwrap_err();
        assert!(matches!(e, ToolIdError::RankDeficient { what, .. } if what.contains("centre of mass")), "{e:?}");
        // Three tilts about one axis are enough (gravity at three points of a circle).
        let down = rots()[0];
        let plane: Vec<_> = [-0.8, 0.0, 0.8].iter().map(|a| Rotation3::from_axis_angle(&Vector3::x_axis(), *a) * down).collect();
        assert!((fit(&poses(m, c, z, z, &plane), &g).unwrap().com[2].value - 0.03).abs() < 1e-12);
    }

    #[test]
    fn static_segments_keep_runs_long_enough() {
        let t: Vec<f64> = (0..20).map(|k| k as f64 * 0.1).collect();
        let mut still = vec![true; 20];
        still[5] = false;
        still[6] = false;
        still[15] = false;
        assert_eq!(static_segments(&still, &t, 0.35), vec![0..5, 7..15]);
        assert_eq!(static_segments(&still, &t, 0.5), vec![7..15]);
        assert!(static_segments(&[false; 5], &t[..5], 0.0).is_empty());
    }
}
