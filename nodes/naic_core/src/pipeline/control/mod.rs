//! Stage 3 of the pipeline: the Cartesian impedance controller.
pub mod force_law;
