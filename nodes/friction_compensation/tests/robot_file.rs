//! `-p robot:=FILE` (issue 37): the friction node takes the joint names and the friction
//! file from a robot file, and a robot file without friction gives no feedforward.

use friction_compensation::{runner::Runner, setup::{Setup, NODE}};
use naic_ros::{
    msgs::{effort_msg, Header, JointState},
    time::time_from_ns,
    ParamTable, RosArgs,
};

fn root() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/../..").to_string()
}

#[test]
fn a_ur5_robot_file_reads_its_joint_names_and_applies_no_jk5_friction() {
    if std::env::var("NAIC_VENV").is_err() {
        eprintln!("skipped: set NAIC_VENV to the test venv (with example-robot-data)");
        return;
    }
    let args = RosArgs::with_params([format!("robot:={}/params/robots/ur5.yaml", root())]).unwrap();
    let setup = Setup::from_args(&args).unwrap();
    let names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"];
    assert_eq!(setup.joints, names);
    let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
    let mut r = Runner::new(&setup, &table).unwrap();
    assert!(r.p.friction.is_none(), "friction: none in the robot file");
    // The UR's own names, in another order than the chain, moving: the JK5's Table 1 would add
    // several N m; with no friction model the command passes the guard unchanged.
    let order = [5, 0, 3, 1, 4, 2];
    r.joint_states(&JointState {
        header: Header { stamp: time_from_ns(1_000_000), frame_id: String::new() },
        name: order.iter().map(|&i| names[i].to_string()).collect(),
        position: vec![0.0; 6],
        velocity: vec![0.3; 6],
        effort: vec![0.0; 6],
    });
    let tau = [0.5, -0.5, 0.25, 0.0, 0.1, -0.1];
    let out = r.command(&effort_msg(&tau, Some(1_000_000)), |_| None).expect("a command");
    assert_eq!(out.data, tau.to_vec());
}

#[test]
fn a_seven_joint_robot_file_reads_seven_names_and_commands_seven_torques_in_their_order() {
    let args = RosArgs::with_params([format!("robot:={}/params/robots/panda.yaml", root())]).unwrap();
    let (robot, n) = friction_compensation::setup::arm(&args).unwrap();
    assert_eq!(n, 7);
    let setup = Setup::<7>::for_arm(&args, robot.clone()).unwrap();
    let names = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6", "joint7"];
    assert_eq!(setup.joints, names);
    // The Panda URDF's effort limits (87 N m on joints 1-4, 12 N m on 5-7).
    assert_eq!(setup.effort_limit, [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]);
    let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
    let mut r = Runner::new(&setup, &table).unwrap();
    // The broadcaster's order (shuffled, a gripper finger added): the command is in the robot
    // file's order, each torque the one for its joint.
    let order = [6, 2, 0, 5, 1, 3, 4];
    let mut js = JointState {
        header: Header { stamp: time_from_ns(1_000_000), frame_id: String::new() },
        name: order.iter().map(|&i| names[i].to_string()).chain(["finger_joint1".to_string()]).collect(),
        position: vec![0.0; 8],
        velocity: vec![0.0; 8],
        effort: order.iter().map(|&i| i as f64).chain([0.0]).collect(),
    };
    r.joint_states(&js);
    let tau = [0.5, -0.5, 0.25, 0.0, 0.1, -0.1, 0.3];
    let out = r.command(&effort_msg(&tau, Some(1_000_000)), |_| None).expect("a command");
    // The take-over: the rate limit (10 N m) from the measured torque of each joint, by name.
    assert_eq!(out.data, tau.to_vec());
    // A command of six values for the seven-joint arm is refused (never a torque on the wrong joint).
    js.header.stamp = time_from_ns(2_000_000);
    r.joint_states(&js);
    assert!(r.command(&effort_msg(&tau[..6], Some(2_000_000)), |_| None).is_none());
    // A shell of another joint count refuses the file, naming it and both counts.
    let e = Setup::<6>::for_arm(&args, robot).err().expect("7 joints in a 6-joint shell").to_string();
    assert!(e.contains("panda.yaml") && e.contains("7 joints") && e.contains("friction_compensation"), "{e}");
}
