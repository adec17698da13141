//! Stage 0 of the pipeline: the reference the controller follows, made from
//! what the user publishes on `/naic/target_pose` (`geometry_msgs/PoseStamped`)
//! and `/naic/desired_wrench` (`geometry_msgs/WrenchStamped`), both in the base
//! frame. What arrives is a reference, not a command:
//!
//! * a sample is checked first ([`sample`]): base frame, finite, unit
//!   quaternion, inside the workspace box, not older than the last one, force
//!   within range; a rejected sample is reported as a value and changes nothing;
//! * the accepted target becomes the goal. While the stream is live (the
//!   previous sample came less than `timeout` ago) the goal moves from where
//!   it is to the new target over [`SPAN`] times the samples' stamp interval,
//!   so a 50 Hz stream gives a smooth velocity instead of steps, and a sample
//!   that comes late does not stop it; after a pause the goal jumps and the
//!   limits alone shape the motion;
//! * the reference follows the goal within `max_speed` / `max_accel`
//!   (translation) and `max_angular_speed` / `max_angular_accel` (rotation),
//!   stopping on it without overshoot ([`limit`]); the force moves towards its
//!   target at most `max_force_rate`;
//! * when a stream stops, the last target is held (reported as stale after
//!   `timeout`); with no `/naic/desired_wrench` ever accepted, the force is
//!   `default_force` (the node's `desired_force` parameter).
//!
//! The output is the controller's [`Reference`] plus a [`ReferenceReport`]
//! (what is active, where it came from, why a sample was refused). Pure step
//! `(params, state, inbox, now) -> (state, outputs)`, no heap allocation.

pub mod limit;
pub mod sample;

use nalgebra::{UnitQuaternion, Vector3, Vector6};

use super::control::ForceAxis;
use super::controller::Reference;
pub use limit::Limits;
pub use sample::{DesiredWrench, Field, Rejection, TargetPose, Workspace};

/// Settings of the reference stage (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceParams {
    /// The only `header.frame_id` accepted (the URDF's root link, `base_link` for the JK5).
    pub base_frame: String,
    /// Translation: speed [m/s] and acceleration [m/s²] bounds.
    pub linear: Limits,
    /// Rotation: angular speed [rad/s] and acceleration [rad/s²] bounds.
    pub angular: Limits,
    /// Fastest change of the force reference [N/s] (`inf`: steps pass through).
    pub max_force_rate: f64,
    /// A stream with no sample for this long is stale [s]: its last target is held.
    pub timeout: f64,
    /// The force when no `/naic/desired_wrench` has been accepted [N].
    pub default_force: f64,
    /// Accepted force range along the force axis [N] (pushing positive).
    pub force_min: f64,
    pub force_max: f64,
    /// The direction the tool pushes along (the controller's force axis).
    pub force_axis: ForceAxis,
    /// Targets outside this box are refused.
    pub workspace: Workspace,
    /// Longest time one step advances the reference [s]: after a gap in the
    /// control loop the reference moves at most `max_speed · max_step`, never jumps.
    pub max_step: f64,
}

impl ReferenceParams {
    /// Defaults for a collaborative arm's tool: 0.1 m/s, 1 m/s², 0.5 rad/s, 5 rad/s²,
    /// 100 N/s, 0.5 s timeout, ±1.5 m box around the base, forces 0..100 N, 10 ms step.
    pub fn new(base_frame: &str, force_axis: ForceAxis, default_force: f64) -> Self {
        ReferenceParams {
            base_frame: base_frame.to_string(),
            linear: Limits { max_speed: 0.1, max_accel: 1.0 },
            angular: Limits { max_speed: 0.5, max_accel: 5.0 },
            max_force_rate: 100.0,
            timeout: 0.5,
            default_force,
            force_min: 0.0,
            force_max: 100.0,
            force_axis,
            workspace: Workspace { min: Vector3::repeat(-1.5), max: Vector3::repeat(1.5) },
            max_step: 0.01,
        }
    }

