//! The rclpy example (`examples/slide_with_force_profile.py`) in process: the same
//! reference profile, fed as `/naic/target_pose` and `/naic/desired_wrench` messages at
//! 50 Hz of simulated time into the controller's core, on the chain the DDS test runs
//! (`naic launch --lockstep -p naic_controller:scenario:=none`): the driver's simulated
//! JK5 on the flat scenario, friction_compensation, naic_controller, each node's core
//! with the parameters of `params/*.yaml`, in lockstep (one plant step per command).
//! No DDS and no clock: deterministic, and the numbers the DDS test must reproduce.

mod common;

use std::path::PathBuf;

use common::{push, target, Chain};
use jk5_sim_driver::plant::Plant;
use naic_controller::core as ctl;
use naic_core::pipeline::control::Phase;
use nalgebra::Vector3;

/// One cycle of the slide (what the figure and the summary need).
#[derive(Clone, Copy, Debug)]
struct Sample {
    t: f64,
    f_d: f64,
    f: f64,
    phase: Phase,
    /// Tip and reference position along the slide [m].
    x: f64,
    x_ref: f64,
}

/// The example's profile: 1 s still, approach at 20 mm/s until contact (5 N), the target
/// 5 mm into the surface, `settle` s at 5 N, then 10 cm at 10 mm/s with 5, 10, 5 N thirds;
/// targets at 50 Hz. Returns the cycles of the slide.
fn slide(c: &mut Chain, settle: f64) -> Vec<Sample> {
    const PERIOD_NS: i64 = 20_000_000; // 50 Hz
    let (speed, length, forces) = (0.010, 0.10, [5.0, 10.0, 5.0]);
    let mut first = None;
    while first.is_none() {
        first = c.step(None, None);
    }
    let (q, _, _) = c.plant.joints();
    let model = c.cp.controller.model();
    let (p0, r0) = naic_core::task::tip_pose(model, &q);
    let mut next_pub = c.now_ns() + 1_000_000_000;
    let mut run_until = |c: &mut Chain, end: &mut dyn FnMut(i64, Option<&ctl::Report>) -> bool, pose: &dyn Fn(i64) -> (Vector3<f64>, f64)| {
        let mut out = Vec::new();
        loop {
            let now = c.now_ns();
            let due = now >= next_pub;
            let (p, f) = pose(now);
            let (tp, dw) = (target(now, &p, &r0), push(now, f));
            if due {
                next_pub += PERIOD_NS;
            }
            let r = c.step(due.then_some(&tp), due.then_some(&dw));
            if let Some(r) = r {
                let st = r.status;
                out.push(Sample { t: now as f64 * 1e-9, f_d: st.f_d, f: st.f_ext, phase: st.phase, x: st.tip_position.x, x_ref: r.reference.position[0] });
            }
            if end(now, r.as_ref()) {
                return out;
            }
        }
    };
    // Still for 1 s (the example waits for the recorder).
    let t_still = c.now_ns() + 1_000_000_000;
    run_until(c, &mut |now, _| now >= t_still, &|_| (p0, forces[0]));
    // Approach: descend until the controller reports contact.
    let t0 = c.now_ns();
    let down = move |now: i64| p0 + Vector3::new(0.0, 0.0, -0.02 * (now - t0) as f64 * 1e-9);
    run_until(c, &mut |_, r| r.is_some_and(|r| r.status.phase == Phase::Contact), &|now| (down(now), forces[0]));
    let p_contact = down(c.now_ns()) + Vector3::new(0.0, 0.0, -0.005);
        let t_settle = c.now_ns() + (settle * 1e9) as i64;
    run_until(c, &mut |now, _| now >= t_settle, &|_| (p_contact, forces[0]));
    let t_slide = c.now_ns();
    let duration = length / speed;
    let d = Vector3::x();
    let at = move |now: i64| {
        let t = (now - t_slide) as f64 * 1e-9;
        (p_contact + d * speed * t.min(duration), forces[((3.0 * t / duration) as usize).min(2)])
    };
    let end_ns = t_slide + (duration * 1e9) as i64;
    run_until(c, &mut |now, _| now >= end_ns, &at)
}

