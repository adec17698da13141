//! Force-tracking metrics (`metrics.json`, issue 3).
//!
//! The force signal is the true contact force along the force axis
//! (`f_ext = n · F_robot_on_env`, positive when pushing) sampled every control
//! period. A run is split into phases: the first starts at the first contact,
//! the others at every desired-force step or environment-stiffness switch
//! after it (events before the first contact are dropped). Per phase:
//!
//! * `settling_time_{2,5}pct_s`: time from the phase start after which the
//!   force stays within ±2 % / ±5 % of the desired force until the phase ends;
//!   `null` if it is outside the band at the end of the phase.
//! * `overshoot_pct`: for a phase that starts with a desired-force step
//!   (first contact: from 0 N), the classic overshoot, peak excursion beyond
//!   the new desired force in the direction of the step, in % of the step
//!   size (0 if none); for a phase that starts with a stiffness switch
//!   (desired force unchanged) the peak |f − f_d| in % of |f_d|.
//! * `steady_state_error_n`: mean of `f − f_d` over the last 0.2 s of the
//!   phase (or its last half if shorter than 0.4 s).
//! * `rms_error_n`: RMS of `f − f_d` over the phase; `max_force_n`: peak `f`.
//!
//! The honest metrics ([`Honest`], issue 42 item 8; `honest` in `metrics.json`), per phase:
//!
//! * the band is `max(2 % |f_d|, 3 σ)` with `σ` the F/T noise along n ([`band_n`]): a band
//!   narrower than the sensor's noise scores the noise, not the controller;
//! * `settling_band_s`: the time from the phase start after which the force stays inside
//!   that band until the phase ends (`None`: outside at the end);
//! * at first contact, the impact is scored apart: the peak force over the first `d + 1`
//!   control periods after contact (`d` the loop delay), before the loop can answer at
//!   all, against the bound `k_e v₀ (d + 1) T + b_e v₀` (`v₀` the tip's speed along n at
//!   contact, `k_e`, `b_e` the true stiffness and damping; item 5's `k_e v₀ (d + ½) T` is the
//!   spring's mean over where in a period contact happens, `d + 1` its worst case, and a
//!   damped surface answers `b_e v₀` at once); the overshoot is then taken after
//!   those periods (`overshoot_after_impact_pct`).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What starts a phase.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseStart {
    /// The desired force steps from `from` (0 N for the first contact).
    ForceStep { from: f64 },
    /// The environment changes with the desired force unchanged.
    Disturbance,
}

/// A phase: start time, desired force during it, what starts it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSpec {
    pub t_start: f64,
    pub desired_force: f64,
    pub start: PhaseStart,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhaseMetrics {
    pub t_start_s: f64,
    pub desired_force_n: f64,
    pub settling_time_2pct_s: Option<f64>,
    pub settling_time_5pct_s: Option<f64>,
    pub overshoot_pct: f64,
    pub steady_state_error_n: f64,
    pub rms_error_n: f64,
    pub max_force_n: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerMetrics {
    pub contact_time_s: Option<f64>,
    pub phases: Vec<PhaseMetrics>,
    /// The honest metrics of each phase ([`Honest`]; empty where not computed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub honest: Vec<Honest>,
}

/// The honest metrics of one phase (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Honest {
    /// `max(2 % |f_d|, 3 σ)` [N].
    pub band_n: f64,
    /// Settling into `band_n` until the phase ends [s] (`None`: never).
    pub settling_band_s: Option<f64>,
    /// First contact only: the peak force over the first `d + 1` periods [N] ...
    pub impact_n: Option<f64>,
    /// ... and its bound `k_e v₀ (d + 1) T + b_e v₀` [N].
    pub impact_bound_n: Option<f64>,
    /// The overshoot (as `overshoot_pct`) after the impact's periods [%].
    pub overshoot_after_impact_pct: f64,
}

/// The settling band `max(2 % |f_d|, 3 σ)` [N] for F/T noise `sigma_n` along n.
pub fn band_n(f_d: f64, sigma_n: f64) -> f64 {
    (0.02 * f_d.abs()).max(3.0 * sigma_n)
}

/// What the honest metrics need besides the force: the loop delay `d` [periods], the period
/// `T` [s], the F/T noise σ along n [N], and at first contact the tip's speed along n `v₀`
/// [m/s], the true stiffness `k_e` [N/m] and damping `b_e` [N·s/m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HonestInputs {
    pub delay_cycles: usize,
    pub period: f64,
    pub noise_sigma_n: f64,
    pub v0: f64,
    pub k_e: f64,
    pub b_e: f64,
}

