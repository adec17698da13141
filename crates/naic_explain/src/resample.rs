//! Real controllers do not log on a uniform clock: the Franka Panda's 1 kHz log has steps
//! of 0.7–8.8 ms, a 100 Hz cobot's 2–34 ms. The analysis filters (Savitzky–Golay, see
//! [`crate::prepare`]) need a uniform grid, so a recording is
//!
//! 1. **split at gaps**: a step longer than [`GAP_FACTOR`] median steps is a gap (the robot
//!    was not logging; nothing can be interpolated across it). The parts are analysed as
//!    separate segments (no filter window crosses a gap); parts shorter than the minimum
//!    length are dropped and listed.
//! 2. **resampled** when its steps are not uniform (any step off the median by more than
//!    [`UNIFORM_TOL`]): onto a grid of the median step, each grid value the exact mean of
//!    the linearly interpolated signal over its grid step (a box filter one grid step
//!    wide: the anti-aliasing filter of the resampling, the same on every column, so
//!    torque and positions keep the same phase). Uniform data is used unchanged.
//!
//! The step statistics (the jitter) are returned for the report.

use crate::input::{Rows, TimeSeries};
use crate::ExplainError;
use std::borrow::Cow;

/// A step longer than this many median steps is a gap.
pub const GAP_FACTOR: f64 = 20.0;

/// Steps within this relative distance of the median count as uniform.
pub const UNIFORM_TOL: f64 = 1e-3;

/// The sampling of one recording, as found.
#[derive(Clone, Debug, Default)]
pub struct Sampling {
    pub median_dt: f64,
    pub mean_dt: f64,
    pub min_dt: f64,
    pub max_dt: f64,
    /// 5th and 95th percentile of the steps [s].
    pub p05_dt: f64,
    pub p95_dt: f64,
    /// Steps longer than twice the median (not gaps).
    pub long_steps: usize,
    /// Whether the data were resampled.
    pub resampled: bool,
    /// Gaps the recording was split at: (time before, time after) [s].
    pub gaps: Vec<(f64, f64)>,
    /// Segments kept: (first time, last time, raw samples).
    pub segments: Vec<(f64, f64, usize)>,
    /// Segments dropped as too short: (first time, last time).
    pub dropped: Vec<(f64, f64)>,
}

impl Sampling {
    /// One line for the report's method table.
    pub fn describe(&self) -> String {
        let ms = |x: f64| x * 1e3;
        let mut s = format!(
            "steps median {:.3} ms, mean {:.3} ms, min {:.3} ms, max {:.3} ms, 90 % within {:.3}–{:.3} ms, {} step(s) > 2× median",
            ms(self.median_dt),
            ms(self.mean_dt),
            ms(self.min_dt),
            ms(self.max_dt),
            ms(self.p05_dt),
            ms(self.p95_dt),
            self.long_steps
        );
        if self.resampled {
            s.push_str(&format!(
                "; resampled onto a uniform {:.3} ms grid (each value the mean of the linearly interpolated signal over its grid step, the anti-aliasing box filter)",
                ms(self.median_dt)
            ));
        } else {
            s.push_str("; uniform, used as recorded");
        }
        if !self.gaps.is_empty() {
            let g: Vec<String> = self.gaps.iter().map(|(a, b)| format!("{a:.3}–{b:.3} s")).collect();
            s.push_str(&format!("; split at {} gap(s) > {GAP_FACTOR}× the median step: {}", self.gaps.len(), g.join(", ")));
        }
        if !self.dropped.is_empty() {
            let g: Vec<String> = self.dropped.iter().map(|(a, b)| format!("{a:.3}–{b:.3} s")).collect();
            s.push_str(&format!("; segment(s) too short to analyse, left out: {}", g.join(", ")));
        }
        s
    }
}

/// Rank of quantile `q` among `n` sorted values.
fn rank(n: usize, q: f64) -> usize {
    ((n - 1) as f64 * q).round() as usize
}

/// The 5 %, 50 % and 95 % quantiles of `x` (the values at those ranks of `x` sorted), by
/// selection in O(n) instead of a sort (an hour at 1 kHz has 3.6 M steps).
fn quantiles_05_50_95(x: &[f64]) -> (f64, f64, f64) {
    let mut v = x.to_vec();
    let n = v.len();
    let (i05, i50, i95) = (rank(n, 0.05), rank(n, 0.5), rank(n, 0.95));
    let (lo, med, hi) = v.select_nth_unstable_by(i50, f64::total_cmp);
    let med = *med;
    // ranks below the median are in `lo` (same rank), above it in `hi` (rank − i50 − 1)
    let p05 = if i05 < i50 { *lo.select_nth_unstable_by(i05, f64::total_cmp).1 } else { med };
    let p95 = if i95 > i50 { *hi.select_nth_unstable_by(i95 - i50 - 1, f64::total_cmp).1 } else { med };
    (p05, med, p95)
}

