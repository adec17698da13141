//! The speed and acceleration limit of the reference: a discrete-time
//! second-order tracker that follows a (moving) goal as fast as the limits
//! allow and stops on it without overshoot.
//!
//! One function for both halves of the pose: the translation works on the
//! position error `goal − p` [m], the rotation on the rotation vector of
//! `R_goal Rᵀ` [rad] (base frame).
//!
//! Per step of length `dt`, with `e = goal − x` (the goal at the end of the
//! step, `x` at its start), `r = e − v_goal dt` (where the goal is seen from a
//! point moving with it), `d = |r|` and `δ = a_max dt`:
//!
//! ```text
//! v_want = clamp_norm( v_goal + v_stop(d) r/d , v_max )
//! v'     = v + clamp_norm( v_want − v , δ )
//! ```
//!
//! `v_stop(d)` is the fastest speed from which steps of at most `δ` brake to
//! rest exactly on the goal: with `n` the largest integer such that
//! `n (n+1)/2 · δ dt ≤ d` and the rest `ρ = d − n (n+1)/2 · δ dt`,
//! `v_stop = n δ + ρ / ((n+1) dt)` (braking from there in steps of exactly δ
//! covers d; it tends to `√(2 a_max d)` as `dt → 0` and is `d/dt` in the last
//! step). Because `v'` lies on the segment from `v` to `v_want`, both of norm
//! `≤ v_max`, the limits `|v'| ≤ v_max` and `|v' − v| ≤ a_max dt` hold for any
//! input (the property test in `super::tests` checks them on random sequences).

use nalgebra::Vector3;

/// Speed and acceleration bounds of one half of the pose (SI: m/s, m/s² or rad/s, rad/s²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub max_speed: f64,
    pub max_accel: f64,
}

/// One step of the tracker: the new velocity, and which limits were active.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    pub v: Vector3<f64>,
    /// `v_want` was cut to `max_speed`.
    pub speed_limited: bool,
    /// The change of velocity was cut to `max_accel · dt`.
    pub accel_limited: bool,
}

/// `x` scaled down to norm `max` if it is longer (`max ≥ 0`); and whether it was.
fn clamp_norm(x: Vector3<f64>, max: f64) -> (Vector3<f64>, bool) {
    let n = x.norm();
    if n > max {
        (x * (max / n), true)
    } else {
        (x, false)
    }
}

/// The fastest speed from which steps of `a dt` brake to rest exactly `d` further on.
fn stop_speed(d: f64, a: f64, dt: f64) -> f64 {
    let unit = a * dt * dt; // distance of one step at speed δ
    let n = ((-1.0 + (1.0 + 8.0 * d / unit).sqrt()) / 2.0).floor().max(0.0);
    let rest = (d - unit * n * (n + 1.0) / 2.0).max(0.0);
    n * a * dt + rest / ((n + 1.0) * dt)
}

/// Steps shorter than this advance nothing (keeps `d / (a dt²)` finite).
const MIN_DT: f64 = 1e-9;

/// Velocity for the step of `dt` [s] towards a goal that is `e` away at the step's end and
/// moves at `v_goal`. `dt ≤ 1 ns` keeps the velocity. Inputs are finite (checked by the caller).
pub fn track(l: &Limits, e: &Vector3<f64>, v: &Vector3<f64>, v_goal: &Vector3<f64>, dt: f64) -> Tracked {
    if !(dt > MIN_DT) {
        return Tracked { v: *v, speed_limited: false, accel_limited: false };
    }
    // A goal faster than the limit is followed at the limit.
    let (v_goal, _) = clamp_norm(*v_goal, l.max_speed);
    let r = e - v_goal * dt;
    let d = r.norm();
    // Any speed above 2 v_max is cut to v_max below; bound it so the product stays finite.
    let stop = stop_speed(d, l.max_accel, dt).min(2.0 * l.max_speed);
    let toward = if d > 0.0 { r * (stop / d) } else { Vector3::zeros() };
    let (want, speed_limited) = clamp_norm(v_goal + toward, l.max_speed);
    let (dv, accel_limited) = clamp_norm(want - v, l.max_accel * dt);
    Tracked { v: v + dv, speed_limited, accel_limited }
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: Limits = Limits { max_speed: 0.1, max_accel: 1.0 };

    /// Run the tracker on a still goal `g` from rest at 0; returns (steps to settle, max overshoot).
    fn settle(g: f64, dt: f64) -> (usize, f64) {
        let (mut x, mut v) = (Vector3::zeros(), Vector3::zeros());
        let goal = Vector3::new(g, 0.0, 0.0);
        let mut overshoot: f64 = 0.0;
        for k in 0..100_000 {
            let t = track(&L, &(goal - x), &v, &Vector3::zeros(), dt);
            v = t.v;
            x += v * dt;
            overshoot = overshoot.max(x.x - g);
            if (goal - x).norm() < 1e-12 && v.norm() < 1e-12 {
                return (k, overshoot);
            }
        }
        panic!("did not settle on {g}");
    }

    #[test]
    fn a_step_becomes_a_trapezoid_that_stops_on_the_goal() {
        let dt = 1e-3;
        // 5 cm at 0.1 m/s, 1 m/s²: 0.1 s ramp up, 0.4 s cruise, 0.1 s ramp down = 0.6 s.
        let (steps, overshoot) = settle(0.05, dt);
        assert!((steps as f64 * dt - 0.6).abs() < 0.01, "{steps} steps");
        assert!(overshoot <= 1e-12, "overshoot {overshoot}");
        // Short step: triangular profile, 2 √(d/a) = 20 ms for 0.1 mm.
        let (steps, overshoot) = settle(1e-4, dt);
        assert!((steps as f64 * dt - 0.02).abs() < 0.003, "{steps} steps");
        assert!(overshoot <= 1e-12, "overshoot {overshoot}");
    }

    #[test]
    fn follows_a_goal_moving_at_constant_speed_without_lag_once_caught_up() {
        let dt = 1e-3;
        let u = Vector3::new(0.01, 0.0, 0.0);
        let (mut x, mut v) = (Vector3::zeros(), Vector3::zeros());
        for k in 1..=2000 {
            let goal = u * (k as f64 * dt);
            let t = track(&L, &(goal - x), &v, &u, dt);
            v = t.v;
            x += v * dt;
        }
        assert!((v - u).norm() < 1e-9, "v = {v}");
        assert!((x - u * 2.0).norm() < 1e-9, "x = {x}");
    }

    #[test]
    fn braking_speed_is_continuous_and_drops_by_one_step_per_step() {
        let (a, dt) = (5.0, 1e-3);
        let mut prev = 0.0;
        for i in 1..20_000 {
            let d = i as f64 * 1e-7;
            let v = stop_speed(d, a, dt);
            assert!(v >= prev && v - prev < 1e-3, "jump at d = {d}: {prev} -> {v}");
            // Moving at v for dt leaves a distance whose braking speed is v − a dt.
            if v > a * dt {
                let v2 = stop_speed(d - v * dt, a, dt);
                assert!((v2 - (v - a * dt)).abs() < 1e-9, "d = {d}: {v} -> {v2}");
            } else {
                assert!((v - d / dt).abs() < 1e-12, "last step must land: d = {d}, v = {v}");
            }
            prev = v;
        }
    }

    #[test]
    fn no_time_no_motion() {
        let v = Vector3::new(0.05, 0.0, 0.0);
        assert_eq!(track(&L, &Vector3::new(1.0, 0.0, 0.0), &v, &Vector3::zeros(), 0.0).v, v);
    }
}
