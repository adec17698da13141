//! The estimator's parameters ([`ContactParams`]): each with its unit, range, default and
//! why (the table is in docs/controller.md, "The contact estimator").

use crate::pipeline::ConfigError;

/// Settings of the contact estimator. Every field is physical (a bound on the surfaces
/// expected, a speed, a rate) or statistical (a confidence multiplier); none is tuned to
/// a scenario.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams {
    /// `k_max` [N/m], (0, 1e8]: the stiffest surface expected. The prior on `k_e` at a new
    /// contact is uniform-like on `[0, k_max]` (mean `k_max/2`, σ `k_max/(2 z)`), so that
    /// `k̄ = k_max` before any evidence. Default 500 000 (issue 42: every stiffness from
    /// 100 to 500 000 N/m).
    pub k_max: f64,
    /// `μ_max` [-], (0, 1]: the largest feed-through expected; prior μ on `[0, μ_max]`.
    /// Default 1 (a rigid contact passes the whole push).
    pub mu_max: f64,
    /// `b_max` [N·s/m], [0, 1e6]: the largest surface damping expected; prior `b_e` on
    /// `[0, b_max]`. Default 100 (twice naic's acrylic, 50 N·s/m).
    pub b_max: f64,
    /// `z` [-], [1, 10]: the confidence multiplier of every bound (`k̄ = k̂ + z σ_k`, and the
    /// priors' half-widths are `z σ`). Default 3 (a one-sided Gaussian tail of 0.13 %).
    pub z: f64,
    /// `z_x` [-], [1, 100]: a parameter is updated only where its regressor's excursion
    /// (the effective regressor, module docs) exceeds `z_x` times that regressor's noise.
    /// Errors in the variables then bias the update by at most `1/z_x²`. Default 10 (≤ 1 %
    /// bias, a tenth of the 10 % the estimate must meet).
    pub z_x: f64,
    /// `v_e,max` [m/s], [0, 1]: 1 σ of the surface speed along n once the stiffness is known
    /// (the prior of `ẋ_e`). Default 0.02 (issue 42's fastest moving surface).
    pub surface_speed: f64,
    /// `a_e` [m/s²·√s], [0, 100]: random-walk intensity of the surface speed (its change
    /// over `t` seconds has σ `a_e √t`). Default 0.003 (3 mm/s in 1 s, 23 mm/s in 60 s): a
    /// surface that starts to move is followed through the jump test and its manoeuvre
    /// (module docs, "Jumps"); a faster walk lets `k_e` and `x_e` trade along the direction
    /// the data at rest leaves unobserved (`k_e (x − x_e)` = const).
    pub surface_accel: f64,
    /// `ρ` [1/√s], [0, 1]: random-walk intensity of the parameters (k_e relative, μ absolute,
    /// b_e relative to `b_max`): without evidence `σ_k/k̂` grows by `ρ √t`. Default 0.01
    /// (1 % in 1 s, 8 % in 60 s: a surface that wears or warms slowly).
    pub drift: f64,
    /// `z_jump` [-], [2, 100]: a stiffness jump is declared when the normalised innovation
    /// `|ν|/√S` exceeds this for [`Self::jump_cycles`] consecutive samples. Default 5.
    pub z_jump: f64,
    /// Consecutive samples of the jump test, 1–8. Default 3: a false alarm needs three
    /// 5 σ samples in a row (p ≈ 1e-20 per cycle for Gaussian noise).
    pub jump_cycles: u32,
}

impl Default for ContactParams {
    fn default() -> Self {
        Self {
            k_max: 500_000.0,
            mu_max: 1.0,
            b_max: 100.0,
            z: 3.0,
            z_x: 10.0,
            surface_speed: 0.02,
            surface_accel: 0.003,
            drift: 0.01,
            z_jump: 5.0,
            jump_cycles: 3,
        }
    }
}

/// Most samples the jump test holds back (and [`ContactParams::jump_cycles`]' upper bound).
pub const MAX_JUMP_CYCLES: usize = 8;

impl ContactParams {
    /// Every field in its range; the error names the field (`contact.<name>`) and the range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let check = |name: &str, v: f64, lo: f64, lo_open: bool, hi: f64| -> Result<(), ConfigError> {
            let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && v <= hi;
            if ok {
                Ok(())
            } else {
                let open = if lo_open { "(" } else { "[" };
                Err(ConfigError::invalid(format!("contact.{name}"), v, format!("must be in {open}{lo}, {hi}]")))
            }
        };
        check("k_max", self.k_max, 0.0, true, 1e8)?;
        check("mu_max", self.mu_max, 0.0, true, 1.0)?;
        check("b_max", self.b_max, 0.0, false, 1e6)?;
        check("z", self.z, 1.0, false, 10.0)?;
        check("z_x", self.z_x, 1.0, false, 100.0)?;
        check("surface_speed", self.surface_speed, 0.0, false, 1.0)?;
        check("surface_accel", self.surface_accel, 0.0, false, 100.0)?;
        check("drift", self.drift, 0.0, false, 1.0)?;
        check("z_jump", self.z_jump, 2.0, false, 100.0)?;
        if !(1..=MAX_JUMP_CYCLES as u32).contains(&self.jump_cycles) {
            return Err(ConfigError::invalid("contact.jump_cycles", self.jump_cycles, format!("must be in [1, {MAX_JUMP_CYCLES}]")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_each_bad_field_is_named() {
        ContactParams::default().validate().unwrap();
        let bad: [(&str, fn(&mut ContactParams)); 11] = [
            ("k_max", |p| p.k_max = 0.0),
            ("mu_max", |p| p.mu_max = 1.5),
            ("b_max", |p| p.b_max = -1.0),
            ("z", |p| p.z = f64::NAN),
            ("z_x", |p| p.z_x = 0.5),
            ("surface_speed", |p| p.surface_speed = -0.1),
            ("surface_accel", |p| p.surface_accel = f64::INFINITY),
            ("drift", |p| p.drift = 2.0),
            ("z_jump", |p| p.z_jump = 1.0),
            ("jump_cycles", |p| p.jump_cycles = 0),
            ("jump_cycles", |p| p.jump_cycles = 9),
        ];
        for (name, f) in bad {
            let mut p = ContactParams::default();
            f(&mut p);
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(&format!("contact.{name}")) && e.contains("must be in"), "{name}: {e}");
        }
    }
}
