//! `-p robot:=FILE` (issue 37): the controller takes the URDF, joint names, friction file,
//! base frame and scenario placement from a robot file.

use naic_controller::setup::{Setup, NODE};
use naic_ros::{ParamTable, RosArgs};

fn root() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/../..").to_string()
}

#[test]
fn a_ur5_robot_file_gives_its_joint_names_frames_and_a_scenario_placed_on_it() {
    if std::env::var("NAIC_VENV").is_err() {
        eprintln!("skipped: set NAIC_VENV to the test venv (with example-robot-data)");
        return;
    }
    let args = RosArgs::with_params([format!("robot:={}/params/robots/ur5.yaml", root())]).unwrap();
    let setup = Setup::from_args(&args).unwrap();
    assert_eq!(setup.params.joints, ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]);
    // The flat scenario starts under the UR5's start tip (0.45, -0.225, 0.25), not at the JK5 table.
    let r = setup.params.reference.as_ref().expect("flat").at(0.0);
    assert!((r.p_d - nalgebra::Vector3::new(0.45, -0.225, 0.25 - 0.197)).norm() < 1e-3, "{}", r.p_d);
    // The parameters show where the values came from: no friction file, the UR's base frame.
    let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
    table.with(|p| {
        assert_eq!(p.str("friction_file"), "");
        assert_eq!(p.str("base_frame"), "base_link");
        assert!(p.str("urdf").ends_with("ur5_robot.urdf"), "{}", p.str("urdf"));
        assert!(p.str("robot").ends_with("ur5.yaml"));
    });
}

#[test]
fn a_seven_joint_robot_file_runs_the_seven_joint_shell() {
    let args = RosArgs::with_params([format!("robot:={}/params/robots/panda.yaml", root())]).unwrap();
    let (robot, n) = naic_controller::setup::arm(&args).unwrap();
    assert_eq!(n, 7);
    let setup = Setup::<7>::for_arm(&args, robot.clone()).unwrap();
    assert_eq!(setup.params.joints, ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7"]);
    // The flat scenario starts under the Panda's start tip (0.45, -0.225, 0.30).
    let r = setup.params.reference.as_ref().expect("flat").at(0.0);
    assert!((r.p_d - nalgebra::Vector3::new(0.45, -0.225, 0.30 - 0.197)).norm() < 1e-3, "{}", r.p_d);
    // A shell of another joint count refuses it, naming the file and both counts.
    let e = Setup::<6>::for_arm(&args, robot).err().expect("7 joints in a 6-joint shell").to_string();
    assert!(e.contains("panda.yaml") && e.contains("7 joints") && e.contains("6 joints"), "{e}");
    // A URDF of 7 joints without a robot file: refused, naming the fix.
    let args = RosArgs::with_params([format!("urdf:={}/urdf/panda.urdf", root())]).unwrap();
    let e = naic_controller::setup::arm(&args).err().expect("no robot file").to_string();
    assert!(e.contains("7 joints") && e.contains("robot:=FILE"), "{e}");
}

#[test]
fn a_robot_file_that_contradicts_urdf_is_refused_by_name() {
    let args = RosArgs::with_params([format!("robot:={}/params/robots/nothere.yaml", root())]).unwrap();
    let e = Setup::from_args(&args).err().expect("no file").to_string();
    assert!(e.contains("nothere.yaml") && e.contains("robot:=FILE"), "{e}");
    let args =
        RosArgs::with_params([format!("robot:={}/params/robots/jk5.yaml", root()), format!("urdf:={}/urdf/panda.urdf", root())]).unwrap();
    let e = Setup::from_args(&args).err().expect("two URDFs").to_string();
    assert!(e.contains("give the URDF in the robot file"), "{e}");
    // The JK5's robot file is the JK5 as without one.
    let args = RosArgs::with_params([format!("robot:={}/params/robots/jk5.yaml", root())]).unwrap();
    let setup = Setup::from_args(&args).unwrap();
    assert_eq!(setup.params.joints, naic_ros::msgs::JOINT_NAMES.map(String::from));
}
