//! ATI mini45 six-axis force/torque sensor at the `ft_sensor` frame, and the
//! joint encoders.
//!
//! What the F/T sensor reports (team convention, BRIEF.md): the wrench the
//! tool (sensor + rod beyond the measuring plane, 0.424 kg, centre of mass
//! 0.015 m along the sensor z axis — the `ft_sensor` link inertial of
//! `urdf/jk5.urdf`, from the authors' MJCF `ee_link`) exerts on the sensor, in
//! the `ft_sensor` frame, force then torque, about the sensor origin. In static
//! equilibrium that is the tool weight plus the contact force at the tip:
//! `F = m g + F_contact`, `T = r_com × m g + r_tip × F_contact`
//! (`r_tip` = 0.169 m along the sensor z axis). A moving tool adds its inertial
//! wrench, as on a real sensor: with `a_c` the acceleration of the tool's centre
//! of mass, `ω`, `α` its angular velocity and acceleration and `I_c` its inertia
//! about the centre of mass (all in the base frame here),
//! `F = m (g − a_c) + F_contact`,
//! `T = r_com × m (g − a_c) + r_tip × F_contact − (I_c α + ω × I_c ω)`
//! (Newton–Euler for the tool, whose other wrenches are gravity and the contact:
//! [`Mini45::true_wrench_moving`]; the own plant passes the sensor frame's motion
//! from its forward dynamics, issue 36 item 4). The tool's inertia is the
//! `ft_sensor` link's `<inertial>` ([`tool_inertia_from_urdf`]); a sensor made
//! without it (`tool_inertia` zero) still has the `m (g − a_c)` part.
//!
//! Errors added on top, in this order: a constant bias (drawn once per run
//! from the seed), white Gaussian noise, saturation at the calibrated range,
//! quantisation to the resolution. Range and resolution are the ATI Mini45
//! datasheet figures for the SI-145-5 calibration as quoted in the team
//! brief (range ±145 N Fx/Fy, ±290 N Fz, ±5 N·m torques; resolution 1/16 N
//! for forces, 1/752 N·m for torques — the datasheet's DAQ/Net F/T class).
//! The noise σ equals one resolution step (our choice: ATI quotes resolution
//! as the smallest change above noise). Bias magnitude (±1 N, ±0.02 N·m) is
//! our choice for an un-tared strain-gauge sensor. The sensor is sampled at
//! the control rate (1 kHz; the mini45 electronics go up to 7 kHz, §5.2.1).

use crate::rng::Rng;
use naic_core::JointVec;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Parameters of the F/T sensor model.
#[derive(Clone, Debug, PartialEq)]
pub struct Mini45 {
    /// ± saturation per axis (Fx, Fy, Fz [N], Tx, Ty, Tz [N·m]).
    pub range: [f64; 6],
    /// Quantisation step per axis.
    pub resolution: [f64; 6],
    /// Standard deviation of the white noise per axis.
    pub noise_sigma: [f64; 6],
    /// Constant bias added to every reading (drawn per run).
    pub bias: [f64; 6],
    /// Tool mass beyond the measuring plane [kg].
    pub tool_mass: f64,
    /// Tool centre of mass in the sensor frame [m].
    pub tool_com: Vector3<f64>,
    /// Tool inertia about its centre of mass, sensor frame axes [kg m²].
    pub tool_inertia: Matrix3<f64>,
    /// Whether the reading includes the tool's inertial wrench (a real sensor's does;
    /// [`INERTIAL_WRENCH`] by default). `false`: the tool's weight only, as before issue 36.
    pub inertial: bool,
    /// Gravity, base frame [m/s²].
    pub gravity: Vector3<f64>,
}

/// Whether [`Mini45::si_145_5`] reads the tool's inertial wrench (a real sensor's does, and the
/// MuJoCo plant's). Off by default on naic's own plant until the controllers stay stable with it:
/// with it on, the force laws lose contact (docs/notes/2026-12-06-sensor-inertial-wrench.md).
pub const INERTIAL_WRENCH: bool = false;

