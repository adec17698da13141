//! No heap allocation per call: `naic_core::alloc_count`'s counting global allocator (per
//! thread, so the test harness's own threads don't count) around every dynamics call.

mod dynamics_common;

use dynamics_common::*;
use naic_core::dynamics::{self, Damping};
use naic_core::model::{Data, Data6, Model};
use nalgebra::{DVector, SVector};
use naic_core::alloc_count::{counted, CountingAlloc};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations(f: impl FnOnce()) -> u64 {
    let ((), n) = counted(f);
    n
}

#[test]
fn the_counter_is_installed() {
    assert!(allocations(|| drop(vec![0u8; 8])) >= 1, "no allocation counted: every check here would pass vacuously");
}

#[test]
fn six_dof_path_does_not_allocate() {
    let model = Model::from_urdf_str(&arm6_urdf()).unwrap();
    let tip = model.frame_id("tip").unwrap();
    let mut data = Data6::try_new(&model).unwrap();
    // the counter works
    assert!(allocations(|| drop(std::hint::black_box(vec![1u8; 16]))) >= 1);
    let q = SVector::<f64, 6>::new(0.1, -0.5, 0.7, 0.05, 1.2, -0.3);
    let v = SVector::<f64, 6>::new(0.3, 0.2, -0.1, 0.02, 0.5, 1.0);
    let a = SVector::<f64, 6>::new(1.0, -2.0, 0.5, 0.1, 3.0, -1.0);
    let damping = Damping::default();
    let n = allocations(|| {
        for _ in 0..10 {
            std::hint::black_box(dynamics::rnea(&model, &mut data, &q, &v, &a));
            std::hint::black_box(dynamics::bias_torques(&model, &mut data, &q, &v));
            std::hint::black_box(dynamics::gravity_torques(&model, &mut data, &q));
            std::hint::black_box(dynamics::crba(&model, &mut data, &q));
            std::hint::black_box(dynamics::aba(&model, &mut data, &q, &v, &a));
            dynamics::forward_kinematics(&model, &mut data, &q);
            std::hint::black_box(data.frame_placement(tip));
            std::hint::black_box(dynamics::frame_jacobian(&model, &mut data, &q, tip));
            std::hint::black_box(dynamics::frame_jdot_qdot(&model, &mut data, &q, &v, tip));
            std::hint::black_box(dynamics::cartesian_terms(&model, &mut data, &q, &v, tip, &damping).unwrap());
            let j = *dynamics::frame_jacobian(&model, &mut data, &q, tip);
            std::hint::black_box(dynamics::solve_damped(&j, &a, &damping));
            std::hint::black_box(dynamics::solve_damped(&(j * 1e-3), &a, &damping)); // SVD branch
        }
        // near a singularity too (damped branch)
        std::hint::black_box(dynamics::cartesian_terms(&model, &mut data, &SVector::zeros(), &v, tip, &damping).unwrap());
    });
    assert_eq!(n, 0, "the 6-DOF path allocated {n} times");
}

#[test]
fn dynamic_path_does_not_allocate_after_data_new() {
    let model = Model::from_urdf_str(&planar3_urdf()).unwrap();
    let tip = model.frame_id("tip").unwrap();
    let mut data = Data::new(&model);
    let q = DVector::from_vec(vec![0.1, -0.5, 0.7]);
    let v = DVector::from_vec(vec![0.3, 0.2, -0.1]);
    let a = DVector::from_vec(vec![1.0, -2.0, 0.5]);
    let n = allocations(|| {
        for _ in 0..10 {
            std::hint::black_box(dynamics::rnea(&model, &mut data, &q, &v, &a));
            std::hint::black_box(dynamics::crba(&model, &mut data, &q));
            std::hint::black_box(dynamics::aba(&model, &mut data, &q, &v, &a));
            dynamics::forward_kinematics(&model, &mut data, &q);
            std::hint::black_box(dynamics::frame_jacobian(&model, &mut data, &q, tip));
            std::hint::black_box(dynamics::frame_jdot_qdot(&model, &mut data, &q, &v, tip));
        }
    });
    assert_eq!(n, 0, "the dynamic-size path allocated {n} times after Data::new");
}

#[test]
fn reference_step_does_not_allocate() {
    use naic_core::pipeline::control::ForceAxis;
    use naic_core::pipeline::reference::{self, DesiredWrench, Inbox, ReferenceParams, ReferenceState, TargetPose};
    use nalgebra::{UnitQuaternion, Vector3};
    let p = ReferenceParams::new("base_link", ForceAxis::base(2, -1.0), 10.0);
    let start = Vector3::new(0.4, 0.0, 0.3);
    let mut s = ReferenceState::new(start, UnitQuaternion::identity(), (start, UnitQuaternion::identity()));
    let frames = ["base_link", "world"];
    let n = allocations(|| {
        for k in 0..1000 {
            let t = k as f64 * 1e-3;
            let inbox = Inbox {
                target: (k % 20 == 0).then(|| TargetPose {
                    frame_id: frames[k % 3 / 2],
                    stamp: t,
                    position: [0.4 + 0.01 * t, 0.0, 0.3],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }),
                wrench: (k % 50 == 0).then(|| DesiredWrench { frame_id: "base_link", stamp: t, force: [0.0, 0.0, -5.0], torque: [0.0; 3] }),
            };
            let (next, out) = reference::step(&p, &s, &inbox, t);
            s = std::hint::black_box(next);
            std::hint::black_box(out);
        }
    });
    assert_eq!(n, 0, "reference::step allocated {n} times in 1000 cycles");
    assert!(s.p.x > 0.4, "the reference did not move: {:?}", s.p);
}
