//! Stage 2 of the pipeline: from the raw F/T reading to the contact wrench
//! the controller needs.
//!
//! The ATI mini45 sits between the flange and the tool (sensor + rod,
//! 0.424 kg in the authors' model). It reports, in the `ft_sensor` frame, the
//! wrench applied to its tool side: the contact wrench the environment exerts
//! on the tip, plus the weight of the tool, plus the sensor's bias. So with
//! `R` the sensor orientation in the base frame, `g` gravity, `m`/`c` the tool
//! mass and centre of mass and `r` the tip, both in the sensor frame:
//!
//! ```text
//! f_raw = Rᵀ (F_c + m g) + b_f
//! τ_raw = r × Rᵀ F_c + τ_c,s + c × Rᵀ m g + b_τ        (moments about the sensor origin)
//! ```
//!
//! This stage removes the bias (a tare: the mean over the first samples, taken
//! with the tool in free space, minus the tool weight expected there) and the
//! tool weight at the current orientation, and returns `F_e = −F_c`, the
//! wrench the robot applies to the environment at the tip, in the base frame
//! (eq 3's `F_ext`). Tool inertial forces are neglected: at the speeds of
//! force tracking (< 0.1 m/s, < 1 rad/s) they are below 0.05 N.
//!
//! The tool is a rod along the sensor z axis touching at its tip, on that axis:
//! no contact force at the tip has a moment about the tool axis. So the moment
//! the sensor reads about its z axis is never contact: it is the tool's inertial
//! moment (`I α + ω × I ω` when joint 6 turns the tool) and the sensor's errors.
//! Fed back through `Jᵀ F_e` and eq 6's rotational rows it would drive the joint
//! that turns the tool with the tool's own inertia (on MuJoCo's physical sensor
//! `τ₆ ≈ −2·t_z`, a loop gain near 1 that oscillates); so `F_e` carries no moment
//! about the tool axis (the component along the sensor z axis is removed before
//! the moment is expressed in the base frame).

use nalgebra::{Matrix3, Vector3, Vector6};

/// The tool beyond the sensor's measuring plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolParams {
    /// Mass of sensor + rod [kg] (0.424 kg in the authors' MJCF).
    pub mass: f64,
    /// Centre of mass in the sensor frame [m].
    pub com: Vector3<f64>,
    /// Contact point (`tip`) in the sensor frame [m] (0.169 m along z).
    pub tip: Vector3<f64>,
    /// Gravity in the base frame [m/s²].
    pub gravity: Vector3<f64>,
}

/// The tare: the sensor bias, estimated over the first `samples` readings.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TareState {
    /// Readings accumulated so far.
    pub count: u32,
    sum: [f64; 6],
}

impl TareState {
    /// True once `samples` readings have been averaged.
    pub fn done(&self, samples: u32) -> bool {
        self.count >= samples
    }

    /// The bias estimate so far (zero before the first sample).
    pub fn bias(&self) -> [f64; 6] {
        let n = self.count.max(1) as f64;
        self.sum.map(|s| s / n)
    }
}

/// The weight of the tool as the sensor sees it (force, moment about the
/// sensor origin), in the sensor frame, at orientation `r_ws`.
pub fn tool_weight_wrench(tool: &ToolParams, r_ws: &Matrix3<f64>) -> Vector6<f64> {
    let w = r_ws.transpose() * (tool.mass * tool.gravity);
    let m = tool.com.cross(&w);
    Vector6::new(w.x, w.y, w.z, m.x, m.y, m.z)
}

/// Adds one free-space reading to the tare (until `samples` are in).
pub fn tare_step(tool: &ToolParams, samples: u32, s: &TareState, raw: &[f64; 6], r_ws: &Matrix3<f64>) -> TareState {
    if s.done(samples) {
        return *s;
    }
    let expected = tool_weight_wrench(tool, r_ws);
    let mut next = *s;
    for i in 0..6 {
        next.sum[i] += raw[i] - expected[i];
    }
    next.count += 1;
    next
}

