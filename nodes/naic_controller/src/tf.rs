//! `/tf` and `/tf_static` from the measured joint states (what robot_state_publisher does,
//! so that RViz and Foxglove show the arm with `/robot_description`).
//!
//! One transform per URDF joint, parent link → child link: the moving joints on `/tf` at
//! `tf_rate` (throttled on the joint states' stamps, so simulated time works too), the
//! fixed joints once on `/tf_static` (transient local). Each transform is
//! `ᵒM_parent⁻¹ · ᵒM_child` from the model's forward kinematics (`naic_core::dynamics`),
//! the same kinematics the controller uses. Filling the message is allocation-free after
//! the first one (the strings and the vector keep their capacity); publishing clones it,
//! as every publish through ros2-client does.

use naic_core::{
    dynamics::forward_kinematics,
    model::{Data, FrameId, FrameKind, Model},
};
use nalgebra::{DVector, Isometry3};
use naic_ros::{
    msgs::{JointState, Quaternion, TFMessage, Transform, TransformStamped, Vector3},
    time::time_from_ns,
};

/// `tf_rate`'s default [Hz] (robot_state_publisher's `publish_frequency` is 20 Hz; issue 39
/// asks for 100 Hz: smooth in RViz at the arm's speeds, 1 % of the 1 kHz loop's messages).
pub const DEFAULT_TF_RATE: f64 = 100.0;

/// Why the link tree of a URDF could not be built for `/tf`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    /// The robot model does not load (the model's own message).
    #[error("{0}")]
    Model(#[from] naic_core::model::ModelError),
    /// urdf-rs refuses the text.
    #[error("cannot read the URDF: {0}")]
    Urdf(String),
    /// A joint names a link that is not a link frame of the model.
    #[error("joint '{joint}': link '{link}' is not a frame of the model")]
    Link { joint: String, link: String },
}

/// One URDF joint: its parent and child links as model frames.
#[derive(Clone, Debug)]
struct Edge {
    parent: FrameId,
    child: FrameId,
}

/// The link tree and the kinematics workspace.
pub struct TfTree {
    model: Model,
    data: Data,
    q: DVector<f64>,
    /// Where each model joint is in the last joint state's names (cached while the names
    /// stay the same).
    index: Vec<usize>,
    moving: Vec<Edge>,
    fixed: Vec<Edge>,
    msg: TFMessage,
    period_ns: i64,
    last_ns: Option<i64>,
}

impl TfTree {
    /// From the URDF text the controller loaded (`urdf`). Errors name the link or joint.
    pub fn new(urdf: &str, rate_hz: f64) -> Result<TfTree, TfError> {
        let model = Model::from_urdf_str(urdf)?;
        let robot = urdf_rs::read_from_string(urdf).map_err(|e| TfError::Urdf(e.to_string()))?;
        let link = |joint: &str, name: &str| -> Result<FrameId, TfError> {
            model
                .frames()
                .iter()
                .position(|f| f.kind == FrameKind::Link && f.name == name)
                .map(FrameId)
                .ok_or_else(|| TfError::Link { joint: joint.to_string(), link: name.to_string() })
        };
        let (mut moving, mut fixed) = (Vec::new(), Vec::new());
        for j in &robot.joints {
            let e = Edge { parent: link(&j.name, &j.parent.link)?, child: link(&j.name, &j.child.link)? };
            if matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                fixed.push(e);
            } else {
                moving.push(e);
            }
        }
        let frame_name = |id: FrameId| model.frame(id).name.clone();
        let transforms = moving
            .iter()
            .map(|e| TransformStamped {
                header: naic_ros::msgs::Header { frame_id: frame_name(e.parent), ..Default::default() },
                child_frame_id: frame_name(e.child),
                ..Default::default()
            })
            .collect();
        let n = model.nv();
        let data = Data::new(&model);
        let mut t = TfTree {
            data,
            q: DVector::zeros(n),
            index: Vec::with_capacity(n),
            moving,
            fixed,
            msg: TFMessage { transforms },
            period_ns: 0,
            last_ns: None,
            model,
        };
        t.set_rate(rate_hz);
        Ok(t)
    }

    /// `tf_rate` [Hz]; 0: no `/tf` (the static transforms still go out).
    pub fn set_rate(&mut self, rate_hz: f64) {
        self.period_ns = if rate_hz > 0.0 { (1e9 / rate_hz).round() as i64 } else { -1 };
    }

    /// The fixed joints' transforms (constant), stamped `stamp_ns`.
    pub fn static_message(&mut self, stamp_ns: i64) -> TFMessage {
        let q = DVector::zeros(self.model.nv());
        forward_kinematics(&self.model, &mut self.data, &q);
        let transforms = self
            .fixed
            .iter()
            .map(|e| {
                let mut t = TransformStamped {
                    header: naic_ros::msgs::Header {
                        stamp: time_from_ns(stamp_ns),
                        frame_id: self.model.frame(e.parent).name.clone(),
                    },
                    child_frame_id: self.model.frame(e.child).name.clone(),
                    ..Default::default()
                };
                set_transform(&mut t.transform, &relative(&self.data, e));
                t
            })
            .collect();
        TFMessage { transforms }
    }

    /// The moving joints' transforms at this joint state, when `tf_rate` says one is due
    /// (its stamp at least one period after the last one published, or earlier than it:
    /// simulated time restarted). `None`: not due, or a joint of the model missing from
    /// the message (the controller logs that one).
    pub fn joint_states(&mut self, js: &JointState) -> Option<&TFMessage> {
        let stamp = js.header.stamp.to_nanos();
        if self.period_ns < 0 || self.moving.is_empty() {
            return None;
        }
        if let Some(last) = self.last_ns {
            if stamp >= last && stamp - last < self.period_ns {
                return None;
            }
        }
        if !self.map_names(js) {
            return None;
        }
        for (i, &k) in self.index.iter().enumerate() {
            self.q[i] = *js.position.get(k)?;
        }
        if !self.q.iter().all(|x| x.is_finite()) {
            return None;
        }
        forward_kinematics(&self.model, &mut self.data, &self.q);
        for (e, t) in self.moving.iter().zip(self.msg.transforms.iter_mut()) {
            t.header.stamp = time_from_ns(stamp);
            set_transform(&mut t.transform, &relative(&self.data, e));
        }
        self.last_ns = Some(stamp);
        Some(&self.msg)
    }

    /// Index of each model joint in `js.name`; false when one is missing.
    fn map_names(&mut self, js: &JointState) -> bool {
        let n = self.model.nv();
        let same = self.index.len() == n
            && self.model.joint_names().zip(&self.index).all(|(name, &k)| js.name.get(k).is_some_and(|s| s == name));
        if same {
            return true;
        }
        self.index.clear();
        for name in self.model.joint_names() {
            match js.name.iter().position(|s| s == name) {
                Some(k) => self.index.push(k),
                None => {
                    self.index.clear();
                    return false;
                }
            }
        }
        true
    }
}

