//! The driver's ROS parameters, the URDF checks made before the DDS participant exists,
//! and the chain-latency report.

use naic_core::JointVec;
use naic_ros::{
    params::{effort_limit_within, ParamError, SetCheck, EFFORT_CAP},
    ParamSpec, ParamView, ParameterValue,
};

use crate::{core, latency, runner::SensorFault, sim_plant::PLANT_NAME};

/// The parameters of a driver of an arm with the joints `joints` (`/joint_states` names),
/// whose URDF allows `urdf_effort`.
pub fn specs<const N: usize>(urdf_effort: &JointVec<N>, joints: &[String; N]) -> Vec<ParamSpec> {
    vec![
        ParamSpec::doubles(
            "effort_limit",
            urdf_effort,
            0.0,
            EFFORT_CAP,
            "Per-joint saturation of every torque the driver applies (commands and its own hold) [N m]; at most the URDF effort limit (default: the URDF's)",
        ),
        ParamSpec::double("rate", 1000.0, 1.0, 5000.0, "Simulation and publishing rate [Hz]; the simulator's control period is 1/rate").read_only(),
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model of the simulator").read_only(),
        ParamSpec::string("friction_file", "params/friction_jk5.yaml", "Joint friction acting in the simulator, on either plant (naic_core::friction YAML; with -p robot:=FILE the robot file's, '' for none)").read_only(),
        ParamSpec::double("friction_smoothing", naic_core::friction::DEFAULT_V_S, 1.0e-5, 1.0, "v_s [rad/s] of the simulator's tanh-smoothed friction").read_only(),
        ParamSpec::double("tool_mass_error", 1.0, 0.1, 10.0, "The simulated sensor's tool is this many times as heavy as the URDF's ft_sensor link says (as naic sim --tool-mass-error; to test naic tool identify)").read_only(),
        ParamSpec::doubles("tool_com_offset", &[0.0, 0.0, 0.0], -0.2, 0.2, "The simulated sensor's tool centre of mass is this far from the URDF's [m], sensor frame, 3 numbers (as naic sim --tool-com-offset)").read_only(),
        ParamSpec::boolean(
            "lockstep",
            false,
            "Advance one simulator step per /joint_effort_cmd received (deterministic, faster than real time); stamps become simulated time",
        ),
        ParamSpec::double(
            "real_time_factor",
            0.0,
            0.0,
            1000.0,
            "Lockstep only: simulated time runs at most this many times wall time (1: real time, as Gazebo's real_time_factor), so slower participants (an rclpy script, a recorder) keep up; 0: as fast as the chain allows",
        ),
        ParamSpec::boolean(
            "paused",
            false,
            "Simulation paused: no steps, the current state is published again every command_timeout (set false to run)",
        ),
        ParamSpec::double(
            "command_timeout",
            0.02,
            0.001,
            1.0,
            "Hold the arm (gravity compensation + damping) when no command arrived for this long [s]",
        ),
        ParamSpec::double("hold_damping", 5.0, 0.0, 200.0, "Joint damping of the driver's own hold [N m s/rad]"),
        ParamSpec::choice(
            "scenario",
            "flat",
            &["flat", "stiffness-step", "slope", "foam", "two-material"],
            "Paper scenario of naic_sim: environment and start pose",
        )
        .read_only(),
        joint_order_spec(joints),
        ParamSpec::choice(
            "sensor_fault",
            "none",
            SensorFault::NAMES,
            "Test hook, settable while running: corrupt the published measurements as a failing sensor would (nan_wrench, absurd_wrench: 5 kN on z, stale_wrench: /wrench frozen at its last value and stamp, nan_joint); none: the true measurements",
        ),
        ParamSpec::string("plant", PLANT_NAME, "Simulator behind the driver: naic_sim (naic's own plant) or mujoco (MuJoCo on mjcf; a build with --features mujoco)").read_only(),
        ParamSpec::string("mjcf", naic_sim::plants::DEFAULT_MJCF, "MuJoCo model for plant:=mujoco (default: the paper authors' JK5)").read_only(),
        ParamSpec::double("latency_warmup", 2.0, 0.0, 3600.0, "Chain-latency statistics ignore the first seconds after start").read_only(),
        naic_ros::source::spec("command_source", "friction_compensation", "/joint_effort_cmd"),
        ParamSpec::string("latency_report", "", "If set, write chain-latency statistics (JSON) to this file at exit").read_only(),
    ]
}

