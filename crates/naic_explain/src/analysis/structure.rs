//! The model structures the analysis fits: regressor columns ([`Col`]), scanned shape
//! parameters ([`ScanParam`]), the nominal Stribeck shape and a joint model ([`Structure`]).

use super::JointSamples;
use crate::catalogue::Effect;
use std::collections::BTreeSet;

/// Direction a friction column applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dir {
    Both,
    Pos,
    Neg,
}

/// A regressor column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Col {
    Coul(Dir),
    Visc(Dir),
    Strib(Dir),
    Offset,
    RipSin,
    RipCos,
    /// `position_torque`: `sin(k' q)`, `cos(k' q)`.
    PosSin,
    PosCos,
    Payload,
    Drift,
    Rotor,
    /// `viscous_nonlinearity`: `s·q̇²`, split by direction on friction points with the asymmetry
    /// ([`Structure::points`]).
    Visc2(Dir),
    /// The rigid-body torque (`torque_scale`).
    Scale,
    /// The joint's share of the cross-fitted base-parameter correction (`inertial_parameters`).
    Inertial,
    /// Contact spring `u·δ₊ⁿ` (n = 1 nominal).
    Spring,
    /// Contact damping `u·δ̇·[δ > 0]`.
    CDamp,
    /// Tool-gravity columns (see [`crate::catalogue`]).
    Grav0,
    Grav1,
}

/// A scanned shape parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanParam {
    Qs,
    QsPos,
    QsNeg,
    K,
    /// `position_torque` wave number k'.
    KPos,
    /// Surface height h [m] (contact).
    H,
    /// Contact exponent n.
    NExp,
    /// Delay of the torque channel [s] (`delay`: the model is evaluated at the motion of t − delay).
    Delay,
}

/// The nominal Stribeck shape σ₀(q̇) = 1 + r₀·e^{−(q̇/q_s0)²} (from `--nominal`; r₀ = 0 = flat).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NominalShape {
    pub r0: f64,
    pub q_s0: f64,
}

impl Default for NominalShape {
    fn default() -> Self {
        Self { r0: 0.0, q_s0: 0.01 }
    }
}

/// A joint model: the nominal friction plus a set of effects with their shape values.
#[derive(Clone, Debug, PartialEq)]
pub struct Structure {
    pub effects: BTreeSet<Effect>,
    pub q_s_pos: f64,
    pub q_s_neg: f64,
    pub k: f64,
    /// `position_torque` wave number k' [rad⁻¹].
    pub k_pos: f64,
    /// Contact structures: the spring is `u·(h − z)₊ⁿ`.
    pub contact: bool,
    /// Contact: the target sees the contact force (has the spring column).
    pub coupled: bool,
    pub h: f64,
    pub n_exp: f64,
    /// `delay`: the torque channel lags the motion by this [s] (the model is evaluated at the
    /// motion of t − delay, see [`JointSamples::target`] and `col`).
    pub delay: f64,
    /// The delay was found on other joints and is fixed here (no parameter of this joint).
    pub delay_fixed: bool,
    /// Friction points: with `friction_asymmetry`, `viscous_nonlinearity`'s column is split by
    /// direction like every other friction column (each direction is its own curve there).
    /// Time series keep the one shared column.
    pub points: bool,
}

