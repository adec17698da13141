//! `naic tool identify`: the tool's mass and centre of mass and the F/T sensor's bias from
//! static poses in a bag (`naic record`'s MCAP: `/joint_states` + `/wrench`) or live over
//! DDS from the running chain (no `--bag`: until `--poses` static poses were held), by
//! linear least squares (`naic_ident::tool`), written as the tool section of a robot file.
//!
//! Static segments: maximal runs of joint states with every joint's speed at most
//! `--velocity-bound` (default 0.01 rad/s: the tool's centripetal and Coriolis forces are
//! then below 1e-4 N) lasting at least `--min-static` seconds (default 0.5 s). The first
//! `--settle` seconds of each segment are left out (the arm's and the sensor's ringing after
//! a stop). Each segment is one pose: the mean wrench of the samples stamped inside it, the
//! sensor frame's orientation from the model's forward kinematics at the mean joint
//! position.

use super::{CliError, CliResult};
use naic_bag::{run::topics, Bag, RunData};
use naic_core::{dynamics, model::Model};
use naic_ident::tool::{self, StaticPose, ToolFit};
use nalgebra::{DVector, Rotation3, Vector3};
use std::path::PathBuf;

#[derive(clap::Subcommand)]
pub enum ToolCmd {
    /// Fit the tool (mass, centre of mass) and the sensor bias from the static poses of a bag.
    Identify(IdentifyArgs),
}

#[derive(clap::Args)]
pub struct IdentifyArgs {
    /// The MCAP bag (`naic record`): /joint_states and /wrench with the arm still in at least
    /// 3 orientations (6 or more: a confident fit). Without it: live, over DDS (--poses).
    #[arg(long)]
    pub bag: Option<PathBuf>,
    /// Live (no --bag): read /joint_states and /wrench from the running chain while the arm
    /// is moved (by hand, your node, or examples/tool_poses.py) and fit once this many static
    /// poses were held.
    #[arg(long, default_value_t = 8)]
    pub poses: usize,
    /// Live: give up after this many seconds (wall clock) [s].
    #[arg(long, default_value_t = 600.0)]
    pub timeout: f64,
    /// Robot model (its 'ft_sensor' frame) [default: urdf/jk5.urdf].
    #[arg(long)]
    pub urdf: Option<PathBuf>,
    /// A joint state is at rest when every joint is at most this fast [rad/s].
    #[arg(long, default_value_t = 0.01)]
    pub velocity_bound: f64,
    /// Shortest static segment used [s].
    #[arg(long, default_value_t = 0.5)]
    pub min_static: f64,
    /// Left out at the start of each static segment [s].
    #[arg(long, default_value_t = 0.1)]
    pub settle: f64,
    /// Write the tool section (robot-file layout) to this YAML file.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(c: ToolCmd) -> CliResult {
    match c {
        ToolCmd::Identify(a) => identify(&a),
    }
}

fn identify(a: &IdentifyArgs) -> CliResult {
    let fit = identify_bag(a)?;
    print!("{}", report(&fit));
    let section = fit.robot_file_section();
    match &a.out {
        Some(p) => {
            std::fs::write(p, &section).map_err(|e| CliError::failure(format!("--out {}: cannot write: {e}", p.display())))?;
            eprintln!("wrote {}", p.display());
        }
        None => print!("{section}"),
    }
    Ok(())
}

