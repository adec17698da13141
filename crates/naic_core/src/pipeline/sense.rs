//! Stage 1 of the pipeline: take the raw measurements, reject what cannot be
//! true, and condition what can.
//!
//! * Validity: NaN/Inf, joint positions outside their limits (plus a margin),
//!   joint speeds far above their limits, wrenches far beyond the sensor
//!   range, and stale data (older than the timeout) become a [`Fault`]; the
//!   controller then holds the arm instead of acting on them.
//! * Conditioning: the servo drive's joint velocity is noisy (paper §5.1,
//!   Fig 5a); a running median over `median_window` samples removes the
//!   spikes the paper median-filters. Window 1 passes the signal through.

use crate::{JointVec, N_JOINTS};

/// Longest median window supported (the history lives in a fixed array).
pub const MAX_MEDIAN_WINDOW: usize = 15;

/// Which measured signal a fault concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    JointPosition,
    JointVelocity,
    Wrench,
}

impl Signal {
    pub fn as_str(self) -> &'static str {
        match self {
            Signal::JointPosition => "joint position",
            Signal::JointVelocity => "joint velocity",
            Signal::Wrench => "wrench",
        }
    }
}

/// Why a cycle's measurements cannot be used. `Copy`, so the 1 kHz path never allocates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// NaN or ±Inf in `signal[index]`.
    NonFinite { signal: Signal, index: usize },
    /// `signal[index] = value` is outside what the hardware can produce (`limit`).
    OutOfRange { signal: Signal, index: usize, value: f64, limit: f64 },
    /// The newest sample of `signal` is `age` seconds old (more than the timeout).
    Stale { signal: Signal, age: f64 },
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Fault::NonFinite { signal, index } => {
                write!(f, "{}[{}] is not finite (NaN or Inf): check the sensor driver", signal.as_str(), index)
            }
            Fault::OutOfRange { signal, index, value, limit } => write!(
                f,
                "{}[{}] = {:.4} is beyond the plausible limit {:.4}: sensor fault or wrong units",
                signal.as_str(),
                index,
                value,
                limit
            ),
            Fault::Stale { signal, age } => {
                write!(f, "no fresh {} for {:.1} ms (timeout exceeded): is the publisher alive?", signal.as_str(), age * 1e3)
            }
        }
    }
}

/// Limits and filter settings of the sense stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SenseParams<const N: usize = N_JOINTS> {
    /// Joint position limits [rad] (from the URDF), widened by `q_margin`.
    pub q_min: JointVec<N>,
    pub q_max: JointVec<N>,
    pub q_margin: f64,
    /// Largest plausible |q̇| per joint [rad/s] (for example 2× the URDF velocity limit).
    pub dq_max: JointVec<N>,
    /// Largest plausible |wrench| component (force N, torque N·m), e.g. 1.5× the sensor range.
    pub wrench_max: [f64; 6],
    /// Median window for the joint velocity (1 = no filtering, at most [`MAX_MEDIAN_WINDOW`]).
    pub median_window: usize,
    /// Joint data older than this is stale [s].
    pub joint_timeout: f64,
    /// Wrench data older than this is stale [s] (ROS parameter `wrench_timeout`).
    pub wrench_timeout: f64,
}

impl<const N: usize> SenseParams<N> {
    /// The settings for a robot model: joint position limits as the URDF gives them,
    /// widened by `q_margin` = 0.1 rad; |q̇| up to 2× the URDF velocity limit
    /// (2π rad/s where it gives none), the ATI mini45 SI-145-5 range ×1.5 as the wrench
    /// limit, a 5-sample velocity median and 10 ms staleness (the paper's §4.1 setup).
    pub fn for_model(model: &crate::model::Model) -> SenseParams<N> {
        let mut q_min = [-std::f64::consts::PI; N];
        let mut q_max = [std::f64::consts::PI; N];
        let mut dq_max = [2.0 * std::f64::consts::PI; N];
        for (i, j) in model.joints().iter().take(N).enumerate() {
            q_min[i] = j.limits.lower;
            q_max[i] = j.limits.upper;
            if j.limits.velocity.is_finite() {
                dq_max[i] = 2.0 * j.limits.velocity;
            }
        }
        SenseParams {
            q_min,
            q_max,
            q_margin: 0.1,
            dq_max,
            // ATI mini45 SI-145-5: ±145 N (Fx, Fy), ±290 N (Fz), ±5 N·m; ×1.5.
            wrench_max: [217.5, 217.5, 435.0, 7.5, 7.5, 7.5],
            median_window: 5,
            joint_timeout: 0.01,
            wrench_timeout: 0.01,
        }
    }

    /// Checks the settings themselves; the message names the field and the fix.
    pub fn validate(&self) -> Result<(), crate::pipeline::ConfigError> {
        if self.median_window == 0 || self.median_window > MAX_MEDIAN_WINDOW {
            return Err(crate::pipeline::ConfigError::invalid("median_window", self.median_window, format!("must be in 1..={MAX_MEDIAN_WINDOW}")));
        }
        for (name, v) in [("joint_timeout", self.joint_timeout), ("wrench_timeout", self.wrench_timeout)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(crate::pipeline::ConfigError::invalid(format!("{name}"), v, "must be a positive number of seconds"));
            }
        }
        Ok(())
    }
}