/// Splits `ts` at gaps and resamples non-uniform parts (see the module docs). Segments
/// shorter than `min_len_s` are dropped; if none is left that is an input error naming
/// the gaps. A recording that is one uniform segment is borrowed, not copied.
pub fn uniform_segments<'a>(name: &str, ts: &'a TimeSeries, min_len_s: f64) -> Result<(Vec<Cow<'a, TimeSeries>>, Sampling), ExplainError> {
    let n = ts.len();
    if n < 2 {
        return Err(ExplainError::input(format!("{name}: {n} sample(s); a time series needs many more (record longer)")));
    }
    let steps: Vec<f64> = ts.t.windows(2).map(|w| w[1] - w[0]).collect();
    let (p05, med, p95) = quantiles_05_50_95(&steps);
    let mut s = Sampling {
        median_dt: med,
        mean_dt: (ts.t[n - 1] - ts.t[0]) / (n - 1) as f64,
        min_dt: steps.iter().copied().fold(f64::INFINITY, f64::min),
        max_dt: steps.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        p05_dt: p05,
        p95_dt: p95,
        long_steps: steps.iter().filter(|&&d| d > 2.0 * med && d <= GAP_FACTOR * med).count(),
        ..Default::default()
    };
    // cut at gaps
    let mut cuts = vec![0usize];
    for (i, &d) in steps.iter().enumerate() {
        if d > GAP_FACTOR * med {
            s.gaps.push((ts.t[i], ts.t[i + 1]));
            cuts.push(i + 1);
        }
    }
    cuts.push(n);
    let mut out = Vec::new();
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (t0, t1) = (ts.t[a], ts.t[b - 1]);
        if t1 - t0 < min_len_s || b - a < 8 {
            s.dropped.push((t0, t1));
            continue;
        }
        let uniform = steps[a..b - 1].iter().all(|&d| (d - med).abs() <= UNIFORM_TOL * med);
        let seg = if uniform && a == 0 && b == n {
            Cow::Borrowed(ts)
        } else if uniform {
            Cow::Owned(slice(ts, a, b))
        } else {
            Cow::Owned(resample(ts, a, b, med))
        };
        s.resampled |= !uniform;
        s.segments.push((t0, t1, b - a));
        out.push(seg);
    }
    if out.is_empty() {
        return Err(ExplainError::input(format!(
            "{name}: no part of the recording between gaps lasts {min_len_s} s or more ({} gap(s) longer than {GAP_FACTOR}× \
             the median step {:.4} s, e.g. {}); record without interruptions",
            s.gaps.len(),
            med,
            s.gaps.first().map(|(x, y)| format!("{x} s → {y} s")).unwrap_or_else(|| "none: the recording is too short".into())
        )));
    }
    Ok((out, s))
}

fn slice(ts: &TimeSeries, a: usize, b: usize) -> TimeSeries {
    let rows = |r: &Rows| {
        let mut o = Rows::with_capacity(r.width(), b - a);
        for i in a..b {
            o.push(&r[i]);
        }
        o
    };
    TimeSeries {
        t: ts.t[a..b].to_vec(),
        q: rows(&ts.q),
        dq: rows(&ts.dq),
        tau: rows(&ts.tau),
        wrench: ts.wrench.as_ref().map(|w| w[a..b].to_vec()),
        ignored_columns: ts.ignored_columns.clone(),
    }
}

