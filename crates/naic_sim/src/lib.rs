//! # naic_sim
//!
//! Simulated JAKA JK5 + ATI mini45 F/T sensor with compliant contact
//! environments, the paper's scenario presets, the closed-loop runner and the
//! force-tracking metrics and plots (issue 3).
//!
//! Style (BRIEF.md): immutable parameters, a small `Copy` state, a
//! preallocated workspace, and pure step functions
//! `(params, state, inputs) -> (state, outputs)`:
//!
//! * [`plant`] — the robot: ABA dynamics of `urdf/jk5.urdf`, Table 1 friction,
//!   effort saturation, contact at `tip`, encoders, the F/T sensor.
//! * [`plants`] — the plant interface: the own plant or MuJoCo (feature `mujoco`)
//!   behind one trait, built at one dispatch point.
//! * [`environment`] — compliant, unilateral contact surfaces.
//! * [`sensor`] — ATI mini45 (SI-145-5) and joint encoders.
//! * [`scenario`] — the paper's presets and their references.
//! * [`runner`] — the closed loop and its records; [`metrics`], [`plots`],
//!   [`svg`] — what comes out of a run.

// `!(x > 0.0)` is deliberate: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod arm;
pub mod controllers;
pub mod environment;
pub mod metrics;
#[cfg(feature = "mujoco")]
pub mod mujoco_plant;
pub mod plant;
pub mod plants;
pub mod plots;
pub mod rng;
pub mod runner;
pub mod scenario;
pub mod sensor;
#[doc(hidden)]
pub mod test_support;
