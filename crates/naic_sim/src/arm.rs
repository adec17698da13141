//! A stateful handle on the simulator for drivers (e.g. the `jk5_sim_driver`
//! ROS node): the pure [`crate::plant::step`] with its state and workspace
//! kept inside, one call per control period.
//!
//! It has no hold of its own: a driver holds the arm with `naic_core::pipeline::hold` at
//! the *measured* state, as a real driver does from its encoders (`jk5_sim_driver`'s
//! `SimPlant`), the same law the controller applies on a fault.

use crate::plant::{self, Observation, PlantParams, PlantState, PlantWorkspace};
use naic_core::{JointVec, N_JOINTS};

/// The simulated JK5 + mini45 in one scenario's world.
pub struct SimArm<const N: usize = N_JOINTS> {
    params: PlantParams<N>,
    state: PlantState<N>,
    ws: PlantWorkspace<N>,
    obs: Observation<N>,
}

impl<const N: usize> SimArm<N> {
    /// At rest at `q0`, noise seeded with `seed`. The control period is `params.dt`.
    pub fn new(params: PlantParams<N>, q0: JointVec<N>, seed: u64) -> Self {
        let mut ws = PlantWorkspace::new(&params);
        let (state, obs) = plant::observe(&params, &PlantState::at_rest(q0, seed), &mut ws, [0.0; N], false);
        Self { params, state, ws, obs }
    }

    /// Advance one control period (`params().dt`) under `tau` [N·m] (saturated at the effort limits).
    pub fn step(&mut self, tau: &JointVec<N>) {
        (self.state, self.obs) = plant::step(&self.params, &self.state, tau, &mut self.ws);
    }

    /// Measured joint positions [rad], velocities [rad/s], and the applied joint torques [N·m].
    pub fn joints(&self) -> (JointVec<N>, JointVec<N>, JointVec<N>) {
        (self.obs.meas.q, self.obs.meas.dq, self.obs.truth.tau_applied)
    }

    /// Raw F/T reading in the `ft_sensor` frame (force then torque).
    pub fn wrench(&self) -> [f64; 6] {
        self.obs.meas.wrench
    }

    /// Simulated time [s].
    pub fn time(&self) -> f64 {
        self.state.t
    }

    /// The last observation (measurements and ground truth).
    pub fn observation(&self) -> &Observation<N> {
        &self.obs
    }

    /// The true state (positions, velocities, time).
    pub fn true_state(&self) -> &PlantState<N> {
        &self.state
    }

    pub fn params(&self) -> &PlantParams<N> {
        &self.params
    }
}
