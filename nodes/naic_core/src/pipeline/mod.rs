//! The control path, in the order data flows through it:
//! `sense → estimate → control → feedforward → actuate`.
pub mod actuate;
pub mod control;
pub mod estimate;
pub mod feedforward;
pub mod sense;
