//! # naic_sim
//!
//! Simulated JAKA JK5 + ATI mini45 F/T sensor with compliant contact
//! environments, the paper's scenario presets, the closed-loop runner and the
//! force-tracking metrics and plots (issue 3).
//!
//! Style (BRIEF.md): immutable parameters, a small `Copy` state, a
//! preallocated workspace, and pure step functions
//! `(params, state, inputs) -> (state, outputs)`.

pub mod environment;
pub mod metrics;
pub mod rng;
pub mod sensor;
pub mod svg;