    /// Every bound positive (rates may be `inf`), ranges ordered; the message names the parameter.
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        let positive = [
            ("max_speed", self.linear.max_speed),
            ("max_accel", self.linear.max_accel),
            ("max_angular_speed", self.angular.max_speed),
            ("max_angular_accel", self.angular.max_accel),
            ("reference_timeout", self.timeout),
            ("max_step", self.max_step),
        ];
        for (name, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(crate::pipeline::ConfigError::invalid(format!("{name}"), v, "must be a positive finite number (SI units)"));
            }
        }
        if !(self.max_force_rate > 0.0) {
            return Err(crate::pipeline::ConfigError::invalid("max_force_rate", self.max_force_rate, "N/s must be > 0 (inf: no limit)"));
        }
        if !(self.force_min.is_finite() && self.force_max.is_finite() && self.force_min <= self.force_max) {
            return Err(crate::pipeline::ConfigError::invalid("force range", format!("[{}, {}]", self.force_min, self.force_max), "N must be finite and ordered"));
        }
        if !(self.default_force >= self.force_min && self.default_force <= self.force_max) {
            return Err(crate::pipeline::ConfigError::invalid("desired_force", self.default_force, format!("N is outside the accepted range [{}, {}] N", self.force_min, self.force_max)));
        }
        let ws = &self.workspace;
        if !(0..3).all(|i| ws.min[i].is_finite() && ws.max[i].is_finite() && ws.min[i] < ws.max[i]) {
            return Err(crate::pipeline::ConfigError::invalid("workspace box", format!("min {:?} / max {:?}", ws.min.as_slice(), ws.max.as_slice()), "must be finite with min < max"));
        }
        if self.base_frame.is_empty() {
            return Err(crate::pipeline::ConfigError::invalid("base_frame", "''", "is empty: give the URDF's root link (e.g. base_link)"));
        }
        Ok(())
    }

    fn n(&self) -> Vector3<f64> {
        self.force_axis.n
    }
}

/// Where the goal is: moving in a straight line (and a constant-rate rotation) from
/// `(p0, r0)` at `t0` to `(p1, r1)` at `t0 + duration`, then resting at `(p1, r1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Goal {
    pub p0: Vector3<f64>,
    pub r0: UnitQuaternion<f64>,
    pub p1: Vector3<f64>,
    pub r1: UnitQuaternion<f64>,
    pub t0: f64,
    pub duration: f64,
}

impl Goal {
    fn still(p: Vector3<f64>, r: UnitQuaternion<f64>) -> Self {
        Goal { p0: p, r0: r, p1: p, r1: r, t0: 0.0, duration: 0.0 }
    }

    /// Pose and twist (linear, angular; base frame) of the goal at `t`.
    fn at(&self, t: f64) -> (Vector3<f64>, UnitQuaternion<f64>, Vector3<f64>, Vector3<f64>) {
        let s = if self.duration > 0.0 { ((t - self.t0) / self.duration).clamp(0.0, 1.0) } else { 1.0 };
        if s >= 1.0 {
            return (self.p1, self.r1, Vector3::zeros(), Vector3::zeros());
        }
        let w = (self.r1 * self.r0.inverse()).scaled_axis();
        let r = UnitQuaternion::from_scaled_axis(w * s) * self.r0;
        (self.p0 + (self.p1 - self.p0) * s, r, (self.p1 - self.p0) / self.duration, w / self.duration)
    }
}

/// The last accepted sample of a stream: its stamp and when it was taken (the step's `now`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Received {
    pub stamp: f64,
    pub at: f64,
}

/// Everything the reference stage remembers (all of it, `Copy`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceState {
    /// Time of the last step (`None` before the first).
    pub t: Option<f64>,
    /// The reference pose and twist (base frame).
    pub p: Vector3<f64>,
    pub v: Vector3<f64>,
    pub r: UnitQuaternion<f64>,
    pub w: Vector3<f64>,
    /// The force reference [N] (`None` before the first step).
    pub f: Option<f64>,
    pub goal: Goal,
    pub target: Option<Received>,
    /// The last accepted desired force and its sample.
    pub wrench: Option<(f64, Received)>,
    pub rejected_targets: u32,
    pub rejected_wrenches: u32,
}

