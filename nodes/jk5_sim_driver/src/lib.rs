//! `jk5_sim_driver` as a library: the driver's core ([`core`]: command reception, hold,
//! saturation, missed cycles), its parameters ([`config`]), its set-up from the command
//! line ([`setup`]), its loop body ([`runner`]), the simulator behind it ([`plant`],
//! [`sim_plant`]) and the chain-latency histogram ([`latency`]), used by the DDS shell
//! (`main.rs`) and by `naic launch --composed`.

pub mod config;
pub mod core;
pub mod latency;
pub mod plant;
pub mod runner;
pub mod setup;
pub mod sim_plant;

#[cfg(test)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;
