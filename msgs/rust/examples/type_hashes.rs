//! Prints `type<TAB>RIHS01 hash` for every naic_msgs type (used by tests/python/test_msgs_cdr.py).
use naic_msgs::*;
fn main() {
    for info in [
        Time::type_info(), Header::type_info(), JointState::type_info(), Vector3::type_info(),
        Wrench::type_info(), WrenchStamped::type_info(), Float64MultiArray::type_info(),
        MultiArrayLayout::type_info(), MultiArrayDimension::type_info(), Clock::type_info(),
        Point::type_info(), Quaternion::type_info(), Pose::type_info(), PoseStamped::type_info(),
        Transform::type_info(), TransformStamped::type_info(), TFMessage::type_info(),
        NaicParams::type_info(),
    ] {
        println!("{}\t{}", info.name, type_hash(info));
    }
}
