//! The 1 kHz path does not touch the heap: one plant step (with friction and
//! contact) and one controller step, counted with `naic_core::alloc_count`.

use naic_core::friction::{FrictionParams, Smoothing, DEFAULT_V_S};
use naic_core::model::Model;
use naic_sim::controllers::{LoopSettings, PipelineController};
use naic_sim::plant::{self, Integrator, PlantParams, PlantState, PlantWorkspace};
use naic_sim::rng::Rng;
use naic_sim::runner::Controller;
use naic_sim::scenario;
use naic_sim::sensor::{Encoders, Mini45};
use nalgebra::Vector3;
use naic_core::alloc_count::{counted, CountingAlloc};

#[global_allocator]
static A: CountingAlloc = CountingAlloc;

#[test]
fn plant_and_controller_steps_do_not_allocate() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let m = Model::from_urdf_file(format!("{root}/urdf/jk5.urdf")).unwrap();
    let f = FrictionParams::from_yaml_file(format!("{root}/params/friction_jk5.yaml"))
        .unwrap()
        .to_model()
        .unwrap()
        .with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S })
        .unwrap();
    let s = scenario::preset("flat", &m).unwrap();
    let ft = Mini45::si_145_5(0.424, Vector3::new(0.0, 0.0, 0.015), &mut Rng::seed(1));
    let p = PlantParams::new(m.clone(), Some(f.clone()), Integrator::ImplicitFriction, 1e-3, 2, s.env.clone(), ft, Encoders::default()).unwrap();
    // every law; the scheduled one with the DDS-chain delay and a model mass error of 1.25
    // (the oracle is the scheduled law with the true stiffness): its approach servo reaches
    // the surface with the model 25 % heavy, so the contact path is covered; and with the
    // model 20 % light, where the gravity correction by the learnt gain is on
    // (scheduled::gain::GravityCorrection). The derived law (contact estimator, gain rule,
    // the apparent mass along n) and its oracle with the same delay and model error.
    let delayed = LoopSettings { delay_cycles: 2, model_mass_error: 1.25, ..LoopSettings::default() };
    let light = LoopSettings { delay_cycles: 1, model_mass_error: 0.8, ..LoopSettings::default() };
    for (name, settings) in [("naic", LoopSettings::default()), ("aic", LoopSettings::default()), ("fixed", LoopSettings::default()), ("scheduled", delayed), ("oracle", delayed), ("scheduled", light), ("derived", delayed), ("derived_oracle", delayed)] {
        let c = PipelineController::by_name(name, &s, &m, Some(f.clone()), (0.424, Vector3::new(0.0, 0.0, 0.015)), &settings).unwrap();
        count_in_contact(name, c, &s, &p);
    }
    // The heavy side's static reading (a forward dynamics, once in the approach):
    // the approach counted from the start, with the reading taken in it.
    let heavy = LoopSettings { delay_cycles: 1, model_mass_error: 1.25, ..LoopSettings::default() };
    let mut c = PipelineController::by_name("scheduled", &s, &m, Some(f.clone()), (0.424, Vector3::new(0.0, 0.0, 0.015)), &heavy).unwrap();
    let mut ws = PlantWorkspace::new(&p);
    let (mut st, mut obs) = plant::observe(&p, &PlantState::at_rest(s.task.q0, 1), &mut ws, [0.0; 6], false);
    let ((), n) = counted(|| {
        for k in 1..1200 {
            c.set_true_stiffness(obs.truth.contact.k_e);
            let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * 1e-3));
            (st, obs) = plant::step(&p, &st, &tau, &mut ws);
        }
    });
    let g = c.state().controller.control.sched.gain.heavy;
    assert!(g.is_some_and(|f| f > 1.1), "the heavy reading must be covered: {g:?}");
    assert_eq!(n, 0, "scheduled F = 1.25: {n} heap allocations in the approach");
}

fn count_in_contact(name: &str, mut c: PipelineController, s: &scenario::Scenario, p: &PlantParams) {
    let mut ws = PlantWorkspace::new(p);
    let (mut st, mut obs) = plant::observe(p, &PlantState::at_rest(s.task.q0, 1), &mut ws, [0.0; 6], false);
    // run into contact first (allocation-free too, but counted only below)
    let mut k = 0;
    while k < 1700 || (!obs.truth.contact.in_contact && k < 4000) {
        k += 1;
        c.set_true_stiffness(obs.truth.contact.k_e);
        let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * 1e-3));
        (st, obs) = plant::step(p, &st, &tau, &mut ws);
    }
    assert!(obs.truth.contact.in_contact, "{name}: the check must cover the contact path");
    let ((), n) = counted(|| {
        for k in k..k + 100 {
            c.set_true_stiffness(obs.truth.contact.k_e);
            let (tau, _) = c.step(&obs.meas, &s.reference(k as f64 * 1e-3));
            (st, obs) = plant::step(p, &st, &tau, &mut ws);
        }
    });
    assert_eq!(n, 0, "{name}: {n} heap allocations in 100 closed-loop periods");
    assert!(counted(|| drop(vec![0u8; 8])).1 >= 1, "no allocation counted: this check would pass vacuously");
}
