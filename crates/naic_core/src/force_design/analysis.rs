//! Stability of the force-axis loop: closed-loop poles, the dominant pole's damping and the
//! phase margin at the force input.

use super::model::{Contact, DesignError, Gains, Loop, LoopModel};
use nalgebra::linalg::Schur;
use nalgebra::Complex;

/// What the analysis finds for one (model, contact, gains).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// The largest pole magnitude `max |z|` (< 1: stable).
    pub spectral_radius: f64,
    /// Damping ratio `ζ = −Re s / |s|`, `s = ln z / T`, of the dominant pole (the largest |z|);
    /// 1 for a real positive pole.
    pub dominant_zeta: f64,
    /// Time constant of the dominant pole, `−T / ln |z|` [s].
    pub dominant_time_constant: f64,
    /// The least damping ratio over the poles slower than the loop's delay, i.e. with a time
    /// constant of at least `(d + 1) T`: a faster mode is gone before the loop could see it.
    pub slow_zeta_min: f64,
    /// The smallest phase margin over every gain crossover of the open loop [deg];
    /// `inf` when the open loop's gain never reaches 1.
    pub phase_margin_deg: f64,
}

/// The damping ratio of a discrete pole.
pub fn zeta_of(z: Complex<f64>) -> f64 {
    let r = z.norm();
    if r == 0.0 {
        return 1.0;
    }
    let s = Complex::new(r.ln(), z.arg());
    if s.norm() == 0.0 {
        return 0.0;
    }
    (-s.re / s.norm()).clamp(-1.0, 1.0)
}

/// Poles, dominant damping and phase margin of the loop.
pub fn margins(m: &LoopModel, c: &Contact, g: &Gains) -> Result<Margins, DesignError> {
    m.validate()?;
    c.validate()?;
    g.validate()?;
    let l = Loop::new(m, c, g);
    let poles = Schur::try_new(l.closed(), 1e-14, 10_000)
        .ok_or(DesignError::NoEigenvalues)?
        .complex_eigenvalues();
    let dominant = poles
        .iter()
        .copied()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .ok_or(DesignError::NoEigenvalues)?;
    // Of a conjugate pair and a real pole of nearly the same magnitude, the least damped.
    let r = dominant.norm();
    let dominant_zeta = poles
        .iter()
        .filter(|p| p.norm() >= r * (1.0 - 1e-9))
        .map(|p| zeta_of(*p))
        .fold(1.0, f64::min);
    let slow = (-1.0 / (m.delay as f64 + 1.0)).exp();
    let slow_zeta_min = poles
        .iter()
        .filter(|p| p.norm() >= slow)
        .map(|p| zeta_of(*p))
        .fold(1.0, f64::min);
    Ok(Margins {
        spectral_radius: r,
        slow_zeta_min,
        dominant_zeta,
        dominant_time_constant: if r > 0.0 && r < 1.0 {
            -m.period / r.ln()
        } else {
            f64::INFINITY
        },
        phase_margin_deg: phase_margin_deg(&l),
    })
}

/// The phase margin of `L = −y/w` (negative feedback): at each gain crossover
/// (`|L| = 1`) the angle between `L` and −1, `180° − |arg L|`, the smallest over the
/// crossovers on a logarithmic grid of `θ = ωT` from 1e-5 to π, each refined by bisection.
/// It is the phase a perturbation must add to put the loop on the edge of stability
/// (together with [`Margins::spectral_radius`] < 1 for the loop as it is).
fn phase_margin_deg(l: &Loop) -> f64 {
    let open = |th: f64| -l.open_response(th);
    let n = 1500;
    let (lo, hi) = (1e-5f64.ln(), std::f64::consts::PI.ln());
    let mut best = f64::INFINITY;
    let mut prev_th = lo.exp();
    let mut prev = open(prev_th).norm() - 1.0;
    for i in 1..=n {
        let th = (lo + (hi - lo) * i as f64 / n as f64).exp();
        let cur = open(th).norm() - 1.0;
        if prev.signum() != cur.signum() {
            let (mut a, mut b) = (prev_th, th);
            for _ in 0..60 {
                let mid = 0.5 * (a + b);
                if (open(mid).norm() - 1.0).signum() == prev.signum() {
                    a = mid;
                } else {
                    b = mid;
                }
            }
            best = best.min(180.0 - open(0.5 * (a + b)).arg().to_degrees().abs());
        }
        prev = cur;
        prev_th = th;
    }
    best
}