/// SI-145-5 range (ATI Mini45 datasheet, via the team brief).
pub const MINI45_SI_145_5_RANGE: [f64; 6] = [145.0, 145.0, 290.0, 5.0, 5.0, 5.0];
/// SI-145-5 resolution class (ATI Mini45 datasheet, via the team brief).
pub const MINI45_SI_145_5_RESOLUTION: [f64; 6] =
    [1.0 / 16.0, 1.0 / 16.0, 1.0 / 16.0, 1.0 / 752.0, 1.0 / 752.0, 1.0 / 752.0];

impl Mini45 {
    /// The SI-145-5 model with the tool of the authors' MJCF and a bias drawn
    /// from `rng` (uniform in ±1 N / ±0.02 N·m).
    pub fn si_145_5(tool_mass: f64, tool_com: Vector3<f64>, rng: &mut Rng) -> Self {
        let mut bias = [0.0; 6];
        for (i, b) in bias.iter_mut().enumerate() {
            *b = rng.symmetric(if i < 3 { 1.0 } else { 0.02 });
        }
        Self {
            range: MINI45_SI_145_5_RANGE,
            resolution: MINI45_SI_145_5_RESOLUTION,
            noise_sigma: MINI45_SI_145_5_RESOLUTION,
            bias,
            tool_mass,
            tool_com,
            tool_inertia: Matrix3::zeros(),
            inertial: INERTIAL_WRENCH,
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }

    /// The same sensor with the tool's inertia about its centre of mass (sensor frame).
    pub fn with_tool_inertia(self, inertia: Matrix3<f64>) -> Self {
        Self { tool_inertia: inertia, ..self }
    }

    /// A perfect sensor (no bias, noise, saturation or quantisation), same tool.
    pub fn ideal(&self) -> Self {
        Self {
            range: [f64::INFINITY; 6],
            resolution: [0.0; 6],
            noise_sigma: [0.0; 6],
            bias: [0.0; 6],
            ..self.clone()
        }
    }

    /// The true wrench the tool exerts on the sensor, sensor frame.
    /// `r_ws`: orientation of the sensor frame in the base frame;
    /// `r_tip`: tip origin minus sensor origin, base frame;
    /// `f_contact`: force of the environment on the tip, base frame.
    /// The tool at rest: [`Mini45::true_wrench_moving`] with no motion.
    pub fn true_wrench(&self, r_ws: &Rotation3<f64>, r_tip: &Vector3<f64>, f_contact: &Vector3<f64>) -> [f64; 6] {
        self.true_wrench_moving(r_ws, r_tip, f_contact, &SensorMotion::default())
    }

    /// The true wrench of the moving tool on the sensor, sensor frame: weight, contact
    /// and inertial wrench (Newton–Euler; module docs). `m`: the sensor frame's motion.
    pub fn true_wrench_moving(&self, r_ws: &Rotation3<f64>, r_tip: &Vector3<f64>, f_contact: &Vector3<f64>, m: &SensorMotion) -> [f64; 6] {
        let rest = SensorMotion::default();
        let m = if self.inertial { m } else { &rest };
        let r_com = r_ws * self.tool_com;
        let a_com = m.accel + m.alpha.cross(&r_com) + m.omega.cross(&m.omega.cross(&r_com));
        let f_tool = (self.gravity - a_com) * self.tool_mass;
        let i_w = r_ws.matrix() * self.tool_inertia * r_ws.matrix().transpose();
        let f_world = f_tool + f_contact;
        let t_world = r_com.cross(&f_tool) + r_tip.cross(f_contact) - (i_w * m.alpha + m.omega.cross(&(i_w * m.omega)));
        let f = r_ws.inverse_transform_vector(&f_world);
        let t = r_ws.inverse_transform_vector(&t_world);
        [f.x, f.y, f.z, t.x, t.y, t.z]
    }

    /// One reading of the moving tool ([`Mini45::true_wrench_moving`]) through [`Mini45::read`].
    pub fn measure_moving(
        &self,
        r_ws: &Rotation3<f64>,
        r_tip: &Vector3<f64>,
        f_contact: &Vector3<f64>,
        m: &SensorMotion,
        rng: &mut Rng,
    ) -> [f64; 6] {
        self.read(&self.true_wrench_moving(r_ws, r_tip, f_contact, m), rng)
    }

    /// One reading: true wrench + bias + noise, saturated and quantised.
    pub fn measure(
        &self,
        r_ws: &Rotation3<f64>,
        r_tip: &Vector3<f64>,
        f_contact: &Vector3<f64>,
        rng: &mut Rng,
    ) -> [f64; 6] {
        self.read(&self.true_wrench(r_ws, r_tip, f_contact), rng)
    }

    /// What the sensor reports for the true wrench `w` (sensor frame): `w` + bias +
    /// noise, saturated and quantised. The MuJoCo plant passes its physical sensor's
    /// wrench through this.
    pub fn read(&self, w: &[f64; 6], rng: &mut Rng) -> [f64; 6] {
        let mut out = [0.0; 6];
        for i in 0..6 {
            let mut v = w[i] + self.bias[i];
            if self.noise_sigma[i] > 0.0 {
                v += self.noise_sigma[i] * rng.gaussian();
            }
            v = v.clamp(-self.range[i], self.range[i]);
            if self.resolution[i] > 0.0 {
                v = (v / self.resolution[i]).round() * self.resolution[i];
            }
            out[i] = v;
        }
        out
    }
}

/// The motion of the sensor frame, base frame axes: the classical acceleration of its
/// origin [m/s²] (without gravity), its angular velocity [rad/s] and angular
/// acceleration [rad/s²]. Zero: at rest.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorMotion {
    pub accel: Vector3<f64>,
    pub omega: Vector3<f64>,
    pub alpha: Vector3<f64>,
}

