//! The force-axis loop as a linear discrete-time system (docs/notes/2026-12-06-force-law-design.md).
//!
//! Along the force axis n the controller commands the task acceleration
//! `V_k = (f_d − f_m,k + I_k − b_d v_m,k) / m_d` and the push `u_k = D̂ V_k + f_m,k` (eq 6 with
//! `k_d = 0` on n, the measured contact force fed forward; or the desired force, [`Feedforward`]), with the measurements
//! `f_m,k = f_{k−d}` and `v_m,k = v_{k−d−d_v}` and the integral `I_{k+1} = I_k + k_i T (f_d − f_m,k)`.
//! The arm (true apparent mass `D = D̂ / F`) and the contact obey
//!
//! ```text
//! D ẍ = u − f,    f = μ u + k_e x + b_e ẋ            (u held over each period)
//! ```
//!
//! `μ` is the contact's feed-through: the fraction of a push that reaches the force at once
//! (0 for a spring, MuJoCo's constraint impedance for its soft contact, 1 for a rigid one).
//! The arm–contact pair is discretised exactly under the zero-order hold; the force sampled at
//! `k` is `k_e x_k + b_e v_k + μ u_{k−1}` (the push held over the period before the sample).
//!
//! This is design-time code: it allocates, and is not called in the 1 kHz path.

use nalgebra::{Complex, DMatrix, DVector, Matrix3};
use crate::pipeline::control::derived::observer_gains;

/// Which force the push carries besides `D̂ V` (eq 6's `+ Jᵀ F_e` term).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feedforward {
    /// The measured force `f_m` (eq 6 as the paper writes it: the contact force cancelled).
    Measured,
    /// The desired force `f_d` (the contact force is left to the impedance).
    Desired,
}

/// What the loop is made of, apart from the contact and the gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopModel {
    /// Control period `T` [s].
    pub period: f64,
    /// Loop delay `d` [periods]: the force used in cycle k was sampled at k − d.
    pub delay: u32,
    /// The velocity's extra lag `d_v` [periods] (the paper's 5-sample median: 2).
    pub velocity_lag: u32,
    /// The velocity the law damps with from a state observer on the measured position
    /// instead (`derived::observe`): the three poles of its error dynamics at this `z` in [0, 1)
    /// (`velocity_lag` then unused). `None`: the measured velocity, `d + d_v` periods old.
    pub observer: Option<f64>,
    /// `D̂`, the controller model's apparent mass along n [kg].
    pub model_mass: f64,
    /// `F = D̂ / D`, the model's mass error (1: exact).
    pub mass_error: f64,
    /// The force fed forward in the push.
    pub feedforward: Feedforward,
}

/// The surface along n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Stiffness `k_e` [N/m].
    pub k_e: f64,
    /// Damping `b_e` [N·s/m].
    pub b_e: f64,
    /// Feed-through `μ` in [0, 1].
    pub feedthrough: f64,
}

/// The force axis's gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    /// `m_d` [kg].
    pub m_d: f64,
    /// `b_d` [N·s/m].
    pub b_d: f64,
    /// Integral rate `k_i` [1/s] (0: no integral).
    pub k_i: f64,
}

/// A value the analysis cannot use.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DesignError {
    /// `name` = `value` is outside `rule`.
    #[error("force design: {name} = {value} is not {rule}")]
    Invalid {
        name: &'static str,
        value: f64,
        rule: &'static str,
    },
    /// The eigenvalue solver did not converge (an ill-conditioned loop).
    #[error("force design: the closed loop's eigenvalues did not converge")]
    NoEigenvalues,
}

fn check(name: &'static str, value: f64, ok: bool, rule: &'static str) -> Result<(), DesignError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(DesignError::Invalid { name, value, rule })
    }
}

impl LoopModel {
    pub(crate) fn validate(&self) -> Result<(), DesignError> {
        check("period", self.period, self.period > 0.0, "> 0 s")?;
        check(
            "model_mass",
            self.model_mass,
            self.model_mass > 0.0,
            "> 0 kg",
        )?;
        check("mass_error", self.mass_error, self.mass_error > 0.0, "> 0")
    }
}