/// The fit of a bag's static poses, or of the live chain's (module docs).
pub fn identify_bag(a: &IdentifyArgs) -> Result<ToolFit, CliError> {
    if !(a.velocity_bound > 0.0 && a.min_static >= 0.0 && a.settle >= 0.0) {
        return Err(CliError::usage("--velocity-bound must be > 0, --min-static and --settle >= 0"));
    }
    let urdf = a.urdf.clone().unwrap_or_else(|| super::sim::default_path("urdf/jk5.urdf"));
    let model = Model::from_urdf_file(&urdf).map_err(|e| CliError::usage(format!("--urdf {}: {e}", urdf.display())))?;
    let sensor = model
        .frame_id("ft_sensor")
        .ok_or_else(|| CliError::usage(format!("--urdf {}: no frame 'ft_sensor' (the F/T sensor link)", urdf.display())))?;
    let Some(bag_path) = &a.bag else {
        let (run, src) = live(&model, sensor, a)?;
        let poses = static_poses(&model, sensor, &run, a, &src)?;
        eprintln!("naic tool identify: {} static pose(s) {src}", poses.len());
        return tool::fit(&poses, &model.gravity).map_err(|e| CliError::usage(format!("{src}: {e}")));
    };
    let src = format!("--bag {}", bag_path.display());
    let bag = Bag::open(bag_path).map_err(|e| CliError::usage(format!("{src}: {e}")))?;
    let run = RunData::load(&bag, ..);
    for (topic, n) in [(topics::JOINT_STATES, run.joint_states.len()), (topics::WRENCH, run.wrench.len())] {
        if n == 0 {
            let have: Vec<String> = bag.topics().iter().map(|t| t.topic.clone()).collect();
            return Err(CliError::usage(format!(
                "{src}: no {topic} messages (topics in the bag: {have:?}); record with `naic record` while the arm holds still in several orientations"
            )));
        }
    }
    let poses = static_poses(&model, sensor, &run, a, &src)?;
    eprintln!("naic tool identify: {} static pose(s) in {}", poses.len(), bag_path.display());
    tool::fit(&poses, &model.gravity).map_err(|e| CliError::usage(format!("{src}: {e}")))
}