/// Joint encoders and the drive's velocity signal.
///
/// Position: quantised to `counts_per_rev` counts per joint revolution.
/// JAKA publishes no encoder figure; we use 2^20 counts/rev (≈ 6.0 µrad), the
/// class of the 20-bit absolute encoders common on cobot joints (our choice).
/// Velocity: the true joint velocity plus white Gaussian noise of
/// `velocity_noise_sigma` rad/s (our choice 0.002 rad/s; the paper's Fig 5
/// shows the drive's velocity is noisy enough to need a median filter, but
/// gives no number). The controller side may median-filter it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Encoders {
    pub counts_per_rev: f64,
    pub velocity_noise_sigma: f64,
}

impl Default for Encoders {
    fn default() -> Self {
        Self { counts_per_rev: (1u64 << 20) as f64, velocity_noise_sigma: 0.002 }
    }
}

impl Encoders {
    /// Perfect encoders.
    pub fn ideal() -> Self {
        Self { counts_per_rev: f64::INFINITY, velocity_noise_sigma: 0.0 }
    }

    pub fn resolution_rad(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.counts_per_rev
    }

    pub fn measure<const N: usize>(&self, q: &JointVec<N>, dq: &JointVec<N>, rng: &mut Rng) -> (JointVec<N>, JointVec<N>) {
        let step = self.resolution_rad();
        let mut qm = *q;
        let mut dqm = *dq;
        for i in 0..N {
            if step > 0.0 {
                qm[i] = (q[i] / step).round() * step;
            }
            if self.velocity_noise_sigma > 0.0 {
                dqm[i] += self.velocity_noise_sigma * rng.gaussian();
            }
        }
        (qm, dqm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tool_errors_name_the_file_and_the_missing_link() {
        let dir = std::env::temp_dir().join(format!("naic_tool_error_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let urdf = dir.join("no_sensor.urdf");
        std::fs::write(&urdf, r#"<robot name="r"><link name="base_link"/></robot>"#).unwrap();
        let e = tool_from_urdf(&urdf).unwrap_err();
        assert_eq!(e, ToolError::NoSensorLink { path: urdf.display().to_string() });
        let m = e.to_string();
        assert!(m.contains("no_sensor.urdf") && m.contains("'ft_sensor'") && m.contains("add it"), "{m}");
        let missing = dir.join("missing.urdf");
        let e = tool_from_urdf(&missing).unwrap_err();
        assert!(matches!(&e, ToolError::Urdf { path, .. } if path.ends_with("missing.urdf")), "{e:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Tool pointing down: sensor z = −base z (180° about base y).
    fn down() -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI)
    }

    fn tool() -> Mini45 {
        Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(1)).ideal()
    }

    #[test]
    fn static_weight_reads_along_sensor_z_and_contact_adds() {
        let s = tool();
        let r_tip = down() * Vector3::new(0.0, 0.0, 0.169);
        // free space, tool pointing down: the tool pulls the sensor towards +z_s
        let w = s.true_wrench(&down(), &r_tip, &Vector3::zeros());
        assert!((w[2] - 0.424 * 9.81).abs() < 1e-12, "{w:?}");
        assert!(w[0].abs() < 1e-12 && w[1].abs() < 1e-12);
        assert!(w[3..].iter().all(|t| t.abs() < 1e-12), "COM on the axis: no torque");
        // pushing 10 N on the table: the sensor reads −10 N more along z_s
        // (the paper's "−10 N in the sensor frame", §5.2.1)
        let w = s.true_wrench(&down(), &r_tip, &Vector3::new(0.0, 0.0, 10.0));
        assert!((w[2] - (0.424 * 9.81 - 10.0)).abs() < 1e-12);
        // tangential contact force 2 N along base x at 0.169 m lever arm
        let w = s.true_wrench(&down(), &r_tip, &Vector3::new(2.0, 0.0, 0.0));
        let t_norm = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
        assert!((t_norm - 2.0 * 0.169).abs() < 1e-12);
    }

    #[test]
    fn a_moving_tool_adds_its_inertial_wrench() {
        let i_c = Matrix3::from_diagonal(&Vector3::new(2e-4, 3e-4, 1e-4));
        let s = Mini45 { inertial: true, ..tool().with_tool_inertia(i_c) };
        let r = down();
        let r_tip = r * Vector3::new(0.0, 0.0, 0.169);
        let rest = s.true_wrench(&r, &r_tip, &Vector3::zeros());
        // Accelerating straight down at g: the tool is weightless, the sensor reads nothing.
        let fall = SensorMotion { accel: Vector3::new(0.0, 0.0, -9.81), ..Default::default() };
        let w = s.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &fall);
        assert!(w.iter().all(|x| x.abs() < 1e-12), "{w:?} (at rest {rest:?})");
        // Spinning about the tool axis (sensor z, base −z) at a constant rate: the COM is
        // on the axis, a principal axis: no wrench beyond the weight.
        let spin = SensorMotion { omega: Vector3::new(0.0, 0.0, 7.0), ..Default::default() };
        let w = s.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &spin);
        assert!(w.iter().zip(&rest).all(|(a, b)| (a - b).abs() < 1e-12), "{w:?}");
        // Angular acceleration about the tool axis: base +z is sensor −z, so α_s = (0, 0, −50)
        // and the tool's reaction on the sensor is −I α_s = +I_zz 50 about sensor z.
        let alpha = SensorMotion { alpha: Vector3::new(0.0, 0.0, 50.0), ..Default::default() };
        let w = s.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &alpha);
        assert!((w[5] - 1e-4 * 50.0).abs() < 1e-12, "{w:?}");
        assert!((w[3] - rest[3]).abs() < 1e-12 && (w[4] - rest[4]).abs() < 1e-12);
        // Spinning about a horizontal axis through the sensor origin: the COM's centripetal
        // acceleration (ω² c toward the axis) is felt as m ω² c outward, along sensor z.
        let omega = 10.0;
        let swing = SensorMotion { omega: Vector3::new(omega, 0.0, 0.0), ..Default::default() };
        let w = s.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &swing);
        let extra = w[2] - rest[2];
        assert!((extra - 0.424 * omega * omega * 0.015).abs() < 1e-12, "{extra}");
        let weight_only = Mini45 { inertial: false, ..s.clone() };
        assert_eq!(weight_only.true_wrench_moving(&r, &r_tip, &Vector3::zeros(), &swing), rest);
        let urdf = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/jk5.urdf"));
        let i = tool_inertia_from_urdf(urdf).unwrap();
        assert_eq!((i[(0, 0)], i[(2, 2)], i[(0, 1)]), (0.00019875, 0.0001908, 0.0));
    }

