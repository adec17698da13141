//! What the driver needs from a simulator: one pure step per cycle and the sensor readings.

use naic_core::JointVec;

/// A simulated arm of `N` joints with F/T sensor.
pub trait Plant<const N: usize = { naic_core::N_JOINTS }> {
    /// Advance by `dt` seconds under joint torques `tau` [N m].
    fn step(&mut self, tau: &JointVec<N>, dt: f64);
    /// Torques that hold the arm where it is: gravity compensation + joint damping
    /// (`damping` N m s/rad, capped per joint for stability at the control period as in
    /// `naic_core::pipeline::hold`). Used when no command arrives in time; the driver
    /// saturates it like any command.
    fn hold_torque(&mut self, damping: f64) -> JointVec<N>;
    /// Joint positions [rad], velocities [rad/s] and measured joint torques [N m].
    fn joints(&self) -> (JointVec<N>, JointVec<N>, JointVec<N>);
    /// Raw F/T sensor reading in the `ft_sensor` frame: [fx, fy, fz, tx, ty, tz].
    fn wrench(&self) -> [f64; 6];
    /// Simulated time since start [s].
    fn time(&self) -> f64;
}
