//! `friction_compensation` as a library: the node's pure core ([`core`]), its ROS
//! parameters ([`config`]), its set-up from the command line ([`setup`]) and its loop body
//! ([`runner`]), used by the DDS shell (`main.rs`) and by `naic launch --composed`.

pub mod config;
pub mod core;
pub mod runner;
pub mod setup;

#[cfg(test)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;