impl Structure {
    pub fn nominal() -> Self {
        Self {
            effects: BTreeSet::new(),
            q_s_pos: 0.02,
            q_s_neg: 0.02,
            k: 10.0,
            k_pos: 5.0,
            contact: false,
            coupled: false,
            h: 0.0,
            n_exp: 1.0,
            delay: 0.0,
            delay_fixed: false,
            points: false,
        }
    }
    /// The nominal structure of a target and the shape parameters its calibration scans
    /// (joints: none; contact axes: the surface height).
    pub fn nominal_for(js: &JointSamples) -> (Self, Vec<ScanParam>) {
        if js.contact {
            let h = js.h_grid.get(js.h_grid.len() / 2).copied().unwrap_or(0.0);
            let scan = if js.coupled { vec![ScanParam::H] } else { vec![] };
            (Self { contact: true, coupled: js.coupled, h, ..Self::nominal() }, scan)
        } else {
            (Self { points: !js.time_series, ..Self::nominal() }, vec![])
        }
    }
    /// Number of shape (non-linear, scanned) parameters of the structure, for the information criterion.
    pub fn n_shape(&self) -> usize {
        if self.contact {
            return self.coupled as usize * (1 + self.has(Effect::ContactNonlinearity) as usize);
        }
        let strib = if self.has(Effect::Stribeck) { 1 + self.has(Effect::FrictionAsymmetry) as usize } else { 0 };
        strib
            + self.has(Effect::PositionRipple) as usize
            + self.has(Effect::PositionTorque) as usize
            + (self.has(Effect::Delay) && !self.delay_fixed) as usize
    }
    pub fn has(&self, e: Effect) -> bool {
        self.effects.contains(&e)
    }
    pub fn columns(&self) -> Vec<Col> {
        if self.contact {
            let mut c = if self.coupled { vec![Col::Spring] } else { vec![] };
            for e in &self.effects {
                match e {
                    Effect::ContactDamping => c.push(Col::CDamp),
                    Effect::FtBias => c.push(Col::Offset),
                    Effect::ToolGravity => {
                        c.push(Col::Grav0);
                        c.push(Col::Grav1)
                    }
                    _ => {}
                }
            }
            return c;
        }
        let asym = self.has(Effect::FrictionAsymmetry);
        let dirs: &[Dir] = if asym { &[Dir::Pos, Dir::Neg] } else { &[Dir::Both] };
        let mut c = Vec::new();
        for &d in dirs {
            c.push(Col::Coul(d));
            c.push(Col::Visc(d));
            if self.has(Effect::Stribeck) {
                c.push(Col::Strib(d));
            }
        }
        for e in &self.effects {
            match e {
                Effect::TorqueOffset => c.push(Col::Offset),
                Effect::PositionRipple => {
                    c.push(Col::RipSin);
                    c.push(Col::RipCos)
                }
                Effect::Payload => c.push(Col::Payload),
                Effect::Drift => c.push(Col::Drift),
                Effect::RotorInertia => c.push(Col::Rotor),
                Effect::ViscousNonlinearity => {
                    if self.points && asym {
                        c.push(Col::Visc2(Dir::Pos));
                        c.push(Col::Visc2(Dir::Neg))
                    } else {
                        c.push(Col::Visc2(Dir::Both))
                    }
                }
                Effect::TorqueScale => c.push(Col::Scale),
                Effect::PositionTorque => {
                    c.push(Col::PosSin);
                    c.push(Col::PosCos)
                }
                Effect::InertialParameters => c.push(Col::Inertial),
                // no column: it shifts the motion the model is evaluated at (JointSamples::target, col)
                Effect::FrictionAsymmetry | Effect::Stribeck | Effect::Delay => {}
                Effect::ContactNonlinearity | Effect::ContactDamping | Effect::FtBias | Effect::ToolGravity => {}
            }
        }
        c
    }
    pub(super) fn get(&self, p: ScanParam) -> f64 {
        match p {
            ScanParam::Qs | ScanParam::QsPos => self.q_s_pos,
            ScanParam::QsNeg => self.q_s_neg,
            ScanParam::K => self.k,
            ScanParam::KPos => self.k_pos,
            ScanParam::H => self.h,
            ScanParam::NExp => self.n_exp,
            ScanParam::Delay => self.delay,
        }
    }
    pub(super) fn set(&mut self, p: ScanParam, v: f64) {
        match p {
            ScanParam::Qs => {
                self.q_s_pos = v;
                self.q_s_neg = v
            }
            ScanParam::QsPos => self.q_s_pos = v,
            ScanParam::QsNeg => self.q_s_neg = v,
            ScanParam::K => self.k = v,
            ScanParam::KPos => self.k_pos = v,
            ScanParam::H => self.h = v,
            ScanParam::NExp => self.n_exp = v,
            ScanParam::Delay => self.delay = v,
        }
    }
    /// The structure with `e` added and the shape parameters to scan for it.
    pub fn with(&self, e: Effect) -> (Structure, Vec<ScanParam>) {
        let mut s = self.clone();
        s.effects.insert(e);
        if s.contact {
            // contact: the surface height is re-calibrated with every candidate (per fold),
            // and the exponent too once the spring is non-linear
            let scan = if !s.coupled {
                vec![]
            } else if s.has(Effect::ContactNonlinearity) {
                vec![ScanParam::NExp, ScanParam::H]
            } else {
                vec![ScanParam::H]
            };
            return (s, scan);
        }
        let scan = match e {
            Effect::Stribeck if s.has(Effect::FrictionAsymmetry) => vec![ScanParam::QsPos, ScanParam::QsNeg],
            Effect::Stribeck => vec![ScanParam::Qs],
            Effect::FrictionAsymmetry if s.has(Effect::Stribeck) => vec![ScanParam::QsPos, ScanParam::QsNeg],
            Effect::PositionRipple => vec![ScanParam::K],
            Effect::PositionTorque => vec![ScanParam::KPos],
            Effect::Delay => vec![ScanParam::Delay],
            _ => vec![],
        };
        (s, scan)
    }
}