impl ReferenceState {
    /// At rest at `(p, r)` (the measured tip pose at start), heading for `goal` until a
    /// target arrives (the start pose itself, or e.g. a point `approach_depth` along n).
    pub fn new(p: Vector3<f64>, r: UnitQuaternion<f64>, goal: (Vector3<f64>, UnitQuaternion<f64>)) -> Self {
        ReferenceState {
            t: None,
            p,
            v: Vector3::zeros(),
            r,
            w: Vector3::zeros(),
            f: None,
            goal: Goal::still(goal.0, goal.1),
            target: None,
            wrench: None,
            rejected_targets: 0,
            rejected_wrenches: 0,
        }
    }
}

/// The samples that arrived since the last step (the newest of each topic).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inbox<'a> {
    pub target: Option<TargetPose<'a>>,
    pub wrench: Option<DesiredWrench<'a>>,
}

/// Where a part of the reference comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Pose: the start goal given to [`ReferenceState::new`]; force: `default_force`.
    Default,
    /// The topic's last accepted sample.
    Topic,
}

/// What this step did with a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    None,
    Accepted,
    Rejected(Rejection),
}

/// The active reference and where it came from (what `/naic/params` can report).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceReport {
    pub pose_source: Source,
    pub force_source: Source,
    /// The goal the reference is heading for (the held or interpolated target).
    pub goal_position: Vector3<f64>,
    pub goal_orientation: UnitQuaternion<f64>,
    /// The force target before the rate limit [N].
    pub goal_force: f64,
    /// Seconds since the last accepted sample (`inf`: none yet).
    pub target_age: f64,
    pub wrench_age: f64,
    /// The stream's last sample is older than `timeout`: its last target is held.
    pub target_stale: bool,
    pub wrench_stale: bool,
    pub target: Verdict,
    pub wrench: Verdict,
    pub rejected_targets: u32,
    pub rejected_wrenches: u32,
    /// The speed or acceleration limit (translation or rotation) or the force rate cut in this step.
    pub limited: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOutputs {
    pub reference: Reference,
    pub report: ReferenceReport,
}

/// A live stream's goal reaches each target this many stamp intervals after it arrived.
/// Over one interval (`1`) the goal would stand still, and the reference brake, whenever
/// the next sample came a cycle late (every sample, when samples are taken between two
/// control cycles as the node does); over two it keeps moving through a delay of up to one
/// interval, follows a steady stream at the stream's speed two intervals behind, and takes
/// a change of speed over a few intervals (the lag halves every interval) instead of in one.
pub const SPAN: f64 = 2.0;

fn age(r: Option<Received>, now: f64) -> f64 {
    r.map_or(f64::INFINITY, |r| now - r.at)
}

