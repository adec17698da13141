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
    let r = root();
    let mut a: Vec<String> = vec!["--ros-args".into(), "--params-file".into(), r.join(format!("params/{node}.yaml")).display().to_string()];
    let mut p = |s: String| a.extend(["-p".to_string(), s]);
    p("use_sim_time:=true".into());
    p(format!("urdf:={}", r.join("urdf/jk5.urdf").display()));
    if node == drv_shell::NODE {
        p("lockstep:=true".into());
    }
    p(format!("friction_file:={}", r.join("params/friction_jk5.yaml").display()));
    for e in extra {
        p(e.to_string());
    }
    RosArgs::parse(a).unwrap()
}

/// The three cores in lockstep, as `naic launch --composed --lockstep` runs them.
pub struct Chain {
    dp: drv::Params,
    pub plant: jk5_sim_driver::sim_plant::SimPlant,
    /// The failing sensor the driver plays (its `sensor_fault` parameter).
    pub fault: SensorFault,
    cmds: Commands,
    ds: drv::State,
    pub cp: ctl::Params,
    pub cs: ctl::State,
    ws: naic_core::pipeline::controller::Workspace,
    fp: fc::Params,
    fs: fc::State,
    state: StateMsgs,
    effort: Float64MultiArray,
    cmd: Float64MultiArray,
}

impl Chain {
    /// The chain with extra controller parameters (`name:=value`; the scenario is `none`
    /// unless they set another).
    pub fn new(controller: &[&str]) -> Chain {
        let da = args(drv_shell::NODE, &[]);
        let d = drv_shell::Setup::from_args(&da).unwrap();
        let dp = ParamTable::new(d.specs(), None, &da.overrides(drv_shell::NODE).unwrap()).unwrap().with(drv_config::core_params);
        let mut c_extra = vec!["scenario:=none"];
        c_extra.extend_from_slice(controller);
        let c = ctl_shell::Setup::from_args(&args(ctl_shell::NODE, &c_extra)).unwrap();
        let fa = args(fc_shell::NODE, &[]);
        let f = fc_shell::Setup::from_args(&fa).unwrap();
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
            state: StateMsgs::default(),
            effort: Float64MultiArray::default(),
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
        let stamp = self.state.fill(&self.plant, true, self.fault);
        self.cmds.expect(Some(stamp));
        self.ds.last_published_stamp = Some(stamp);
        let (cp, ws) = (&self.cp, &mut self.ws);
        let mut c_step = |s: &mut ctl::State, inbox: ctl::Inbox| {
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
            msgs::set_effort_msg(&mut self.effort, &tau, Some(src), out.friction_velocity.as_ref().map(|v| &v[..]));
            let f = |s: &mut fc::State, inbox: fc::Inbox, now: i64| {
                let (next, out) = fc::step(&self.fp, s, &inbox, now);
                *s = next;
                out
            };
            f(&mut self.fs, fc::Inbox { joint_states: Some(&self.state.js), ..Default::default() }, stamp);
            let mut o = f(&mut self.fs, fc::Inbox { command: Some(&self.effort), ..Default::default() }, stamp);
            if let Some(until) = o.wait_until_ns {
                // Only an unusable joint state leaves a command waiting for the state of its
                // stamp: the shell steps again with an empty inbox when the wait is over.
                assert_eq!(self.fault, SensorFault::NanJoint, "the joint state of the stamp is in");
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

