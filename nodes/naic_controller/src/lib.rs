//! `naic_controller` as a library: the node's pure core ([`core`]), its ROS parameters
//! ([`config`]), the position reference ([`reference`]), its set-up from the command line
//! ([`setup`]), its loop body ([`runner`]) and `/tf` ([`tf`]), used by the DDS shell (`main.rs`) and by
//! `naic launch --composed`.

pub mod config;
pub mod core;
pub mod reference;
pub mod runner;
pub mod setup;
pub mod tf;

#[cfg(test)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;
