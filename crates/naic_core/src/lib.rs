//! # naic_core
//!
//! The foundation of naic, with no middleware in it: the robot model and its
//! rigid-body dynamics, joint friction, and the force-tracking controllers of
//! the NAIC paper (`../shared/seed/naic-paper.md`).
//!
//! Layout (Pinocchio's Model/Data split; data flows one way through `pipeline`):
//!
//! * [`model`]    — immutable [`model::Model`] loaded from a serial-chain URDF,
//!   and the preallocated workspace [`model::Data`].
//! * [`dynamics`] — algorithms as plain functions over `(&Model, &mut Data)`:
//!   forward kinematics, frame Jacobians, J̇q̇, RNEA, CRBA, ABA, and the
//!   Cartesian terms of equation 3.
//! * [`friction`] — joint friction models (equations 4 and 5, per direction as
//!   in Table 1, and a smooth variant) and their parameter files; identifying
//!   them from data is offline work, in the `naic_ident` crate.
//! * [`pipeline`] — the 1 kHz control path, one stage per folder, in the order
//!   the data flows: `sense → estimate → control → feedforward → actuate`.
//! * [`task`]     — the paper's tasks as the controller sees them: start joints,
//!   reference trajectory, desired force schedule, impedance settings.

pub mod alloc_count;
pub mod dynamics;
pub mod force_design;
pub mod friction;
pub mod model;
pub mod pipeline;
pub mod rng;
pub mod robot_file;
pub mod task;

/// Joints of the JK5 (six revolute joints): the default joint count of the
/// generic types below, so `JointVec`, `Controller`, ... without a count are the JK5's.
///
/// # N joints: how the joint count is carried
///
/// The 1 kHz path is generic over the joint count as a const parameter `N`
/// (`JointVec<N> = [f64; N]`, `Data<Const<N>>`, `Controller<N>`, the pipeline
/// stages, the simulator plant): the count is chosen once, when the robot is
/// loaded, by [`with_joints!`] (the one dispatch point from the URDF's joint
/// count to a compiled `N`), and is fixed from then on. Why this design
/// rather than a fixed-capacity vector or heap `DVector`s: every joint-space
/// vector and matrix stays on the stack with a compile-time bound (no
/// allocation in the cycle, no `n` to check at run time, the same speed as the
/// 6-joint code had), and the JK5's `N = 6` instance is exactly the code that
/// ran before, so its results are bit-identical (a dynamic nalgebra product
/// can take another summation order, e.g. through `matrixmultiply`). The cost
/// is one compiled instance per supported count, [`MIN_JOINTS`]`..=`[`MAX_JOINTS`].
///
/// Not every six in the code is a joint count: a wrench (Fx, Fy, Fz, Tx, Ty, Tz), a
/// twist, a pose error (3 position + 3 orientation) and the Cartesian impedance
/// diagonals (`m_d`, `b_d`, `k_*`) have six components because space has six
/// degrees of freedom, and stay `[f64; 6]` / `Vector6<f64>`.
pub const N_JOINTS: usize = 6;

/// The fewest joints the 1 kHz path is compiled for.
pub const MIN_JOINTS: usize = 3;
/// The most joints the 1 kHz path is compiled for (a 7-joint arm: Panda, iiwa, Gen3).
pub const MAX_JOINTS: usize = 7;

/// One value per joint [SI unit of the quantity: rad, rad/s, N·m, ...], joint 1 first.
///
/// The plain-array form of a joint-space vector (positions, velocities,
/// torques, per-joint limits and gains); `SVector::<f64, N>::from(q)` is its
/// nalgebra form. `N` defaults to the JK5's [`N_JOINTS`].
pub type JointVec<const N: usize = N_JOINTS> = [f64; N];

/// Why a joint count has no compiled 1 kHz path.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the arm has {found} joints; naic's 1 kHz path runs arms of {min} to {max} joints: use a URDF (or a `joints` list) whose actuated chain has {min} to {max} joints")]
pub struct JointCountError {
    pub found: usize,
    pub min: usize,
    pub max: usize,
}

/// Runs `$body` with `const $n: usize` set to the run-time joint count `$count`:
/// the one dispatch point from a loaded robot's joint count to the compiled
/// instance of the generic 1 kHz path. Evaluates to
/// `Result<body's value, JointCountError>`.
///
/// ```
/// let n_model = 7;
/// let r = naic_core::with_joints!(n_model, N => { let q: naic_core::JointVec<N> = [0.0; N]; q.len() });
/// assert_eq!(r, Ok(7));
/// assert!(naic_core::with_joints!(13, N => N).is_err());
/// ```
#[macro_export]
macro_rules! with_joints {
    ($count:expr, $n:ident => $body:expr) => {{
        match $count {
            3 => { const $n: usize = 3; Ok($body) }
            4 => { const $n: usize = 4; Ok($body) }
            5 => { const $n: usize = 5; Ok($body) }
            6 => { const $n: usize = 6; Ok($body) }
            7 => { const $n: usize = 7; Ok($body) }
            found => Err($crate::JointCountError { found, min: $crate::MIN_JOINTS, max: $crate::MAX_JOINTS }),
        }
    }};
}