impl Contact {
    pub(crate) fn validate(&self) -> Result<(), DesignError> {
        check("k_e", self.k_e, self.k_e >= 0.0, ">= 0 N/m")?;
        check("b_e", self.b_e, self.b_e >= 0.0, ">= 0 N·s/m")?;
        check(
            "feedthrough",
            self.feedthrough,
            (0.0..=1.0).contains(&self.feedthrough),
            "in [0, 1]",
        )
    }
}

impl Gains {
    pub(crate) fn validate(&self) -> Result<(), DesignError> {
        check("m_d", self.m_d, self.m_d > 0.0, "> 0 kg")?;
        check("b_d", self.b_d, self.b_d >= 0.0, ">= 0 N·s/m")?;
        check("k_i", self.k_i, self.k_i >= 0.0, ">= 0 1/s")
    }
}

/// The closed loop in state-space form, `z_{k+1} = A z_k + B w_k`, `y_k = Cᵀ z_k`, broken at
/// the commanded task acceleration: `w` is the `V` the push is made of (`u = D̂ w + f_m`, the
/// measured force's feedforward counted as part of the plant it compensates) and `y` the `V`
/// the law computes from the measurements; closing it is `w = y`.
pub(crate) struct Loop {
    pub a: DMatrix<f64>,
    pub b: DVector<f64>,
    pub c: DVector<f64>,
}

/// Exact zero-order-hold discretisation of `D ẍ + b_e ẋ + k_e x = (1 − μ) u`:
/// `(Φ, Γ)` with `[x, v]_{k+1} = Φ [x, v]_k + Γ u_k`.
fn discretise(t: f64, d: f64, c: &Contact) -> ([[f64; 2]; 2], [f64; 2]) {
    let m = Matrix3::new(
        0.0,
        1.0,
        0.0,
        -c.k_e / d,
        -c.b_e / d,
        (1.0 - c.feedthrough) / d,
        0.0,
        0.0,
        0.0,
    ) * t;
    let e = m.exp();
    (
        [[e[(0, 0)], e[(0, 1)]], [e[(1, 0)], e[(1, 1)]]],
        [e[(0, 2)], e[(1, 2)]],
    )
}