fn summary(s: &[Sample]) -> (f64, f64, usize) {
    let e: Vec<f64> = s.iter().map(|x| x.f - x.f_d).collect();
    let max = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let rms = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    let worst = e.iter().enumerate().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())).map_or(0, |w| w.0);
    (max, rms, worst)
}

/// `NAIC_SLIDE_CSV=DIR`: the slide's cycles as CSV, to look at.
fn write_csv(name: &str, s: &[Sample]) {
    if let Ok(dir) = std::env::var("NAIC_SLIDE_CSV") {
        let mut t = String::from("t,f_d,f_ext,phase,x\n");
        for x in s {
            t.push_str(&format!("{:.4},{:.4},{:.4},{},{:.6}\n", x.t, x.f_d, x.f, x.phase as u8, x.x));
        }
        std::fs::write(PathBuf::from(dir).join(format!("{name}.csv")), t).unwrap();
    }
}

/// The controller settings the example sets (examples/slide_with_force_profile.py
/// `CONTROLLER_PARAMS`): the stiffness-scheduled force law, and the force reference at
/// 5 N/s (the default 100 N/s makes each 5 N step a step for the force loop).
const EXAMPLE_PARAMS: [&str; 2] = ["mode:=scheduled", "max_force_rate:=5.0"];

#[test]
fn the_example_profile_tracks_force_in_process() {
    // The slide starting at a few moments (how long the example settles first): the joint
    // friction's breakaway at the slide start differs with the state the arm is in.
    for settle in [1.9, 2.0, 2.2] {
        let mut c = Chain::new(&EXAMPLE_PARAMS);
        let s = slide(&mut c, settle);
        write_csv(&format!("slide_settle_{settle}"), &s);
        let (max, rms, worst) = summary(&s);
        let t0 = s[0].t;
        let lead = s.iter().fold(0.0f64, |m, x| m.max((x.x - x.x_ref).abs()));
        let (first, last) = (s[0], s[s.len() - 1]);
        eprintln!(
            "settle {settle} s: {} cycles, max |e_f| {max:.3} N at {:.3} s into the slide (f_d {:.2} N), rms {rms:.3} N; tip {:.1} mm along the slide, largest |x - x_ref| {:.1} mm",
            s.len(),
            s[worst].t - t0,
            s[worst].f_d,
            (last.x - first.x) * 1e3,
            lead * 1e3
        );
        // 10 cm at 10 mm/s, 1 kHz, in contact all the way, through 5 -> 10 -> 5 N.
        assert_eq!(s.len(), 10_001);
        assert!(s.iter().all(|x| x.phase == Phase::Contact));
        // The reference stage follows the 50 Hz targets two intervals behind: 0.4 mm at 10 mm/s.
        assert!((last.x_ref - first.x_ref - 0.0996).abs() < 1e-4, "the reference moved {} m", last.x_ref - first.x_ref);
        // The tip follows the reference within 5 mm along the slide (the DDS test's bound;
        // measured 0.2-0.6 mm; 3.3-3.6 mm before the scheduled law bounded the tangential
        // impedance for the loop delay).
        assert!(lead < 0.005, "settle {settle}: the tip was {lead} m from the reference");
        assert!(s.iter().any(|x| x.f_d == 10.0) && last.f_d == 5.0);
        // Issue #16's goal: |e_f| <= 0.5 N while sliding (measured 0.26-0.30 N over eleven
        // starts between 1.8 and 2.3 s; docs/nodes.md).
        assert!(max <= 0.5 && rms <= 0.1, "settle {settle}: max {max} N, rms {rms} N");
    }
}
