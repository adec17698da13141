//! The node's ROS parameters and their mapping onto the core's [`crate::core::Params`].

use naic_core::{
    friction::{FrictionModel, FrictionParams, Smoothing, DEFAULT_V_S},
    pipeline::{actuate, sense::SenseParams},
    JointVec, N_JOINTS,
};
use naic_ros::{params::{ParamError, EFFORT_CAP}, timebase::TimeBase, ParamSpec, ParamView};

use crate::core::Params;

/// The core's parameters from the ROS parameters; `sense` is the velocity filter for the
/// robot model (its median window comes from the parameters). Fails when the friction
/// file does not load.
pub fn core_params<const N: usize>(p: &ParamView, sense: &SenseParams<N>, joints: &[String; N]) -> Result<Params<N>, ParamError> {
    let ns = |name: &str| (p.f64(name) * 1e9) as i64;
    Ok(Params {
        friction: load_model::<N>(p)?,
        enabled: p.bool("enabled"),
        time: TimeBase::from_use_sim_time(p.bool("use_sim_time")),
        joint_state_timeout_ns: ns("joint_state_timeout"),
        takeover_gap_ns: ns("takeover_gap"),
        takeover_blend_ns: ns("takeover_blend"),
        actuate: actuate_params(p),
        sense: SenseParams { median_window: p.i64("median_window") as usize, ..*sense },
        joints: joints.clone(),
    })
}

/// Default `torque_rate_limit` of every joint [N m per cycle] (as in params/friction_compensation.yaml).
pub const DEFAULT_RATE: f64 = 10.0;
/// [`DEFAULT_RATE`] on each of the JK5's joints.
pub const DEFAULT_RATE_LIMIT: JointVec = [DEFAULT_RATE; N_JOINTS];

/// The actuation guard's limits from the parameters (both are per joint, N values each;
/// the parameter table has checked the length, finiteness and ranges).
pub fn actuate_params<const N: usize>(p: &ParamView) -> actuate::ActuateParams<N> {
    let per_joint = |v: &[f64]| -> JointVec<N> { std::array::from_fn(|i| v[i]) };
    actuate::ActuateParams { effort_limit: per_joint(p.f64s("effort_limit")), max_delta: per_joint(p.f64s("torque_rate_limit")) }
}

pub fn specs<const N: usize>(urdf_effort: &JointVec<N>) -> Vec<ParamSpec> {
    vec![
        ParamSpec::doubles("effort_limit", urdf_effort, 0.0, EFFORT_CAP, "Per-joint torque saturation [N m], at most the URDF effort limit (default: the URDF's)"),
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model: effort limits of the actuation guard").read_only(),
        ParamSpec::string("friction_file", "params/friction_jk5.yaml", "Friction model YAML (naic_core::friction format; Table 1 of the paper by default; '': no friction model, the command passes through the actuation guard; with -p robot:=FILE the robot file's, none by default)"),
        ParamSpec::boolean("enabled", true, "Add the friction feedforward (false: pass the controller torque through the actuation guard only)"),
        ParamSpec::double("smoothing_velocity", DEFAULT_V_S, 0.0, 1.0, "v_s [rad/s] of sgn(q̇) → tanh(q̇/v_s) near rest (0: the printed discontinuous law; the file's own value when it sets one)"),
        ParamSpec::doubles("torque_rate_limit", &[DEFAULT_RATE; N], 0.001, 1000.0, "Largest torque change per command, per joint in the arm's joint order [N m per cycle]; one number sets every joint (1 N m on every joint destabilises the paper's impedance gains on the simulated JK5; 10 does not)").scalar_fills(),
        ParamSpec::double("joint_state_timeout", 0.02, 0.001, 1.0, "Joint velocity older than this [s] is not used: no feedforward"),
        ParamSpec::int("median_window", 5, 1, 9, "Median filter window of the joint velocity (the controller's sense stage, same filter)"),
        ParamSpec::double("takeover_gap", 0.02, 0.001, 1.0, "After a gap in /naic/effort longer than this [s] (the driver's command_timeout: it holds the arm itself by then), the rate limit restarts from the measured joint torque"),
        naic_ros::source::spec("command_source", "naic_controller", "/naic/effort"),
        ParamSpec::double("takeover_blend", 0.0, 0.0, 1.0, "At a take-over (start, or after a takeover_gap) the command moves from the measured joint torque to the controller's over this time [s] (smoothstep), then the rate limit applies; 0 (default): the rate limit alone. Off by default: CPU stalls of 5-30 ms make take-overs, and blends after them spun the wrist (docs/nodes.md)"),
    ]
}