/// The robot model's topics for RViz, Foxglove and late joiners, advertised by the node
/// process and by `naic launch --composed` alike: `/robot_description` (the URDF text) and
/// `/tf_static` published once, transient local (their writers live as long as this), and
/// the tree that fills `/tf` (its publisher is handed out beside: the composed launch
/// publishes from another thread).
pub struct ModelTopics {
    /// `None` when the URDF cannot be read again (logged; the controller has loaded it).
    tree: Option<TfTree>,
    gen: u64,
    _static: ros2_client::Publisher<TFMessage>,
    _description: ros2_client::Publisher<naic_ros::msgs::StringMsg>,
}

impl ModelTopics {
    /// From the node's `urdf` and `tf_rate` parameters; `stamp_ns` stamps `/tf_static`.
    /// Also the `/tf` publisher.
    #[allow(clippy::type_complexity)]
    pub fn advertise(
        node: &mut naic_ros::RosNode,
        stamp_ns: i64,
    ) -> Result<(ModelTopics, ros2_client::Publisher<TFMessage>), naic_ros::RosError> {
        use naic_ros::{msgs, node::{QOS_LATCHED, QOS_PUB}};
        let (urdf, rate) = node.params.with(|p| (p.str("urdf").to_string(), p.f64("tf_rate")));
        let gen = node.params.generation();
        let description = node.publisher::<msgs::StringMsg>("robot_description", msgs::STRING, QOS_LATCHED)?;
        let tf_static = node.publisher::<TFMessage>("/tf_static", msgs::TF_MESSAGE, QOS_LATCHED)?;
        // tf2's TransformBroadcaster: reliable, volatile, keep last 100.
        let tf = node.publisher::<TFMessage>("/tf", msgs::TF_MESSAGE, QOS_PUB.history(ros2_client::qos::History::KeepLast { depth: 100 }))?;
        let tree = match std::fs::read_to_string(&urdf) {
            Ok(data) => {
                let tree = match TfTree::new(&data, rate) {
                    Ok(mut t) => {
                        if let Err(e) = tf_static.publish(t.static_message(stamp_ns)) {
                            log::warn!("cannot publish /tf_static: {e:?}");
                        }
                        Some(t)
                    }
                    Err(e) => {
                        log::warn!("/tf and /tf_static not published: robot model '{urdf}': {e}");
                        None
                    }
                };
                if let Err(e) = description.publish(msgs::StringMsg { data }) {
                    log::warn!("cannot publish /robot_description: {e:?}");
                }
                tree
            }
            Err(e) => {
                log::warn!("/robot_description, /tf and /tf_static not published: cannot read '{urdf}': {e}");
                None
            }
        };
        Ok((ModelTopics { tree, gen, _static: tf_static, _description: description }, tf))
    }

    /// The `/tf` message due at this joint state (see [`TfTree::joint_states`]), with
    /// `tf_rate` as last accepted.
    pub fn joint_states(&mut self, params: &naic_ros::ParamTable, js: &JointState) -> Option<&TFMessage> {
        let tree = self.tree.as_mut()?;
        if params.generation() != self.gen {
            self.gen = params.generation();
            tree.set_rate(params.with(|p| p.f64("tf_rate")));
        }
        tree.joint_states(js)
    }
}