    #[test]
    fn horizontal_tool_weight_makes_a_moment() {
        let s = tool();
        // sensor z along base x: COM lever 0.015 m, weight 4.16 N
        let r = Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        let w = s.true_wrench(&r, &(r * Vector3::new(0.0, 0.0, 0.169)), &Vector3::zeros());
        let t_norm = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
        assert!((t_norm - 0.424 * 9.81 * 0.015).abs() < 1e-12);
    }

    #[test]
    fn bias_noise_saturation_and_quantisation() {
        let mut rng = Rng::seed(3);
        let s = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut rng);
        assert!(s.bias[..3].iter().all(|b| b.abs() <= 1.0) && s.bias.iter().any(|b| *b != 0.0));
        let r_tip = down() * Vector3::new(0.0, 0.0, 0.169);
        let f = Vector3::new(0.0, 0.0, 10.0);
        let truth = s.true_wrench(&down(), &r_tip, &f);
        let n = 20_000;
        let mut mean = [0.0; 6];
        for _ in 0..n {
            let m = s.measure(&down(), &r_tip, &f, &mut rng);
            for i in 0..6 {
                // quantised to the resolution grid
                let k = m[i] / s.resolution[i];
                assert!((k - k.round()).abs() < 1e-6);
                mean[i] += m[i] / n as f64;
            }
        }
        for i in 0..6 {
            // the mean reading is truth + bias (noise averages out)
            assert!((mean[i] - truth[i] - s.bias[i]).abs() < 0.1 * s.resolution[i] + 1e-4, "axis {i}");
        }
        // saturation: 400 N pushing saturates Fz at the 290 N range
        let m = s.measure(&down(), &r_tip, &Vector3::new(0.0, 0.0, 400.0), &mut rng);
        assert_eq!(m[2], -290.0);
        let m = s.measure(&down(), &r_tip, &Vector3::new(200.0, 0.0, 0.0), &mut rng);
        assert_eq!(m[0].abs(), 145.0);
    }

    #[test]
    fn encoders_quantise_and_add_velocity_noise() {
        let e = Encoders::default();
        let mut rng = Rng::seed(5);
        let q = [0.1234567, -1.0, 2.0, 0.0, 1e-7, 3.0];
        let (qm, dqm) = e.measure(&q, &[0.0; 6], &mut rng);
        for i in 0..6 {
            assert!((qm[i] - q[i]).abs() <= 0.5 * e.resolution_rad() + 1e-15);
            let k = qm[i] / e.resolution_rad();
            assert!((k - k.round()).abs() < 1e-6);
        }
        assert_eq!(qm[4], 0.0, "below half a count reads zero");
        assert!(dqm.iter().any(|v| *v != 0.0));
        let (qi, dqi) = Encoders::ideal().measure(&q, &[0.5; 6], &mut rng);
        assert_eq!(qi, q);
        assert_eq!(dqi, [0.5; 6]);
    }
}

