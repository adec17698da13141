//! The stages of a run, in the order [`crate::explain_runs`] calls them: read (the robot
//! model, the tool frame) → prepare (filter window, gaps, resampling, filtering:
//! `prepare.rs`) → contact (sensor axes, `contact.rs`) → nominal (per-joint samples and
//! folds, `samples.rs`; the nominal shape and Coulomb law, `nominal.rs`) → catalogue
//! (forward selection per joint, with the baseline beside it: `catalogue.rs`) → inertial
//! (`inertial.rs`) → report (notes and method table: `method.rs`). Friction points
//! ([`crate::explain_points`]) take their own outlier pass (`points.rs`).

mod catalogue;
mod contact;
mod inertial;
mod laps;
mod method;
mod nominal;
mod points;
mod prepare;
mod samples;

pub use catalogue::analyse_all;
pub(crate) use catalogue::catalogue_and_baseline;
pub(crate) use contact::contact_stage;
pub(crate) use inertial::inertial_stage;
pub(crate) use laps::Laps;
pub(crate) use method::{series_method, series_notes, SeriesMethod};
pub(crate) use nominal::{calibrate_coulomb_widths, load_nominal};
pub use nominal::nominal_shapes;
pub(crate) use points::{leave_out_outliers, points_method, points_notes};
pub use points::{Outlier, OUTLIER_K, POINTS_V_MIN};
pub(crate) use prepare::{choose_window, prepare_runs};
pub use prepare::tip_frame;
pub(crate) use samples::series_joint_samples;
pub use samples::{joint_samples_from_points, joint_samples_from_series, time_fold};