/// `ᵒM_parent⁻¹ · ᵒM_child`: the child link's pose in its parent link.
fn relative(data: &Data, e: &Edge) -> Isometry3<f64> {
    data.frame_placement(e.parent).inv_mul(&data.frame_placement(e.child))
}

fn set_transform(t: &mut Transform, m: &Isometry3<f64>) {
    let (p, r) = (&m.translation.vector, m.rotation.as_ref());
    t.translation = Vector3 { x: p.x, y: p.y, z: p.z };
    t.rotation = Quaternion { x: r.i, y: r.j, z: r.k, w: r.w };
}

#[cfg(test)]
mod tests {
    use super::*;
    use naic_ros::msgs::Header;
    use nalgebra::{Translation3, UnitQuaternion};

    fn jk5() -> String {
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../urdf/jk5.urdf")).unwrap()
    }

    fn js(stamp_ns: i64, q: [f64; 6]) -> JointState {
        JointState {
            header: Header { stamp: time_from_ns(stamp_ns), frame_id: String::new() },
            // Not in the model's order: the transforms follow the names.
            name: ["joint6", "joint5", "joint4", "joint3", "joint2", "joint1"].map(String::from).to_vec(),
            position: q.iter().rev().copied().collect(),
            ..Default::default()
        }
    }

    fn iso(t: &TransformStamped) -> Isometry3<f64> {
        let (p, r) = (&t.transform.translation, &t.transform.rotation);
        Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::new_normalize(nalgebra::Quaternion::new(r.w, r.x, r.y, r.z)),
        )
    }

    /// Chaining the published transforms from the root link to `child` (every link has one
    /// parent: a serial chain with fixed side links).
    fn chain(msgs: &[&TFMessage], child: &str) -> (Isometry3<f64>, String) {
        let all: Vec<&TransformStamped> = msgs.iter().flat_map(|m| m.transforms.iter()).collect();
        let (mut m, mut at) = (Isometry3::identity(), child.to_string());
        while let Some(t) = all.iter().find(|t| t.child_frame_id == at) {
            m = iso(t) * m;
            at = t.header.frame_id.clone();
        }
        (m, at)
    }

    #[test]
    fn base_to_tip_through_the_published_transforms_is_the_models_forward_kinematics() {
        let urdf = jk5();
        let mut tree = TfTree::new(&urdf, 100.0).unwrap();
        let st = tree.static_message(0);
        let names: Vec<&str> = st.transforms.iter().map(|t| t.child_frame_id.as_str()).collect();
        assert_eq!(names, ["ft_sensor", "tip"], "the fixed joints go to /tf_static");
        let model = Model::from_urdf_str(&urdf).unwrap();
        let mut data = Data::new(&model);
        let q = [0.3, -0.4, 1.7, 0.2, 0.9, -1.1];
        let msg = tree.joint_states(&js(5_000_000, q)).unwrap().clone();
        assert_eq!(msg.transforms.len(), 6);
        assert!(msg.transforms.iter().all(|t| t.header.stamp.to_nanos() == 5_000_000), "stamped with the joint state");
        let (m, root) = chain(&[&st, &msg], "tip");
        assert_eq!(root, "base_link");
        forward_kinematics(&model, &mut data, &DVector::from_row_slice(&q));
        let want = data.frame_placement(model.frame_id("tip").unwrap());
        assert!((m.translation.vector - want.translation.vector).norm() < 1e-12, "{m} vs {want}");
        assert!(m.rotation.angle_to(&want.rotation) < 1e-9);
    }

    #[test]
    fn tf_rate_throttles_on_the_stamps_and_a_missing_joint_publishes_nothing() {
        let mut tree = TfTree::new(&jk5(), 100.0).unwrap();
        let q = [0.0; 6];
        assert!(tree.joint_states(&js(0, q)).is_some());
        assert!(tree.joint_states(&js(1_000_000, q)).is_none(), "1 ms later: not due at 100 Hz");
        assert!(tree.joint_states(&js(9_999_999, q)).is_none());
        assert!(tree.joint_states(&js(10_000_000, q)).is_some());
        assert!(tree.joint_states(&js(3_000_000, q)).is_some(), "time went back (simulation restarted)");
        let mut short = js(50_000_000, q);
        short.name.pop();
        short.position.pop();
        assert!(tree.joint_states(&short).is_none(), "joint1 missing");
        tree.set_rate(0.0);
        assert!(tree.joint_states(&js(90_000_000, q)).is_none(), "tf_rate 0: no /tf");
    }

    #[test]
    fn filling_the_message_again_does_not_allocate() {
        let mut tree = TfTree::new(&jk5(), 1000.0).unwrap();
        let q = [0.1, 0.2, 1.5, 0.0, 0.7, 0.3];
        let (a, b) = (js(0, q), js(1_000_000, q));
        tree.joint_states(&a).unwrap();
        let (done, n) = naic_core::alloc_count::counted(|| tree.joint_states(&b).is_some());
        assert!(done);
        assert_eq!(n, 0, "allocations while filling /tf");
    }
}
