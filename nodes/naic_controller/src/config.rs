//! The controller node's ROS parameters and their mapping onto
//! `naic_core::pipeline::controller::ControllerParams` (one place for both).

use naic_core::{
    dynamics::Damping,
    model::Model,
    pipeline::{
        control::{
            force_law::{ForceLawParams, Mode, WeightBounds},
            ContactDetect, ControlParams, ForceAxis, ImpedanceParams,
        },
        controller::ControllerParams,
        estimate::ToolParams,
        sense::SenseParams,
    },
};
use nalgebra::Vector3;
use naic_ros::{ParamSpec, ParamView};

pub const FORCE_AXES: [&str; 6] = ["x", "y", "z", "-x", "-y", "-z"];

pub fn specs() -> Vec<ParamSpec> {
    vec![
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model (URDF with 'tip' and 'ft_sensor' frames)").read_only(),
        ParamSpec::choice("mode", "naic", &["naic", "aic", "fixed"], "Force law on the force axis: NAIC (eq 10-15), AIC (eq 9) or fixed impedance (eq 8)"),
        ParamSpec::double("desired_force", 10.0, 0.0, 100.0, "f_d [N]: force the tool applies to the environment along the force axis (pushing positive)"),
        ParamSpec::double("learning_rate", 0.01, 0.0, 100.0, "gamma of eq 15 (NAIC): requested learning rate, clipped every cycle to the eq-15 bound"),
        ParamSpec::doubles("m_d", &[1.0; 6], 0.001, 1000.0, "Impedance mass M_d per Cartesian axis x,y,z,rx,ry,rz [kg, kg m^2] (eq 6); force-axis entry is NAIC weight w1"),
        ParamSpec::doubles("b_d", &[500.0, 500.0, 40.0, 500.0, 500.0, 500.0], 0.0, 1.0e5, "Impedance damping B_d per axis [N s/m, N m s/rad] (eq 6); force-axis entry is NAIC weight w2"),
        ParamSpec::doubles("k_d", &[500.0, 500.0, 50.0, 1000.0, 1000.0, 1000.0], 0.0, 1.0e5, "Impedance stiffness K_d per axis in free space [N/m, N m/rad]; in contact the force-axis entry is 0"),
        ParamSpec::double("sigma", 0.01, 0.0, 1.0, "Update rate sigma of eq 9 (NAIC weight w3, initial value)"),
        ParamSpec::double("sigma_margin", 0.5, 0.01, 1.0e9, "NAIC keeps sigma <= sigma_margin * lambda * b_d / m_d (fraction of the force-loop stability limit)"),
        ParamSpec::choice("force_axis", "-z", &FORCE_AXES, "Direction n in the base frame along which the tool pushes ('-z': down onto a table)"),
        ParamSpec::double("contact_threshold", 1.0, 0.01, 100.0, "Enter contact when the measured force along n exceeds this [N]"),
        ParamSpec::int("contact_exit_cycles", 0, 0, 100_000, "Leave contact after this many cycles below half the threshold (0: contact latches, as in the paper)"),
        ParamSpec::double("force_limit", 50.0, 0.1, 500.0, "Above this measured force [N] the controller stops pushing and retracts to the start pose"),
        ParamSpec::double("wrench_timeout", 0.01, 0.0005, 1.0, "Wrench older than this [s] is stale: safe hold"),
        ParamSpec::double("joint_timeout", 0.01, 0.0005, 1.0, "Joint state older than this [s] is stale: safe hold"),
        ParamSpec::double("approach_depth", 0.05, -0.5, 0.5, "Free-space target: start tip position moved this far along n [m]"),
        ParamSpec::double("control_period", 0.001, 1.0e-5, 0.1, "Expected control period lambda [s] (the driver's 1/rate)"),
        ParamSpec::double("tool_mass", 0.424, 0.0, 10.0, "Mass of sensor half + rod beyond the measuring plane [kg] (authors' MJCF)"),
        ParamSpec::doubles("tool_com", &[0.0, 0.0, 0.015], -1.0, 1.0, "Tool centre of mass in the ft_sensor frame [m]"),
        ParamSpec::doubles("tool_tip", &[0.0, 0.0, 0.169], -1.0, 1.0, "Contact point in the ft_sensor frame [m]"),
        ParamSpec::int("tare_samples", 100, 1, 100_000, "Free-space F/T samples averaged for the tare at start"),
        ParamSpec::int("median_window", 5, 1, 9, "Median filter window of the joint velocity"),
        ParamSpec::double("hold_damping", 5.0, 0.0, 200.0, "Joint damping of the safe hold [N m s/rad]"),
    ]
}

/// `"-z"` → axis 2, sign −1.
pub fn force_axis(s: &str) -> ForceAxis {
    let (sign, name) = match s.strip_prefix('-') {
        Some(n) => (-1.0, n),
        None => (1.0, s),
    };
    let axis = match name {
        "x" => 0,
        "y" => 1,
        _ => 2,
    };
    ForceAxis { axis, sign }
}

fn arr6(v: &[f64]) -> [f64; 6] {
    let mut a = [0.0; 6];
    for (o, x) in a.iter_mut().zip(v) {
        *o = *x;
    }
    a
}

