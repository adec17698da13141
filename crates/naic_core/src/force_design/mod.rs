//! The force axis's loop on paper: a linear discrete-time model of the loop along the force
//! axis ([`model`]) and its closed-loop poles and phase margin ([`analysis`]), the tool a
//! force law's gains are checked with (docs/notes/2026-12-06-force-law-design.md).
//! Design-time code (it allocates); not in the 1 kHz path.

pub mod analysis;
pub mod model;
pub mod rule;

pub use analysis::{margins, zeta_of, Margins};
pub use model::{Contact, DesignError, Feedforward, Gains, LoopModel};
pub use rule::{gains, RuleInputs};

#[cfg(test)]
mod tests;