/// Live: /joint_states and /wrench of the running chain until `--poses` static poses were
/// held (each announced as it is), or `--timeout`. The data and a label for the messages.
fn live(model: &Model, sensor: naic_core::model::FrameId, a: &IdentifyArgs) -> Result<(RunData, String), CliError> {
    use naic_ros::{msgs as m, RosArgs, RosNode};
    use ros2_client::qos::{History, Reliability, WhenFull};
    use std::time::{Duration, Instant};
    if a.poses < 3 || !(a.timeout > 0.0 && a.timeout.is_finite()) {
        return Err(CliError::usage(format!("--poses must be at least 3 (6 or more: a confident fit), --timeout a positive number of seconds; got {} and {}", a.poses, a.timeout)));
    }
    let src = "live (/joint_states, /wrench over DDS)".to_string();
    let ros = |e: naic_ros::RosError| CliError::failure(e.to_string());
    let mut node = RosNode::new(RosArgs::parse(std::iter::empty::<String>()).map_err(ros)?, "naic_tool_identify", Vec::new(), None).map_err(ros)?;
    let qos = ros2_client::QosProfile::subscription_default()
        .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_millis(10)) })
        .history(History::KeepLast { depth: naic_ros::node::SIM_TIME_HISTORY });
    let js = node.subscription::<naic_msgs::JointState>("/joint_states", m::JOINT_STATE, qos.clone()).map_err(ros)?;
    let ws = node.subscription::<naic_msgs::WrenchStamped>("/wrench", m::WRENCH_STAMPED, qos).map_err(ros)?;
    let mut run = RunData::default();
    let start = Instant::now();
    let (mut last_check, mut held) = (Instant::now(), 0usize);
    fn stamped<M>(msg: M) -> naic_bag::Stamped<M> {
        naic_bag::Stamped { log_time: naic_ros::time::wall_ns().max(0) as u64, publish_time: 0, sequence: 0, msg }
    }
    eprintln!("naic tool identify: waiting for {} static poses on /joint_states and /wrench; move the arm and hold it still in each orientation", a.poses);
    loop {
        while let Ok(Some((msg, _))) = js.take() {
            run.joint_states.push(stamped(msg));
        }
        while let Ok(Some((msg, _))) = ws.take() {
            run.wrench.push(stamped(msg));
        }
        if last_check.elapsed() >= Duration::from_millis(500) && !run.joint_states.is_empty() && !run.wrench.is_empty() {
            last_check = Instant::now();
            // A pose counts once the arm has left it (the segment is complete) or the last
            // one has lasted long enough; the fit uses all of them.
            let n = static_poses(model, sensor, &run, a, &src).map_or(0, |p| p.len());
            if n > held {
                held = n;
                eprintln!("naic tool identify: pose {held}/{} held", a.poses);
            }
            if held >= a.poses {
                return Ok((run, src));
            }
        }
        if start.elapsed().as_secs_f64() > a.timeout {
            return Err(CliError::with_code(
                3,
                format!(
                    "{src}: {held} of {} static poses after {} s ({} joint states, {} wrenches received): is the chain running on this ROS_DOMAIN_ID, and is the arm held still (every joint at most {} rad/s for {} s) in each orientation?",
                    a.poses,
                    a.timeout,
                    run.joint_states.len(),
                    run.wrench.len(),
                    a.velocity_bound,
                    a.min_static + a.settle
                ),
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn stamp_s(t: &naic_msgs::Time) -> f64 {
    t.to_nanos() as f64 * 1e-9
}

/// One pose per static segment of the joint states (module docs).
fn static_poses(model: &Model, sensor: naic_core::model::FrameId, run: &RunData, a: &IdentifyArgs, src: &str) -> Result<Vec<StaticPose>, CliError> {
    let names: Vec<&str> = model.joint_names().collect();
    let n = names.len();
    // Joint positions and speeds in the model's order (a message without a joint is skipped).
    let mut qs = Vec::new();
    let mut t = Vec::new();
    let mut still = Vec::new();
    for m in &run.joint_states {
        let js = &m.msg;
        let idx: Option<Vec<usize>> = names.iter().map(|nm| js.name.iter().position(|x| x == nm)).collect();
        let Some(idx) = idx else { continue };
        let q: Option<Vec<f64>> = idx.iter().map(|&k| js.position.get(k).copied()).collect();
        let Some(q) = q else { continue };
        let v_ok = idx.iter().all(|&k| js.velocity.get(k).is_some_and(|v| v.abs() <= a.velocity_bound));
        qs.push(q);
        t.push(stamp_s(&js.header.stamp));
        still.push(v_ok);
    }
    if qs.is_empty() {
        return Err(CliError::usage(format!("{src}: no /joint_states message names every joint of the model {names:?}")));
    }
    let segments = tool::static_segments(&still, &t, a.min_static + a.settle);
    if segments.is_empty() {
        return Err(CliError::usage(format!(
            "{src}: no static segment (every joint at most {} rad/s for at least {} s): hold the arm still in each orientation (or raise --velocity-bound, lower --min-static)",
            a.velocity_bound,
            a.min_static + a.settle
        )));
    }
    let mut data = naic_core::model::Data::new(model);
    let mut poses = Vec::new();
    for seg in segments {
        let (t0, t1) = (t[seg.start] + a.settle, t[seg.end - 1]);
        let mut q = DVector::zeros(n);
        let mut k = 0usize;
        for i in seg.clone() {
            if t[i] >= t0 {
                q += DVector::from_column_slice(&qs[i]);
                k += 1;
            }
        }
        q /= k.max(1) as f64;
        let (mut f, mut tq, mut w) = (Vector3::zeros(), Vector3::zeros(), 0usize);
        for m in &run.wrench {
            let ts = stamp_s(&m.msg.header.stamp);
            if ts >= t0 && ts <= t1 {
                let x = &m.msg.wrench;
                f += Vector3::new(x.force.x, x.force.y, x.force.z);
                tq += Vector3::new(x.torque.x, x.torque.y, x.torque.z);
                w += 1;
            }
        }
        if w == 0 {
            continue; // no wrench stamped inside: not a pose
        }
        dynamics::forward_kinematics(model, &mut data, &q);
        let r = Rotation3::from_matrix_unchecked(data.frame_se3(sensor).rot);
        poses.push(StaticPose { r_ws: r, force: f / w as f64, torque: tq / w as f64, samples: w });
    }
    if poses.is_empty() {
        return Err(CliError::usage(format!("{src}: static segments found, but no /wrench message stamped inside any")));
    }
    Ok(poses)
}

/// The fit as the user reads it: each parameter with its standard error, the residuals.
pub fn report(f: &ToolFit) -> String {
    let e = |x: &naic_ident::tool::Estimate, scale: f64, unit: &str| format!("{:.4} ± {:.4} {unit}", x.value * scale, x.std_error * scale);
    let mut s = format!("{} static poses\n", f.poses);
    s += &format!("mass        {}\n", e(&f.mass, 1.0, "kg"));
    for (k, ax) in ["x", "y", "z"].iter().enumerate() {
        s += &format!("com {ax}       {}\n", e(&f.com[k], 1e3, "mm"));
    }
    for (k, ax) in ["x", "y", "z"].iter().enumerate() {
        s += &format!("force bias {ax} {}\n", e(&f.force_bias[k], 1.0, "N"));
    }
    for (k, ax) in ["x", "y", "z"].iter().enumerate() {
        s += &format!("torque bias {ax} {}\n", e(&f.torque_bias[k], 1.0, "N m"));
    }
    s += &format!("residual RMS: force {:.4} N, torque {:.5} N m (± : one standard error)\n", f.force_rms, f.torque_rms);
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use naic_bag::{BagWriter, Qos};
    use naic_msgs::{Header, JointState, Time, Wrench, WrenchStamped};
    use naic_sim::rng::Rng;
    use naic_sim::sensor::Mini45;

    const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

    /// A bag of the JK5 held still in `poses` (1.2 s each, 1 kHz, moving 0.3 s between them),
    /// the F/T readings from naic_sim's sensor model (bias, noise, resolution) of a tool of
    /// mass `m` and centre of mass `c`.
    fn sim_bag(path: &Path, m: f64, c: Vector3<f64>, poses: &[[f64; 6]]) {
        let model = Model::from_urdf_file(format!("{ROOT}/urdf/jk5.urdf")).unwrap();
        let sensor = model.frame_id("ft_sensor").unwrap();
        let mut data = naic_core::model::Data::new(&model);
        let mut rng = Rng::seed(7);
        let ft = Mini45::si_145_5(m, c, &mut rng);
        let mut w = BagWriter::create(path).unwrap();
        let js_t = w.add_topic::<JointState>(topics::JOINT_STATES, Qos::default()).unwrap();
        let w_t = w.add_topic::<WrenchStamped>(topics::WRENCH, Qos::default()).unwrap();
        let names: Vec<String> = model.joint_names().map(String::from).collect();
        let mut ns: i64 = 1_000_000_000;
        let mut q_prev = poses[0];
        for q in poses {
            // Moving from the previous pose (not static), then holding still.
            for k in 0..1500 {
                let (qk, v) = if k < 300 {
                    let s = k as f64 / 300.0;
                    (std::array::from_fn(|j| q_prev[j] + (q[j] - q_prev[j]) * s), std::array::from_fn(|j| (q[j] - q_prev[j]) / 0.3))
                } else {
                    (*q, [0.0; 6])
                };
                let qk: [f64; 6] = qk;
                let v: [f64; 6] = v;
                dynamics::forward_kinematics(&model, &mut data, &DVector::from_column_slice(&qk));
                let se = data.frame_se3(sensor);
                let r = Rotation3::from_matrix_unchecked(se.rot);
                let tip = data.frame_se3(model.frame_id("tip").unwrap()).trans - se.trans;
                let x = ft.measure(&r, &tip, &Vector3::zeros(), &mut rng);
                let header = Header { stamp: Time::from_nanos(ns), frame_id: String::new() };
                let js = JointState { header: header.clone(), name: names.clone(), position: qk.to_vec(), velocity: v.to_vec(), effort: vec![0.0; 6] };
                let wr = WrenchStamped {
                    header,
                    wrench: Wrench {
                        force: naic_msgs::Vector3 { x: x[0], y: x[1], z: x[2] },
                        torque: naic_msgs::Vector3 { x: x[3], y: x[4], z: x[5] },
                    },
                };
                w.write(js_t, &js, ns as u64, ns as u64).unwrap();
                w.write(w_t, &wr, ns as u64, ns as u64).unwrap();
                ns += 1_000_000;
            }
            q_prev = *q;
        }
        w.finish().unwrap();
    }

    fn args(bag: &Path) -> IdentifyArgs {
        IdentifyArgs { bag: Some(bag.to_path_buf()), poses: 8, timeout: 600.0, urdf: Some(format!("{ROOT}/urdf/jk5.urdf").into()), velocity_bound: 0.01, min_static: 0.5, settle: 0.1, out: None }
    }

    /// 8 orientations of the tool from the flat start pose (joints 4-6 turned).
    const POSES: [[f64; 6]; 8] = [
        [0.0, 0.3, 1.8, 0.0, 1.0, 0.0],
        [0.0, 0.3, 1.8, 0.6, 1.0, 0.0],
        [0.0, 0.3, 1.8, -0.6, 1.0, 0.0],
        [0.0, 0.3, 1.8, 0.0, 0.4, 0.0],
        [0.0, 0.3, 1.8, 0.0, 1.6, 1.0],
        [0.0, 0.3, 1.8, 0.8, 0.6, 2.0],
        [0.0, 0.3, 1.8, -0.9, 1.3, -1.5],
        [0.0, 0.3, 1.8, 0.3, 2.0, 0.7],
    ];

    #[test]
    fn a_tool_unlike_the_urdfs_is_identified_within_2_percent_and_2_mm_from_8_simulated_poses() {
        let dir = std::env::temp_dir().join(format!("naic_tool_id_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bag = dir.join("poses.mcap");
        // The URDF's tool is 0.424 kg at (0, 0, 15) mm: the true one is heavier and off axis.
        let (m, c) = (0.51, Vector3::new(0.004, -0.003, 0.028));
        sim_bag(&bag, m, c, &POSES);
        let f = identify_bag(&args(&bag)).unwrap();
        eprintln!("{}", report(&f));
        assert_eq!(f.poses, 8);
        assert!((f.mass.value - m).abs() / m < 0.02, "mass {:?}", f.mass);
        let dc = Vector3::new(f.com[0].value, f.com[1].value, f.com[2].value) - c;
        assert!(dc.norm() < 0.002, "centre of mass off by {} mm", dc.norm() * 1e3);
        // The standard errors are honest: the errors within 4 of them (or the resolution).
        assert!((f.mass.value - m).abs() < 4.0 * f.mass.std_error + 1e-4, "{:?}", f.mass);
        // Written in the robot file's layout, readable as YAML.
        let out = dir.join("tool.yaml");
        identify(&IdentifyArgs { out: Some(out.clone()), ..args(&bag) }).unwrap();
        let y: serde_yaml::Value = serde_yaml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert!((y["tool"]["mass"].as_f64().unwrap() - f.mass.value).abs() < 1e-4);
        assert_eq!(y["tool"]["com"].as_sequence().unwrap().len(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn what_identify_writes_is_what_naic_sim_tool_file_reads() {
        let dir = std::env::temp_dir().join(format!("naic_tool_file_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bag = dir.join("poses.mcap");
        sim_bag(&bag, 0.45, Vector3::new(0.0, 0.002, 0.02), &POSES[..6]);
        let out = dir.join("tool.yaml");
        identify(&IdentifyArgs { out: Some(out.clone()), ..args(&bag) }).unwrap();
        let (m, c) = crate::cmd::sim::tool_file(&out).unwrap();
        assert!((m - 0.45).abs() < 0.009 && (c - Vector3::new(0.0, 0.002, 0.02)).norm() < 0.002, "{m} {c:?}");
        std::fs::write(&out, "tool:\n  mass: 0.3\n").unwrap();
        let e = crate::cmd::sim::tool_file(&out).unwrap_err();
        assert!(e.message.contains("tool.com must be [x, y, z]"), "{}", e.message);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// `naic sim --scenario flat` with the true tool given by `--tool-mass-error` and
    /// `--tool-com-offset` (relative to the URDF's), the controller's from `tool_file` (or the
    /// URDF's): each controller's mean force error over the last 0.2 s of each force phase.
    fn flat_late_errors(dir: &Path, seed: u64, true_tool: (f64, Vector3<f64>), tool_file: Option<&Path>) -> Vec<(String, f64)> {
        let urdf = naic_sim::sensor::tool_from_urdf(Path::new(&format!("{ROOT}/urdf/jk5.urdf"))).unwrap();
        let off = true_tool.1 - urdf.1;
        let a = crate::cmd::sim::SimArgs {
            scenario: Some("flat".into()),
            out: Some(dir.to_path_buf()),
            seed: Some(seed),
            tool_mass_error: Some(true_tool.0 / urdf.0),
            tool_com_offset: Some(format!("{:e},{:e},{:e}", off[0], off[1], off[2])),
            tool_file: tool_file.map(Path::to_path_buf),
            ..Default::default()
        };
        crate::cmd::sim::run(a).unwrap();
        let m: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap();
        let mut out = Vec::new();
        for (name, c) in m["controllers"].as_object().unwrap() {
            for (k, ph) in c["phases"].as_array().unwrap().iter().enumerate() {
                out.push((format!("{name} phase {}", k + 1), ph["steady_state_error_n"].as_f64().unwrap()));
            }
        }
        out
    }

    /// Issue 39's goal: after identification, `flat` tracks within 0.05 N of the run with the
    /// true tool. The tool is identified from 8 simulated static poses (the sensor model's
    /// bias, noise and resolution), written as `naic tool identify --out` writes it, and given
    /// to `naic sim --tool-file`; the plant's sensor carries the true tool. Compared: the
    /// mean force over the last 0.2 s of each force phase (10 N, 20 N), every controller,
    /// seeds 1-3. The URDF's tool (the controller's without identification) is printed
    /// alongside: on `flat` the tool points down throughout and the start-up tare absorbs
    /// most of a wrong weight, so this goal is met by a wrong tool too.
    #[test]
    fn flat_with_the_identified_tool_tracks_within_0_05_n_of_the_true_tool() {
        let dir = std::env::temp_dir().join(format!("naic_tool_flat_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bag = dir.join("poses.mcap");
        let truth = (0.51, Vector3::new(0.004, -0.003, 0.028));
        sim_bag(&bag, truth.0, truth.1, &POSES);
        let tool_yaml = dir.join("tool.yaml");
        identify(&IdentifyArgs { out: Some(tool_yaml.clone()), ..args(&bag) }).unwrap();
        let mut worst: f64 = 0.0;
        let mut worst_urdf: f64 = 0.0;
        // The true-tool run: the controller is given the true tool (a tool file saying so).
        let true_yaml = dir.join("true.yaml");
        std::fs::write(&true_yaml, format!("tool:\n  mass: {}\n  com: [{}, {}, {}]\n", truth.0, truth.1[0], truth.1[1], truth.1[2])).unwrap();
        for seed in 1..=3 {
            let t = flat_late_errors(&dir.join(format!("urdf-{seed}")), seed, truth, None);
            let t_true = flat_late_errors(&dir.join(format!("truetool-{seed}")), seed, truth, Some(&true_yaml));
            let t_id = flat_late_errors(&dir.join(format!("ident-{seed}")), seed, truth, Some(&tool_yaml));
            assert_eq!(t_true.len(), t_id.len());
            for (((name, e_true), (_, e_id)), (_, e_urdf)) in t_true.iter().zip(&t_id).zip(&t) {
                let d = (e_id - e_true).abs();
                let d_urdf = (e_urdf - e_true).abs();
                eprintln!("seed {seed} {name}: identified - true {:+.4} N, URDF tool - true {:+.4} N", e_id - e_true, e_urdf - e_true);
                worst = worst.max(d);
                worst_urdf = worst_urdf.max(d_urdf);
            }
        }
        eprintln!("largest |identified - true| {worst:.4} N (goal 0.05 N); URDF tool {worst_urdf:.4} N");
        assert!(worst <= 0.05, "flat with the identified tool is {worst:.4} N from the true tool's run (goal: within 0.05 N)");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bags_that_cannot_identify_a_tool_get_a_reason() {
        let dir = std::env::temp_dir().join(format!("naic_tool_id_bad_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // One orientation held: one static segment, too few poses.
        let bag = dir.join("one.mcap");
        sim_bag(&bag, 0.424, Vector3::new(0.0, 0.0, 0.015), &[POSES[0], POSES[0], POSES[0]]);
        let e = identify_bag(&args(&bag)).unwrap_err();
        assert!(e.message.contains("1 static pose(s): the fit needs at least 3"), "{}", e.message);
        // Two orientations, each visited twice: four poses, but the centre of mass along
        // their difference is not separable from the torque bias.
        let two = dir.join("two.mcap");
        sim_bag(&two, 0.424, Vector3::new(0.0, 0.0, 0.015), &[POSES[0], POSES[1], POSES[0], POSES[1]]);
        let e = identify_bag(&args(&two)).unwrap_err();
        assert!(e.message.contains("centre of mass") && e.message.contains("add poses rotated about a different axis"), "{}", e.message);
        // A bound nothing meets: no static segment.
        let e = identify_bag(&IdentifyArgs { min_static: 100.0, ..args(&bag) }).unwrap_err();
        assert!(e.message.contains("no static segment"), "{}", e.message);
        // A bag without /wrench.
        let nowrench = dir.join("nowrench.mcap");
        let mut w = BagWriter::create(&nowrench).unwrap();
        let t = w.add_topic::<JointState>(topics::JOINT_STATES, Qos::default()).unwrap();
        w.write(t, &JointState::default(), 1, 1).unwrap();
        w.finish().unwrap();
        let e = identify_bag(&args(&nowrench)).unwrap_err();
        assert!(e.message.contains("no /wrench messages"), "{}", e.message);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