fn vec3(v: &[f64]) -> Vector3<f64> {
    Vector3::new(v.first().copied().unwrap_or(0.0), v.get(1).copied().unwrap_or(0.0), v.get(2).copied().unwrap_or(0.0))
}

/// The control-stage parameters (no model needed).
pub fn control_params(p: &ParamView) -> Result<ControlParams, String> {
    let axis = force_axis(p.str("force_axis"));
    let k_free = arr6(p.f64s("k_d"));
    let mut k_contact = k_free;
    k_contact[axis.axis] = 0.0;
    let enter = p.f64("contact_threshold");
    let cp = ControlParams {
        impedance: ImpedanceParams { m_d: arr6(p.f64s("m_d")), b_d: arr6(p.f64s("b_d")), k_free, k_contact },
        force_axis: axis,
        force_law: ForceLawParams {
            mode: Mode::parse(p.str("mode"))?,
            sigma: p.f64("sigma"),
            gamma: p.f64("learning_rate"),
            bounds: WeightBounds::default(),
            lambda: p.f64("control_period"),
            sigma_margin: p.f64("sigma_margin"),
        },
        contact: ContactDetect { enter_n: enter, exit_n: 0.5 * enter, exit_cycles: p.i64("contact_exit_cycles") as u32 },
    };
    cp.validate()?;
    Ok(cp)
}

pub fn sense_params(p: &ParamView, model: Option<&Model>) -> SenseParams {
    let (q_min, q_max, dq_max) = match model {
        Some(m) => (
            arr6(&m.lower_limits()),
            arr6(&m.upper_limits()),
            arr6(&m.velocity_limits().iter().map(|v| 2.0 * v).collect::<Vec<_>>()),
        ),
        None => ([-10.0; 6], [10.0; 6], [10.0; 6]),
    };
    SenseParams {
        q_min,
        q_max,
        q_margin: 0.05,
        dq_max,
        // 1.5x the ATI mini45 ranges (SI-580-20: 580 N Fx/Fy, 1160 N Fz, 20 N m).
        wrench_max: [870.0, 870.0, 1740.0, 30.0, 30.0, 30.0],
        median_window: p.i64("median_window") as usize,
        joint_timeout: p.f64("joint_timeout"),
        wrench_timeout: p.f64("wrench_timeout"),
    }
}

pub fn controller_params(p: &ParamView, model: Option<&Model>) -> Result<ControllerParams, String> {
    let control = control_params(p)?;
    let sense = sense_params(p, model);
    sense.validate()?;
    Ok(ControllerParams {
        sense,
        tool: ToolParams {
            mass: p.f64("tool_mass"),
            com: vec3(p.f64s("tool_com")),
            tip: vec3(p.f64s("tool_tip")),
            gravity: Vector3::new(0.0, 0.0, -9.81),
        },
        tare_samples: p.i64("tare_samples") as u32,
        control,
        hold_damping: [p.f64("hold_damping"); 6],
        damping: Damping::default(),
    })
}

/// Whole-set check for the parameter services: the core's own validation plus the
/// node's cross-parameter rules. Rejections carry the core's reason.
pub fn check(p: &ParamView) -> Result<(), String> {
    controller_params(p, None)?;
    if p.f64("contact_threshold") >= p.f64("force_limit") {
        return Err(format!(
            "contact_threshold ({} N) must be below force_limit ({} N)",
            p.f64("contact_threshold"),
            p.f64("force_limit")
        ));
    }
    if p.f64("desired_force") >= p.f64("force_limit") {
        return Err(format!(
            "desired_force ({} N) must be below force_limit ({} N)",
            p.f64("desired_force"),
            p.f64("force_limit")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_ros::{ParamTable, ParameterValue as V};

    fn table() -> ParamTable {
        ParamTable::new(specs(), Some(Box::new(check)), &[]).unwrap()
    }

    #[test]
    fn defaults_are_valid_and_map_onto_the_core() {
        let t = table();
        let cp = t.with(|p| controller_params(p, None)).unwrap();
        assert_eq!(cp.control.force_axis, ForceAxis { axis: 2, sign: -1.0 });
        assert_eq!(cp.control.impedance.k_contact[2], 0.0);
        assert_eq!(cp.control.force_law.mode, Mode::Naic);
        assert_eq!(cp.tool.mass, 0.424);
    }

    #[test]
    fn bad_values_are_rejected_with_reasons() {
        let t = table();
        let set = |n: &str, v: V| t.set_atomically(&[(n.to_string(), v)]);
        assert!(set("learning_rate", V::Double(-0.1)).unwrap_err().contains("outside its range"));
        assert!(set("mode", V::String("pid".into())).unwrap_err().contains("naic, aic, fixed"));
        assert!(set("desired_force", V::Double(60.0)).unwrap_err().contains("below force_limit"));
        // The core's own bound: b_d on the force axis must lie in the NAIC weight bounds.
        let e = set("b_d", V::DoubleArray(vec![500.0, 500.0, 0.5, 500.0, 500.0, 500.0])).unwrap_err();
        assert!(e.contains("b_d"), "{e}");
        set("force_axis", V::String("x".into())).unwrap();
        assert_eq!(t.with(|p| control_params(p)).unwrap().force_axis, ForceAxis { axis: 0, sign: 1.0 });
    }
}
