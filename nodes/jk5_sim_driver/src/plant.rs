//! What the driver needs from a simulator: one pure step per cycle and the sensor readings.

/// A simulated arm with F/T sensor.
pub trait Plant {
    /// Advance by `dt` seconds under joint torques `tau` [N m].
    fn step(&mut self, tau: &[f64; 6], dt: f64);
    /// Torques that hold the arm where it is: gravity compensation + joint damping
    /// (`damping` N m s/rad). Used when no command arrives in time.
    fn hold_torque(&mut self, damping: f64) -> [f64; 6];
    /// Joint positions [rad], velocities [rad/s] and measured joint torques [N m].
    fn joints(&self) -> ([f64; 6], [f64; 6], [f64; 6]);
    /// Raw F/T sensor reading in the `ft_sensor` frame: [fx, fy, fz, tx, ty, tz].
    fn wrench(&self) -> [f64; 6];
    /// Simulated time since start [s].
    fn time(&self) -> f64;
}

/// Which simulator the driver runs (the read-only `plant` parameter).
#[cfg_attr(feature = "naic_sim_plant", allow(dead_code))]
pub const PLANT_NAME: &str = "placeholder";

/// SCRATCH placeholder until `naic_sim`'s arm simulator lands on main: six decoupled
/// joints (unit inertia, light viscous friction, no gravity, no contact). It only
/// exercises the DDS plumbing; no test of physics may rely on it.
#[cfg_attr(feature = "naic_sim_plant", allow(dead_code))]
pub struct PlaceholderPlant {
    q: [f64; 6],
    v: [f64; 6],
    tau: [f64; 6],
    t: f64,
}

#[cfg_attr(feature = "naic_sim_plant", allow(dead_code))]
impl PlaceholderPlant {
    pub fn new() -> Self {
        PlaceholderPlant { q: [0.0, 0.5, -1.0, 0.0, 1.0, 0.0], v: [0.0; 6], tau: [0.0; 6], t: 0.0 }
    }
}

/// The plant the driver's parameters describe (the placeholder ignores them).
#[cfg_attr(feature = "naic_sim_plant", allow(dead_code))]
pub fn make_plant(_p: &naic_ros::ParamView) -> Result<PlaceholderPlant, String> {
    Ok(PlaceholderPlant::new())
}

impl Plant for PlaceholderPlant {
    fn step(&mut self, tau: &[f64; 6], dt: f64) {
        for i in 0..6 {
            let a = tau[i] - 0.5 * self.v[i];
            self.v[i] += a * dt;
            self.q[i] += self.v[i] * dt;
        }
        self.tau = *tau;
        self.t += dt;
    }
    fn hold_torque(&mut self, damping: f64) -> [f64; 6] {
        let mut t = [0.0; 6];
        for i in 0..6 {
            t[i] = -damping * self.v[i];
        }
        t
    }
    fn joints(&self) -> ([f64; 6], [f64; 6], [f64; 6]) {
        (self.q, self.v, self.tau)
    }
    fn wrench(&self) -> [f64; 6] {
        [0.0; 6]
    }
    fn time(&self) -> f64 {
        self.t
    }
}
