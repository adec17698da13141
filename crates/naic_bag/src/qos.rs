//! The QoS profile a publisher offered, as rosbag2 stores it (metadata version 9 spelling).

/// An offered QoS profile (only the policies rosbag2 stores; durations are infinite).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// `keep_last` depth (0 with `keep_all`).
    pub depth: u32,
    pub keep_all: bool,
    pub reliable: bool,
    pub transient_local: bool,
}

impl Default for Qos {
    /// rclcpp/rclpy's default for publishers: reliable, volatile, keep last 10.
    fn default() -> Self {
        Self { depth: 10, keep_all: false, reliable: true, transient_local: false }
    }
}

impl Qos {
    /// Best-effort "sensor data" profile (keep last 5).
    pub fn sensor_data() -> Self {
        Self { depth: 5, keep_all: false, reliable: false, transient_local: false }
    }

    /// The profile as a YAML mapping, each line prefixed by `indent` (first line carries `- `).
    pub(crate) fn yaml_item(&self, indent: &str) -> String {
        const INF: &str = "sec: 9223372036\n{i}    nsec: 854775807";
        let inf = INF.replace("{i}", indent);
        format!(
            "{indent}- history: {}\n{indent}  depth: {}\n{indent}  reliability: {}\n{indent}  durability: {}\n\
             {indent}  deadline:\n{indent}    {inf}\n{indent}  lifespan:\n{indent}    {inf}\n\
             {indent}  liveliness: automatic\n{indent}  liveliness_lease_duration:\n{indent}    {inf}\n\
             {indent}  avoid_ros_namespace_conventions: false\n",
            if self.keep_all { "keep_all" } else { "keep_last" },
            self.depth,
            if self.reliable { "reliable" } else { "best_effort" },
            if self.transient_local { "transient_local" } else { "volatile" },
        )
    }

    /// Parses the fields we keep from one YAML mapping of an `offered_qos_profiles` list
    /// (either spelling: names as in version 9 or the integer enums of older versions).
    pub(crate) fn from_yaml_lines(text: &str) -> Vec<Qos> {
        let mut out = Vec::new();
        let mut cur: Option<Qos> = None;
        for line in text.lines() {
            let t = line.trim();
            let t = if let Some(rest) = t.strip_prefix("- ") {
                if let Some(q) = cur.take() {
                    out.push(q);
                }
                cur = Some(Qos::default());
                rest
            } else {
                t
            };
            let Some(q) = cur.as_mut() else { continue };
            let Some((k, v)) = t.split_once(':') else { continue };
            let v = v.trim();
            match k.trim() {
                "history" => q.keep_all = v == "keep_all" || v == "2",
                "depth" => q.depth = v.parse().unwrap_or(q.depth),
                "reliability" => q.reliable = !(v == "best_effort" || v == "2"),
                "durability" => q.transient_local = v == "transient_local" || v == "1",
                _ => {}
            }
        }
        out.extend(cur);
        out
    }
}

/// The `offered_qos_profiles` channel metadata value: a YAML sequence as a string.
pub fn qos_yaml_string(qos: &[Qos]) -> String {
    if qos.is_empty() {
        return "[]".to_string();
    }
    let s: String = qos.iter().map(|q| q.yaml_item("")).collect();
    s.trim_end().to_string()
}