/// The velocity history of the median filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SenseState<const N: usize = N_JOINTS> {
    hist: [JointVec<N>; MAX_MEDIAN_WINDOW],
    len: usize,
    next: usize,
}

impl<const N: usize> Default for SenseState<N> {
    fn default() -> Self {
        Self { hist: [[0.0; N]; MAX_MEDIAN_WINDOW], len: 0, next: 0 }
    }
}

/// Raw measurements of one cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawMeasurements<const N: usize = N_JOINTS> {
    /// Controller time now [s].
    pub t: f64,
    /// Joint positions [rad] and velocities [rad/s], and their stamp [s].
    pub q: JointVec<N>,
    pub dq: JointVec<N>,
    pub joints_stamp: f64,
    /// Raw F/T reading in the `ft_sensor` frame (Fx, Fy, Fz [N], Tx, Ty, Tz [N·m]) and its stamp [s].
    pub wrench: [f64; 6],
    pub wrench_stamp: f64,
}

/// Conditioned measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensed<const N: usize = N_JOINTS> {
    pub q: JointVec<N>,
    /// Median-filtered joint velocity.
    pub dq: JointVec<N>,
    /// The newest joint velocity unfiltered (two periods younger than `dq` behind the
    /// 5-sample median): the scheduled law's friction feedforward may use it while a joint
    /// slides (`feedforward::FastVelocity`).
    pub dq_raw: JointVec<N>,
    /// The unfiltered joint velocity 1 and 2 cycles before `dq_raw` (`dq_raw_prev[k − 1]`, k
    /// cycles before), from the median's own history; where that history is shorter (the
    /// first cycles, a median window below 3) the oldest sample it has, `dq_raw` itself at
    /// worst. The friction feedforward's lead uses them (`feedforward::FastVelocity::lead`).
    pub dq_raw_prev: [JointVec<N>; 2],
    pub wrench: [f64; 6],
}

/// The first thing wrong with a cycle's measurements, if any.
pub fn check<const N: usize>(p: &SenseParams<N>, m: &RawMeasurements<N>) -> Option<Fault> {
    use Signal::*;
    let groups: [(Signal, &[f64]); 3] = [(JointPosition, &m.q), (JointVelocity, &m.dq), (Wrench, &m.wrench)];
    for (signal, v) in groups {
        if let Some(index) = v.iter().position(|x| !x.is_finite()) {
            return Some(Fault::NonFinite { signal, index });
        }
    }
    // Joint i and wrench component i in turn (for N = 6 the order the JK5 always had).
    for i in 0..N.max(6) {
        if i < N {
            let (lo, hi) = (p.q_min[i] - p.q_margin, p.q_max[i] + p.q_margin);
            if m.q[i] < lo || m.q[i] > hi {
                let limit = if m.q[i] < lo { lo } else { hi };
                return Some(Fault::OutOfRange { signal: JointPosition, index: i, value: m.q[i], limit });
            }
            if m.dq[i].abs() > p.dq_max[i] {
                return Some(Fault::OutOfRange { signal: JointVelocity, index: i, value: m.dq[i], limit: p.dq_max[i] });
            }
        }
        if i < 6 && m.wrench[i].abs() > p.wrench_max[i] {
            return Some(Fault::OutOfRange { signal: Wrench, index: i, value: m.wrench[i], limit: p.wrench_max[i] });
        }
    }
    let age_j = m.t - m.joints_stamp;
    if !(age_j <= p.joint_timeout) {
        return Some(Fault::Stale { signal: JointPosition, age: age_j });
    }
    let age_w = m.t - m.wrench_stamp;
    if !(age_w <= p.wrench_timeout) {
        return Some(Fault::Stale { signal: Wrench, age: age_w });
    }
    None
}

