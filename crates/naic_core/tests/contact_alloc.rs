//! The contact estimator's step does not allocate (`naic_core::alloc_count`'s counting
//! global allocator, per thread): a contact start, ordinary samples, a jump (the held
//! samples refiltered under both hypotheses, the two run side by side) and unusable inputs.

use naic_core::alloc_count::{counted, CountingAlloc};
use naic_core::pipeline::control::contact::{step, ContactInputs, ContactParams, ContactState};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

#[test]
fn the_contact_step_does_not_allocate() {
    let ((), probe) = counted(|| drop(std::hint::black_box(vec![1u8; 16])));
    assert!(probe >= 1, "no allocation counted: the check below would pass vacuously");
    let p = ContactParams::default();
    let base = ContactInputs { dt: 1e-3, delay_cycles: 1, x_resolution: 1.5e-6, sigma_f: 1.0 / 16.0, ..Default::default() };
    let mut s = ContactState::default();
    let mut jumps = 0;
    let ((), n) = counted(|| {
        for k in 0..600 {
            let t = k as f64 * 1e-3;
            // approach at 38 mm/s onto a 50 000 N/m surface at x = 0, the tip stopping at
            // 0.2 mm; at 0.4 s the surface turns to foam (2000 N/m) at the same place
            let x = (-0.002 + 0.038 * t).min(2e-4);
            let k_e = if t < 0.4 { 50_000.0 } else { 2000.0 };
            let f = (k_e * x).max(0.0);
            let i = ContactInputs { x, x_dot: if x < 2e-4 { 0.038 } else { 0.0 }, f, u: f, contact_start: f > 0.5 && !s.active, in_contact: f > 0.5 || s.active, ..base };
            s = std::hint::black_box(step(&p, &s, &i)).0;
            jumps = s.jumps;
        }
        std::hint::black_box(step(&p, &s, &ContactInputs { f: f64::NAN, ..base }));
    });
    assert_eq!(n, 0, "the contact step allocated {n} times");
    assert!(s.active && jumps >= 1, "the run did not reach a contact and a jump: {s:?}");
}
