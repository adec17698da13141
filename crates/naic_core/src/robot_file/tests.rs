use super::*;
use crate::dynamics;
use crate::model::DataN;
use nalgebra::SVector;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn no_env(_: &str) -> Option<String> {
    None
}

/// A scratch folder per test (removed at the end of the test process by the OS tmp cleaner).
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("naic_robot_file_{}_{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write `body` as a robot file in a scratch folder; `{root}` is the repository root.
fn write(name: &str, body: &str) -> PathBuf {
    let d = scratch(name);
    let p = d.join("robot.yaml");
    std::fs::write(&p, body.replace("{root}", &root().display().to_string())).unwrap();
    p
}

fn load_err(name: &str, body: &str) -> RobotFileError {
    let p = write(name, body);
    let e = Robot::load_with_env(&p, &no_env).expect_err("the file is wrong");
    assert_eq!(e.file, p.display().to_string(), "the error names the file");
    e
}

const JK5: &str = "urdf: {root}/urdf/jk5.urdf\ntip_frame: tip\nsensor_frame: ft_sensor\n";

#[test]
fn the_jk5_file_is_exactly_the_jk5_as_before() {
    let r = Robot::load_with_env(&root().join(DEFAULT_ROBOT_FILE), &no_env).unwrap();
    let urdf = Model::from_urdf_file(root().join("urdf/jk5.urdf")).unwrap();
    assert_eq!(r.model, urdf, "no frame added, no limit changed, no mass added");
    assert_eq!(r.joints, ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]);
    assert!(r.locked.is_empty() && r.start_q.is_none() && !r.sensor_frame_added);
    assert_eq!(r.base_frame, "base_link");
    // The tool: the ft_sensor link's inertial (what naic_sim::sensor::tool_from_urdf reads).
    assert_eq!(r.tool, Tool { mass: 0.424, com: Vector3::new(0.0, 0.0, 0.015) });
    let (fp, fm) = r.friction.as_ref().expect("Table 1");
    assert!(fp.ends_with("friction_jk5.yaml"));
    assert_eq!(*fm, FrictionParams::load_feedforward_model(root().join("params/friction_jk5.yaml")).unwrap());
    assert_eq!(r.sensor, SensorSpec::default());
    assert!(r.is_paper_jk5());
}

/// FK of the tip of a loaded robot at its start joints.
fn tip_at_start<const N: usize>(r: &Robot) -> (Vector3<f64>, Vector3<f64>) {
    let mut d = DataN::<N>::try_new(&r.model).unwrap();
    let q = SVector::<f64, N>::from_column_slice(r.start_q.as_ref().unwrap());
    dynamics::forward_kinematics(&r.model, &mut d, &q);
    let iso = d.frame_placement(r.tip());
    (iso.translation.vector, iso.rotation * Vector3::z())
}

#[test]
fn the_panda_file_adds_sensor_tip_and_tool_to_the_stock_urdf() {
    let r = Robot::load_with_env(&root().join("params/robots/panda.yaml"), &no_env).unwrap();
    assert_eq!(r.model.nv(), 7);
    assert!(r.sensor_frame_added);
    assert_eq!(r.tool.mass, 0.424);
    let stock = Model::from_urdf_file(root().join("urdf/panda.urdf")).unwrap();
    assert!((r.model.moving_mass() - stock.moving_mass() - 0.424).abs() < 1e-12, "the tool's mass is on the arm");
    // The start joints were solved with Pinocchio on urdf/panda.urdf (tip = flange + 0.169 m z):
    // tip at (0.45, -0.225, 0.30), tool down, to the 4 digits written in the file.
    let (p, z) = tip_at_start::<7>(&r);
    assert!((p - Vector3::new(0.45, -0.225, 0.30)).norm() < 2e-4, "{p}");
    assert!((z + Vector3::z()).norm() < 1e-3, "{z}");
    assert!((r.tip_in_sensor().unwrap() - Vector3::new(0.0, 0.0, 0.169)).norm() < 1e-12);
    // The default limits are the URDF's.
    assert_eq!(r.model.effort_limits(), stock.effort_limits());
}