/// The honest metrics of every phase of `m` (computed by [`controller_metrics`] on `t`, `f`).
pub fn honest(t: &[f64], f: &[f64], m: &ControllerMetrics, h: &HonestInputs) -> Vec<Honest> {
    let index_of = |ts: f64| t.iter().position(|&ti| ti >= ts - 1e-9).unwrap_or(t.len());
    let mut out = Vec::with_capacity(m.phases.len());
    for (k, ph) in m.phases.iter().enumerate() {
        let i0 = index_of(ph.t_start_s);
        let i1 = m.phases.get(k + 1).map_or(t.len(), |p| index_of(p.t_start_s)).max(i0 + 1);
        let f_d = ph.desired_force_n;
        let band = band_n(f_d, h.noise_sigma_n);
        let tol = if f_d != 0.0 { band / f_d.abs() } else { f64::INFINITY };
        let settling_band_s = settling_time(t, f, f_d, tol, i0, i1);
        let (impact_n, impact_bound_n, overshoot_after_impact_pct) = if k == 0 {
            let w = (i0 + h.delay_cycles + 1).min(i1);
            let peak = f[i0..w].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let bound = h.k_e * h.v0.abs() * (h.delay_cycles as f64 + 1.0) * h.period + h.b_e * h.v0.abs();
            let after = if w + 1 < i1 {
                let spec = PhaseSpec { t_start: t[w], desired_force: f_d, start: PhaseStart::ForceStep { from: 0.0 } };
                phase_metrics(t, f, &spec, w, i1).overshoot_pct
            } else {
                0.0
            };
            (Some(peak), Some(bound), after)
        } else {
            (None, None, ph.overshoot_pct)
        };
        out.push(Honest { band_n: band, settling_band_s, impact_n, impact_bound_n, overshoot_after_impact_pct });
    }
    out
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MetricsFile {
    pub scenario: String,
    pub controllers: BTreeMap<String, ControllerMetrics>,
}

/// Settling time of `f` to `f_d` within ±`tol`·|f_d| over samples `[i0, i1)`,
/// measured from `t[i0]`; `None` if the last sample is outside the band.
pub fn settling_time(t: &[f64], f: &[f64], f_d: f64, tol: f64, i0: usize, i1: usize) -> Option<f64> {
    let band = tol * f_d.abs();
    let last_out = (i0..i1).rev().find(|&i| (f[i] - f_d).abs() > band);
    match last_out {
        None => Some(0.0),
        Some(i) if i + 1 >= i1 => None,
        Some(i) => Some(t[i + 1] - t[i0]),
    }
}

/// Metrics of one phase over samples `[i0, i1)`.
pub fn phase_metrics(t: &[f64], f: &[f64], spec: &PhaseSpec, i0: usize, i1: usize) -> PhaseMetrics {
    let f_d = spec.desired_force;
    let n = (i1 - i0).max(1) as f64;
    let mut sq = 0.0;
    let mut max_f = f64::NEG_INFINITY;
    for &fi in &f[i0..i1] {
        sq += (fi - f_d) * (fi - f_d);
        max_f = max_f.max(fi);
    }
    let overshoot_pct = match spec.start {
        PhaseStart::ForceStep { from } => {
            let step = f_d - from;
            let dir = step.signum();
            let peak = f[i0..i1].iter().map(|fi| dir * (fi - f_d)).fold(0.0, f64::max);
            if step.abs() > 0.0 { 100.0 * peak / step.abs() } else { 0.0 }
        }
        PhaseStart::Disturbance => {
            let peak = f[i0..i1].iter().map(|fi| (fi - f_d).abs()).fold(0.0, f64::max);
            100.0 * peak / f_d.abs().max(f64::MIN_POSITIVE)
        }
    };
    let t_end = t[i1 - 1];
    let window = 0.2_f64.min(0.5 * (t_end - t[i0]));
    let (mut ss, mut ns) = (0.0, 0usize);
    for i in i0..i1 {
        if t[i] >= t_end - window {
            ss += f[i] - f_d;
            ns += 1;
        }
    }
    PhaseMetrics {
        t_start_s: t[i0],
        desired_force_n: f_d,
        settling_time_2pct_s: settling_time(t, f, f_d, 0.02, i0, i1),
        settling_time_5pct_s: settling_time(t, f, f_d, 0.05, i0, i1),
        overshoot_pct,
        steady_state_error_n: if ns > 0 { ss / ns as f64 } else { f64::NAN },
        rms_error_n: (sq / n).sqrt(),
        max_force_n: max_f,
    }
}

/// Contact time and per-phase metrics of a recorded run.
///
/// `t`, `f` (true contact force along the force axis) and `in_contact` are
/// per control step. `events` are the desired-force steps and stiffness
/// switches after t = 0 (ascending); the first phase starts at the first
/// contact with desired force `f_d_at(contact)`.
pub fn controller_metrics(
    t: &[f64],
    f: &[f64],
    in_contact: &[bool],
    first_desired_force: impl Fn(f64) -> f64,
    events: &[PhaseSpec],
) -> ControllerMetrics {
    let Some(ic) = in_contact.iter().position(|c| *c) else {
        return ControllerMetrics { contact_time_s: None, phases: vec![], honest: vec![] };
    };
    let t_c = t[ic];
    let mut specs = vec![PhaseSpec {
        t_start: t_c,
        desired_force: first_desired_force(t_c),
        start: PhaseStart::ForceStep { from: 0.0 },
    }];
    specs.extend(events.iter().filter(|e| e.t_start > t_c).copied());
    let index_of = |ts: f64| t.iter().position(|&ti| ti >= ts - 1e-9).unwrap_or(t.len());
    let mut phases = Vec::with_capacity(specs.len());
    for (k, spec) in specs.iter().enumerate() {
        let i0 = index_of(spec.t_start);
        let i1 = specs.get(k + 1).map_or(t.len(), |s| index_of(s.t_start));
        if i1 > i0 + 1 {
            phases.push(phase_metrics(t, f, spec, i0, i1));
        }
    }
    ControllerMetrics { contact_time_s: Some(t_c), phases, honest: vec![] }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn time(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 * dt).collect()
    }

    #[test]
    fn first_order_response_settles_at_tau_ln_50_with_no_overshoot() {
        let dt = 1e-4;
        let t = time(20_000, dt);
        let tau = 0.1;
        let f: Vec<f64> = t.iter().map(|t| 10.0 * (1.0 - (-t / tau).exp())).collect();
        let spec = PhaseSpec { t_start: 0.0, desired_force: 10.0, start: PhaseStart::ForceStep { from: 0.0 } };
        let m = phase_metrics(&t, &f, &spec, 0, t.len());
        let s2 = m.settling_time_2pct_s.unwrap();
        let s5 = m.settling_time_5pct_s.unwrap();
        assert!((s2 - tau * 50f64.ln()).abs() < 2.0 * dt, "{s2}");
        assert!((s5 - tau * 20f64.ln()).abs() < 2.0 * dt, "{s5}");
        assert_eq!(m.overshoot_pct, 0.0);
        assert!(m.max_force_n < 10.0);
        assert!(m.steady_state_error_n.abs() < 1e-6);
    }

    #[test]
    fn second_order_overshoot_matches_the_formula() {
        // f = f_d (1 − e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t)), step 10 → 20 N
        let (zeta, w) = (0.3_f64, 40.0_f64);
        let wd = w * (1.0 - zeta * zeta).sqrt();
        let dt = 1e-5;
        let t = time(300_000, dt);
        let f: Vec<f64> = t
            .iter()
            .map(|&t| {
                let env = (-zeta * w * t).exp();
                10.0 + 10.0 * (1.0 - env * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin()))
            })
            .collect();
        let spec = PhaseSpec { t_start: 0.0, desired_force: 20.0, start: PhaseStart::ForceStep { from: 10.0 } };
        let m = phase_metrics(&t, &f, &spec, 0, t.len());
        let expected = 100.0 * (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
        assert!((m.overshoot_pct - expected).abs() < 0.01, "{} vs {expected}", m.overshoot_pct);
        assert!((m.max_force_n - 20.0 - expected / 10.0).abs() < 1e-3);
        // 2 % band (0.4 N): the last peak of the envelope outside it is before
        // the envelope bound 10 e^{-ζωt}/√(1−ζ²) = 0.4 crosses
        let s2 = m.settling_time_2pct_s.unwrap();
        let bound = (10.0 / (0.4 * (1.0 - zeta * zeta).sqrt())).ln() / (zeta * w);
        assert!(s2 <= bound + dt && s2 > 0.5 * bound, "{s2} vs {bound}");
        // settling time definition: inside the band from s2 on, outside just before
        let i = (s2 / dt).round() as usize;
        assert!(f[i..].iter().all(|v| (v - 20.0).abs() <= 0.4));
        assert!((f[i - 1] - 20.0).abs() > 0.4);
    }

    /// The band is the sensor's 3 σ where 2 % of f_d is below it; settling is the last exit
    /// from it (not the first entry); the impact is the first d + 1 periods, scored apart.
    #[test]
    fn honest_metrics_use_the_noise_band_and_score_the_impact_apart() {
        assert_eq!(band_n(10.0, 1.0 / 16.0), 0.2);
        assert_eq!(band_n(3.0, 1.0 / 16.0), 0.1875);
        let dt = 1e-3;
        let t = time(1000, dt);
        // Contact at 0.1 s; a ramp of 4 N/period for 3 periods (the impact), then 10 N with
        // an excursion to 10.15 N at 0.5 s (inside the 0.2 N band) and one to 10.3 N at
        // 0.6 s (outside): settling = 0.601 − 0.1 s.
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, _)| match i {
                0..=99 => 0.0,
                100..=102 => 4.0 * (i - 99) as f64,
                500 => 10.15,
                600 => 10.3,
                _ => 10.0,
            })
            .collect();
        let c: Vec<bool> = (0..t.len()).map(|i| i >= 100).collect();
        let m = controller_metrics(&t, &f, &c, |_| 10.0, &[]);
        let h = honest(&t, &f, &m, &HonestInputs { delay_cycles: 2, period: dt, noise_sigma_n: 1.0 / 16.0, v0: 0.04, k_e: 50_000.0, b_e: 0.0 });
        assert_eq!(h.len(), 1);
        assert!((h[0].settling_band_s.unwrap() - 0.501).abs() < 1e-9, "{:?}", h[0]);
        assert_eq!(h[0].impact_n, Some(12.0));
        assert!((h[0].impact_bound_n.unwrap() - 6.0).abs() < 1e-12);
        // After the impact's three periods the largest excursion is 10.3 N: 3 %.
        assert!((h[0].overshoot_after_impact_pct - 3.0).abs() < 1e-9, "{}", h[0].overshoot_after_impact_pct);
        // The classic overshoot includes the impact: 20 %.
        assert!((m.phases[0].overshoot_pct - 20.0).abs() < 1e-9);
    }

    #[test]
    fn never_settling_gives_null_and_disturbance_overshoot_is_peak_deviation() {
        let t = time(1000, 1e-3);
        // oscillates ±1 N around 10 N forever
        let f: Vec<f64> = t.iter().map(|t| 10.0 + (30.0 * t).sin()).collect();
        let spec = PhaseSpec { t_start: 0.0, desired_force: 10.0, start: PhaseStart::Disturbance };
        let m = phase_metrics(&t, &f, &spec, 0, t.len());
        assert_eq!(m.settling_time_2pct_s, None);
        assert_eq!(m.settling_time_5pct_s, None);
        assert!((m.overshoot_pct - 10.0).abs() < 0.01);
        assert!((m.rms_error_n - (0.5f64).sqrt()).abs() < 0.02);
    }

    #[test]
    fn phases_start_at_contact_and_at_later_events_only() {
        let dt = 1e-3;
        let t = time(5000, dt);
        let in_contact: Vec<bool> = t.iter().map(|&t| t >= 0.7).collect();
        let f: Vec<f64> = t.iter().map(|&t| if t < 0.7 { 0.0 } else if t < 3.0 { 10.0 } else { 20.0 }).collect();
        let events = [
            PhaseSpec { t_start: 0.5, desired_force: 10.0, start: PhaseStart::Disturbance },
            PhaseSpec { t_start: 3.0, desired_force: 20.0, start: PhaseStart::ForceStep { from: 10.0 } },
        ];
        let m = controller_metrics(&t, &f, &in_contact, |_| 10.0, &events);
        assert!((m.contact_time_s.unwrap() - 0.7).abs() < 1e-9);
        assert_eq!(m.phases.len(), 2);
        assert!((m.phases[0].t_start_s - 0.7).abs() < 1e-9);
        assert_eq!(m.phases[0].settling_time_2pct_s, Some(0.0));
        assert!((m.phases[1].t_start_s - 3.0).abs() < 1e-9);
        assert_eq!(m.phases[1].max_force_n, 20.0);
        let none = controller_metrics(&t, &f, &vec![false; t.len()], |_| 10.0, &events);
        assert_eq!(none.contact_time_s, None);
        // JSON shape: nulls where it never settles
        let json = serde_json::to_value(&m).unwrap();
        assert!(json["phases"][0].get("settling_time_2pct_s").is_some());
    }
}

