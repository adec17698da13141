//! The simulator's random numbers: `naic_core::rng` (one generator for the workspace).
pub use naic_core::rng::*;
