//! Two-material's phase on the foam, per seed —
//! the ±2 % settling after the switch, the first entry into ±2 %, the force's spread once
//! recovered (slide and rest), and the samples outside ±2 % after +0.3 s.
//!
//! ```text
//! cargo run --release -p naic_sim --example foam_noise -- CONTROLLER D MASS_ERROR SEED_FROM SEED_TO [KEY=VALUE ...]
//! ```
//! `KEY=VALUE` overrides a scheduled parameter for the experiment: `sigma_fraction`,
//! `integral_bandwidth`, `m_d_min`, `g_max`, `zeta`, `integral_band_n`, `hold` (`disturbance_hold`).
//! `SCEN=<scenario>` (environment) runs another scenario and prints its phases' settling only.
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::scenario;
use naic_sim::test_support::{model, table1_friction};
use nalgebra::Vector3;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let ctl = a[1].as_str();
    let d: usize = a[2].parse().unwrap();
    let mass: f64 = a[3].parse().unwrap();
    let s0: u64 = a[4].parse().unwrap();
    let s1: u64 = a[5].parse().unwrap();
    let m = model();
    let tool = (0.424, Vector3::new(0.0, 0.0, 0.015));
    let mut settles = vec![];
    let mut sds = vec![];
    for seed in s0..=s1 {
        let sc = std::env::var("SCEN").unwrap_or("two-material".into());
        let mut s = scenario::preset(&sc, &m).unwrap();
        s.seed = seed;
        let fr = Some(table1_friction());
        let plant = scenario::plant_for(&s, m.clone(), fr.clone(), tool).unwrap();
        let settings = LoopSettings { delay_cycles: d, model_mass_error: mass, ..LoopSettings::default() };
        let mut c = PipelineController::by_name(ctl, &s, &m, fr.clone(), tool, &settings).unwrap();
        let mut p = c.params().clone();
        {
            let sp = &mut p.control.force_law.scheduled;
            for kv in &a[6..] {
                let (k, v) = kv.split_once('=').unwrap();
                let v: f64 = v.parse().unwrap();
                match k {
                    "sigma_fraction" => sp.schedule.sigma_fraction = v,
                    "integral_bandwidth" => sp.schedule.integral_bandwidth = v,
                    "m_d_min" => sp.schedule.m_d_min = v,
                    "zeta" => sp.schedule.zeta = v,
                    "g_max" => sp.model_gain.g_max = v,
                    "integral_band_n" => sp.integral_band_n = v,
                    "hold" => sp.disturbance_hold = v,
                    _ => panic!("unknown key {k}"),
                }
            }
        }
        c.set_params(p).unwrap();
        let r = naic_sim::runner::run(&s, &plant, &mut c, &mut |_| {});
        let sum = naic_sim::runner::summarize(&r);
        let rec = &r.records;
        let ts = r.metrics.phases.get(1).map_or(f64::NAN, |p| p.t_start_s);
        let f_d = 3.0;
        let band = 0.02 * f_d;
        let first_in = rec.iter().find(|x| x.t >= ts && (x.f_ext - f_d).abs() <= band).map_or(f64::NAN, |x| x.t - ts);
        let stat = |t0: f64, t1: f64| {
            let f: Vec<f64> = rec.iter().filter(|x| x.t >= t0 && x.t < t1).map(|x| x.f_ext).collect();
            let n = f.len() as f64;
            let mean = f.iter().sum::<f64>() / n;
            let sd = (f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
            let lo = f.iter().cloned().fold(f64::INFINITY, f64::min);
            let out = f.iter().filter(|v| (*v - f_d).abs() > band).count();
            (mean, sd, lo, out)
        };
        if sc != "two-material" {
            println!("seed {seed:2}: first {:.1} % {:?} later {:?}", sum.contact_overshoot_pct, sum.contact_settle_s, sum.later_settle_s);
            continue;
        }
        let (m1, sd1, lo1, o1) = stat(ts + 0.3, 8.0);
        let (m2, sd2, lo2, o2) = stat(8.0_f64.max(ts + 0.3), 1e9);
        let settle = sum.later_settle_s.first().copied().flatten();
        settles.push(settle.unwrap_or(f64::INFINITY));
        sds.push(sd1);
        println!(
            "seed {seed:2}: g {:.3}, switch {ts:.3} s, first in ±2 % +{first_in:.3} s, settle {}, rec.os {:.2} % | slide mean {m1:.4} sd {sd1:.4} min {lo1:.3} out {o1} | rest mean {m2:.4} sd {sd2:.4} min {lo2:.3} out {o2} | first contact {:.1} %",
            c.state().controller.control.sched.gain.g,
            settle.map_or("never".into(), |t| format!("{t:.3} s")),
            sum.later_recovery_overshoot_pct.first().copied().unwrap_or(f64::NAN),
            sum.contact_overshoot_pct
        );
    }
    if settles.is_empty() {
        return;
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
    };
    println!("median settle {:.3} s, median slide sd {:.4} N", med(&mut settles), med(&mut sds));
}