impl Loop {
    /// State layout: `x, v, u_{k−1}`, the integral `I` (only with `k_i > 0`), the forces
    /// `f_{k−1} … f_{k−d}`, the velocities `v_{k−1} … v_{k−d−d_v}`; with an observer instead of
    /// the velocities: the positions `x_{k−1} … x_{k−d}`, the commands `w_{k−1} … w_{k−1−d}`
    /// and the observer's `x̂_{k−1}`, `v̂_{k−1}`, `ŵ_{k−1}`.
    pub(crate) fn new(m: &LoopModel, c: &Contact, g: &Gains) -> Self {
        let d = m.delay as usize;
        let dv = if m.observer.is_some() { 0 } else { (m.delay + m.velocity_lag) as usize };
        let with_i = g.k_i > 0.0;
        let (ix, iv, iu) = (0, 1, 2);
        let ii = 3;
        let f0 = if with_i { 4 } else { 3 };
        let v0 = f0 + d;
        // observer states: positions, commands, x̂, v̂, ŵ
        let (p0, w0) = (v0 + dv, v0 + dv + d);
        let (ixh, ivh, iwh) = (w0 + d + 1, w0 + d + 2, w0 + d + 3);
        let n = if m.observer.is_some() { iwh + 1 } else { v0 + dv };
        let true_mass = m.model_mass / m.mass_error;
        let (phi, gamma) = discretise(m.period, true_mass, c);

        // The sampled force f_k and the measured one f_m = f_{k−d}.
        let mut f_now = DVector::zeros(n);
        f_now[ix] = c.k_e;
        f_now[iv] = c.b_e;
        f_now[iu] = c.feedthrough;
        let f_m = if d == 0 {
            f_now.clone()
        } else {
            let mut r = DVector::zeros(n);
            r[f0 + d - 1] = 1.0;
            r
        };
        // The velocity the law damps with: the measured v_{k−d−d_v}, or the observer's v̂_k
        // (predicted with the command of d + 1 cycles before, corrected by the measured
        // position x_{k−d}: derived::observe).
        let mut v_m = DVector::zeros(n);
        let mut x_hat = DVector::zeros(n);
        let mut w_hat = DVector::zeros(n);
        if let Some(p) = m.observer {
            let t = m.period;
            let [l1, l2, l3] = observer_gains(p);
            let mut x_pred = DVector::zeros(n);
            let mut v_pred = DVector::zeros(n);
            x_pred[ixh] = 1.0;
            x_pred[ivh] = t;
            x_pred[w0 + d] = 0.5 * t * t;
            x_pred[iwh] = 0.5 * t * t;
            v_pred[ivh] = 1.0;
            v_pred[w0 + d] = t;
            v_pred[iwh] = t;
            w_hat[iwh] = 1.0;
            let mut x_meas = DVector::zeros(n);
            x_meas[if d == 0 { ix } else { p0 + d - 1 }] = 1.0;
            let r = &x_meas - &x_pred;
            v_m = &v_pred + &r * (l2 / t);
            x_hat = &x_pred + &r * l1;
            w_hat += &r * (l3 / (t * t));
        } else {
            v_m[if dv == 0 { iv } else { v0 + dv - 1 }] = 1.0;
        }

        // The law's V = (−f_m + I − b_d v_m) / m_d (f_d = 0: the loop's own dynamics).
        let mut v_law = (-&f_m - g.b_d * &v_m) / g.m_d;
        if with_i {
            v_law[ii] += 1.0 / g.m_d;
        }
        // The push u_k = D̂ w + f_m (or + f_d = 0): its state part, its input part D̂.
        let u_z = match m.feedforward {
            Feedforward::Measured => f_m.clone(),
            Feedforward::Desired => DVector::zeros(n),
        };
        let u_w = m.model_mass;

        let mut a = DMatrix::zeros(n, n);
        let mut b = DVector::zeros(n);
        for r in 0..2 {
            a[(r, ix)] += phi[r][0];
            a[(r, iv)] += phi[r][1];
            for j in 0..n {
                a[(r, j)] += gamma[r] * u_z[j];
            }
            b[r] = gamma[r] * u_w;
        }
        a.row_mut(iu).copy_from(&u_z.transpose());
        b[iu] = u_w;
        if with_i {
            a[(ii, ii)] = 1.0;
            for j in 0..n {
                a[(ii, j)] -= g.k_i * m.period * f_m[j];
            }
        }
        if d > 0 {
            a.row_mut(f0).copy_from(&f_now.transpose());
            for j in 1..d {
                a[(f0 + j, f0 + j - 1)] = 1.0;
            }
        }
        if dv > 0 {
            a[(v0, iv)] = 1.0;
            for j in 1..dv {
                a[(v0 + j, v0 + j - 1)] = 1.0;
            }
        }
        if m.observer.is_some() {
            if d > 0 {
                a[(p0, ix)] = 1.0;
                for j in 1..d {
                    a[(p0 + j, p0 + j - 1)] = 1.0;
                }
            }
            // w_k is the loop's input; the older commands shift.
            b[w0] = 1.0;
            for j in 1..=d {
                a[(w0 + j, w0 + j - 1)] = 1.0;
            }
            a.row_mut(ixh).copy_from(&x_hat.transpose());
            a.row_mut(ivh).copy_from(&v_m.transpose());
            a.row_mut(iwh).copy_from(&w_hat.transpose());
        }
        Loop { a, b, c: v_law }
    }

    /// The closed loop's state matrix `A + B Cᵀ`.
    pub(crate) fn closed(&self) -> DMatrix<f64> {
        &self.a + &self.b * self.c.transpose()
    }

    /// The open loop's frequency response `y/w` at `z = e^{jθ}`.
    pub(crate) fn open_response(&self, theta: f64) -> Complex<f64> {
        let n = self.a.nrows();
        let z = Complex::from_polar(1.0, theta);
        let m = DMatrix::from_fn(n, n, |i, j| {
            let diag = if i == j { z } else { Complex::new(0.0, 0.0) };
            diag - Complex::new(self.a[(i, j)], 0.0)
        });
        let rhs = self.b.map(|v| Complex::new(v, 0.0));
        match m.lu().solve(&rhs) {
            Some(x) => self.c.iter().zip(x.iter()).map(|(c, x)| x * *c).sum(),
            None => Complex::new(f64::INFINITY, 0.0),
        }
    }
}
