//! The plant interface: one trait for every simulated robot + sensor that the
//! closed loop ([`crate::runner`]), the benches and the `jk5_sim_driver` node drive,
//! and one place that builds the chosen one ([`PlantChoice::build`]).
//!
//! * [`PlantChoice::Own`]: naic's own plant ([`crate::plant`]: ABA of the URDF, Table 1
//!   friction, spring contact, the mini45 model), through [`crate::arm::SimArm`].
//! * [`PlantChoice::Mujoco`]: MuJoCo stepping an MJCF (default: the paper authors'
//!   JK5 file), in process through `mujoco-rs` (cargo feature `mujoco`;
//!   [`crate::mujoco_plant`]). Without the feature, building it is an error that
//!   says how to turn it on.
//!
//! Joint vectors cross the interface as slices of length [`Plant::dof`].

use crate::plant::{Observation, PlantError, PlantParams};
use std::path::PathBuf;

/// A simulated robot + F/T sensor in one scenario's world, advanced one control
/// period at a time. Implementations preallocate; `step` does not allocate.
pub trait Plant<const N: usize = { naic_core::N_JOINTS }> {
    /// `own` or `mujoco` (files and reports).
    fn name(&self) -> &'static str;
    /// Number of joints; every joint slice in and out has this length.
    fn dof(&self) -> usize;
    /// The control period [s] (torque zero-order hold).
    fn dt(&self) -> f64;
    /// Advance one control period under the commanded joint torques `tau` [N·m]
    /// (`tau.len() == dof()`; saturated at the effort limits, non-finite entries read as 0).
    fn step(&mut self, tau: &[f64]);
    /// Measurements and ground truth at the current time.
    fn observation(&self) -> &Observation<N>;
    /// True joint positions [rad] (ground truth, for records).
    fn q(&self) -> &[f64];
    /// True joint velocities [rad/s] (ground truth, for records).
    fn dq(&self) -> &[f64];
}

/// Which plant to build (`naic sim --plant`, `jk5_sim_driver -p plant:=`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlantChoice {
    /// naic's own plant.
    Own,
    /// MuJoCo stepping the MJCF file `mjcf`.
    Mujoco { mjcf: PathBuf },
}

/// The plant names [`PlantChoice::parse`] accepts.
pub const PLANTS: [&str; 2] = ["own", "mujoco"];

/// The paper authors' JK5 MJCF, relative to the repository root.
pub const DEFAULT_MJCF: &str = "../shared/reference/jk5/jk5_table.nomesh.mjcf.xml";

impl PlantChoice {
    /// `name` is `own` or `mujoco`; `mjcf` is the MuJoCo model file (ignored for `own`,
    /// `default_mjcf` when `None`).
    pub fn parse(name: &str, mjcf: Option<PathBuf>, default_mjcf: PathBuf) -> Result<Self, PlantError> {
        match name {
            "own" => match mjcf {
                Some(f) => Err(PlantError::MjcfWithoutMujoco { mjcf: f.display().to_string() }),
                None => Ok(Self::Own),
            },
            // Refused here, before any run, in a build without MuJoCo.
            "mujoco" if !cfg!(feature = "mujoco") => Err(PlantError::MujocoNotBuilt),
            "mujoco" => Ok(Self::Mujoco { mjcf: mjcf.unwrap_or(default_mjcf) }),
            o => Err(PlantError::UnknownPlant { name: o.to_string() }),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Self::Own => "own",
            Self::Mujoco { .. } => "mujoco",
        }
    }

    /// The one dispatch point: the plant `p` describes (control period, effort
    /// limits, environment, sensor and encoder models; its URDF model and friction
    /// are the own plant's), at rest at `q0`, noise seeded with `seed`.
    pub fn build(&self, p: &PlantParams, q0: &[f64], seed: u64) -> Result<Box<dyn Plant + Send>, PlantError> {
        match self {
            Self::Own => {
                let mut q = [0.0; naic_core::N_JOINTS];
                if q0.len() != q.len() {
                    return Err(PlantError::Config(format!("q0 has {} joints; the arm has {}", q0.len(), q.len())));
                }
                q.copy_from_slice(q0);
                Ok(Box::new(crate::arm::SimArm::new(p.clone(), q, seed)))
            }
            #[cfg(feature = "mujoco")]
            Self::Mujoco { mjcf } => Ok(Box::new(crate::mujoco_plant::MujocoPlant::new(mjcf, p, q0, seed)?)),
            #[cfg(not(feature = "mujoco"))]
            Self::Mujoco { .. } => Err(PlantError::MujocoNotBuilt),
        }
    }

    /// [`PlantChoice::build`] for an arm of any joint count `N` (a robot file's arm): the own
    /// plant; MuJoCo steps the paper's JK5 MJCF only, so it is an error here.
    pub fn build_n<const N: usize>(&self, p: &PlantParams<N>, q0: &naic_core::JointVec<N>, seed: u64) -> Result<Box<dyn Plant<N> + Send>, PlantError> {
        match self {
            Self::Own => Ok(Box::new(crate::arm::SimArm::<N>::new(p.clone(), *q0, seed))),
            Self::Mujoco { .. } => Err(PlantError::Config(
                "--plant mujoco steps the JK5's MJCF only; drop --plant mujoco for this robot file (the own plant runs any robot file)".into(),
            )),
        }
    }
}

impl<const N: usize> Plant<N> for crate::arm::SimArm<N> {
    fn name(&self) -> &'static str {
        "own"
    }
    fn dof(&self) -> usize {
        N
    }
    fn dt(&self) -> f64 {
        self.params().dt
    }
    fn step(&mut self, tau: &[f64]) {
        let mut t = [0.0; N];
        for (o, v) in t.iter_mut().zip(tau) {
            *o = *v;
        }
        crate::arm::SimArm::step(self, &t);
    }
    fn observation(&self) -> &Observation<N> {
        crate::arm::SimArm::observation(self)
    }
    fn q(&self) -> &[f64] {
        &self.true_state().q
    }
    fn dq(&self) -> &[f64] {
        &self.true_state().dq
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plant_names_parse_and_errors_name_the_fix() {
        let d = PathBuf::from("default.xml");
        assert_eq!(PlantChoice::parse("own", None, d.clone()).unwrap(), PlantChoice::Own);
        if cfg!(feature = "mujoco") {
            assert_eq!(PlantChoice::parse("mujoco", None, d.clone()).unwrap(), PlantChoice::Mujoco { mjcf: d.clone() });
        } else {
            // Without MuJoCo the choice is refused before any run, naming the feature.
            let e = PlantChoice::parse("mujoco", None, d.clone()).unwrap_err().to_string();
            assert!(e.contains("--features mujoco"), "{e}");
        }
        let e = PlantChoice::parse("gazebo", None, d.clone()).unwrap_err().to_string();
        assert!(e.contains("'gazebo'") && e.contains("own or mujoco"), "{e}");
        let e = PlantChoice::parse("own", Some("x.xml".into()), d).unwrap_err().to_string();
        assert!(e.contains("x.xml") && e.contains("--plant mujoco"), "{e}");
    }
}