/// `median [min–max]` of optional values over seeds, with how many never settled.
/// Median of `v` (sorted in place): the middle value, the mean of the middle two for an even
/// count, NaN for none; `+∞` entries (a phase that never settles) count as values. (statrs's
/// `OrderStatistics::median` panics on an empty slice.)
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

pub fn fmt_spread(vals: &[Option<f64>], decimals: usize) -> String {
    let mut v: Vec<f64> = vals.iter().flatten().copied().collect();
    let never = vals.len() - v.len();
    if v.is_empty() {
        return format!("never ({never}/{})", vals.len());
    }
    let med = median(&mut v);
    let mut s = format!("{med:.decimals$} [{:.decimals$}–{:.decimals$}]", v[0], v[v.len() - 1]);
    if never > 0 {
        s.push_str(&format!(", never in {never}/{}", vals.len()));
    }
    s
}

/// The markdown table of one scenario over several seeds (one [`MetricsFile`]
/// per seed): per controller and phase, median [min–max] of every metric.
pub fn spread_table(files: &[MetricsFile], with_header: bool) -> String {
    let mut t = String::new();
    if with_header {
        t.push_str("| scenario | controller | contact [s] | phase start [s] | f_d [N] | settle 2 % [s] | settle 5 % [s] | overshoot [%] | ss error [N] | RMS error [N] | max force [N] |\n");
        t.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    }
    let Some(first) = files.first() else { return t };
    for name in crate::controllers::CONTROLLERS.iter().filter(|n| first.controllers.contains_key(**n)) {
        let cms: Vec<&ControllerMetrics> = files.iter().filter_map(|f| f.controllers.get(*name)).collect();
        let n_ph = cms.iter().map(|c| c.phases.len()).min().unwrap_or(0);
        let contact: Vec<Option<f64>> = cms.iter().map(|c| c.contact_time_s).collect();
        let med = |mut v: Vec<f64>| median(&mut v);
        let contact_med = med(contact.iter().flatten().copied().collect());
        for i in 0..n_ph {
            let ph: Vec<&PhaseMetrics> = cms.iter().map(|c| &c.phases[i]).collect();
            let col = |f: &dyn Fn(&PhaseMetrics) -> Option<f64>| ph.iter().map(|p| f(p)).collect::<Vec<_>>();
            t.push_str(&format!(
                "| {} | {} | {:.3} | {:.3} | {:.0} | {} | {} | {} | {} | {} | {} |\n",
                first.scenario,
                name,
                contact_med,
                med(ph.iter().map(|p| p.t_start_s).collect()),
                ph[0].desired_force_n,
                fmt_spread(&col(&|p| p.settling_time_2pct_s), 3),
                fmt_spread(&col(&|p| p.settling_time_5pct_s), 3),
                fmt_spread(&col(&|p| Some(p.overshoot_pct)), 1),
                fmt_spread(&col(&|p| Some(p.steady_state_error_n)), 3),
                fmt_spread(&col(&|p| Some(p.rms_error_n)), 3),
                fmt_spread(&col(&|p| Some(p.max_force_n)), 2),
            ));
        }
    }
    t
}

#[cfg(test)]
mod spread_tests {
    use super::*;

    #[test]
    fn spread_reports_median_range_and_never() {
        assert_eq!(fmt_spread(&[Some(1.0), Some(3.0), Some(2.0)], 1), "2.0 [1.0–3.0]");
        assert_eq!(fmt_spread(&[Some(1.0), None, Some(2.0), Some(4.0)], 1), "2.0 [1.0–4.0], never in 1/4");
        assert_eq!(fmt_spread(&[None, None], 3), "never (2/2)");
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [f64::INFINITY, 0.2, f64::INFINITY]), f64::INFINITY, "most never settled");
        assert!(median(&mut []).is_nan());
    }
}
