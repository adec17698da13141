//! Stage 5 of the pipeline: the last guard before torques reach the drives.
//!
//! * A non-finite torque is never passed on: the previous command is held.
//! * Per-joint rate limit: |τ(t) − τ(t−λ)| ≤ `max_delta` [N·m per cycle].
//! * Per-joint saturation at the effort limit.
//! * [`Blend`]: after a take-over (a node that starts, or restarts after the driver held
//!   the arm), the command moves from the torque the arm had to the controller's over a
//!   set time, ahead of the rate limit.

use crate::{JointVec, N_JOINTS};

/// Limits of the actuation stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActuateParams<const N: usize = N_JOINTS> {
    /// Effort limit per joint [N·m].
    pub effort_limit: JointVec<N>,
    /// Largest change per control cycle [N·m] (`f64::INFINITY` disables it).
    pub max_delta: JointVec<N>,
}

/// The command sent last cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActuateState<const N: usize = N_JOINTS> {
    pub tau_prev: JointVec<N>,
    /// False until the first command has gone out (the rate limit starts from it).
    pub started: bool,
}

/// What the stage did this cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActuateReport<const N: usize = N_JOINTS> {
    pub tau: JointVec<N>,
    /// Joints whose command was saturated at the effort limit.
    pub saturated: [bool; N],
    /// Joints whose command was rate limited.
    pub rate_limited: [bool; N],
    /// The input had a NaN or Inf; the previous command was held.
    pub rejected_non_finite: bool,
}

impl<const N: usize> Default for ActuateState<N> {
    fn default() -> Self {
        Self { tau_prev: [0.0; N], started: false }
    }
}

impl<const N: usize> Default for ActuateReport<N> {
    fn default() -> Self {
        Self { tau: [0.0; N], saturated: [false; N], rate_limited: [false; N], rejected_non_finite: false }
    }
}

/// A take-over blend: `τ = τ_from + α(x)·(τ_cmd − τ_from)`, `x = (t − t0)/duration`,
/// `α = 3x² − 2x³` (smoothstep: the torque's rate is zero at both ends and at most
/// 1.5·|τ_cmd − τ_from|/duration in between). It follows the command as it moves, so the
/// output is the command itself once `x ≥ 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blend<const N: usize = N_JOINTS> {
    /// The torque the arm had at the take-over [N·m].
    pub from: JointVec<N>,
    /// When the take-over happened [ns, the caller's time base].
    pub t0_ns: i64,
}

impl<const N: usize> Blend<N> {
    /// The blended torque at `t_ns`, and whether the blend has ended (`duration_ns` ≤ 0:
    /// at once).
    pub fn apply(&self, tau: &JointVec<N>, t_ns: i64, duration_ns: i64) -> (JointVec<N>, bool) {
        let x = if duration_ns > 0 { t_ns.saturating_sub(self.t0_ns) as f64 / duration_ns as f64 } else { 1.0 };
        if x >= 1.0 {
            return (*tau, true);
        }
        let x = x.max(0.0);
        let a = x * x * (3.0 - 2.0 * x);
        (std::array::from_fn(|i| self.from[i] + a * (tau[i] - self.from[i])), false)
    }
}

/// Per-joint saturation: `|τ_i| ≤ limit_i`. Returns the torque and which joints were
/// clipped. A non-finite entry becomes 0 and counts as clipped (callers that can hold
/// the previous command instead, like [`step`], reject non-finite input before this).
/// Also the last guard of a driver, on whatever it is about to apply.
pub fn saturate<const N: usize>(limit: &JointVec<N>, tau: &JointVec<N>) -> (JointVec<N>, [bool; N]) {
    let mut out = [0.0; N];
    let mut clipped = [false; N];
    for i in 0..N {
        let t = if tau[i].is_finite() { tau[i] } else { 0.0 };
        out[i] = t.clamp(-limit[i], limit[i]);
        clipped[i] = out[i] != tau[i];
    }
    (out, clipped)
}

/// One cycle. Pure: `(params, state, input) -> (state, outputs)`.
pub fn step<const N: usize>(p: &ActuateParams<N>, s: &ActuateState<N>, tau_in: &JointVec<N>) -> (ActuateState<N>, ActuateReport<N>) {
    let mut r = ActuateReport::default();
    if tau_in.iter().any(|t| !t.is_finite()) {
        r.rejected_non_finite = true;
        r.tau = s.tau_prev;
        return (*s, r);
    }
    for i in 0..N {
        let mut t = tau_in[i];
        if s.started {
            let lo = s.tau_prev[i] - p.max_delta[i];
            let hi = s.tau_prev[i] + p.max_delta[i];
            if t < lo || t > hi {
                t = t.clamp(lo, hi);
                r.rate_limited[i] = true;
            }
        }
        r.tau[i] = t;
    }
    (r.tau, r.saturated) = saturate(&p.effort_limit, &r.tau);
    (ActuateState { tau_prev: r.tau, started: true }, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturates_rate_limits_and_never_passes_nan() {
        let p = ActuateParams { effort_limit: [10.0; 6], max_delta: [1.0; 6] };
        let (s, r) = step(&p, &ActuateState::default(), &[50.0, -50.0, 3.0, 0.0, 0.0, 0.0]);
        assert_eq!(&r.tau[..3], &[10.0, -10.0, 3.0]);
        assert!(r.saturated[0] && r.saturated[1] && !r.saturated[2]);
        let (s, r) = step(&p, &s, &[0.0, 0.0, 3.5, 0.0, 0.0, 0.0]);
        assert_eq!(&r.tau[..3], &[9.0, -9.0, 3.5]);
        assert!(r.rate_limited[0] && !r.rate_limited[2]);
        let (s2, r) = step(&p, &s, &[f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(r.rejected_non_finite);
        assert_eq!(r.tau, s.tau_prev);
        assert_eq!(s2, s);
        assert!(r.tau.iter().all(|t| t.is_finite()));
    }

    #[test]
    fn a_blend_starts_at_the_old_torque_follows_the_command_and_ends_on_it() {
        let b = Blend { from: [10.0; 6], t0_ns: 1_000 };
        let cmd = [-30.0, 10.0, 50.0, 0.0, 0.0, 0.0];
        assert_eq!(b.apply(&cmd, 1_000, 100), ([10.0; 6], false));
        let (mid, done) = b.apply(&cmd, 1_050, 100);
        assert!(!done);
        assert_eq!(&mid[..3], &[-10.0, 10.0, 30.0], "halfway: α(0.5) = 0.5");
        // Early on it moves slowly (smoothstep): 10 % of the time, 2.8 % of the way.
        let (early, _) = b.apply(&cmd, 1_010, 100);
        assert!((early[0] - (10.0 - 40.0 * 0.028)).abs() < 1e-12, "{early:?}");
        assert_eq!(b.apply(&cmd, 1_100, 100), (cmd, true));
        assert_eq!(b.apply(&cmd, 1_000, 0), (cmd, true), "duration 0: no blend");
        // A stamp before the take-over (a late message) is clamped to the start.
        assert_eq!(b.apply(&cmd, 900, 100).0, [10.0; 6]);
    }

    #[test]
    fn saturate_clips_each_joint_at_its_own_limit_and_zeroes_non_finite() {
        let lim = [100.0, 100.0, 50.0, 20.0, 20.0, 10.0];
        let (t, c) = saturate(&lim, &[1000.0, -1000.0, 49.0, -20.0, f64::NAN, f64::NEG_INFINITY]);
        assert_eq!(t, [100.0, -100.0, 49.0, -20.0, 0.0, 0.0]);
        assert_eq!(c, [true, true, false, false, true, true]);
    }
}