/// `F_e`: the wrench the robot applies to the environment at the tip, in the
/// base frame (force [N], moment about the tip [N·m] without its component about
/// the tool axis — see the module docs).
pub fn contact_wrench(tool: &ToolParams, bias: &[f64; 6], raw: &[f64; 6], r_ws: &Matrix3<f64>) -> Vector6<f64> {
    let weight = tool_weight_wrench(tool, r_ws);
    let f_c_s = Vector3::new(raw[0] - bias[0] - weight[0], raw[1] - bias[1] - weight[1], raw[2] - bias[2] - weight[2]);
    let m_c_s = Vector3::new(raw[3] - bias[3] - weight[3], raw[4] - bias[4] - weight[4], 0.0);
    // Moment of the contact wrench about the tip instead of the sensor origin
    // (the tip is on the sensor z axis: r × f has no z component).
    let m_tip_s = m_c_s - tool.tip.cross(&f_c_s);
    let f = -(r_ws * f_c_s);
    let m = -(r_ws * m_tip_s);
    Vector6::new(f.x, f.y, f.z, m.x, m.y, m.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn tool() -> ToolParams {
        ToolParams {
            mass: 0.424,
            com: Vector3::new(0.0, 0.0, 0.015),
            tip: Vector3::new(0.0, 0.0, 0.169),
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }

    /// What an ideal sensor reads for a contact force `f_c` (base frame) at the tip.
    fn reading(t: &ToolParams, r: &Matrix3<f64>, f_c: Vector3<f64>, bias: [f64; 6]) -> [f64; 6] {
        let f_s = r.transpose() * f_c;
        let w = tool_weight_wrench(t, r);
        let m = t.tip.cross(&f_s);
        [
            f_s.x + w[0] + bias[0],
            f_s.y + w[1] + bias[1],
            f_s.z + w[2] + bias[2],
            m.x + w[3] + bias[3],
            m.y + w[4] + bias[4],
            m.z + w[5] + bias[5],
        ]
    }

    #[test]
    fn tare_then_compensation_recovers_the_contact_force_at_any_orientation() {
        let t = tool();
        let bias = [0.7, -0.3, 1.9, 0.02, -0.01, 0.005];
        // Tare with the tool pointing down (sensor frame = base rotated 180° about y, paper Fig 7).
        let r0 = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let mut s = TareState::default();
        for _ in 0..50 {
            s = tare_step(&t, 50, &s, &reading(&t, &r0, Vector3::zeros(), bias), &r0);
        }
        assert!(s.done(50));
        for (k, b) in s.bias().iter().zip(bias) {
            assert!((k - b).abs() < 1e-12);
        }
        // Now tilt the tool and push: pushing down 10 N on a table means F_c = +10 z.
        let axis = Unit::new_normalize(Vector3::new(0.3, -0.2, 1.0));
        let r = *(Rotation3::from_axis_angle(&axis, 0.4) * Rotation3::from_axis_angle(&Vector3::y_axis(), 3.0)).matrix();
        let f_c = Vector3::new(1.0, -2.0, 10.0);
        let fe = contact_wrench(&t, &s.bias(), &reading(&t, &r, f_c, bias), &r);
        for i in 0..3 {
            assert!((fe[i] + f_c[i]).abs() < 1e-12, "F_e = −F_c");
            assert!(fe[3 + i].abs() < 1e-12, "a pure force at the tip has no moment about the tip");
        }
    }

    #[test]
    fn a_torque_about_the_tool_axis_never_reaches_the_contact_wrench() {
        // The tool's inertial moment about its axis (joint 6 accelerating): measured by
        // the sensor, never a contact moment, so F_e carries none of it.
        let t = tool();
        let r = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let mut raw = reading(&t, &r, Vector3::new(0.0, 0.0, 10.0), [0.0; 6]);
        let clean = contact_wrench(&t, &[0.0; 6], &raw, &r);
        raw[5] += 0.5;
        let fe = contact_wrench(&t, &[0.0; 6], &raw, &r);
        assert!((fe[2] + 10.0).abs() < 1e-12, "{fe:?}");
        assert_eq!(fe, clean, "a torque about the tool axis must not change F_e");
        // the tool axis is base −z here: F_e's moment about it is zero
        assert!(fe[5].abs() < 1e-15, "{fe:?}");
        // a moment about a sensor axis across the tool still passes (not a contact moment
        // of a point tip either, but the controller's rotational impedance uses it)
        raw[3] += 0.3;
        let across = contact_wrench(&t, &[0.0; 6], &raw, &r);
        assert!(((across - clean).fixed_rows::<3>(3).norm() - 0.3).abs() < 1e-12, "{across:?}");
    }

    #[test]
    fn paper_sensor_frame_sign_of_the_desired_force() {
        // §5.2.1: pressing down with 10 N reads −10 N along the sensor z (sensor frame = base rotated 180° about y).
        let t = ToolParams { mass: 0.0, ..tool() };
        let r = *Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI).matrix();
        let raw = reading(&t, &r, Vector3::new(0.0, 0.0, 10.0), [0.0; 6]);
        assert!((raw[2] + 10.0).abs() < 1e-12);
    }
}
