//! The closed loop, in process and deterministic: plant + sensor →
//! controller → torque, one control period per iteration, recording every
//! period; then metrics, CSV and plots.

use crate::metrics::{controller_metrics, ControllerMetrics, PhaseSpec, PhaseStart};
use crate::plant::{self, Observation, PlantParams, PlantState, PlantWorkspace, RawMeasurements};
use crate::plants::Plant;
use crate::scenario::{Reference, Scenario};
use naic_core::pipeline::control::Phase;
use naic_core::pipeline::controller::Status;
use naic_core::{JointVec, N_JOINTS};

/// A force-tracking controller as the simulator drives it: measured signals
/// and the reference in, torque out. Implementations keep their own state and
/// preallocated workspace (the pure `(params, state, inputs)` step lives
/// inside; this trait only threads the state through).
pub trait Controller<const N: usize = N_JOINTS> {
    /// Name used in files and legends (`naic`, `aic`, `fixed`).
    fn name(&self) -> &str;
    /// The torque to the drives and the controller's report of this period.
    fn step(&mut self, meas: &RawMeasurements<N>, reference: &Reference) -> (JointVec<N>, Status);
    /// The simulator's true stiffness under the tip before each step: only the
    /// `oracle` benchmark uses it (default: ignored).
    fn set_true_stiffness(&mut self, _k_e: f64) {}
}

/// One recorded control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record<const N: usize = N_JOINTS> {
    pub t: f64,
    pub q: JointVec<N>,
    pub dq: JointVec<N>,
    pub tau: JointVec<N>,
    pub tip: [f64; 3],
    /// Reference tip position.
    pub p_d: [f64; 3],
    /// True force the robot applies to the environment along the force axis [N].
    pub f_ext: f64,
    /// The controller's estimate of it [N].
    pub f_ext_est: f64,
    pub f_d: f64,
    /// Surface height under the tip [m].
    pub surface_z: f64,
    pub penetration: f64,
    pub in_contact: bool,
    pub k_e: f64,
    /// The contact is with a block's side face, not a top ([`crate::environment::Contact::on_side`]).
    pub on_side: bool,
    /// Raw F/T reading (sensor frame).
    pub wrench: [f64; 6],
    pub m_d: f64,
    pub b_d: f64,
    pub sigma: f64,
    pub gamma: f64,
    pub gamma_bound: f64,
    pub phase: Phase,
    pub saturated: bool,
    /// The scheduled law's stiffness estimate [N/m] and its confidence [0, 1] (0 otherwise).
    pub k_e_hat: f64,
    pub k_e_confidence: f64,
    /// The model's gain along n the scheduled law acts with (1 otherwise).
    pub model_gain: f64,
    /// The factor on the model's gravity torque the scheduled law applies (1 otherwise).
    pub gravity_scale: f64,
}

impl<const N: usize> Default for Record<N> {
    fn default() -> Self {
        Self {
            t: 0.0,
            q: [0.0; N],
            dq: [0.0; N],
            tau: [0.0; N],
            tip: [0.0; 3],
            p_d: [0.0; 3],
            f_ext: 0.0,
            f_ext_est: 0.0,
            f_d: 0.0,
            surface_z: 0.0,
            penetration: 0.0,
            in_contact: false,
            k_e: 0.0,
            on_side: false,
            wrench: [0.0; 6],
            m_d: 0.0,
            b_d: 0.0,
            sigma: 0.0,
            gamma: 0.0,
            gamma_bound: 0.0,
            phase: Phase::default(),
            saturated: false,
            k_e_hat: 0.0,
            k_e_confidence: 0.0,
            model_gain: 0.0,
            gravity_scale: 0.0,
        }
    }
}

/// The outcome of one closed-loop run.
#[derive(Clone, Debug)]
pub struct RunResult<const N: usize = N_JOINTS> {
    pub controller: String,
    pub records: Vec<Record<N>>,
    pub metrics: ControllerMetrics,
    /// A joint left its position limits at some point.
    pub limit_violation: bool,
    /// Some torque command saturated at some point.
    pub saturated: bool,
}

