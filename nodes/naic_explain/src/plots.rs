//! SVG plots of the report (residual vs velocity before/after like the paper's Fig. 6,
//! vs position and vs time), drawn with `naic_sim::svg`.
use crate::report::Finding;
use crate::Explained;

/// (file name, SVG text) of every plot.
pub fn plots(_ex: &Explained, _fs: &[Finding]) -> Vec<(String, String)> {
    Vec::new() // placeholder until naic_sim (svg.rs) is on main
}