/// Median of the first `n` values of `buf` (n ≤ [`MAX_MEDIAN_WINDOW`]); sorts a stack copy.
fn median(buf: &[f64; MAX_MEDIAN_WINDOW], n: usize) -> f64 {
    let mut s = *buf;
    let s = &mut s[..n];
    // Insertion sort: n ≤ 15, branch-predictable, no allocation.
    for i in 1..n {
        let mut j = i;
        while j > 0 && s[j - 1] > s[j] {
            s.swap(j - 1, j);
            j -= 1;
        }
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// One cycle of the sense stage. Pure: `(params, state, inputs) -> (state, outputs)`.
/// Faulty measurements do not enter the filter history.
pub fn step<const N: usize>(p: &SenseParams<N>, s: &SenseState<N>, m: &RawMeasurements<N>) -> (SenseState<N>, Result<Sensed<N>, Fault>) {
    let mut next = *s;
    let out = update(p, &mut next, m);
    (next, out)
}

/// [`step`] on a state the caller keeps: `next` is this cycle's state on entry and the next
/// cycle's on return (unchanged by a fault), without copying the filter history in and out.
pub fn update<const N: usize>(p: &SenseParams<N>, next: &mut SenseState<N>, m: &RawMeasurements<N>) -> Result<Sensed<N>, Fault> {
    if let Some(f) = check(p, m) {
        return Err(f);
    }
    let w = p.median_window.clamp(1, MAX_MEDIAN_WINDOW);
    next.hist[next.next] = m.dq;
    next.next = (next.next + 1) % w;
    next.len = (next.len + 1).min(w);
    let mut dq = [0.0; N];
    for (j, out) in dq.iter_mut().enumerate() {
        let mut col = [0.0; MAX_MEDIAN_WINDOW];
        for k in 0..next.len {
            col[k] = next.hist[k][j];
        }
        *out = median(&col, next.len);
    }
    // `next.next` is the slot after the newest; k cycles before it is k + 1 slots back.
    let back = |k: usize| next.hist[(next.next + 2 * w - 1 - k.min(next.len - 1)) % w];
    Ok(Sensed { q: m.q, dq, dq_raw: m.dq, dq_raw_prev: [back(1), back(2)], wrench: m.wrench })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(window: usize) -> SenseParams {
        SenseParams {
            q_min: [-3.14; 6],
            q_max: [3.14; 6],
            q_margin: 0.05,
            dq_max: [6.28; 6],
            wrench_max: [200.0, 200.0, 400.0, 6.0, 6.0, 6.0],
            median_window: window,
            joint_timeout: 0.01,
            wrench_timeout: 0.01,
        }
    }

    fn meas(t: f64) -> RawMeasurements {
        RawMeasurements { t, q: [0.1; 6], dq: [0.0; 6], joints_stamp: t, wrench: [0.0; 6], wrench_stamp: t }
    }

    #[test]
    fn median_filter_removes_isolated_spikes_and_window_one_passes_through() {
        let p = params(5);
        let mut s = SenseState::default();
        let mut last = [0.0; 6];
        for k in 0..20 {
            let mut m = meas(k as f64 * 1e-3);
            m.dq = [0.2; 6];
            if k % 7 == 3 {
                m.dq[2] = 5.0; // a spike
            }
            let (n, out) = step(&p, &s, &m);
            s = n;
            last = out.unwrap().dq;
            if k >= 4 {
                assert!((last[2] - 0.2).abs() < 1e-12, "spike leaked at k={k}: {}", last[2]);
            }
        }
        assert_eq!(last, [0.2; 6]);
        let mut m = meas(0.0);
        m.dq[0] = 1.234;
        let (_, out) = step(&params(1), &SenseState::default(), &m);
        assert_eq!(out.unwrap().dq[0], 1.234);
    }

    #[test]
    fn the_unfiltered_velocity_one_and_two_cycles_back() {
        for w in [5, 3, 2, 1] {
            let p = params(w);
            let mut s = SenseState::default();
            for k in 0..8 {
                let mut m = meas(k as f64 * 1e-3);
                m.dq[0] = 0.5 * k as f64;
                let (n, out) = step(&p, &s, &m);
                s = n;
                let out = out.unwrap();
                assert_eq!(out.dq_raw[0], 0.5 * k as f64);
                // c cycles back as far as the history reaches (w samples), the oldest it has beyond.
                let back = |c: usize| 0.5 * (k - c.min(k).min(w - 1)) as f64;
                assert_eq!(out.dq_raw_prev[0][0], back(1), "w = {w}, k = {k}");
                assert_eq!(out.dq_raw_prev[1][0], back(2), "w = {w}, k = {k}");
            }
        }
    }

    #[test]
    fn faults_are_named() {
        let p = params(3);
        let mut m = meas(1.0);
        m.wrench[2] = f64::NAN;
        assert_eq!(check(&p, &m), Some(Fault::NonFinite { signal: Signal::Wrench, index: 2 }));
        let mut m = meas(1.0);
        m.q[4] = 4.0;
        assert!(matches!(check(&p, &m), Some(Fault::OutOfRange { signal: Signal::JointPosition, index: 4, .. })));
        let mut m = meas(1.0);
        m.wrench_stamp = 0.95;
        let f = check(&p, &m).unwrap();
        assert!(matches!(f, Fault::Stale { signal: Signal::Wrench, .. }));
        assert!(f.to_string().contains("50.0 ms"), "{f}");
        let mut m = meas(1.0);
        m.joints_stamp = f64::NAN;
        assert!(matches!(check(&p, &m), Some(Fault::Stale { signal: Signal::JointPosition, .. })));
        // A faulty sample leaves the filter state untouched.
        let s = SenseState::default();
        let mut m = meas(1.0);
        m.dq[0] = f64::INFINITY;
        assert_eq!(step(&p, &s, &m).0, s);
    }

    #[test]
    fn bad_settings_are_rejected_with_the_field_name() {
        let mut p = params(0);
        assert!(p.validate().unwrap_err().to_string().contains("median_window"));
        p.median_window = 3;
        p.wrench_timeout = -1.0;
        assert!(p.validate().unwrap_err().to_string().contains("wrench_timeout"));
    }
}
