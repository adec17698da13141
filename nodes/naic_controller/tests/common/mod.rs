//! The three node cores chained in process, as `naic launch --composed --lockstep` runs
//! them: the driver's simulated JK5, naic_controller and friction_compensation, each with
//! the parameters of `params/*.yaml`, in lockstep (one plant step per command). No DDS and
//! no clock: deterministic. Shared by the in-process tests of this crate.
#![allow(dead_code)]

use std::path::PathBuf;

use friction_compensation::{config as fc_config, core as fc, setup as fc_shell};
use jk5_sim_driver::{
    config as drv_config,
    core::{self as drv, Commands},
    runner::{sim_stamp_ns, SensorFault, StateMsgs},
    setup as drv_shell,
};
use naic_controller::{core as ctl, setup as ctl_shell};
use naic_ros::{
    msgs::{self, Float64MultiArray, Header, Point, Pose, PoseStamped, Quaternion, Vector3 as V3, Wrench, WrenchStamped},
    time::time_from_ns,
    ParamTable, RosArgs,
};
use nalgebra::{UnitQuaternion, Vector3};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A node's arguments as `naic launch --lockstep` gives them, files by absolute path.
pub fn args(node: &str, extra: &[&str]) -> RosArgs {
    args_for(node, None, extra)
}

/// [`args`] with a robot file (`naic launch --robot FILE --lockstep`; `None`: the JK5).
pub fn args_for(node: &str, robot: Option<&str>, extra: &[&str]) -> RosArgs {
    let r = root();
    let mut a: Vec<String> = vec!["--ros-args".into(), "--params-file".into(), r.join(format!("params/{node}.yaml")).display().to_string()];
    let mut p = |s: String| a.extend(["-p".to_string(), s]);
    p("use_sim_time:=true".into());
    match robot {
        Some(f) => p(format!("robot:={}", r.join(f).display())),
        None => {
            p(format!("urdf:={}", r.join("urdf/jk5.urdf").display()));
            p(format!("friction_file:={}", r.join("params/friction_jk5.yaml").display()));
        }
    }
    if node == drv_shell::NODE {
        p("lockstep:=true".into());
    }
    for e in extra {
        p(e.to_string());
    }
    RosArgs::parse(a).unwrap()
}

/// The three cores in lockstep, as `naic launch --composed --lockstep` runs them (an arm
/// of `N` joints).
pub struct Chain<const N: usize = 6> {
    dp: drv::Params<N>,
    pub plant: jk5_sim_driver::sim_plant::SimPlant<N>,
    /// The failing sensor the driver plays (its `sensor_fault` parameter).
    pub fault: SensorFault,
    cmds: Commands<N>,
    ds: drv::State,
    pub cp: ctl::Params<N>,
    pub cs: ctl::State<N>,
    ws: naic_core::pipeline::controller::Workspace<N>,
    fp: fc::Params<N>,
    fs: fc::State<N>,
    /// The driver's `/joint_states` and `/wrench` (its joint order: `joint_order`).
    pub state: StateMsgs<N>,
    /// [`Chain::step_with`] has edited the names of `/joint_states` (they stay edited).
    names_edited: bool,
    effort: msgs::EffortBuffer,
    cmd: Float64MultiArray,
}

impl Chain {
    /// The chain with extra controller parameters (`name:=value`; the scenario is `none`
    /// unless they set another).
    pub fn new(controller: &[&str]) -> Chain {
        Chain::for_robot(None, controller, &[])
    }
}

impl<const N: usize> Chain<N> {
    /// The chain on the robot file `robot` (relative to the repository; `None`: the JK5)
    /// with extra controller and driver parameters.
    pub fn for_robot(robot: Option<&str>, controller: &[&str], driver: &[&str]) -> Chain<N> {
        let load = |a: &RosArgs, node| robot.map(|_| naic_ros::robot::from_args(a, node).unwrap().unwrap());
        let da = args_for(drv_shell::NODE, robot, driver);
        let d = drv_shell::Setup::<N>::for_arm(&da, load(&da, drv_shell::NODE)).unwrap();
        let dt = ParamTable::new(d.specs(), Some(d.check()), &da.overrides(drv_shell::NODE).unwrap()).unwrap();
        let dp = dt.with(drv_config::core_params);
        let order = dt.with(|v| drv_config::joint_order(v, &d.joints)).unwrap();
        let mut c_extra = vec!["scenario:=none"];
        c_extra.extend_from_slice(controller);
        let ca = args_for(ctl_shell::NODE, robot, &c_extra);
        let c = ctl_shell::Setup::<N>::for_arm(&ca, load(&ca, ctl_shell::NODE)).unwrap();
        let fa = args_for(fc_shell::NODE, robot, &[]);
        let f = fc_shell::Setup::<N>::for_arm(&fa, load(&fa, fc_shell::NODE)).unwrap();
        let fp = ParamTable::new(f.specs(), None, &fa.overrides(fc_shell::NODE).unwrap())
            .unwrap()
            .with(|v| fc_config::core_params(v, &f.sense, &f.joints))
            .unwrap();
        let cs = ctl::State::new(&c.params);
        let ws = c.params.controller.workspace();
        Chain {
            dp,
            plant: d.plant,
            fault: SensorFault::None,
            cmds: Commands::new(0, true),
            ds: drv::State::default(),
            cp: c.params,
            cs,
            ws,
            fp,
            fs: fc::State::default(),
            state: StateMsgs::in_order(order, &d.joints),
            names_edited: false,
            effort: msgs::EffortBuffer::new(N),
            cmd: Float64MultiArray::default(),
        }
    }