fn record<const N: usize>(s: &Scenario<N>, k: usize, obs: &Observation<N>, rep: &Status, reference: &Reference, plant: &dyn Plant<N>) -> Record<N> {
    let tr = &obs.truth;
    let tip = tr.tip.translation.vector;
    let (mut q, mut dq) = ([0.0; N], [0.0; N]);
    q.copy_from_slice(plant.q());
    dq.copy_from_slice(plant.dq());
    Record {
        t: k as f64 * s.task.dt,
        q,
        dq,
        tau: tr.tau_applied,
        tip: tip.into(),
        p_d: reference.p_d.into(),
        // F_robot_on_env = −F_contact
        f_ext: -s.task.force_axis.dot(&tr.contact.force),
        f_ext_est: rep.f_ext,
        f_d: reference.f_d,
        surface_z: s.env.height_at(tip.x, tip.y),
        penetration: tr.contact.penetration,
        in_contact: tr.contact.in_contact,
        k_e: tr.contact.k_e,
        on_side: tr.contact.on_side,
        wrench: obs.meas.wrench,
        m_d: rep.m_d,
        b_d: rep.b_d,
        sigma: rep.sigma,
        gamma: rep.gamma,
        gamma_bound: rep.gamma_bound,
        phase: rep.phase,
        saturated: tr.saturated,
        k_e_hat: rep.k_e_hat,
        k_e_confidence: rep.k_e_confidence,
        model_gain: rep.model_gain,
        gravity_scale: rep.gravity_scale,
    }
}

/// Run `scenario` with `controller` on the plant `p` from rest at
/// `scenario.task.q0`. `progress(fraction)` is called about 100 times.
/// The loop itself does not allocate (the record buffer is reserved up front).
pub fn run(s: &Scenario, p: &PlantParams, controller: &mut dyn Controller, progress: &mut dyn FnMut(f64)) -> RunResult {
    let mut plant = crate::arm::SimArm::new(p.clone(), s.task.q0, s.seed);
    run_on(s, &mut plant, controller, progress)
}

/// [`run`] on any plant (built by [`crate::plants::PlantChoice::build`] at rest at
/// `scenario.task.q0`, seeded with `scenario.seed`).
pub fn run_on<const N: usize>(s: &Scenario<N>, plant: &mut dyn Plant<N>, controller: &mut dyn Controller<N>, progress: &mut dyn FnMut(f64)) -> RunResult<N> {
    let n = s.steps();
    let mut records = Vec::with_capacity(n + 1);
    let mut limit_violation = false;
    let mut saturated = false;
    let every = (n / 100).max(1);
    for k in 0..=n {
        let reference = s.reference(k as f64 * s.task.dt);
        let obs = *plant.observation();
        controller.set_true_stiffness(obs.truth.contact.k_e);
        let (tau, rep) = controller.step(&obs.meas, &reference);
        records.push(record(s, k, &obs, &rep, &reference, &*plant));
        limit_violation |= obs.truth.limit_violation;
        saturated |= obs.truth.saturated;
        if k == n {
            break;
        }
        plant.step(&tau);
        if k % every == 0 {
            progress(k as f64 / n as f64);
        }
    }
    progress(1.0);
    let metrics = metrics_of(s, &records);
    RunResult { controller: controller.name().to_string(), records, metrics, limit_violation, saturated }
}

/// The changes of the material under the tip in contact (two-material surface), each a
/// phase start like a scheduled stiffness step: `(t, f_d)` at the first period off the old
/// material's top — on the stiffer block's side face ([`Record::on_side`]) or on the new
/// top. A tip that leaves a top for a side face and comes back to the same top starts no phase.
fn top_changes<const N: usize>(records: &[Record<N>]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let (mut prev_k, mut left): (Option<f64>, Option<(f64, f64)>) = (None, None);
    for r in records {
        if r.on_side && r.in_contact {
            left = left.or(Some((r.t, r.f_d)));
            continue;
        }
        if prev_k.is_some_and(|k| k != r.k_e) && r.in_contact {
            out.push(left.unwrap_or((r.t, r.f_d)));
        }
        prev_k = Some(r.k_e);
        left = None;
    }
    out
}