/// One step of the reference stage at time `now` [s] (the controller's clock).
/// A non-finite `now` advances nothing.
pub fn step(p: &ReferenceParams, s: &ReferenceState, inbox: &Inbox, now: f64) -> (ReferenceState, ReferenceOutputs) {
    let mut next = *s;
    let dt = match s.t {
        Some(t) if now.is_finite() => (now - t).clamp(0.0, p.max_step),
        _ => 0.0,
    };
    if now.is_finite() {
        next.t = Some(now);
    }

    // The target pose sample.
    let target = match &inbox.target {
        None => Verdict::None,
        Some(tp) => match tp.check(&p.base_frame, &p.workspace) {
            Err(e) => Verdict::Rejected(e),
            Ok(_) if s.target.is_some_and(|r| tp.stamp < r.stamp) => {
                Verdict::Rejected(Rejection::OutOfOrder { stamp: tp.stamp, last: s.target.map_or(0.0, |r| r.stamp) })
            }
            Ok((pos, rot)) => {
                // Live stream: move the goal from where it is over SPAN stamp intervals.
                let (gp, gr, _, _) = s.goal.at(now);
                let duration = match s.target {
                    Some(r) if age(Some(r), now) <= p.timeout => (SPAN * (tp.stamp - r.stamp)).min(p.timeout),
                    _ => 0.0,
                };
                // (Below 1 µs the interval is no interval: jump, and keep the velocity finite.)
                let duration = if duration >= 1e-6 { duration } else { 0.0 };
                next.goal = Goal { p0: gp, r0: gr, p1: pos, r1: rot, t0: now, duration };
                next.target = Some(Received { stamp: tp.stamp, at: now });
                Verdict::Accepted
            }
        },
    };
    if matches!(target, Verdict::Rejected(_)) {
        next.rejected_targets = s.rejected_targets.saturating_add(1);
    }

    // The desired wrench sample.
    let wrench = match &inbox.wrench {
        None => Verdict::None,
        Some(dw) => match dw.check(&p.base_frame, &p.n(), p.force_min, p.force_max) {
            Err(e) => Verdict::Rejected(e),
            Ok(_) if s.wrench.is_some_and(|(_, r)| dw.stamp < r.stamp) => {
                Verdict::Rejected(Rejection::OutOfOrder { stamp: dw.stamp, last: s.wrench.map_or(0.0, |(_, r)| r.stamp) })
            }
            Ok(f) => {
                next.wrench = Some((f, Received { stamp: dw.stamp, at: now }));
                Verdict::Accepted
            }
        },
    };
    if matches!(wrench, Verdict::Rejected(_)) {
        next.rejected_wrenches = s.rejected_wrenches.saturating_add(1);
    }

    // Follow the goal within the limits.
    let (gp, gr, gv, gw) = next.goal.at(now);
    let lin = limit::track(&p.linear, &(gp - s.p), &s.v, &gv, dt);
    let ang = limit::track(&p.angular, &(gr * s.r.inverse()).scaled_axis(), &s.w, &gw, dt);
    next.v = lin.v;
    next.p = s.p + lin.v * dt;
    next.w = ang.v;
    next.r = UnitQuaternion::from_scaled_axis(ang.v * dt) * s.r;
    let (a_lin, a_ang) = if dt > 0.0 { ((lin.v - s.v) / dt, (ang.v - s.w) / dt) } else { (Vector3::zeros(), Vector3::zeros()) };

    let goal_force = next.wrench.map_or(p.default_force, |(f, _)| f);
    let f = match s.f {
        None => goal_force,
        Some(f) => f + (goal_force - f).clamp(-p.max_force_rate * dt, p.max_force_rate * dt),
    };
    let force_limited = f != goal_force;
    next.f = Some(f);

    let (target_age, wrench_age) = (age(next.target, now), age(next.wrench.map(|(_, r)| r), now));
    let report = ReferenceReport {
        pose_source: if next.target.is_some() { Source::Topic } else { Source::Default },
        force_source: if next.wrench.is_some() { Source::Topic } else { Source::Default },
        goal_position: next.goal.p1,
        goal_orientation: next.goal.r1,
        goal_force,
        target_age,
        wrench_age,
        target_stale: target_age > p.timeout && target_age.is_finite(),
        wrench_stale: wrench_age > p.timeout && wrench_age.is_finite(),
        target,
        wrench,
        rejected_targets: next.rejected_targets,
        rejected_wrenches: next.rejected_wrenches,
        limited: lin.speed_limited || lin.accel_limited || ang.speed_limited || ang.accel_limited || force_limited,
    };
    let reference = Reference {
        p_d: next.p,
        r_d: next.r,
        v_d: Vector6::new(lin.v.x, lin.v.y, lin.v.z, ang.v.x, ang.v.y, ang.v.z),
        a_d: Vector6::new(a_lin.x, a_lin.y, a_lin.z, a_ang.x, a_ang.y, a_ang.z),
        f_d: f,
    };
    (next, ReferenceOutputs { reference, report })
}

#[cfg(test)]
mod tests;
