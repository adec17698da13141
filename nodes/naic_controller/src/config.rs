//! The controller node's ROS parameters and their mapping onto
//! `naic_core::pipeline::controller::ControllerParams` (one place for both).

use naic_core::{
    pipeline::{
        control::{
            force_law::{ForceLawParams, Mode},
            ContactDetect, ForceAxis, ImpedanceParams,
        },
        controller::ControllerParams,
        estimate::ToolParams,
        reference::ReferenceParams,
    },
};
use nalgebra::Vector3;
use naic_ros::{params::SetCheck, timebase::TimeBase, ParamSpec, ParamView};

use crate::core::Settings;

pub const FORCE_AXES: [&str; 6] = ["x", "y", "z", "-x", "-y", "-z"];

/// `friction_file`'s default: friction_compensation's and `naic sim`'s (Table 1 of the paper).
pub const FRICTION_FILE: &str = "params/friction_jk5.yaml";

/// The node's parameters; defaults come from `base` (the core's `paper_defaults` on the
/// loaded model), so the numbers live in one place.
pub fn specs<const N: usize>(base: &ControllerParams<N>) -> Vec<ParamSpec> {
    let c = &base.control;
    let imp = &c.impedance;
    let fl = &c.force_law;
    let axis = force_axis_name(&c.force_axis);
    // The reference stage's defaults (naic_core), so the numbers live in one place.
    let rd = ReferenceParams::new("base_link", c.force_axis, 10.0);
    let ap = &fl.scheduled.approach;
    let dp = &fl.derived;
    vec![
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model (URDF with 'tip' and 'ft_sensor' frames)").read_only(),
        ParamSpec::string("friction_file", FRICTION_FILE, "Mode 'scheduled': the friction model (friction_compensation's friction_file) whose Stribeck drops get the unfiltered joint velocity in contact ('': the median everywhere)").read_only(),
        ParamSpec::choice("mode", fl.mode.as_str(), &["naic", "aic", "fixed", "scheduled", "derived"], "Force law on the force axis: 'scheduled' (the default and the recommended law, docs/controller.md: impedance scheduled from an online stiffness estimate k_e_hat, reported in /naic/params; not a paper law), the paper's NAIC (eq 10-15), AIC (eq 9), fixed impedance (eq 8), or 'derived' (gains from a stability rule on the contact estimator's stiffness bounds, docs/controller.md; not a paper law, not yet as good as 'scheduled')"),
        ParamSpec::double("desired_force", 10.0, 0.0, 100.0, "f_d [N]: force the tool applies to the environment along the force axis (pushing positive)"),
        ParamSpec::double("learning_rate", fl.gamma, 0.0, 100.0, "gamma of eq 15 (NAIC): requested learning rate, clipped every cycle to the eq-15 bound"),
        ParamSpec::doubles("m_d", &imp.m_d, 0.001, 1000.0, "Impedance mass M_d per Cartesian axis x,y,z,rx,ry,rz [kg, kg m^2] (eq 6); force-axis entry is NAIC weight w1"),
        ParamSpec::doubles("b_d", &imp.b_d, 0.0, 1.0e5, "Impedance damping B_d per axis [N s/m, N m s/rad] (eq 6); force-axis entry is NAIC weight w2"),
        ParamSpec::doubles("k_d", &imp.k_free, 0.0, 1.0e5, "Impedance stiffness K_d per axis in free space [N/m, N m/rad] (eq 6)"),
        ParamSpec::doubles("k_d_contact", &imp.k_contact, 0.0, 1.0e5, "K_d per axis in contact; the force-axis entry is always 0 (force tracking)"),
        ParamSpec::double("sigma", fl.sigma, 0.0, 1.0, "Update rate sigma of eq 9 (NAIC weight w3, initial value)"),
        ParamSpec::double("sigma_margin", fl.sigma_margin, 0.01, 1.0e9, "NAIC keeps sigma <= sigma_margin * lambda * b_d / m_d (fraction of the force-loop stability limit)"),
        ParamSpec::string("force_axis", &axis, "Direction n in the base frame along which the tool pushes: x, y, z, -x, -y, -z ('-z': down onto a table) or a vector '[x, y, z]' (normalised; not zero)"),
        ParamSpec::double("contact_threshold", c.contact.enter_n, 0.01, 100.0, "Enter contact when the measured force along n exceeds this [N]"),
        ParamSpec::double("scheduled_contact_threshold", c.contact.scheduled_enter_n, 0.01, 100.0, "Modes 'scheduled' and 'derived': enter contact when the measured force along n exceeds this [N] (8 sigma of the F/T noise, where its stiffness estimator starts; contact_threshold is for the paper's laws)"),
        ParamSpec::double("contact_exit_force", c.contact.exit_n, 0.0, 100.0, "Leave contact below this force [N] (after contact_exit_cycles)"),
        ParamSpec::int("contact_exit_cycles", c.contact.exit_cycles as i64, 0, 100_000, "Leave contact after this many cycles below contact_exit_force (0: contact latches, as in the paper)"),
        ParamSpec::double("force_limit", 50.0, 0.1, 500.0, "Above this measured force [N] the controller stops pushing, backs off along -n and stays off the surface until any parameter is set"),
        ParamSpec::double("wrench_timeout", base.sense.wrench_timeout, 0.0005, 1.0, "Wrench older than this [s] is stale: safe hold"),
        ParamSpec::double("joint_timeout", base.sense.joint_timeout, 0.0005, 1.0, "Joint state older than this [s] is stale: safe hold"),
        ParamSpec::choice("scenario", crate::reference::DEFAULT_SCENARIO, &crate::reference::SCENARIOS,
            "Position reference: a paper task's trajectory (naic_core::task), or 'none' (start pose moved approach_depth along n)").read_only(),
        ParamSpec::double("approach_depth", 0.05, -0.5, 0.5, "With scenario 'none': free-space target = start tip position moved this far along n [m]"),
        ParamSpec::double("approach_speed", fl.scheduled.approach.max_speed, 1.0e-3, 0.5, "Modes 'scheduled' and 'derived': speed limit of the free-space approach along n [m/s] (a velocity servo toward the reference, robust to model error); the first contact adds k_e * approach_speed * (d + 1/2) * T before the loop reacts (50 000 N/m, 2 cycles of delay: 1.25 N per 10 mm/s)"),
        ParamSpec::boolean("use_expected_surface", ap.expected_surface.is_some(), "Modes 'scheduled' and 'derived': slow down toward the surface at expected_surface, to approach_band_speed within approach_band ('scheduled') or braking to the impact-bounded speed of impact_fraction by surface_uncertainty before it ('derived') (false: approach_speed all the way)"),
        ParamSpec::double("expected_surface", ap.expected_surface.unwrap_or(0.0), -2.0, 2.0, "Modes 'scheduled' and 'derived', with use_expected_surface: the surface's coordinate on the force axis's base-frame axis [m] (force_axis '-z': the table top's z in base_frame)"),
        ParamSpec::double("approach_band", ap.band, 0.0, 0.5, "Mode 'scheduled', with use_expected_surface: distance before the expected surface where the approach slows [m]"),
        ParamSpec::double("approach_band_speed", ap.speed, 1.0e-4, 0.5, "Mode 'scheduled', with use_expected_surface: approach speed along n inside approach_band [m/s]"),
        ParamSpec::double("force_observer", fl.scheduled.force_observer, 0.0, 2000.0, "Mode 'scheduled': bandwidth of the disturbance observer that reads the force on stiff surfaces [rad/s] (0: off, the velocity observer alone)"),
        ParamSpec::double("loop_delay_cycles", dp.delay_cycles, 0.0, naic_core::pipeline::control::contact::MAX_DELAY as f64, "Mode 'derived': the loop delay d its gains are designed for [control periods] (sensor sample to torque; measure it on the chain)"),
        ParamSpec::double("stiffness_max", dp.contact.k_max, 1.0, 1.0e8, "Mode 'derived': the stiffest surface expected [N/m]: the stiffness bound k_bar before any evidence (the gains are stable for every surface up to k_bar)"),
        ParamSpec::double("stiffness_min", dp.k_min, 1.0, 1.0e7, "Mode 'derived': the softest surface expected [N/m]: the integral is set for it until the estimate's lower bound is higher"),
        ParamSpec::double("feedthrough_max", dp.contact.mu_max, 1.0e-3, 1.0, "Mode 'derived': bound on the contact's feed-through mu (the fraction of a push that reaches the force at once: 0 a spring, about 0.9 MuJoCo's soft contact, 1 rigid); 1 is safe on any contact"),
        ParamSpec::double("surface_damping_max", dp.contact.b_max, 0.0, 1.0e6, "Mode 'derived': the largest surface damping expected [N s/m]"),
        ParamSpec::double("position_resolution", dp.x_resolution, 1.0e-9, 1.0e-2, "Mode 'derived': the tip's position resolution along n [m] (one encoder count through the Jacobian)"),
        ParamSpec::double("force_noise", dp.force_noise, 1.0e-4, 10.0, "Mode 'derived': the F/T sensor's noise along n, 1 sigma [N]"),
        ParamSpec::double("surface_speed", dp.contact.surface_speed, 0.0, 1.0, "Mode 'derived': 1 sigma of the surface's speed along n the contact estimator allows [m/s]"),
        ParamSpec::double("impact_fraction", dp.impact_fraction, 1.0e-3, 10.0, "Mode 'derived', with use_expected_surface: the approach brakes toward the surface to impact_fraction * f_d / (stiffness_max * (loop_delay_cycles + 1/2) * control_period), so the force a first contact adds before the loop reacts is at most this fraction of f_d"),
        ParamSpec::double("surface_uncertainty", dp.surface_uncertainty, 0.0, 0.5, "Mode 'derived', with use_expected_surface: how far before expected_surface the real surface may be [m]; the approach brakes (at w v_c / 2, w the approach servo's bandwidth) so that it is at the impact-bounded speed this far before expected_surface (more: a slower approach, never a harder impact)"),
        ParamSpec::string("base_frame", "base_link", "The URDF's root link: the frame of /naic/params and of the reference; with scenario 'none', /naic/target_pose and /naic/desired_wrench in any frame of the model (or '' for this one) are expressed in it"),
        ParamSpec::double("tf_rate", crate::tf::DEFAULT_TF_RATE, 0.0, 1000.0, "Rate of /tf [Hz]: the moving joints' transforms from the measured joint states, stamped with them (0: none; the fixed joints go to /tf_static once)"),
        ParamSpec::double("max_speed", rd.linear.max_speed, 1.0e-4, 2.0, "With scenario 'none': speed limit of the position reference [m/s]"),
        ParamSpec::double("max_accel", rd.linear.max_accel, 1.0e-3, 20.0, "With scenario 'none': acceleration limit of the position reference [m/s^2]"),
        ParamSpec::double("max_angular_speed", rd.angular.max_speed, 1.0e-3, 6.0, "With scenario 'none': angular speed limit of the orientation reference [rad/s]"),
        ParamSpec::double("max_angular_accel", rd.angular.max_accel, 1.0e-3, 60.0, "With scenario 'none': angular acceleration limit of the orientation reference [rad/s^2]"),
        naic_ros::source::spec("reference_source", naic_ros::source::ANY, "/naic/target_pose and /naic/desired_wrench (scenario 'none')"),
        ParamSpec::double("max_force_rate", rd.max_force_rate, 0.1, 1.0e4, "With scenario 'none': fastest change of the force reference from /naic/desired_wrench [N/s]"),
        ParamSpec::double("reference_timeout", rd.timeout, 0.001, 60.0, "With scenario 'none': a reference topic silent this long [s] is stale; its last target is held"),
        ParamSpec::double("actuation_timeout", 0.1, 0.001, 10.0, "When the newest /joint_effort_cmd answers a joint state older than this [s] (friction_compensation down: the driver holds the arm), the force law is reset as by a safe hold (contact re-detected when commands reach the arm again), and /naic/params reports it (wall clock only). Above the driver's command_timeout (0.02 s): a loaded machine delays the chain by 20-30 ms now and then, and that should not restart force control"),
        ParamSpec::double("control_period", fl.lambda, 1.0e-5, 0.1, "Expected control period lambda [s] (the driver's 1/rate)"),
        ParamSpec::double("tool_mass", base.tool.mass, 0.0, 10.0, "Mass of sensor half + rod beyond the measuring plane [kg] (authors' MJCF)"),
        ParamSpec::doubles("tool_com", base.tool.com.as_slice(), -1.0, 1.0, "Tool centre of mass in the ft_sensor frame [m]"),
        ParamSpec::doubles("tool_tip", base.tool.tip.as_slice(), -1.0, 1.0, "Contact point in the ft_sensor frame [m]"),
        ParamSpec::int("tare_samples", base.tare_samples as i64, 1, 100_000, "Free-space F/T samples averaged for the tare at start"),
        ParamSpec::boolean("tare_at_rest", true, "The start-up tare takes only consecutive samples at rest (every joint <= 0.02 rad/s, <= 0.1 rad/s^2 over the window) and holds the arm at its start position meanwhile; false: the first tare_samples cycles, controlled as usual (what naic sim does)"),
        ParamSpec::int("median_window", base.sense.median_window as i64, 1, 9, "Median filter window of the joint velocity"),
        ParamSpec::double("hold_damping", base.hold_damping[0], 0.0, 200.0, "Joint damping of the safe hold [N m s/rad]"),
        ParamSpec::boolean("robot_compensates_gravity", false, "The arm's torque interface adds its own gravity compensation (a Franka arm under franka_ros2 / libfranka): /naic/effort leaves the model's G(q) out (false: the whole torque, gravity included, as a ros2_control effort interface takes it)").read_only(),
        ParamSpec::double("nullspace_stiffness", base.nullspace.stiffness, 0.0, 1000.0, "Arms of more than 6 joints: stiffness of the posture task in the Jacobian's null space, towards nullspace_q [N m/rad] (docs/controller.md; no effect on 6 joints)"),
        ParamSpec::double("nullspace_damping", base.nullspace.damping, 0.0, 200.0, "Arms of more than 6 joints: joint damping of the null-space posture task [N m s/rad], capped per joint for stability at the control period"),
        ParamSpec::new("nullspace_q", naic_ros::ParameterValue::DoubleArray(vec![]), "Arms of more than 6 joints: the posture q_n of the null-space task [rad], one per joint in the arm's joint order ([]: the first measured joint position, the start pose)").read_only(),
    ]
}