/// Why the tool of a URDF could not be read ([`tool_from_urdf`]); names the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ToolError {
    /// The URDF does not parse (`problem`: the parser's words).
    #[error("{path}: {problem}")]
    Urdf { path: String, problem: String },
    #[error("{path}: no link 'ft_sensor' (the F/T sensor + tool link) in the URDF; add it with the tool's <inertial>")]
    NoSensorLink { path: String },
}

/// The tool's inertia about its centre of mass in the sensor frame [kg m²]: the
/// `<inertial>` of link `ft_sensor` (its `rpy` applied).
pub fn tool_inertia_from_urdf(path: &std::path::Path) -> Result<Matrix3<f64>, ToolError> {
    let l = sensor_link(path)?;
    let i = &l.inertial.inertia;
    let m = Matrix3::new(i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz);
    let rpy = l.inertial.origin.rpy;
    let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    Ok(r.matrix() * m * r.matrix().transpose())
}

/// The URDF's link `ft_sensor` (the tool below the sensor), or why there is none.
fn sensor_link(path: &std::path::Path) -> Result<urdf_rs::Link, ToolError> {
    let shown = || path.display().to_string();
    let robot = urdf_rs::read_file(path).map_err(|e| ToolError::Urdf { path: shown(), problem: e.to_string() })?;
    robot.links.into_iter().find(|l| l.name == "ft_sensor").ok_or_else(|| ToolError::NoSensorLink { path: shown() })
}

/// The tool of the `ft_sensor` link of a URDF: its mass [kg] and centre of
/// mass in the sensor frame [m] (the `<inertial>` of link `ft_sensor`).
pub fn tool_from_urdf(path: &std::path::Path) -> Result<(f64, Vector3<f64>), ToolError> {
    let l = sensor_link(path)?;
    let o = l.inertial.origin.xyz;
    Ok((l.inertial.mass.value, Vector3::new(o[0], o[1], o[2])))
}
