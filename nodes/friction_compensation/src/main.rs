//! `friction_compensation`: the last two pipeline stages as a ROS 2 node.
//!
//! Subscribes `/naic/effort` (the controller's torque, std_msgs/Float64MultiArray) and
//! `/joint_states`; on every command adds the friction feedforward
//! `τ_f(q̇)` of `friction_file` (`naic_core::pipeline::feedforward`, eq 5 per direction as
//! in the paper's Table 1, evaluated at the measured joint velocity) and applies the
//! actuation guard (`naic_core::pipeline::actuate`: torque-rate limit, effort limits of the
//! URDF, never NaN); publishes `/joint_effort_cmd` for the driver.
//!
//! On start, and after a gap in `/naic/effort` longer than `takeover_gap` (a restarted
//! controller; the driver held the arm meanwhile), the rate limit starts from the measured
//! joint torque (`/joint_states` effort), so a restarted node takes over without a torque jump. Without fresh joint data the
//! feedforward is left out (it needs q̇); without commands nothing is published and the
//! driver holds the arm after its own timeout.
//!
//! With `use_sim_time` (the lockstep loop) everything is judged by stamps, not by the wall
//! clock: the feedforward uses the `/joint_states` sample the command was computed from
//! (waiting up to `joint_state_timeout` for it), a gap is a gap in simulated time, and a
//! command for a stamp already answered gets the same output again.

use std::time::Duration;

use naic_core::{
    friction::{FrictionModel, FrictionParams, Smoothing, DEFAULT_V_S},
    model::Model,
    pipeline::{
        actuate, feedforward,
        sense::{self, RawMeasurements, SenseParams, SenseState},
    },
};
use naic_ros::{
    msgs::{self, Float64MultiArray, JointState},
    node::{QOS_PUB, QOS_SUB},
    params::{effort_limit_within, EFFORT_CAP},
    time::wall_ns,
    wait::{take_until, Waiter},
    ParamSpec, ParamView, RosArgs, RosError, RosNode,
};

/// Default `torque_rate_limit` per joint [N m per cycle] (as in params/friction_compensation.yaml).
const DEFAULT_RATE_LIMIT: [f64; 6] = [10.0; 6];

/// The actuation guard's limits from the parameters (both are per joint, six values each;
/// the parameter table has checked the length, finiteness and ranges).
fn actuate_params(p: &ParamView) -> actuate::ActuateParams {
    let six = |v: &[f64]| -> [f64; 6] { std::array::from_fn(|i| v[i]) };
    actuate::ActuateParams { effort_limit: six(p.f64s("effort_limit")), max_delta: six(p.f64s("torque_rate_limit")) }
}

fn specs(urdf_effort: &[f64; 6]) -> Vec<ParamSpec> {
    vec![
        ParamSpec::doubles("effort_limit", urdf_effort, 0.0, EFFORT_CAP, "Per-joint torque saturation [N m], at most the URDF effort limit (default: the URDF's)"),
        ParamSpec::string("urdf", "urdf/jk5.urdf", "Robot model: effort limits of the actuation guard").read_only(),
        ParamSpec::string("friction_file", "params/friction_jk5.yaml", "Friction model YAML (naic_core::friction format; Table 1 of the paper by default)"),
        ParamSpec::boolean("enabled", true, "Add the friction feedforward (false: pass the controller torque through the actuation guard only)"),
        ParamSpec::double("smoothing_velocity", DEFAULT_V_S, 0.0, 1.0, "v_s [rad/s] of sgn(q̇) → tanh(q̇/v_s) near rest (0: the printed discontinuous law; the file's own value when it sets one)"),
        ParamSpec::doubles("torque_rate_limit", &DEFAULT_RATE_LIMIT, 0.001, 1000.0, "Largest torque change per command, per joint joint1..joint6 [N m per cycle]; one number sets all six (1 N m on every joint destabilises the paper's impedance gains on the simulated JK5; 10 does not)").scalar_fills(),
        ParamSpec::double("joint_state_timeout", 0.02, 0.001, 1.0, "Joint velocity older than this [s] is not used: no feedforward"),
        ParamSpec::int("median_window", 5, 1, 9, "Median filter window of the joint velocity (the controller's sense stage, same filter)"),
        ParamSpec::double("takeover_gap", 0.02, 0.001, 1.0, "After a gap in /naic/effort longer than this [s] (the driver's command_timeout: it holds the arm itself by then), the rate limit restarts from the measured joint torque"),
    ]
}

/// Load the friction model the parameters name.
fn load_model(p: &ParamView) -> Result<FrictionModel, String> {
    let path = p.str("friction_file");
    const FIX: &str = "set -p friction_file:=PATH, e.g. params/friction_jk5.yaml";
    let params = FrictionParams::from_yaml_file(path)
        .map_err(|e| format!("friction_file '{path}': {e} ({FIX})"))?;
    let model = params.to_model().map_err(|e| format!("friction_file '{path}': {e} ({FIX})"))?;
    if model.n_joints() != 6 {
        return Err(format!("friction_file '{path}' has {} joints; the JK5 needs 6 ({FIX})", model.n_joints()));
    }
    let v_s = p.f64("smoothing_velocity");
    match (model.smoothing(), v_s > 0.0) {
        (Smoothing::Exact, true) => model.with_smoothing(Smoothing::Tanh { v_s }).map_err(|e| e.to_string()),
        _ => Ok(model),
    }
}