/// The parameter's text for `n`: one of [`FORCE_AXES`] for an axis-aligned `n`, else `[x, y, z]`.
pub fn force_axis_name(n: &ForceAxis) -> String {
    match n.aligned() {
        Some(ax) => FORCE_AXES[ax + if n.n[ax] < 0.0 { 3 } else { 0 }].to_string(),
        None => format!("[{}, {}, {}]", n.n.x, n.n.y, n.n.z),
    }
}

/// `"-z"` → `n = (0, 0, −1)`; `"[x, y, z]"` → that vector normalised. Anything else, and a
/// zero or non-finite vector, is refused with the accepted forms.
pub fn force_axis(s: &str) -> Result<ForceAxis, naic_core::pipeline::ConfigError> {
    let t = s.trim();
    if let Some(i) = FORCE_AXES.iter().position(|a| *a == t) {
        return Ok(ForceAxis::base(i % 3, if i < 3 { 1.0 } else { -1.0 }));
    }
    let bad = || naic_core::pipeline::ConfigError::invalid("force_axis", format!("'{s}'"), "is not one of x, y, z, -x, -y, -z, nor a vector '[x, y, z]' (base frame)");
    let inner = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')).ok_or_else(bad)?;
    let v: Vec<f64> = inner.split(',').map(|x| x.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    if v.len() != 3 {
        return Err(bad());
    }
    ForceAxis::new(Vector3::new(v[0], v[1], v[2]))
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

/// `base` with the ROS parameters applied, validated by the core.
pub fn controller_params<const N: usize>(p: &ParamView, base: &ControllerParams<N>) -> Result<ControllerParams<N>, naic_ros::params::ParamError> {
    let mut c = *base;
    let axis = force_axis(p.str("force_axis"))?;
    let mut k_contact = arr6(p.f64s("k_d_contact"));
    // k_d = 0 along n (the control stage applies k_d_contact to the tangential error only).
    if let Some(ax) = axis.aligned() {
        k_contact[ax] = 0.0;
    }
    c.control.impedance =
        ImpedanceParams { m_d: arr6(p.f64s("m_d")), b_d: arr6(p.f64s("b_d")), k_free: arr6(p.f64s("k_d")), k_contact };
    c.control.force_axis = axis;
    c.control.force_law = ForceLawParams {
        mode: Mode::parse(p.str("mode"))?,
        sigma: p.f64("sigma"),
        gamma: p.f64("learning_rate"),
        lambda: p.f64("control_period"),
        sigma_margin: p.f64("sigma_margin"),
        ..base.control.force_law
    };
    let sch = &mut c.control.force_law.scheduled;
    sch.approach.max_speed = p.f64("approach_speed");
    sch.approach.expected_surface = p.bool("use_expected_surface").then(|| p.f64("expected_surface"));
    sch.approach.band = p.f64("approach_band");
    sch.approach.speed = p.f64("approach_band_speed");
    sch.force_observer = p.f64("force_observer");
    let der = &mut c.control.force_law.derived;
    der.delay_cycles = p.f64("loop_delay_cycles");
    der.contact.k_max = p.f64("stiffness_max");
    der.k_min = p.f64("stiffness_min");
    der.contact.mu_max = p.f64("feedthrough_max");
    der.contact.b_max = p.f64("surface_damping_max");
    der.x_resolution = p.f64("position_resolution");
    der.force_noise = p.f64("force_noise");
    der.contact.surface_speed = p.f64("surface_speed");
    der.impact_fraction = p.f64("impact_fraction");
    der.surface_uncertainty = p.f64("surface_uncertainty");
    c.control.contact = ContactDetect {
        enter_n: p.f64("contact_threshold"),
        scheduled_enter_n: p.f64("scheduled_contact_threshold"),
        exit_n: p.f64("contact_exit_force"),
        exit_cycles: p.i64("contact_exit_cycles") as u32,
    };
    // The core's force limit is the node's only retraction: it stops pushing, backs off
    // along -n, and (latched) stays off the surface until ~/reset_force_limit is called
    // (core::Inbox::reset_force_limit; a parameter change keeps it: param_change).
    c.control.force_limit.limit_n = p.f64("force_limit");
    // Eq 9's integral never asks for more than the force the robot may apply.
    c.control.force_law.integral_limit_n = p.f64("force_limit");
    c.control.force_limit.latch = true;
    c.sense.median_window = p.i64("median_window") as usize;
    c.sense.joint_timeout = p.f64("joint_timeout");
    c.sense.wrench_timeout = p.f64("wrench_timeout");
    c.tool = ToolParams { mass: p.f64("tool_mass"), com: vec3(p.f64s("tool_com")), tip: vec3(p.f64s("tool_tip")), ..base.tool };
    c.tare_samples = p.i64("tare_samples") as u32;
    c.tare_at_rest = p.bool("tare_at_rest");
    c.hold_damping = [p.f64("hold_damping"); N];
    c.nullspace.stiffness = p.f64("nullspace_stiffness");
    c.nullspace.damping = p.f64("nullspace_damping");
    c.nullspace.q = match p.f64s("nullspace_q") {
        [] => None,
        q if q.len() == N && q.iter().all(|x| x.is_finite()) => Some(std::array::from_fn(|i| q[i])),
        q => {
            return Err(naic_ros::params::ParamError::Rule(format!(
                "nullspace_q has {} values {q:?}; give {N} finite joint positions [rad] in the arm's joint order, or [] for the start pose",
                q.len()
            )))
        }
    };
    c.control.validate()?;
    c.sense.validate()?;
    Ok(c)
}

/// The node's settings besides the controller's parameters.
pub fn settings(p: &ParamView) -> Settings {
    Settings {
        desired_force: p.f64("desired_force"),
        force_limit: p.f64("force_limit"),
        approach_depth: p.f64("approach_depth"),
        time: TimeBase::from_use_sim_time(p.bool("use_sim_time")),
        actuation_timeout_ns: (p.f64("actuation_timeout") * 1e9).round() as i64,
        robot_compensates_gravity: p.bool("robot_compensates_gravity"),
    }
}

/// The reference stage's settings (scenario 'none'): limits and timeout from the
/// parameters, the force default from `desired_force`, accepted forces up to `force_limit`,
/// the force axis the controller's (a `force_axis` it refuses is refused by
/// [`controller_params`], which every accepted set passes; here it falls back to `-z`).
pub fn reference_params(p: &ParamView) -> ReferenceParams {
    let n = force_axis(p.str("force_axis")).unwrap_or(ForceAxis::base(2, -1.0));
    let mut r = ReferenceParams::new(p.str("base_frame"), n, p.f64("desired_force"));
    r.linear.max_speed = p.f64("max_speed");
    r.linear.max_accel = p.f64("max_accel");
    r.angular.max_speed = p.f64("max_angular_speed");
    r.angular.max_accel = p.f64("max_angular_accel");
    r.max_force_rate = p.f64("max_force_rate");
    r.timeout = p.f64("reference_timeout");
    r.force_max = p.f64("force_limit");
    r
}

/// Whole-set check for the parameter services: the core's own validation plus the
/// node's cross-parameter rules. Rejections carry the core's reason.
pub fn check<const N: usize>(base: ControllerParams<N>) -> SetCheck {
    Box::new(move |p: &ParamView| {
        controller_params(p, &base)?;
        let (ct, fl, fd) = (p.f64("contact_threshold"), p.f64("force_limit"), p.f64("desired_force"));
        if ct >= fl {
            return Err(format!("contact_threshold ({ct} N) must be below force_limit ({fl} N)").into());
        }
        let sct = p.f64("scheduled_contact_threshold");
        if sct >= fl {
            return Err(format!("scheduled_contact_threshold ({sct} N) must be below force_limit ({fl} N)").into());
        }
        if fd >= fl {
            return Err(format!("desired_force ({fd} N) must be below force_limit ({fl} N)").into());
        }
        reference_params(p).validate()?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_core::model::Model;
    use naic_ros::{ParamTable, ParameterValue as V};

    fn base() -> ControllerParams {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../urdf/jk5.urdf");
        let model = Model::from_urdf_file(root).unwrap();
        ControllerParams::paper_defaults(&model, Mode::Scheduled, naic_core::pipeline::control::force_law::DEFAULT_GAMMA)
    }

    fn table() -> (ParamTable, ControllerParams) {
        let b = base();
        (ParamTable::new(specs(&b), Some(check(b)), &[]).unwrap(), b)
    }

    #[test]
    fn defaults_reproduce_the_core_paper_defaults() {
        let (t, b) = table();
        let cp = t.with(|p| controller_params(p, &b)).unwrap();
        // The mode is the recommended law ('scheduled') on both sides (base() asks for it).
        // The two differences: the node latches the force-limit retraction (resumed by
        // ~/reset_force_limit; the core's default resumes by itself), and its tare waits
        // for rest (the core's default, the simulator's, tares over the first cycles).
        assert!(cp.control.force_limit.latch && !b.control.force_limit.latch);
        assert!(cp.tare_at_rest && !b.tare_at_rest);
        let mut expect = b;
        expect.control.force_limit.latch = true;
        expect.tare_at_rest = true;
        assert_eq!(cp, expect);
    }

    #[test]
    fn bad_values_are_rejected_with_reasons() {
        let (t, b) = table();
        let set = |n: &str, v: V| t.set_atomically(&[(n.to_string(), v)]);
        assert!(set("learning_rate", V::Double(-0.1)).unwrap_err().to_string().contains("outside its range"));
        assert!(set("mode", V::String("pid".into())).unwrap_err().to_string().contains("naic, aic, fixed"));
        assert!(set("desired_force", V::Double(60.0)).unwrap_err().to_string().contains("below force_limit"));
        // The core's own bound: b_d on the force axis must lie in the NAIC weight bounds.
        let e = set("b_d", V::DoubleArray(vec![500.0, 500.0, 0.5, 500.0, 500.0, 500.0])).unwrap_err().to_string();
        assert!(e.contains("b_d"), "{e}");
        set("force_axis", V::String("x".into())).unwrap();
        set("mode", V::String("aic".into())).unwrap();
        let cp = t.with(|p| controller_params(p, &b)).unwrap();
        assert_eq!(cp.control.force_axis, ForceAxis::base(0, 1.0));
        assert_eq!(cp.control.force_law.mode, Mode::Aic);
        assert_eq!(cp.control.impedance.k_contact[0], 0.0);
        // A vector: normalised; zero and malformed ones refused, naming the parameter.
        set("force_axis", V::String("[0, 3, -4]".into())).unwrap();
        let cp = t.with(|p| controller_params(p, &b)).unwrap();
        assert!((cp.control.force_axis.n - Vector3::new(0.0, 0.6, -0.8)).norm() < 1e-15, "{:?}", cp.control.force_axis);
        for bad in ["[0, 0, 0]", "[1, 2]", "down", "[a, 0, 1]"] {
            let e = set("force_axis", V::String(bad.into())).unwrap_err().to_string();
            assert!(e.contains("force_axis"), "{bad}: {e}");
        }
        assert_eq!(force_axis("-z").unwrap(), ForceAxis::base(2, -1.0));
        assert_eq!(force_axis_name(&ForceAxis::base(1, -1.0)), "-y");
    }

    #[test]
    fn the_scheduled_law_is_a_mode_choice() {
        let (t, b) = table();
        t.set_atomically(&[("mode".to_string(), V::String("scheduled".into()))]).unwrap();
        let cp = t.with(|p| controller_params(p, &b)).unwrap();
        assert_eq!(cp.control.force_law.mode, Mode::Scheduled);
        // Its own settings are the core's defaults (one place).
        assert_eq!(cp.control.force_law.scheduled, b.control.force_law.scheduled);
    }

    /// The scheduled law's contact threshold is its own parameter (the paper's laws keep
    /// `contact_threshold`), with the core's default, and bad values are refused.
    #[test]
    fn the_scheduled_contact_threshold_is_a_parameter_of_its_own() {
        let (t, b) = table();
        let set = |n: &str, v: V| t.set_atomically(&[(n.to_string(), v)]);
        let contact = |t: &ParamTable| t.with(|p| controller_params(p, &b)).unwrap().control.contact;
        assert_eq!(contact(&t).scheduled_enter_n, naic_core::pipeline::control::SCHEDULED_CONTACT_ENTER_N);
        assert_eq!(contact(&t).enter_n, 1.0);
        set("scheduled_contact_threshold", V::Double(0.8)).unwrap();
        assert_eq!((contact(&t).scheduled_enter_n, contact(&t).enter_n), (0.8, 1.0));
        // Below the exit force, at or above the force limit, out of range, NaN: refused.
        let e = set("scheduled_contact_threshold", V::Double(0.1)).unwrap_err().to_string();
        assert!(e.contains("scheduled_contact_threshold"), "{e}");
        let e = set("scheduled_contact_threshold", V::Double(60.0)).unwrap_err().to_string();
        assert!(e.contains("force_limit") && e.contains("60"), "{e}");
        for bad in [0.0, -1.0, 200.0, f64::NAN] {
            assert!(set("scheduled_contact_threshold", V::Double(bad)).is_err(), "{bad} accepted");
        }
        assert_eq!(contact(&t).scheduled_enter_n, 0.8, "a rejected set changed it");
    }

    #[test]
    fn the_approach_speed_reaches_the_scheduled_law_and_is_bounded() {
        let (t, b) = table();
        let set = |n: &str, v: V| t.set_atomically(&[(n.to_string(), v)]);
        set("approach_speed", V::Double(0.02)).unwrap();
        let cp = t.with(|p| controller_params(p, &b)).unwrap();
        assert_eq!(cp.control.force_law.scheduled.approach.max_speed, 0.02);
        // Everything else of the scheduled law stays the core's.
        let mut expect = b.control.force_law.scheduled;
        expect.approach.max_speed = 0.02;
        assert_eq!(cp.control.force_law.scheduled, expect);
        for bad in [0.0, -0.01, 0.6, f64::NAN] {
            assert!(set("approach_speed", V::Double(bad)).is_err(), "{bad} accepted");
        }
        // The core rejects what the range would let through if the range were wider.
        let mut c = b;
        c.control.force_law.mode = Mode::Scheduled;
        c.control.force_law.scheduled.approach.max_speed = 0.0;
        assert!(c.control.validate().unwrap_err().to_string().contains("max_speed"));
    }

    #[test]
    fn the_expected_surface_and_the_force_observer_reach_the_scheduled_law() {
        let (t, b) = table();
        let set = |kv: &[(&str, V)]| t.set_atomically(&kv.iter().map(|(n, v)| (n.to_string(), v.clone())).collect::<Vec<_>>());
        let sch = |t: &ParamTable| t.with(|p| controller_params(p, &b)).unwrap().control.force_law.scheduled;
        // Off by default: the core's default (no expected surface), whatever the coordinate.
        assert_eq!(b.control.force_law.scheduled.approach.expected_surface, None);
        set(&[("expected_surface", V::Double(0.08))]).unwrap();
        assert_eq!(sch(&t).approach.expected_surface, None);
        set(&[
            ("use_expected_surface", V::Boolean(true)),
            ("approach_band", V::Double(0.02)),
            ("approach_band_speed", V::Double(0.003)),
            ("force_observer", V::Double(0.0)),
        ])
        .unwrap();
        let s = sch(&t);
        assert_eq!(s.approach.expected_surface, Some(0.08));
        assert_eq!((s.approach.band, s.approach.speed, s.force_observer), (0.02, 0.003, 0.0));
        // Everything else stays the core's.
        let mut expect = b.control.force_law.scheduled;
        expect.approach.expected_surface = Some(0.08);
        expect.approach.band = 0.02;
        expect.approach.speed = 0.003;
        expect.force_observer = 0.0;
        assert_eq!(s, expect);
        for (name, bad) in [("expected_surface", 3.0), ("approach_band", -0.01), ("approach_band_speed", 0.0), ("force_observer", -1.0), ("force_observer", f64::NAN)] {
            assert!(set(&[(name, V::Double(bad))]).is_err(), "{name} = {bad} accepted");
        }
        assert_eq!(sch(&t), expect, "a rejected set changed the law");
        set(&[("use_expected_surface", V::Boolean(false))]).unwrap();
        assert_eq!(sch(&t).approach.expected_surface, None);
    }
}
