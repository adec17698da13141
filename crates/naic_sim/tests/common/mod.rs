//! Shared by the closed-loop test files: the JK5 model and its Table 1 friction
//! (`naic_sim::test_support`, which the unit tests use too).

#[allow(unused_imports)]
pub use naic_sim::test_support::{model, table1_friction as friction, ROOT};