fn main() {
    naic_ros::run_main("friction_compensation", run)
}

/// What the node knows from `/joint_states`: the sensed joint velocity the feedforward uses
/// and the torque the driver applies now.
struct JointFeed {
    sense_s: SenseState,
    dq: [f64; 6],
    /// Wall-clock arrival and stamp of `dq` [ns] (`i64::MIN`/`None`: none usable).
    dq_rx_ns: i64,
    dq_stamp_ns: Option<i64>,
    /// Torque the driver applies now (/joint_states effort).
    effort_meas: Option<[f64; 6]>,
}

impl JointFeed {
    fn absorb(&mut self, sense_p: &SenseParams, js: &JointState) {
        let stamp = js.header.stamp.to_nanos();
        if self.dq_stamp_ns == Some(stamp) {
            // The same state published again (lockstep, paused): the median filter takes
            // each state once, as the controller's does.
            self.dq_rx_ns = wall_ns();
            return;
        }
        let six = |v: &[f64]| -> Option<[f64; 6]> {
            (v.len() >= 6 && v[..6].iter().all(|x| x.is_finite())).then(|| std::array::from_fn(|i| v[i]))
        };
        if let (Some(q), Some(v)) = (six(&js.position), six(&js.velocity)) {
            let raw = RawMeasurements { t: 0.0, q, dq: v, joints_stamp: 0.0, wrench: [0.0; 6], wrench_stamp: 0.0 };
            let (s, r) = sense::step(sense_p, &self.sense_s, &raw);
            self.sense_s = s;
            match r {
                Ok(sensed) => {
                    self.dq = sensed.dq;
                    self.dq_rx_ns = wall_ns();
                    self.dq_stamp_ns = Some(stamp);
                }
                Err(_) => (self.dq_rx_ns, self.dq_stamp_ns) = (i64::MIN, None), // implausible joint data: no feedforward
            }
        }
        if let Some(e) = six(&js.effort) {
            self.effort_meas = Some(e);
        }
    }
}