/// Contact time and phase metrics of a recorded run.
pub fn metrics_of<const N: usize>(s: &Scenario<N>, records: &[Record<N>]) -> ControllerMetrics {
    let t: Vec<f64> = records.iter().map(|r| r.t).collect();
    let f: Vec<f64> = records.iter().map(|r| r.f_ext).collect();
    let c: Vec<bool> = records.iter().map(|r| r.in_contact).collect();
    let mut events = s.events();
    for (t_start, f_d) in top_changes(records) {
        if !events.iter().any(|e| (e.t_start - t_start).abs() < 1.5 * s.task.dt) {
            events.push(PhaseSpec { t_start, desired_force: f_d, start: PhaseStart::Disturbance });
        }
    }
    events.sort_by(|a, b| a.t_start.total_cmp(&b.t_start));
    controller_metrics(&t, &f, &c, |t| s.f_d(t), &events)
}

/// The honest metrics of a recorded run ([`crate::metrics::honest`]) for a loop delay of
/// `delay_cycles` periods and F/T noise `noise_sigma_n` [N] along n: `v₀` is the tip's
/// speed along n over the period before the first contact, `k_e`, `b_e` the true stiffness and
/// damping there.
pub fn honest_of<const N: usize>(s: &Scenario<N>, records: &[Record<N>], m: &ControllerMetrics, delay_cycles: usize, noise_sigma_n: f64) -> Vec<crate::metrics::Honest> {
    let Some(ic) = records.iter().position(|r| r.in_contact) else {
        return vec![];
    };
    let n = s.task.force_axis;
    let v0 = if ic > 0 {
        let (a, b) = (&records[ic - 1], &records[ic]);
        (0..3).map(|i| n[i] * (b.tip[i] - a.tip[i])).sum::<f64>() / s.task.dt
    } else {
        0.0
    };
    let t: Vec<f64> = records.iter().map(|r| r.t).collect();
    let f: Vec<f64> = records.iter().map(|r| r.f_ext).collect();
    let tip = nalgebra::Vector3::from(records[ic].tip);
    let b_e = s.env.material.at(records[ic].t, &tip).b_e;
    let h = crate::metrics::HonestInputs { delay_cycles, period: s.task.dt, noise_sigma_n, v0, k_e: records[ic].k_e, b_e };
    crate::metrics::honest(&t, &f, m, &h)
}

/// The F/T noise σ along a force axis of the simulated mini45 [N] (one resolution step,
/// [`crate::sensor`]).
pub fn force_noise_sigma() -> f64 {
    let r = crate::sensor::MINI45_SI_145_5_RESOLUTION;
    r[0].max(r[1]).max(r[2])
}

/// The records as CSV (one row per control period).
pub fn to_csv<const N: usize>(records: &[Record<N>]) -> String {
    use std::fmt::Write;
    let mut out = String::with_capacity(records.len() * 400);
    out.push('t');
    for name in ["q", "dq", "tau"] {
        for j in 1..=N {
            let _ = write!(out, ",{name}{j}");
        }
    }
    out.push(',');
    out.push_str("tip_x,tip_y,tip_z,p_d_x,p_d_y,p_d_z,f_ext,f_ext_est,f_d,surface_z,penetration,in_contact,k_e,");
    out.push_str("ft_fx,ft_fy,ft_fz,ft_tx,ft_ty,ft_tz,m_d,b_d,sigma,gamma,gamma_bound,phase,saturated,k_e_hat,k_e_confidence,model_gain,gravity_scale\n");
    for r in records {
        let _ = write!(out, "{:.4}", r.t);
        for v in r.q.iter().chain(&r.dq).chain(&r.tau).chain(&r.tip).chain(&r.p_d) {
            let _ = write!(out, ",{v:.7}");
        }
        let _ = write!(
            out,
            ",{:.5},{:.5},{:.3},{:.6},{:.7},{},{}",
            r.f_ext, r.f_ext_est, r.f_d, r.surface_z, r.penetration, r.in_contact as u8, r.k_e
        );
        for v in &r.wrench {
            let _ = write!(out, ",{v:.5}");
        }
        let _ = writeln!(
            out,
            ",{:.6},{:.6},{:.6},{:.6e},{:.6e},{},{},{:.1},{:.4},{:.4},{:.4}",
            r.m_d, r.b_d, r.sigma, r.gamma, r.gamma_bound, r.phase as u8, r.saturated as u8, r.k_e_hat, r.k_e_confidence, r.model_gain, r.gravity_scale
        );
    }
    out
}

