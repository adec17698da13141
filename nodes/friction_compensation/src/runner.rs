//! friction_compensation's loop body, whatever carries the messages: the DDS shell
//! (`main.rs`) and `naic launch --composed` hand it the messages they received and publish
//! the command it leaves in its buffer.
//!
//! [`Runner`] owns the core's parameters and state and the outgoing `/joint_effort_cmd`
//! (filled in place). Per wake-up the shell calls [`Runner::reload`] (accepted parameter
//! values apply to the data that woke it), [`Runner::joint_states`] for each joint state and
//! [`Runner::command`] for the newest `/naic/effort`. The core's events are logged here.

use naic_core::pipeline::sense::SenseParams;
use naic_ros::{
    alloc_check,
    msgs::{self, Float64MultiArray, JointState},
    time::wall_ns,
    ParamTable,
};

use crate::{
    config, core,
    setup::{Setup, NODE},
};

/// The node between two wake-ups (an arm of `N` joints).
pub struct Runner<const N: usize = { naic_core::N_JOINTS }> {
    pub p: core::Params<N>,
    pub s: core::State<N>,
    sense: SenseParams<N>,
    /// The arm's joint names (the robot file's, or the JK5's).
    joints: [String; N],
    /// Generation of the parameter table last applied.
    gen: u64,
    cmd: Float64MultiArray,
    warned: bool,
}

impl<const N: usize> Runner<N> {
    /// From the node's setup; `params` is the node's parameter table as it starts. `Err`:
    /// the friction file does not load (named).
    pub fn new(setup: &Setup<N>, params: &ParamTable) -> Result<Runner<N>, naic_ros::params::ParamError> {
        let sense = setup.sense.clone();
        let joints = setup.joints.clone();
        let p = params.with(|v| config::core_params(v, &sense, &joints))?;
        Ok(Runner { p, s: core::State::default(), sense, joints, gen: params.generation(), cmd: Float64MultiArray::default(), warned: false })
    }

    /// Take the node's parameters when a set was accepted since the last call.
    pub fn reload(&mut self, params: &ParamTable) {
        if params.generation() != self.gen {
            self.gen = params.generation();
            match params.with(|v| config::core_params(v, &self.sense, &self.joints)) {
                Ok(np) => self.p = np,
                Err(e) => log::error!("{e}"),
            }
        }
    }

    fn step(&mut self, inbox: core::Inbox, now_ns: i64) -> core::Outbox<N> {
        let (p, s) = (&self.p, &self.s);
        let (next, out) = alloc_check::check(NODE, &mut self.warned, || core::step(p, s, &inbox, now_ns));
        self.s = next;
        log_event(&self.p, &out.event);
        out
    }

    /// A `/joint_states` sample (velocity filter, measured torque, lockstep pairing).
    pub fn joint_states(&mut self, js: &JointState) {
        self.step(core::Inbox { joint_states: Some(js), ..Default::default() }, wall_ns());
    }

    /// The newest `/naic/effort`; the `/joint_effort_cmd` to publish, if any. In lockstep the
    /// joint state of its stamp may still be on the way: `paired_joint_states(until_ns)` is
    /// then asked for it (wait for it until that wall time; `None`: it did not come).
    pub fn command(&mut self, m: &Float64MultiArray, mut paired_joint_states: impl FnMut(i64) -> Option<JointState>) -> Option<&Float64MultiArray> {
        let mut out = self.step(core::Inbox { command: Some(m), ..Default::default() }, wall_ns());
        while let Some(until) = out.wait_until_ns {
            let js = paired_joint_states(until);
            let now = if js.is_some() { wall_ns() } else { wall_ns().max(until) };
            out = self.step(core::Inbox { joint_states: js.as_ref(), ..Default::default() }, now);
        }
        let (tau, src) = out.command?;
        msgs::set_effort_msg(&mut self.cmd, &tau, src, None);
        Some(&self.cmd)
    }
}

pub fn log_event<const N: usize>(p: &core::Params<N>, e: &Option<core::Event>) {
    match e {
        Some(core::Event::BadCommand(e)) => log::warn!("ignoring /naic/effort: {e}"),
        Some(core::Event::MissingJoint(j)) => {
            log::error!("/joint_states has no '{}' (joint {} of the arm's joints {:?}): no friction feedforward", p.joints[*j], j + 1, p.joints)
        }
        None => {}
    }
}

#[cfg(test)]
mod tests {
    use naic_ros::{
        msgs::{effort_msg, effort_source_stamp, effort_values, Header, JOINT_NAMES},
        time::time_from_ns,
        ParameterValue, RosArgs,
    };

    use super::*;
    use naic_core::JointVec;

    /// The runner on the repository's JK5 files, with `-p` overrides `extra`, and the node's
    /// parameter table as `RosNode` would build it.
    fn runner(extra: &[&str]) -> (Runner, ParamTable) {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let files = [format!("urdf:={root}/urdf/jk5.urdf"), format!("friction_file:={root}/params/friction_jk5.yaml")];
        let args = RosArgs::with_params(files.into_iter().chain(extra.iter().map(|e| e.to_string()))).unwrap();
        let setup = Setup::from_args(&args).unwrap();
        let table = ParamTable::new(setup.specs(), Some(setup.check()), &args.overrides(NODE).unwrap()).unwrap();
        (Runner::new(&setup, &table).unwrap(), table)
    }

    /// At rest, measured torque `effort` on every joint, at `stamp` [ns].
    fn js(stamp: i64, effort: f64) -> JointState {
        JointState {
            header: Header { stamp: time_from_ns(stamp), frame_id: String::new() },
            name: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
            position: vec![0.0; 6],
            velocity: vec![0.0; 6],
            effort: vec![effort; 6],
        }
    }

    fn values(m: &Float64MultiArray) -> JointVec {
        let mut tau = [0.0; 6];
        effort_values(m, &mut tau).unwrap();
        tau
    }

    #[test]
    fn nothing_before_a_measured_torque_then_the_take_over_starts_from_it() {
        // The rate limit alone (no take-over blend).
        let (mut r, _) = runner(&["use_sim_time:=true", "takeover_blend:=0.0"]);
        assert!(r.command(&effort_msg(&[30.0; 6], Some(0)), |_| None).is_none(), "no measured torque yet: nothing is sent");
        // The joint state of the command's stamp comes while the command waits for it.
        let mut asked = 0;
        let m = r.command(&effort_msg(&[30.0; 6], Some(1_000_000)), |_| {
            asked += 1;
            Some(js(1_000_000, 2.0))
        });
        let m = m.expect("a command once the measured torque is in");
        assert_eq!(asked, 1);
        assert_eq!(effort_source_stamp(m), Some(1_000_000), "it answers the state of its stamp");
        // Rate limit (10 N m per command) from the measured 2 N m, never a jump to 30.
        let tau = values(m);
        assert!(tau.iter().all(|t| (t - 12.0).abs() < 1e-9), "{tau:?}");
    }

    #[test]
    fn an_accepted_parameter_applies_at_the_next_reload() {
        let (mut r, table) = runner(&["takeover_blend:=0.0"]);
        r.joint_states(&js(0, 0.0));
        assert!(r.p.enabled);
        table.set_atomically(&[("enabled".into(), ParameterValue::Boolean(false))]).unwrap();
        assert!(r.p.enabled, "not before the reload");
        r.reload(&table);
        assert!(!r.p.enabled);
        let tau = values(r.command(&effort_msg(&[1.0; 6], None), |_| None).unwrap());
        assert_eq!(tau, [1.0; 6], "no feedforward, within the rate limit: the controller's torque as it is");
    }
}
