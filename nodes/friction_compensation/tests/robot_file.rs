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
fn a_seven_joint_robot_file_is_refused_naming_the_file_and_counts() {
    let args = RosArgs::with_params([format!("robot:={}/params/robots/panda.yaml", root())]).unwrap();
    let e = Setup::from_args(&args).err().expect("7 joints").to_string();
    assert!(e.contains("panda.yaml") && e.contains("7 joints") && e.contains("friction_compensation"), "{e}");
}
