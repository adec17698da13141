//! `jk5_sim_driver` as a library: the driver's core ([`core`]: command reception, hold,
//! saturation, missed cycles), its parameters ([`config`]), its set-up from the command
//! line ([`setup`]), its loop body ([`runner`]), the simulator behind it ([`plant`],
//! [`sim_plant`]) and the chain-latency histogram ([`latency`]), used by the DDS shell
//! (`main.rs`) and by `naic launch --composed`.
//!
//! Publishes `/joint_states` (sensor_msgs/JointState, joint1..joint6: position, velocity,
//! effort = measured joint torque), `/wrench` (geometry_msgs/WrenchStamped, frame_id
//! `ft_sensor`, the raw sensor reading) and `/clock` (rosgraph_msgs/Clock, simulated time);
//! subscribes `/joint_effort_cmd` (std_msgs/Float64MultiArray, six torques in N m).
//!
//! Real-time mode: one simulator step per period (`rate`, default 1 kHz, absolute-deadline
//! sleeps). In real time, if no valid command arrived for `command_timeout` (20 ms), the
//! driver holds the arm itself (gravity compensation + joint damping) and never keeps
//! applying an old torque.
//!
//! Lockstep mode (`lockstep: true`): one step per command *computed from the state just
//! published*, so a closed loop over DDS is deterministic and runs as fast as the chain
//! allows; stamps are then simulated time. A command carries the `/joint_states` stamp it
//! was computed from (`naic_ros::msgs::effort_msg`); commands for any other stamp (a late
//! duplicate, a restarted node's first command) are dropped and counted. When no matching
//! command arrives within `command_timeout`, simulated time stands still and the same state
//! is published again (same stamp), so a late or restarted controller gets it; the nodes
//! answer a repeated stamp with the command they already computed for it. Commands without
//! a stamp (for example from rclpy) are taken as they come.
//!
//! Last guard before the plant, whoever sends the command (friction_compensation, or
//! anyone publishing `/joint_effort_cmd` directly): a command that is not six finite
//! numbers is rejected (rate-limited log) and the driver holds instead of keeping the
//! previous one; whatever is applied, command or the driver's own hold, is saturated per
//! joint at `effort_limit` (default: the URDF `<limit effort>`, values above it refused).
//! The robot model and the friction file are loaded and checked before the DDS
//! participant exists: a bad file exits with code 2 and a message naming it.
//!
//! A separate receive thread wakes on each command and stamps its arrival, so the chain
//! latency (`/joint_states` stamp → command arrival) is measured exactly; it is written as
//! JSON to `latency_report` at exit (see `naic bench chain`).

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