/// Load the friction model the parameters name (`friction_file: ''`: none).
pub fn load_model<const N: usize>(p: &ParamView) -> Result<Option<FrictionModel>, ParamError> {
    let path = p.str("friction_file");
    if path.is_empty() {
        return Ok(None);
    }
    const FIX: &str = "set -p friction_file:=PATH, e.g. params/friction_jk5.yaml";
    let bad = |problem: String| ParamError::file("friction_file", path, problem, FIX);
    let model = FrictionParams::from_yaml_file(path)
        .and_then(|f| f.to_model())
        .map_err(|e| bad(format!("friction_file '{path}': {e}")))?;
    if model.n_joints() != N {
        return Err(bad(format!("friction_file '{path}' has {} joints; the arm has {N}", model.n_joints())));
    }
    let v_s = p.f64("smoothing_velocity");
    match (model.smoothing(), v_s > 0.0) {
        (Smoothing::Exact, true) => model.with_smoothing(Smoothing::Tanh { v_s }).map(Some).map_err(|e| bad(format!("friction_file '{path}': {e}"))),
        _ => Ok(Some(model)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_ros::{ParamTable, ParameterValue as V};

    const URDF_EFFORT: JointVec = [100.0; 6];

    fn table(overrides: &[(&str, V)]) -> Result<ParamTable, naic_ros::params::ParamError> {
        let o: Vec<(String, V)> = overrides.iter().map(|(n, v)| (n.to_string(), v.clone())).collect();
        ParamTable::new(specs(&URDF_EFFORT), None, &o)
    }

    #[test]
    fn torque_rate_limit_is_applied_per_joint() {
        let lim = [1.0, 2.0, 3.0, 0.5, 0.25, 0.125];
        let t = table(&[("torque_rate_limit", V::DoubleArray(lim.to_vec()))]).unwrap();
        let p = t.with(actuate_params);
        assert_eq!(p.max_delta, lim);
        assert_eq!(p.effort_limit, URDF_EFFORT);
        // The guard moves each joint by its own limit towards a far target.
        let s = actuate::ActuateState { tau_prev: [0.0; 6], started: true };
        let (s, r) = actuate::step(&p, &s, &[50.0; 6]);
        assert_eq!(r.tau, lim);
        let (_, r) = actuate::step(&p, &s, &[-50.0; 6]);
        assert_eq!(r.tau, [0.0; 6]);
        // One number sets every joint (the form before the limit was per joint).
        let t1 = table(&[("torque_rate_limit", V::Double(2.5))]).unwrap();
        assert_eq!(t1.with(actuate_params).max_delta, [2.5; 6]);
        // Integers (a YAML list without decimal points) are accepted as doubles.
        let t = table(&[("torque_rate_limit", V::IntegerArray(vec![5, 5, 5, 2, 2, 1]))]).unwrap();
        assert_eq!(t.with(actuate_params).max_delta, [5.0, 5.0, 5.0, 2.0, 2.0, 1.0]);
        // A live change (parameter service) is validated the same way and then applied.
        t.set_atomically(&[("torque_rate_limit".into(), V::DoubleArray(vec![7.0; 6]))]).unwrap();
        assert_eq!(t.with(actuate_params).max_delta, [7.0; 6]);
    }

    #[test]
    fn bad_rate_limits_are_rejected_with_a_reason() {
        let nan = {
            let mut v = vec![10.0; 6];
            v[3] = f64::NAN;
            v
        };
        let cases = [
            (V::DoubleArray(vec![10.0; 5]), "exactly 6 elements, got 5"),
            (V::DoubleArray(vec![10.0; 7]), "exactly 6 elements, got 7"),
            (V::DoubleArray(nan), "must be finite"),
            (V::DoubleArray(vec![10.0, 10.0, 0.0, 10.0, 10.0, 10.0]), "outside its range [0.001, 1000]"),
            (V::DoubleArray(vec![10.0, 10.0, 10.0, 10.0, 10.0, -1.0]), "outside its range"),
            (V::DoubleArray(vec![1e4; 6]), "outside its range"),
            (V::String("fast".into()), "type double array, got string"),
        ];
        let ok = table(&[]).unwrap();
        for (v, needle) in cases {
            // At start-up (files, -p) ...
            let e = table(&[("torque_rate_limit", v.clone())]).err().unwrap().to_string();
            assert!(e.contains("torque_rate_limit") && e.contains(needle), "{v:?}: {e}");
            // ... and at run time: rejected, nothing changes.
            let e = ok.set_atomically(&[("torque_rate_limit".into(), v.clone())]).unwrap_err().to_string();
            assert!(e.contains(needle), "{v:?}: {e}");
            assert_eq!(ok.with(actuate_params).max_delta, DEFAULT_RATE_LIMIT);
        }
    }

    #[test]
    fn the_params_file_sets_one_rate_limit_for_every_joint_of_any_arm() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/friction_compensation.yaml");
        let o = naic_ros::params_file::load_for_node(&path, "/friction_compensation").unwrap();
        let from_file = o.iter().rev().find(|(n, _)| n == "torque_rate_limit").map(|(_, v)| v.clone());
        assert_eq!(from_file, Some(V::Double(DEFAULT_RATE)), "params file and DEFAULT_RATE differ");
        let t = ParamTable::new(specs(&URDF_EFFORT), None, &o).unwrap();
        assert_eq!(t.with(actuate_params), actuate::ActuateParams { effort_limit: URDF_EFFORT, max_delta: DEFAULT_RATE_LIMIT });
        // The same file on a 7-joint arm (the Panda): seven limits.
        let t = ParamTable::new(specs(&[87.0; 7]), None, &o).unwrap();
        assert_eq!(t.with(actuate_params::<7>).max_delta, [DEFAULT_RATE; 7]);
        let e = ParamTable::new(specs(&[87.0; 7]), None, &[("torque_rate_limit".into(), V::DoubleArray(vec![1.0; 6]))]).err().unwrap().to_string();
        assert!(e.contains("exactly 7 elements, got 6"), "{e}");
    }

    #[test]
    fn the_rate_limit_is_described_per_joint() {
        let s = specs(&URDF_EFFORT);
        let d = s.iter().find(|s| s.name == "torque_rate_limit").unwrap().descriptor();
        assert!(d.description.contains("per joint") && d.description.contains("N m per cycle"), "{}", d.description);
        assert!(d.additional_constraints.contains("exactly 6 elements"), "{}", d.additional_constraints);
        assert!(d.additional_constraints.contains("[0.001, 1000]"), "{}", d.additional_constraints);
    }
}