/// Closed-loop throughput (steps per second, medians over repeats).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopThroughput {
    /// Plant + sensors + controller, one control period per step.
    pub closed_loop: f64,
    /// The plant alone (same torque sequence replayed, same start state).
    pub plant_only: f64,
    /// The controller alone (same measurement sequence).
    pub controller_only: f64,
}

/// Closed-loop throughput: run `s` with `controller` up to `t_start` (e.g. in
/// contact), then time `steps` periods of plant + sensor + controller from
/// that state, `repeats` times (each from the same saved state; no
/// recording inside the timed loop). Also times the plant alone on the
/// torques of the first repeat and the controller alone on its measurements.
pub fn bench_closed_loop<C: Controller + Clone>(
    s: &Scenario,
    p: &PlantParams,
    controller: &C,
    t_start: f64,
    steps: usize,
    repeats: usize,
) -> (LoopThroughput, Observation) {
    let mut ws = PlantWorkspace::new(p);
    let mut c = controller.clone();
    let (mut state, mut obs) = plant::observe(p, &PlantState::at_rest(s.task.q0, s.seed), &mut ws, [0.0; N_JOINTS], false);
    let k0 = (t_start / s.task.dt).round() as usize;
    for k in 0..k0 {
        let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * s.task.dt));
        (state, obs) = plant::step(p, &state, &tau, &mut ws);
    }
    let (state0, obs0, c0) = (state, obs, c.clone());
    let median = |mut v: Vec<f64>| crate::metrics::median(&mut v);
    // recorded once, outside the timed loops
    let mut taus = Vec::with_capacity(steps);
    let mut meas = Vec::with_capacity(steps);
    {
        let (mut state, mut obs, mut c) = (state0, obs0, c0.clone());
        for k in k0..k0 + steps {
            meas.push(obs.meas);
            let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * s.task.dt));
            taus.push(tau);
            (state, obs) = plant::step(p, &state, &tau, &mut ws);
        }
    }
    let repeats = repeats.max(1);
    let (mut closed, mut plant_only, mut ctrl_only) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = obs0;
    for _ in 0..repeats {
        let (mut state, mut obs, mut c) = (state0, obs0, c0.clone());
        let t0 = std::time::Instant::now();
        for k in k0..k0 + steps {
            let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * s.task.dt));
            (state, obs) = plant::step(p, &state, &tau, &mut ws);
        }
        closed.push(steps as f64 / t0.elapsed().as_secs_f64());
        last = std::hint::black_box(obs);

        let mut state = state0;
        let t0 = std::time::Instant::now();
        for tau in &taus {
            let (st, o) = plant::step(p, &state, tau, &mut ws);
            state = st;
            std::hint::black_box(&o);
        }
        plant_only.push(steps as f64 / t0.elapsed().as_secs_f64());

        let mut c = c0.clone();
        let t0 = std::time::Instant::now();
        for (i, m) in meas.iter().enumerate() {
            let rep = c.step(m, &s.reference((k0 + i) as f64 * s.task.dt));
            std::hint::black_box(&rep);
        }
        ctrl_only.push(steps as f64 / t0.elapsed().as_secs_f64());
    }
    let thr = LoopThroughput { closed_loop: median(closed), plant_only: median(plant_only), controller_only: median(ctrl_only) };
    (thr, last)
}

/// RMS of `f_ext − f_d` from the first contact to the end of the run [N]
/// (`None` without contact).
pub fn contact_rms<const N: usize>(records: &[Record<N>]) -> Option<f64> {
    let i0 = records.iter().position(|r| r.in_contact)?;
    let n = (records.len() - i0) as f64;
    Some((records[i0..].iter().map(|r| (r.f_ext - r.f_d).powi(2)).sum::<f64>() / n).sqrt())
}

