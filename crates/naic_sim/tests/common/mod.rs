//! Shared by the closed-loop test files: the JK5 model and its Table 1 friction
//! (`naic_sim::test_support`, which the unit tests use too).

#[allow(unused_imports)]
pub use naic_sim::test_support::{model, table1_friction as friction, ROOT};

/// The paper authors' MuJoCo JK5 (`../shared`, or `NAIC_SHARED`); missing: a message naming both.
#[allow(dead_code)]
pub fn mjcf() -> std::path::PathBuf {
    let shared = std::env::var("NAIC_SHARED").unwrap_or_else(|_| format!("{ROOT}/../shared"));
    let p = std::path::PathBuf::from(format!("{shared}/reference/jk5/jk5_table.nomesh.mjcf.xml"));
    assert!(p.exists(), "the authors' MJCF is missing at {} (../shared from the repository, or set NAIC_SHARED)", p.display());
    p
}

/// The JK5's tool (mass [kg], centre of mass [m] in the sensor frame) from its URDF.
#[allow(dead_code)]
pub fn tool() -> (f64, nalgebra::Vector3<f64>) {
    naic_sim::sensor::tool_from_urdf(std::path::Path::new(&format!("{ROOT}/urdf/jk5.urdf"))).unwrap()
}
