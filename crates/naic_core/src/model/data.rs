//! The preallocated workspace of the dynamics algorithms.

use super::{FrameId, Model, ModelError};
use crate::dynamics::spatial::{ArticulatedInertia, Force, Inertia, Motion, Se3};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, DimName, Dyn, Isometry3, OMatrix, OVector, U6};

/// Workspace for one [`Model`]: every buffer the algorithms touch is
/// allocated here once, so no algorithm allocates per call.
///
/// `D` is the number of degrees of freedom as a nalgebra dimension:
/// * `Data<Dyn>` ([`Data::new`]): any chain; joint-space vectors/matrices are
///   `DVector`/`DMatrix` allocated once here.
/// * `Data<U6>` ([`Data::try_new`], alias [`Data6`]): the 6-DOF fast path;
///   joint-space results are stack `SVector<f64, 6>`/`SMatrix<f64, 6, 6>`,
///   loops have a compile-time bound. The algorithm code is the same.
///
/// Per-body buffers follow Pinocchio's names: `li_m_i` (joint i in its parent),
/// `o_m_i` (joint i in the base frame), `o_m_f` (frames in the base frame),
/// `v`/`a`/`f` (body velocity, acceleration, force in the joint frame).
#[derive(Clone, Debug)]
pub struct Data<D: Dim = Dyn>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    pub(crate) nv: D,
    pub(crate) li_m_i: Vec<Se3>,
    pub(crate) o_m_i: Vec<Se3>,
    pub(crate) o_m_f: Vec<Se3>,
    pub(crate) v: Vec<Motion>,
    pub(crate) a: Vec<Motion>,
    pub(crate) f: Vec<Force>,
    pub(crate) ycrb: Vec<Inertia>,
    pub(crate) ia: Vec<ArticulatedInertia>,
    pub(crate) pa: Vec<Force>,
    pub(crate) u_f: Vec<Force>,
    pub(crate) dinv: Vec<f64>,
    pub(crate) u: Vec<f64>,
    pub(crate) c: Vec<Motion>,
    /// The joint positions `li_m_i`/`o_m_i` were last computed for, and how
    /// many of them are current for it: `li_m_i[..li_valid]` and
    /// `o_m_i[..o_valid]` (`o_valid ≤ li_valid`). Every algorithm reuses the
    /// placements when called again at bit-identical q (e.g. FK, Jacobian,
    /// J̇q̇ and RNEA of one controller cycle), so results do not change.
    pub(crate) placed_q: OVector<f64, D>,
    pub(crate) li_valid: usize,
    pub(crate) o_valid: usize,
    /// Joint torques of the last [`crate::dynamics::rnea`] (or bias/gravity torques).
    pub tau: OVector<f64, D>,
    /// Joint accelerations of the last [`crate::dynamics::aba`].
    pub ddq: OVector<f64, D>,
    /// Joint-space inertia matrix of the last [`crate::dynamics::crba`] (full, symmetric).
    pub m: OMatrix<f64, D, D>,
    /// Frame Jacobian of the last [`crate::dynamics::frame_jacobian`] (6×nv).
    pub j: OMatrix<f64, U6, D>,
}

/// The fixed-size workspace of an `N`-joint arm (stack joint-space matrices,
/// compile-time loop bounds): the one of the 1 kHz path; its joint-space
/// vectors are the nalgebra form of a [`crate::JointVec<N>`].
pub type DataN<const N: usize> = Data<nalgebra::Const<N>>;

/// [`DataN`] of the JK5's six joints.
pub type Data6 = DataN<6>;

impl Data<Dyn> {
    /// Workspace for any model (dynamic size).
    pub fn new(model: &Model) -> Self {
        Self::with_dim(model, Dyn(model.nv()))
    }
}

impl<D: Dim> Data<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U6, D>,
{
    /// Workspace with a compile-time DOF count `D` (e.g. `Data::<U6>::try_new`);
    /// fails with [`ModelError::WrongDof`] if the model has another number of joints.
    pub fn try_new(model: &Model) -> Result<Self, ModelError> {
        match D::try_to_usize() {
            Some(n) if n != model.nv() => Err(ModelError::WrongDof { expected: n, found: model.nv() }),
            _ => Ok(Self::with_dim(model, D::from_usize(model.nv()))),
        }
    }

    fn with_dim(model: &Model, nv: D) -> Self {
        let n = model.nv();
        Self {
            nv,
            li_m_i: vec![Se3::identity(); n],
            o_m_i: vec![Se3::identity(); n],
            o_m_f: vec![Se3::identity(); model.frames.len()],
            v: vec![Motion::zero(); n],
            a: vec![Motion::zero(); n],
            f: vec![Force::zero(); n],
            ycrb: vec![Inertia::zero(); n],
            ia: vec![ArticulatedInertia::default(); n],
            pa: vec![Force::zero(); n],
            u_f: vec![Force::zero(); n],
            dinv: vec![0.0; n],
            u: vec![0.0; n],
            c: vec![Motion::zero(); n],
            placed_q: OVector::<f64, D>::zeros_generic(nv, nalgebra::Const::<1>),
            li_valid: 0,
            o_valid: 0,
            tau: OVector::<f64, D>::zeros_generic(nv, nalgebra::Const::<1>),
            ddq: OVector::<f64, D>::zeros_generic(nv, nalgebra::Const::<1>),
            m: OMatrix::<f64, D, D>::zeros_generic(nv, nv),
            j: OMatrix::<f64, U6, D>::zeros_generic(U6::name(), nv),
        }
    }

    /// Number of degrees of freedom.
    #[inline(always)]
    pub fn nv(&self) -> usize {
        self.nv.value()
    }

    /// World (base-frame) pose of a frame, as of the last
    /// [`crate::dynamics::forward_kinematics`] (all frames) or
    /// [`crate::dynamics::frame_jacobian`] / [`crate::dynamics::frame_jdot_qdot`] (that frame).
    pub fn frame_placement(&self, frame: FrameId) -> Isometry3<f64> {
        self.o_m_f[frame.0].to_isometry()
    }

    /// Same as [`Data::frame_placement`] as a rotation + translation pair.
    pub fn frame_se3(&self, frame: FrameId) -> &Se3 {
        &self.o_m_f[frame.0]
    }

    /// World pose of joint `i`'s frame as of the last kinematics pass.
    pub fn joint_placement(&self, i: usize) -> &Se3 {
        &self.o_m_i[i]
    }
}