fn run() -> Result<(), RosError> {
    naic_ros::install_signal_handlers();
    let args = RosArgs::parse(std::env::args().skip(1))?;
    let urdf = args.peek_string("friction_compensation", "urdf", "urdf/jk5.urdf")?;
    let robot = Model::from_urdf_file(&urdf)
        .map_err(|e| RosError::Param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?;
    let effort_limit: [f64; 6] = {
        let l = robot.effort_limits();
        if l.len() != 6 {
            return Err(RosError::Param(format!("'{urdf}' has {} joints; the JK5 needs 6", l.len())));
        }
        std::array::from_fn(|i| if l[i].is_finite() && l[i] > 0.0 { l[i].min(EFFORT_CAP) } else { EFFORT_CAP })
    };
    // The velocity the feedforward uses: the core's sense stage (validity + median filter),
    // as in the in-process pipeline.
    // Joint limits as the controller's (the wrench is not used here; staleness is judged
    // by joint_state_timeout below).
    let mut sense_p = SenseParams {
        wrench_max: [f64::INFINITY; 6],
        joint_timeout: 1.0,
        wrench_timeout: 1.0,
        ..SenseParams::for_model(&robot)
    };
    let mut feed = JointFeed { sense_s: SenseState::default(), dq: [0.0; 6], dq_rx_ns: i64::MIN, dq_stamp_ns: None, effort_meas: None };
    // A friction file that does not load, or a saturation above the URDF's, is rejected like any bad value.
    let check: naic_ros::params::SetCheck = Box::new(move |p: &ParamView| {
        effort_limit_within(p, &effort_limit)?;
        load_model(p).map(|_| ())
    });
    let mut node = RosNode::new(args, "friction_compensation", specs(&effort_limit), Some(check))?;
    let mut cmd_sub = node.subscription::<Float64MultiArray>("naic/effort", msgs::FLOAT64_MULTI_ARRAY, QOS_SUB)?;
    let js_sub = node.subscription::<JointState>("joint_states", msgs::JOINT_STATE, QOS_SUB)?;
    let cmd_pub = node.publisher::<Float64MultiArray>("joint_effort_cmd", msgs::FLOAT64_MULTI_ARRAY, QOS_PUB)?;
    let mut waiter = Waiter::new().map_err(|e| RosError::Node(format!("poll: {e}")))?;
    waiter.add(&mut cmd_sub, 0).map_err(|e| RosError::Node(format!("poll: {e}")))?;

    let mut gen = 0;
    let mut model = node.params.with(load_model).map_err(RosError::Param)?;
    let mut enabled = true;
    let mut js_timeout_ns = 20_000_000i64;
    let mut act_p = node.params.with(actuate_params);
    let mut act_s = actuate::ActuateState::default();
    let mut tau_in = [0.0; 6];
    let mut last_warn = 0i64;
    let mut count = 0u64;
    // When the last command went out (wall clock, or its source stamp with sim time).
    let mut last_pub_ns = i64::MIN;
    let mut gap_ns = 20_000_000i64;
    let mut use_sim_time = false;
    // The last output and the source stamp it answers (a repeated stamp gets the same output).
    let mut last_out: Option<(i64, [f64; 6])> = None;

    while !naic_ros::shutdown_requested() {
        // Wait first, then take the parameters: a value accepted while waiting applies to
        // the data that woke us ("takes effect at the next cycle").
        waiter.wait(Some(Duration::from_millis(100)));
        if node.params.generation() != gen {
            gen = node.params.generation();
            node.params.with(|p| {
                enabled = p.bool("enabled");
                use_sim_time = p.bool("use_sim_time");
                js_timeout_ns = (p.f64("joint_state_timeout") * 1e9) as i64;
                act_p = actuate_params(p);
                sense_p.median_window = p.i64("median_window") as usize;
                gap_ns = (p.f64("takeover_gap") * 1e9) as i64;
                match load_model(p) {
                    Ok(m) => model = m,
                    Err(e) => log::error!("{e}"),
                }
            });
        }
        while let Ok(Some((js, _))) = js_sub.take() {
            feed.absorb(&sense_p, &js);
        }
        let mut newest = None;
        while let Ok(Some((m, _))) = cmd_sub.take() {
            newest = Some(m);
        }
        let Some(m) = newest else { continue };
        if let Err(e) = msgs::effort_values(&m, &mut tau_in) {
            let now = wall_ns();
            if now - last_warn > 1_000_000_000 {
                last_warn = now;
                log::warn!("ignoring /naic/effort: {e}");
            }
            continue;
        }
        let src = msgs::effort_source_stamp(&m);
        let sim = use_sim_time && src.is_some();
        if let Some((st, tau)) = last_out.filter(|(st, _)| Some(*st) == src) {
            let _ = cmd_pub.publish(msgs::effort_msg(&tau, Some(st)));
            continue;
        }
        let fresh = if sim {
            // The joint state this command was computed from (it was published first).
            if feed.dq_stamp_ns.is_none_or(|s| Some(s) < src) {
                take_until(&js_sub, wall_ns() + js_timeout_ns, |js| {
                    feed.absorb(&sense_p, &js);
                    feed.dq_stamp_ns.is_some_and(|s| Some(s) >= src)
                });
            }
            feed.dq_stamp_ns == src
        } else {
            wall_ns().saturating_sub(feed.dq_rx_ns) <= js_timeout_ns
        };
        let tau = if enabled && fresh { feedforward::step(&model, &feed.dq, &tau_in) } else { tau_in };
        // Smooth take-over (first command, or after a gap in which the driver held the arm
        // itself): the rate limit starts from the torque the arm has now.
        let now_ns = if sim { src.unwrap_or_default() } else { wall_ns() };
        if !act_s.started || now_ns.saturating_sub(last_pub_ns) > gap_ns {
            match feed.effort_meas {
                Some(e) => act_s = actuate::ActuateState { tau_prev: e, started: true },
                // Not yet known what the arm gets: publish nothing (the driver holds).
                None => continue,
            }
        }
        let (s, r) = actuate::step(&act_p, &act_s, &tau);
        act_s = s;
        if r.tau.iter().all(|t| t.is_finite()) {
            let _ = cmd_pub.publish(msgs::effort_msg(&r.tau, src));
            last_pub_ns = now_ns;
            last_out = src.map(|st| (st, r.tau));
            count += 1;
        }
    }
    log::info!("stopped after {count} commands");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_ros::{ParamTable, ParameterValue as V};

    const URDF_EFFORT: [f64; 6] = [100.0; 6];

    fn table(overrides: &[(&str, V)]) -> Result<ParamTable, String> {
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
            let e = table(&[("torque_rate_limit", v.clone())]).err().unwrap();
            assert!(e.contains("torque_rate_limit") && e.contains(needle), "{v:?}: {e}");
            // ... and at run time: rejected, nothing changes.
            let e = ok.set_atomically(&[("torque_rate_limit".into(), v.clone())]).unwrap_err();
            assert!(e.contains(needle), "{v:?}: {e}");
            assert_eq!(ok.with(actuate_params).max_delta, DEFAULT_RATE_LIMIT);
        }
    }

    #[test]
    fn the_params_file_sets_six_rate_limits_and_matches_the_defaults() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/friction_compensation.yaml");
        let o = naic_ros::params_file::load_for_node(&path, "/friction_compensation").unwrap();
        let from_file = o.iter().rev().find(|(n, _)| n == "torque_rate_limit").map(|(_, v)| v.clone());
        assert_eq!(from_file, Some(V::DoubleArray(DEFAULT_RATE_LIMIT.to_vec())), "params file and DEFAULT_RATE_LIMIT differ");
        let t = ParamTable::new(specs(&URDF_EFFORT), None, &o).unwrap();
        assert_eq!(t.with(actuate_params).max_delta, DEFAULT_RATE_LIMIT);
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
