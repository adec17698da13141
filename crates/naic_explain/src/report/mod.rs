//! The outputs: `report.json` (schema of issue 6), `report.md` and `extended_params.yaml`.
//!
//! * `gain` of a finding = the share of the nominal model's held-out mean-square residual
//!   that adding the effect removed, averaged over the joints of the data (each joint
//!   normalised by its own nominal held-out mean square; joints where the effect was not
//!   selected contribute 0). The gains of the findings of one joint add up to that joint's
//!   total improvement.
//! * Non-significant candidates are listed too (`significant: false`) with their best
//!   joint, so a reader sees what was checked and how close it came.
//!
//! Layout: `findings.rs` (the ranked findings), `json.rs` (the `report.json` model),
//! `params.rs` (`extended_params.yaml`), `markdown.rs` (`report.md`), `plots.rs` (the SVG plots).

/// The block bootstrap lives with the significance rule it decides ([`crate::analysis::bootstrap`]).
pub use crate::analysis::bootstrap;
mod findings;
mod json;
mod markdown;
mod params;
pub mod plots;

pub use findings::{direction_rmse, direction_rmse_insample, effect_params, findings, Finding, SMALL_SHARE};
pub use json::{inertial_links, noise_floor_pairs, report_json, MOSTLY_LEFT, NO_EFFECT};
pub use params::{extended_friction, extended_params};

use crate::{ExplainError, Explained};
use naic_core::friction::FrictionParams;
use serde_json::Value;
use std::path::Path;

/// Writes report.json, report.md, extended_params.yaml and the SVG plots into `dir`.
pub fn write_all(ex: &Explained, dir: &Path) -> Result<Value, ExplainError> {
    std::fs::create_dir_all(dir).map_err(|e| ExplainError::Io(format!("{}: cannot create ({e})", dir.display())))?;
    let fs = findings(ex);
    let params = extended_params(ex, &fs);
    let yaml_path = dir.join("extended_params.yaml");
    params.save(&yaml_path).map_err(|e| ExplainError::Io(e.to_string()))?;
    // check it loads back with the project's loader
    FrictionParams::from_yaml_file(&yaml_path).map_err(|e| ExplainError::Io(format!("extended_params.yaml does not load back: {e}")))?;
    let v = report_json(ex, &fs, "extended_params.yaml");
    let text = serde_json::to_string_pretty(&v).unwrap_or_default();
    std::fs::write(dir.join("report.json"), text).map_err(|e| ExplainError::Io(format!("report.json: {e}")))?;
    let plots = plots::plots(ex, &fs, &v);
    for (name, svg) in &plots {
        std::fs::write(dir.join(name), svg).map_err(|e| ExplainError::Io(format!("{name}: {e}")))?;
    }
    let md = markdown::report_md(ex, &fs, &v, &plots);
    std::fs::write(dir.join("report.md"), md).map_err(|e| ExplainError::Io(format!("report.md: {e}")))?;
    Ok(v)
}