/// `joint_order`: the order of the joints in the published `/joint_states`, as
/// ros2_control's `joint_state_broadcaster` may publish them (default: the arm's order).
fn joint_order_spec<const N: usize>(joints: &[String; N]) -> ParamSpec {
    let mut s = ParamSpec::new(
        "joint_order",
        ParameterValue::StringArray(joints.to_vec()),
        "Order of the joints in the published /joint_states (each of the arm's joints once; default: the arm's order, joint1..joint6 for the JK5), e.g. to play a joint_state_broadcaster that does not follow the URDF; commands stay in the arm's joint order",
    )
    .read_only();
    s.len = Some(N);
    s
}

/// The published index → joint index map of `joint_order` (published slot `i` carries
/// joint `order[i]` of `joints`), or why the names are not each of `joints` once.
pub fn joint_order<const N: usize>(p: &ParamView, joints: &[String; N]) -> Result<[usize; N], ParamError> {
    let names = match p.get("joint_order") {
        Some(ParameterValue::StringArray(a)) => a.as_slice(),
        _ => &[],
    };
    let mut order = [0; N];
    for i in 0..N {
        let name = names.get(i).map_or("", String::as_str);
        order[i] = joints.iter().position(|j| *j == name).ok_or_else(|| {
            ParamError::Rule(format!("joint_order[{i}] = '{name}' is not a joint of the arm; name each of {} once", joints.join(", ")))
        })?;
        if let Some(k) = order[..i].iter().position(|&o| o == order[i]) {
            return Err(ParamError::Rule(format!("joint_order names '{name}' twice (elements {k} and {i}); name each of {} once", joints.join(", "))));
        }
    }
    Ok(order)
}

/// Live `effort_limit` changes may tighten the URDF limits, never loosen them; the
/// `joint_order` names each joint once.
pub fn check<const N: usize>(urdf_effort: JointVec<N>, joints: [String; N]) -> SetCheck {
    Box::new(move |p: &ParamView| {
        joint_order(p, &joints)?;
        effort_limit_within(p, &urdf_effort)
    })
}

/// The core's parameters from the ROS parameters.
pub fn core_params<const N: usize>(p: &ParamView) -> core::Params<N> {
    core::Params {
        lockstep: p.bool("lockstep"),
        rate: p.f64("rate"),
        real_time_factor: p.f64("real_time_factor"),
        command_timeout_ns: (p.f64("command_timeout") * 1e9) as i64,
        hold_damping: p.f64("hold_damping"),
        effort_limit: std::array::from_fn(|i| p.f64s("effort_limit")[i]),
    }
}

pub fn latency_report(lat: &latency::Histogram, missed: u64, cycles: u64, wall_ns: i64, rejected: u64) -> serde_json::Value {
    let q = |f: f64| -> f64 { lat.quantile_ns(f).map_or(f64::NAN, |ns| ns / 1e3) };
    let minutes = wall_ns as f64 / 60e9;
    serde_json::json!({
        "samples": lat.len(),
        "cycles": cycles,
        "median_us": q(0.5),
        "p99_us": q(0.99),
        "max_us": lat.max_ns().map_or(f64::NAN, |ns| ns as f64 / 1e3),
        "missed_cycles": missed,
        "missed_per_min": if minutes > 0.0 { missed as f64 / minutes } else { 0.0 },
        "rejected_commands": rejected,
        "duration_s": wall_ns as f64 / 1e9,
    })
}