    /// The last `/joint_effort_cmd` the driver received.
    pub fn last_command(&self) -> &[f64] {
        &self.cmd.data
    }

    pub fn now_ns(&self) -> i64 {
        sim_stamp_ns(&self.plant)
    }

    /// One lockstep step: the reference samples (taken before the state, as the shell
    /// does), the state, controller, friction compensation, the plant. The report.
    pub fn step(&mut self, target: Option<&PoseStamped>, wrench: Option<&WrenchStamped>) -> Option<ctl::Report> {
        self.step_with(target, wrench, |_| {})
    }

    /// [`Chain::step`] with `edit` applied to the `/joint_states` the two consumers read
    /// (a joint renamed, say); the driver's own state is unchanged.
    pub fn step_with(&mut self, target: Option<&PoseStamped>, wrench: Option<&WrenchStamped>, edit: impl FnOnce(&mut msgs::JointState)) -> Option<ctl::Report> {
        let stamp = self.state.fill(&self.plant, true, self.fault);
        let names = self.state.js.name.len();
        edit(&mut self.state.js);
        self.names_edited |= self.state.js.name.len() != names || self.state.js.name.iter().zip(&self.cp.joints).any(|(a, b)| a != b);
        self.cmds.expect(Some(stamp));
        self.ds.last_published_stamp = Some(stamp);
        let (cp, ws) = (&self.cp, &mut self.ws);
        let mut c_step = |s: &mut ctl::State<N>, inbox: ctl::Inbox| {
            let (next, out) = ctl::step(cp, s, &inbox, stamp, ws);
            *s = next;
            out
        };
        c_step(&mut self.cs, ctl::Inbox { wrench: Some(&self.state.w), ..Default::default() });
        if target.is_some() || wrench.is_some() {
            let out = c_step(&mut self.cs, ctl::Inbox { target_pose: target, desired_wrench: wrench, ..Default::default() });
            assert!(out.events.target_rejected.is_none() && out.events.wrench_rejected.is_none(), "{:?}", out.events);
        }
        let mut out = c_step(&mut self.cs, ctl::Inbox { joint_states: Some(&self.state.js), ..Default::default() });
        if let Some(until) = out.wait_until_ns {
            // Only a frozen wrench leaves a joint state waiting for the wrench of its stamp:
            // the shell steps again with an empty inbox when the wait is over.
            assert_eq!(self.fault, SensorFault::StaleWrench, "the wrench of the stamp is in");
            let (next, o) = ctl::step(cp, &self.cs, &ctl::Inbox::default(), until, ws);
            (self.cs, out) = (next, o);
        }
        let report = out.report;
        if let Some((tau, src)) = out.effort {
            self.effort.set(&tau, Some(src), out.friction_velocity.as_ref().map(|v| &v[..]));
            let f = |s: &mut fc::State<N>, inbox: fc::Inbox, now: i64| {
                let (next, out) = fc::step(&self.fp, s, &inbox, now);
                *s = next;
                out
            };
            f(&mut self.fs, fc::Inbox { joint_states: Some(&self.state.js), ..Default::default() }, stamp);
            let mut o = f(&mut self.fs, fc::Inbox { command: Some(&self.effort.msg), ..Default::default() }, stamp);
            if let Some(until) = o.wait_until_ns {
                // Only an unusable joint state leaves a command waiting for the state of its
                // stamp: the shell steps again with an empty inbox when the wait is over.
                assert!(self.fault == SensorFault::NanJoint || self.names_edited, "the joint state of the stamp is in");
                o = f(&mut self.fs, fc::Inbox::default(), until);
            }
            if let Some((tau, src)) = o.command {
                msgs::set_effort_msg(&mut self.cmd, &tau, src, None);
                assert!(drv::receive(&mut self.cmds, &self.cmd, stamp).is_none());
            }
        }
        assert!(self.cmds.ready, "lockstep: a command for every state");
        self.cmds.ready = false;
        let (n, _) = drv::step(&self.dp, &self.ds, &self.cmds.view(), stamp, &mut self.plant);
        self.ds = n;
        report
    }
}

pub fn header(ns: i64) -> Header {
    Header { stamp: time_from_ns(ns), frame_id: "base_link".into() }
}

pub fn target(ns: i64, p: &Vector3<f64>, q: &UnitQuaternion<f64>) -> PoseStamped {
    PoseStamped {
        header: header(ns),
        pose: Pose { position: Point { x: p.x, y: p.y, z: p.z }, orientation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w } },
    }
}

pub fn push(ns: i64, f: f64) -> WrenchStamped {
    // The wrench the tool applies to the surface: down (force axis -z).
    WrenchStamped { header: header(ns), wrench: Wrench { force: V3 { x: 0.0, y: 0.0, z: -f }, torque: V3::default() } }
}

