//! `friction_compensation` as a library: the node's pure core ([`core`]) and its ROS
//! parameters ([`config`]), used by the DDS shell (`main.rs`) and by anything that runs
//! the node in process.

pub mod config;
pub mod core;
pub mod shell;

#[cfg(test)]
#[global_allocator]
static COUNTING: naic_ros::alloc_check::CountingAlloc = naic_ros::alloc_check::CountingAlloc;
