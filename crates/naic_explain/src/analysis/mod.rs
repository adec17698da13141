//! Residual analysis: per joint, forward selection of candidate extensions scored on
//! held-out folds.
//!
//! # Held-out scheme
//! * Time series: the recording is cut into blocks of `block_s` seconds (default 2 s,
//!   longer for long files so there are ≤ 400 blocks); block b belongs to fold `b mod K`
//!   (K = 10). Every fold therefore holds ~10 % of the data spread over the whole
//!   session, in contiguous time blocks (not random samples), so correlated noise and
//!   filter smoothing cannot leak from training into test samples.
//! * Friction points: per joint and direction the points are sorted by speed and point
//!   r goes to fold `r mod K` (interleaved velocity blocks): every fold covers the whole
//!   speed range and each held-out point is predicted from its neighbours in speed.
//!
//! Shape parameters (q_s, k) are chosen per fold on that fold's training part (grid
//! scan + local refinement), amplitudes by linear least squares — so held-out numbers
//! contain no information from the held-out samples.
//!
//! # Significance rule (per joint)
//! A candidate that adds Δp parameters to the current model is **significant** when all of:
//! 1. effect size: held-out gain `g = 1 − SSR_ho(new)/SSR_ho(current) ≥ min_gain` (default 2 %);
//! 2. parsimony: BIC on the whole data improves: `n_eff·ln(SSR_new/SSR_cur) + Δp·ln(n_eff) < 0`,
//!    with `n_eff` = samples / (filter window in analysis samples) for time series (filtered
//!    samples are not independent), = points for friction points;
//! 3. the test, which decides: the block-bootstrap interval of `g` over held-out time blocks
//!    at one-sided level a lies above zero, α = 5 % family-wise over m = candidates × targets:
//!    a = each target's share of α balanced over its candidates, never below α/m
//!    ([`family_test`], [`bootstrap`]). Friction points (independent segment means): the
//!    likelihood ratio of the whole-data fits, per direction, has a bootstrap p-value ≤ α/m
//!    ([`points_test`]), and where two significant candidates compete, the richer is better
//!    than the simpler when it is significant in the model holding both.
//!
//! Forward selection: of the significant candidates the one with the lowest held-out BIC
//! (n_eff·ln of the held-out SSR ratio + ln(n_eff) per parameter) is added to the joint's
//! model (where two explain the same residual about equally, the one with fewer
//! parameters; `inertial_parameters` counts its share of the base parameters the joints
//! share there, see [`crate::inertial`]) — unless a significant candidate with fewer
//! parameters is not beaten by it in the test, which is then taken instead, and the ones the
//! test cannot tell apart are named confounded — the rest are re-scored against the extended
//! model, until none is significant.
//!
//! # Layout
//! `structure.rs` (columns, scanned parameters, a joint model), `samples.rs` (the samples of
//! one joint: the rows of the design matrix), `gram.rs` (per-fold Gram matrices of `[X y]`),
//! `solve.rs` (least squares on them), `scan.rs` (the grid scan of shape parameters),
//! `evaluate.rs` (the cross-validated fit: whole data, fold split, per-fold solve, held-out
//! score), `eval.rs` (the fit's result and residuals), `coulomb.rs` (the nominal's Coulomb
//! smoothing), `significance.rs` (the rule above), `points_test.rs` (the test on friction
//! points), `selection.rs` (forward selection).

pub mod bootstrap;
mod coulomb;
mod eval;
mod evaluate;
mod gram;
mod samples;
mod scan;
mod selection;
mod significance;
mod solve;
mod structure;
pub mod points_test;

pub use coulomb::{calibrate_coulomb_width, COULOMB_WIDTH_MAX};
pub use eval::{friction_part, residuals, Eval};
pub use evaluate::evaluate;
pub use samples::{JointSamples, VALIDATION_FOLD};
pub use selection::{analyse_joint, JointResult};
pub use significance::{assess, decide, family_test, score, AnalysisOptions, Candidate, TORQUE_SCALE_MAX_ERROR};
pub(crate) use solve::{heldout, solve};
pub use structure::{Col, Dir, NominalShape, ScanParam, Structure};