/// What one run contributes to the controller table (`naic sim --table`).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RunSummary {
    pub contact_time_s: Option<f64>,
    /// First contact: overshoot [% of f_d] and ±2 % settling [s] (None: never).
    pub contact_overshoot_pct: f64,
    pub contact_settle_s: Option<f64>,
    /// Every later phase (f_d step, stiffness jump): overshoot [%] and ±2 % settling [s].
    pub later_overshoot_pct: Vec<f64>,
    pub later_settle_s: Vec<Option<f64>>,
    /// Every later phase: the overshoot of the recovery, beyond f_d on the far side after
    /// the force first crosses f_d [% of |f_d|] (at a stiffness jump the force jumps away
    /// from f_d — physics; this is what the controller adds while bringing it back).
    pub later_recovery_overshoot_pct: Vec<f64>,
    /// Steady-state error of the last phase [N].
    pub ss_error_n: f64,
    /// RMS of f − f_d from first contact to the end [N].
    pub rms_n: Option<f64>,
    /// Peak contact force [N].
    pub peak_n: f64,
    /// Peak-to-peak force over the last 0.5 s [N] (a limit cycle shows here).
    pub late_p2p_n: f64,
}

/// The table's numbers of a run (`naic sim --table`, the closed-loop goal tests).
pub fn summarize<const N: usize>(r: &RunResult<N>) -> RunSummary {
    let m = &r.metrics;
    let mut n = RunSummary { contact_time_s: m.contact_time_s, rms_n: contact_rms(&r.records), ..Default::default() };
    if let Some(p) = m.phases.first() {
        n.contact_overshoot_pct = p.overshoot_pct;
        n.contact_settle_s = p.settling_time_2pct_s;
    }
    for (k, p) in m.phases.iter().enumerate().skip(1) {
        n.later_overshoot_pct.push(p.overshoot_pct);
        n.later_settle_s.push(p.settling_time_2pct_s);
        let t_end = m.phases.get(k + 1).map_or(f64::INFINITY, |q| q.t_start_s);
        let f_d = p.desired_force_n;
        let phase = r.records.iter().filter(|x| x.t >= p.t_start_s - 1e-9 && x.t < t_end - 1e-9);
        let side = r.records.iter().find(|x| x.t >= p.t_start_s - 1e-9).map_or(0.0, |x| (x.f_ext - f_d).signum());
        let (mut crossed, mut beyond) = (false, 0.0_f64);
        for x in phase {
            let e = side * (x.f_ext - f_d);
            crossed |= e <= 0.0;
            if crossed {
                beyond = beyond.max(-e);
            }
        }
        n.later_recovery_overshoot_pct.push(100.0 * beyond / f_d.abs().max(f64::MIN_POSITIVE));
    }
    n.ss_error_n = m.phases.last().map_or(f64::NAN, |p| p.steady_state_error_n);
    n.peak_n = r.records.iter().map(|x| x.f_ext).fold(0.0, f64::max);
    let t_end = r.records.last().map_or(0.0, |x| x.t);
    let late = r.records.iter().filter(|x| x.t >= t_end - 0.5).map(|x| x.f_ext);
    let (lo, hi) = late.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), f| (lo.min(f), hi.max(f)));
    n.late_p2p_n = if hi >= lo { hi - lo } else { f64::NAN };
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(t: f64, k_e: f64, on_side: bool, in_contact: bool) -> Record {
        Record { t, k_e, on_side, in_contact, f_d: 3.0, ..Default::default() }
    }

    /// Acrylic's top → its side face → the foam's top starts one phase, when the tip left
    /// the acrylic's top; foam → the acrylic's side → foam starts none; a change of material
    /// out of contact starts none (as a scheduled stiffness step would not either).
    #[test]
    fn a_phase_starts_where_the_tip_leaves_a_top_for_another_material() {
        let (a, f) = (50_000.0, 1000.0);
        let over = [rec(0.0, a, false, true), rec(0.001, a, true, true), rec(0.002, a, true, true), rec(0.003, f, false, true), rec(0.004, f, false, true)];
        assert_eq!(top_changes(&over), vec![(0.001, 3.0)]);
        let back = [rec(0.0, f, false, true), rec(0.001, a, true, true), rec(0.002, f, false, true)];
        assert!(top_changes(&back).is_empty());
        let plain = [rec(0.0, a, false, true), rec(0.001, f, false, true)];
        assert_eq!(top_changes(&plain), vec![(0.001, 3.0)]);
        let airborne = [rec(0.0, a, false, true), rec(0.001, f, false, false), rec(0.002, f, false, true)];
        assert!(top_changes(&airborne).is_empty());
    }
}
