//! The nominal's Coulomb law at the lowest speeds: the smoothing width of sgn(q̇), chosen
//! per joint before any candidate is scored.

use super::{evaluate, JointSamples, NominalShape, Structure};

/// Largest Coulomb smoothing width tried by [`calibrate_coulomb_width`] [rad/s].
pub const COULOMB_WIDTH_MAX: f64 = 2e-3;

impl JointSamples {
    /// Sets the Coulomb law's smoothing: s = tanh(q̇/w) on moving samples (the exact sign for
    /// w = 0), 0 at rest.
    pub fn set_coulomb_width(&mut self, w: f64) {
        for (s, &v) in self.s.iter_mut().zip(&self.v) {
            if *s != 0.0 {
                *s = if w > 0.0 { (v / w).tanh() } else { v.signum() };
            }
        }
        self.coulomb_width = w;
    }
}

/// The nominal's Coulomb law at the lowest speeds is structure, like its Stribeck shape: the
/// exact sign (a generator's, many papers'), or a tanh whose width is the simulator's 1 mrad/s
/// or another. At 1–3 mrad/s they differ by up to a quarter of the Coulomb level, and a law
/// fixed at one width leaves that difference as a narrow low-speed bump which `stribeck`
/// (q_s at the bottom of its grid) took on noise-only data with the other law. The width is
/// chosen per joint (time series) on the whole data by the nominal's SSR, 0–2 mrad/s (grid
/// 0.25 mrad/s, then six halvings), before any candidate is scored: the nominal and every
/// candidate use the same law, so the comparison between them stays fair.
pub fn calibrate_coulomb_width(js: &mut JointSamples, sh: &NominalShape, folds: usize) {
    if !js.time_series || js.contact || js.is_empty() {
        return;
    }
    let (st, scan) = Structure::nominal_for(js);
    let ssr_of = |js: &mut JointSamples, w: f64| {
        js.set_coulomb_width(w);
        evaluate(js, &st, &scan, sh, folds).full_ssr
    };
    let step0 = 0.25e-3;
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..=((COULOMB_WIDTH_MAX / step0).round() as usize) {
        let w = k as f64 * step0;
        let ssr = ssr_of(js, w);
        if ssr < best.0 {
            best = (ssr, w);
        }
    }
    let mut step = step0;
    // to 4 µrad/s: at 2 mrad/s a tanh of width 0.9 mrad/s changes by 0.17 % of the Coulomb level
    // per 15 µrad/s of width (≈ 0.01 N·m on the JK5's joint 1), which `stribeck` took on
    // noise-only data when the width was refined to 31 µrad/s only
    for _ in 0..6 {
        step *= 0.5;
        let c = best.1;
        for w in [c - step, c + step] {
            if (0.0..=COULOMB_WIDTH_MAX).contains(&w) {
                let ssr = ssr_of(js, w);
                if ssr < best.0 {
                    best = (ssr, w);
                }
            }
        }
    }
    js.set_coulomb_width(best.1);
}