/// The venv with example-robot-data (`NAIC_VENV`), where the tests run with it.
fn venv_env() -> Option<impl Fn(&str) -> Option<String>> {
    let venv = std::env::var("NAIC_VENV").ok()?;
    Some(move |k: &str| if k == "NAIC_VENV" { Some(venv.clone()) } else { None })
}

#[test]
fn the_ur_files_find_example_robot_data_through_the_venv() {
    let Some(env) = venv_env() else {
        eprintln!("skipped: set NAIC_VENV to the test venv (with example-robot-data) to run this test");
        return;
    };
    for (arm, p0) in [("ur5", Vector3::new(0.45, -0.225, 0.25)), ("ur10", Vector3::new(0.55, -0.225, 0.30))] {
        let r = Robot::load_with_env(&root().join(format!("params/robots/{arm}.yaml")), &env).unwrap();
        assert!(r.urdf.to_string_lossy().contains("cmeel.prefix/share/example-robot-data/robots/ur_description"), "{}", r.urdf.display());
        assert_eq!(r.joints, ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]);
        assert!(!r.is_paper_jk5());
        let (p, z) = tip_at_start::<6>(&r);
        assert!((p - p0).norm() < 2e-4, "{arm}: {p}");
        assert!((z + Vector3::z()).norm() < 1e-3, "{arm}: {z}");
    }
    // Without the environment the URI is not found, and the message says what to set.
    let e = Robot::load_with_env(&root().join("params/robots/ur5.yaml"), &no_env).unwrap_err();
    assert_eq!(e.field, "urdf");
    assert!(e.problem.contains("NAIC_PACKAGE_PATH") && e.problem.contains("example-robot-data"), "{e}");
}

#[test]
fn package_uris_follow_the_documented_search_order() {
    let d = scratch("pkg");
    for sub in ["naic/mypkg", "ament/share/mypkg", "ros1/mypkg", "venv/lib/python3.11/site-packages/cmeel.prefix/share/mypkg"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
    }
    let all = |k: &str| -> Option<String> {
        let v = match k {
            "NAIC_PACKAGE_PATH" => "naic",
            "AMENT_PREFIX_PATH" => "ament",
            "ROS_PACKAGE_PATH" => "ros1",
            "VIRTUAL_ENV" => "venv",
            _ => return None,
        };
        Some(d.join(v).display().to_string())
    };
    let r = |env: &dyn Fn(&str) -> Option<String>| resolve_uri("package://mypkg/a/b.urdf", Path::new("/x"), env).unwrap();
    assert_eq!(r(&all), d.join("naic/mypkg/a/b.urdf"));
    let no_naic = |k: &str| if k == "NAIC_PACKAGE_PATH" { None } else { all(k) };
    assert_eq!(r(&no_naic), d.join("ament/share/mypkg/a/b.urdf"));
    let ros1 = |k: &str| if k == "ROS_PACKAGE_PATH" || k == "VIRTUAL_ENV" { all(k) } else { None };
    assert_eq!(r(&ros1), d.join("ros1/mypkg/a/b.urdf"));
    let venv = |k: &str| if k == "VIRTUAL_ENV" { all(k) } else { None };
    assert_eq!(r(&venv), d.join("venv/lib/python3.11/site-packages/cmeel.prefix/share/mypkg/a/b.urdf"));
    // A plain path is relative to the robot file's folder.
    assert_eq!(resolve_uri("../u.urdf", Path::new("/a/b"), &no_env).unwrap(), Path::new("/a/b/../u.urdf"));
    let e = resolve_uri("package:///x.urdf", Path::new("/"), &no_env).unwrap_err();
    assert!(e.to_string().contains("names no package"), "{e}");
}

