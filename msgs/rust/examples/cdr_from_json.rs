//! Test helper: reads `type_name<TAB>json` lines on stdin, builds the message through its
//! serde `Deserialize`, and prints its CDR as hex (after checking the CDR decodes back to
//! the same value). Used by tests/python/test_msgs_cdr.py to compare with rclpy.
use naic_msgs::*;
use std::io::BufRead;

fn cdr_hex<M: RosMessage + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug>(json: &str) -> String {
    let m: M = serde_json::from_str(json).unwrap_or_else(|e| panic!("bad json for {}: {e}", M::type_name()));
    let b = m.to_cdr();
    assert_eq!(M::from_cdr(&b).expect("decode"), m);
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn main() {
    for line in std::io::stdin().lock().lines() {
        let line = line.unwrap();
        let (ty, json) = line.split_once('\t').expect("type<TAB>json");
        let hex = match ty {
            "builtin_interfaces/msg/Time" => cdr_hex::<Time>(json),
            "std_msgs/msg/Header" => cdr_hex::<Header>(json),
            "sensor_msgs/msg/JointState" => cdr_hex::<JointState>(json),
            "geometry_msgs/msg/Vector3" => cdr_hex::<Vector3>(json),
            "geometry_msgs/msg/Wrench" => cdr_hex::<Wrench>(json),
            "geometry_msgs/msg/WrenchStamped" => cdr_hex::<WrenchStamped>(json),
            "std_msgs/msg/Float64MultiArray" => cdr_hex::<Float64MultiArray>(json),
            "std_msgs/msg/MultiArrayLayout" => cdr_hex::<MultiArrayLayout>(json),
            "std_msgs/msg/MultiArrayDimension" => cdr_hex::<MultiArrayDimension>(json),
            "rosgraph_msgs/msg/Clock" => cdr_hex::<Clock>(json),
            "naic_msgs/msg/NaicParams" => cdr_hex::<NaicParams>(json),
            other => panic!("unknown type {other}"),
        };
        println!("{hex}");
    }
}