/// Box-averaged resampling of raw samples `a..b` onto a grid of step `dt`: grid value k is
/// `(1/dt)∫ y(t) dt` over `[c_k − dt/2, c_k + dt/2]`, y linear between raw samples.
fn resample(ts: &TimeSeries, a: usize, b: usize, dt: f64) -> TimeSeries {
    let nj = ts.nj();
    let nw = if ts.wrench.is_some() { 6 } else { 0 };
    let width = 3 * nj + nw;
    let row = |i: usize, out: &mut [f64]| {
        out[..nj].copy_from_slice(&ts.q[i]);
        out[nj..2 * nj].copy_from_slice(&ts.dq[i]);
        out[2 * nj..3 * nj].copy_from_slice(&ts.tau[i]);
        if let Some(w) = &ts.wrench {
            out[3 * nj..].copy_from_slice(&w[i]);
        }
    };
    let (t0, t1) = (ts.t[a], ts.t[b - 1]);
    let m = ((t1 - t0) / dt).floor() as usize; // grid centres t0 + dt/2 + k·dt, k < m
    let mut out = TimeSeries {
        q: Rows::with_capacity(nj, m),
        dq: Rows::with_capacity(nj, m),
        tau: Rows::with_capacity(nj, m),
        wrench: ts.wrench.as_ref().map(|_| Vec::with_capacity(m)),
        ignored_columns: ts.ignored_columns.clone(),
        ..Default::default()
    };
    // streaming cumulative integral: cum = ∫_{t0}^{t_i} y, advanced interval by interval
    let (mut ya, mut yb) = (vec![0.0; width], vec![0.0; width]);
    let mut cum = vec![0.0; width];
    let mut i = a;
    row(i, &mut ya);
    row(i + 1, &mut yb);
    // ∫_{t0}^{x} y for x in [t_i, t_{i+1}]
    let mut c_prev = vec![0.0; width];
    let mut c_now = vec![0.0; width];
    let mut val = vec![0.0; width];
    let integral_at = |x: f64, c: &mut [f64], i: &mut usize, ya: &mut [f64], yb: &mut [f64], cum: &mut [f64]| {
        while *i + 2 < b && ts.t[*i + 1] <= x {
            let h = ts.t[*i + 1] - ts.t[*i];
            for k in 0..width {
                cum[k] += 0.5 * h * (ya[k] + yb[k]);
            }
            *i += 1;
            ya.copy_from_slice(yb);
            row(*i + 1, yb);
        }
        let h = ts.t[*i + 1] - ts.t[*i];
        let u = (x - ts.t[*i]).clamp(0.0, h);
        for k in 0..width {
            c[k] = cum[k] + u * (ya[k] + 0.5 * u * (yb[k] - ya[k]) / h);
        }
    };
    integral_at(t0, &mut c_prev, &mut i, &mut ya, &mut yb, &mut cum);
    for k in 0..m {
        let e = t0 + (k + 1) as f64 * dt;
        integral_at(e, &mut c_now, &mut i, &mut ya, &mut yb, &mut cum);
        for x in 0..width {
            val[x] = (c_now[x] - c_prev[x]) / dt;
        }
        std::mem::swap(&mut c_prev, &mut c_now);
        out.t.push(t0 + (k as f64 + 0.5) * dt);
        out.q.push(&val[..nj]);
        out.dq.push(&val[nj..2 * nj]);
        out.tau.push(&val[2 * nj..3 * nj]);
        if let Some(w) = &mut out.wrench {
            let mut r = [0.0; 6];
            r.copy_from_slice(&val[3 * nj..]);
            w.push(r);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(t: Vec<f64>, f: impl Fn(f64) -> f64) -> TimeSeries {
        let mut ts = TimeSeries::default();
        for &x in &t {
            ts.q.push([f(x), 2.0 * f(x)]);
            ts.dq.push([0.0, 0.0]);
            ts.tau.push([f(x) + 1.0, 0.0]);
        }
        ts.t = t;
        ts
    }

    #[test]
    fn jittered_linear_signal_is_resampled_exactly() {
        // steps alternating 0.7 / 1.3 ms: a linear signal's box mean is its centre value
        let mut t = vec![0.0];
        for k in 0..3000 {
            t.push(t[k] + if k % 2 == 0 { 0.0007 } else { 0.0013 });
        }
        let ts = series(t, |x| 3.0 * x - 0.5);
        let (segs, s) = uniform_segments("x", &ts, 0.5).expect("ok");
        assert!(s.resampled && segs.len() == 1 && s.gaps.is_empty());
        let g = &segs[0];
        for i in 0..g.len() {
            assert!((g.q[i][0] - (3.0 * g.t[i] - 0.5)).abs() < 1e-10, "sample {i}");
            assert!((g.tau[i][0] - g.q[i][0] - 1.0).abs() < 1e-10);
        }
        let steps: Vec<f64> = g.t.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(steps.iter().all(|d| (d - s.median_dt).abs() < 1e-12));
    }

    #[test]
    fn selected_quantiles_are_those_of_the_sorted_steps() {
        let mut r = naic_core::rng::Rng::seed(4);
        for n in [1usize, 2, 3, 20, 21, 1000, 1001] {
            let x: Vec<f64> = (0..n).map(|_| r.range(0.5e-3, 2e-3)).collect();
            let mut sorted = x.clone();
            sorted.sort_by(f64::total_cmp);
            let q = |p: f64| sorted[rank(n, p)];
            assert_eq!(quantiles_05_50_95(&x), (q(0.05), q(0.5), q(0.95)), "n = {n}");
        }
    }

    #[test]
    fn gaps_split_and_short_parts_are_dropped() {
        let mut t: Vec<f64> = (0..2000).map(|k| k as f64 * 1e-3).collect();
        t.extend((0..100).map(|k| 2.5 + k as f64 * 1e-3)); // 0.1 s part after a 0.5 s gap
        t.extend((0..3000).map(|k| 4.0 + k as f64 * 1e-3));
        let ts = series(t, |x| x.sin());
        let (segs, s) = uniform_segments("x", &ts, 0.5).expect("ok");
        assert_eq!(s.gaps.len(), 2);
        assert_eq!(segs.len(), 2);
        assert_eq!(s.dropped.len(), 1);
        assert!(!s.resampled);
        assert_eq!(segs[0].len() + segs[1].len(), 5000);
    }
}