#[test]
fn moving_joints_off_the_chain_are_locked_with_their_mass() {
    // Two fingers on the last link: a branch the 1 kHz path cannot take.
    let link = |n: &str| format!(r#"<link name="{n}"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>"#);
    let joint = |n: &str, t: &str, p: &str, c: &str| {
        format!(r#"<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>"#)
    };
    let urdf = format!(
        r#"<robot name="r"><link name="base"/>{}{}{}{}{}{}{}{}{}{}</robot>"#,
        link("l1"),
        link("l2"),
        link("l3"),
        link("f1"),
        link("f2"),
        joint("j1", "revolute", "base", "l1").replace("0 1 0", "0 0 1"),
        joint("j2", "revolute", "l1", "l2"),
        joint("j3", "revolute", "l2", "l3"),
        joint("finger1", "prismatic", "l3", "f1"),
        joint("finger2", "prismatic", "l3", "f2"),
    );
    let d = scratch("lock");
    std::fs::write(d.join("r.urdf"), urdf).unwrap();
    std::fs::write(d.join("robot.yaml"), "urdf: r.urdf\ntip_frame: {parent: l3, xyz: [0, 0, 0.1]}\nsensor_frame: l3\n").unwrap();
    let r = Robot::load_with_env(&d.join("robot.yaml"), &no_env).unwrap();
    assert_eq!(r.joints, ["j1", "j2", "j3"]);
    assert_eq!(r.locked, ["finger1", "finger2"]);
    assert!((r.model.moving_mass() - 5.0).abs() < 1e-12, "the fingers' mass stays on l3");
    // Without the robot file the URDF is refused (a branch), naming the fix.
    assert!(Model::from_urdf_file(d.join("r.urdf")).is_err());
}

#[test]
fn every_wrong_field_is_named_with_its_fix() {
    // (field, file body, words the problem must contain)
    let cases: &[(&str, &str, &[&str])] = &[
        ("urdf", "tip_frame: tip\nsensor_frame: ft_sensor\n", &["missing"]),
        ("urdf", "urdf: nowhere.urdf\ntip_frame: tip\nsensor_frame: ft_sensor\n", &["not a file", "relative to the robot file"]),
        ("urdf", "urdf: [1]\ntip_frame: tip\nsensor_frame: ft_sensor\n", &["package://"]),
        ("urdf", "urdf: package://no_such_pkg/x.urdf\ntip_frame: tip\nsensor_frame: ft_sensor\n", &["no_such_pkg", "NAIC_PACKAGE_PATH"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\nsensor_frame: ft_sensor\n", &["missing"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: nose\nsensor_frame: ft_sensor\n", &["'nose'", "link6"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: {parent: link6, xyz: [0, 0]}\nsensor_frame: ft_sensor\n", &["xyz", "give 3"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: {parent: link6, zyx: [0, 0, 1]}\nsensor_frame: ft_sensor\n", &["'zyx'", "parent, xyz"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: {xyz: [0, 0, 1]}\nsensor_frame: ft_sensor\n", &["parent"]),
        ("tip_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: {parent: link6}\nsensor_frame: ft_sensor\n", &["named 'tip' already"]),
        ("sensor_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: tip\nsensor_frame: base_link\n", &["fixed base"]),
        ("sensor_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: tip\n", &["missing"]),
        ("sensor_frame", "urdf: {root}/urdf/jk5.urdf\ntip_frame: tip\nsensor_frame: link6\n", &["another frame named 'ft_sensor'"]),
        ("base_frame", &format!("{JK5}base_frame: link6\n"), &["base_link"]),
        ("base_frame", &format!("{JK5}base_frame: world\n"), &["no frame 'world'", "base_link"]),
        ("joints", &format!("{JK5}joints: [joint1, joint2, joint3, joint4, joint6, joint5]\n"), &["joint1, joint2, joint3, joint4, joint5, joint6", "in this order"]),
        ("joints", &format!("{JK5}joints: 3\n"), &["list of joint names"]),
        ("limits.effort", &format!("{JK5}limits: {{effort: [1, 2, 3]}}\n"), &["has 3 numbers; give 6", "joint1"]),
        ("limits.velocity", &format!("{JK5}limits: {{velocity: [1, 1, 1, 1, -1, 1]}}\n"), &["-1 is not a positive number"]),
        ("limits.torque", &format!("{JK5}limits: {{torque: [1, 1, 1, 1, 1, 1]}}\n"), &["effort", "velocity"]),
        ("start_q", &format!("{JK5}start_q: [0, 0, 0]\n"), &["give 6"]),
        ("start_q", &format!("{JK5}start_q: [0, 0, 4, 0, 0, 0]\n"), &["joint3", "outside its URDF limits"]),
        ("friction", &format!("{JK5}friction: nofile.yaml\n"), &["nofile.yaml", "none"]),
        ("friction", &format!("{JK5}friction: 3\n"), &["friction YAML", "none"]),
        ("sensor.range", &format!("{JK5}sensor: {{range: [1, 2]}}\n"), &["give 6", "Fx"]),
        ("sensor.noise", &format!("{JK5}sensor: {{noise: [0, 0, -1, 0, 0, 0]}}\n"), &[">= 0"]),
        ("sensor.bias", &format!("{JK5}sensor: {{bias: [0, 0, 0, 0, 0, 0]}}\n"), &["range, resolution and noise"]),
        ("tool.mass", &format!("{JK5}tool: {{mass: -1, com: [0, 0, 0]}}\n"), &["kg"]),
        ("tool.com", &format!("{JK5}tool: {{mass: 1}}\n"), &["centre of mass"]),
        ("tool.inertia", &format!("{JK5}tool: {{mass: 1, com: [0, 0, 0], inertia: 1}}\n"), &["mass", "com"]),
        ("tip", &format!("{JK5}tip: tip\n"), &["not a robot file field", "tip_frame"]),
        ("(file)", "- a\n- b\n", &["mapping"]),
        ("(file)", "urdf: [\n", &["YAML"]),
    ];
    for (i, (field, body, words)) in cases.iter().enumerate() {
        let e = load_err(&format!("case{i}"), body);
        assert_eq!(e.field, *field, "case {i}: {e}");
        for w in *words {
            assert!(e.to_string().contains(w), "case {i}: '{w}' not in: {e}");
        }
    }
    // A missing file names itself and the default.
    let e = Robot::load_with_env(Path::new("/no/such/robot.yaml"), &no_env).unwrap_err();
    assert!(e.to_string().contains("/no/such/robot.yaml") && e.problem.contains(DEFAULT_ROBOT_FILE), "{e}");
}

#[test]
fn a_friction_file_for_another_joint_count_is_refused() {
    let p = write("fr", &format!("urdf: {{root}}/urdf/panda.urdf\ntip_frame: flange\nsensor_frame: link7\nfriction: {}/params/friction_jk5.yaml\n", root().display()));
    let e = Robot::load_with_env(&p, &no_env).unwrap_err();
    assert_eq!(e.field, "friction");
    assert!(e.problem.contains("has 6 joints, the arm 7"), "{e}");
}

#[test]
fn limits_and_sensor_fields_are_applied() {
    let p = write(
        "lim",
        &format!("{JK5}limits: {{effort: [50, 50, 50, 20, 20, 20]}}\nsensor: {{range: [100, 100, 200, 4, 4, 4], noise: [0, 0, 0, 0, 0, 0]}}\ntool: {{mass: 0.5, com: [0, 0, 0.02]}}\nfriction: none\n"),
    );
    let r = Robot::load_with_env(&p, &no_env).unwrap();
    assert_eq!(r.model.effort_limits(), vec![50.0, 50.0, 50.0, 20.0, 20.0, 20.0]);
    assert_eq!(r.model.velocity_limits(), Model::from_urdf_file(root().join("urdf/jk5.urdf")).unwrap().velocity_limits());
    assert_eq!(r.sensor.range, Some([100.0, 100.0, 200.0, 4.0, 4.0, 4.0]));
    assert_eq!(r.sensor.noise, Some([0.0; 6]));
    assert_eq!(r.sensor.resolution, None);
    assert_eq!(r.tool, Tool { mass: 0.5, com: Vector3::new(0.0, 0.0, 0.02) });
    assert!(r.friction.is_none());
    // The sensor frame is the URDF's: the tool is not added to the dynamics a second time.
    assert_eq!(r.model.moving_mass(), Model::from_urdf_file(root().join("urdf/jk5.urdf")).unwrap().moving_mass());
}
