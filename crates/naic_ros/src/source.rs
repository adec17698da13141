//! Who may publish on a node's input topics (issue 41, "one owner of the command").
//!
//! DDS lets any participant on the domain write any topic, and a subscription takes every
//! writer's samples: a second publisher on `/joint_effort_cmd` (a misconfigured teleop
//! node as easily as an attacker) had its commands applied interleaved with the chain's.
//! A [`SourceGate`] in front of a subscription accepts the samples of one node only, named
//! by a parameter (`command_source`, `reference_source`), and ignores every other writer,
//! counting each of its samples ([`SourceGate::ignored`]) and logging each foreign writer
//! once with its node's name (the log goes to `/rosout` too).
//!
//! **Which node a sample comes from.** RustDDS gives each sample its writer's GUID
//! (ros2-client's `MessageInfo::publisher_gid`). The ROS graph names the node of a writer:
//! every ROS 2 participant publishes `ros_discovery_info` (`rmw_dds_common`
//! ParticipantEntitiesInfo: per node its name and the GIDs of its writers and readers),
//! which is what `ros2 node info` reads. [`NodeGraph`] reads that topic and maps writer GID
//! → fully qualified node name. A writer whose node is not known yet (its participant's
//! `ros_discovery_info` has not arrived) is not accepted: the gate fails closed, and the
//! driver holds the arm meanwhile as it does without commands.
//!
//! **A restarted owner** has new writer GUIDs under the same node name. The gate accepts
//! one writer of the owning node at a time and changes to another writer of it only after
//! the current one has been silent for the take-over gap (the driver: `command_timeout`,
//! by then it holds the arm itself; friction_compensation: `takeover_gap`, by then it
//! restarts its rate limit from the measured torque). Two live writers of the same name
//! (two processes started with one node name) therefore never interleave.
//!
//! **Any source** (`*`, the reference topics' default): every writer is accepted, and a
//! warning names the writers when two of them wrote within one second.
//!
//! This is a guard against mistakes and against writers that keep to the ROS graph's
//! conventions; a participant can announce any node name it likes. Against a participant
//! that lies, DDS Security (SROS2 permissions: only the chain's enclave may publish the
//! command topics) is the answer: docs/deploy.md, "Who may move the arm". Under DDS
//! Security the gate works the same way: secured participants exchange `ros_discovery_info`
//! like any topic (with the vendored rustdds's key exchange per endpoint pair, PATCHED.md),
//! so a writer in the chain's own enclave under another node name is ignored too.

use std::{
    collections::HashMap,
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc,
    },
};

use ros2_client::{
    builtin_topics::ros_discovery,
    dds::rustdds::{
        no_key::DataReaderCdr,
        policy::{Durability, History, Reliability},
        Duration as DdsDuration, QosPolicyBuilder, TopicKind,
    },
    Context, Gid,
};
use serde::Deserialize;

use crate::{params::ParamSpec, RosError};

/// The source that accepts every writer.
pub const ANY: &str = "*";

/// A node's `<name>` parameter naming who may publish `topic` (read-only: the gate is
/// built at start-up); `default`: a node name, or [`ANY`].
pub fn spec(name: &str, default: &str, topic: &str) -> ParamSpec {
    ParamSpec::string(
        name,
        default,
        &format!(
            "The node whose samples on {topic} are accepted ('name': that node in any namespace, '/ns/name': exactly it, '*': any writer); samples of every other writer are ignored, counted and logged once per writer with its node's name"
        ),
    )
    .read_only()
}

/// `rmw_dds_common/msg/NodeEntitiesInfo`, as on the wire.
#[derive(Deserialize)]
struct NodeEntities {
    node_namespace: String,
    node_name: String,
    #[allow(dead_code)]
    reader_gid_seq: Vec<Gid>,
    writer_gid_seq: Vec<Gid>,
}

/// `rmw_dds_common/msg/ParticipantEntitiesInfo`, as on the wire.
#[derive(Deserialize)]
struct ParticipantEntities {
    #[allow(dead_code)]
    gid: Gid,
    node_entities_info_seq: Vec<NodeEntities>,
}

/// Writer GID → the fully qualified name of its node, from `ros_discovery_info`.
pub struct NodeGraph {
    reader: Option<DataReaderCdr<ParticipantEntities>>,
    writers: HashMap<Gid, String>,
}

impl NodeGraph {
    /// A reader of `ros_discovery_info` in `context`'s participant (transient local: the
    /// participants that started earlier are known as soon as they are discovered).
    pub fn new(context: &Context) -> Result<NodeGraph, RosError> {
        let dp = context.domain_participant();
        let err = |e: &dyn std::fmt::Debug| RosError::Dds(format!("cannot read {}: {e:?}", ros_discovery::TOPIC_NAME));
        let topic = dp
            .create_topic(ros_discovery::TOPIC_NAME.to_string(), ros_discovery::TYPE_NAME.to_string(), &ros_discovery::QOS_PUB, TopicKind::NoKey)
            .map_err(|e| err(&e))?;
        // Every participant's newest list: the topic has no key, so the history must hold
        // the samples of all the participants that answer at once (a new reader of a
        // transient-local topic gets one from each).
        let qos = QosPolicyBuilder::new()
            .durability(Durability::TransientLocal)
            .reliability(Reliability::Reliable { max_blocking_time: DdsDuration::ZERO })
            .history(History::KeepLast { depth: 256 })
            .build();
        let sub = dp.create_subscriber(&qos).map_err(|e| err(&e))?;
        let reader = sub.create_datareader_no_key_cdr::<ParticipantEntities>(&topic, Some(qos)).map_err(|e| err(&e))?;
        Ok(NodeGraph { reader: Some(reader), writers: HashMap::new() })
    }

    /// A graph that learns nothing by itself (tests: names come from [`NodeGraph::insert`]).
    pub fn detached() -> NodeGraph {
        NodeGraph { reader: None, writers: HashMap::new() }
    }

    /// Take the `ros_discovery_info` samples that arrived since the last call.
    pub fn refresh(&mut self) {
        let Some(reader) = self.reader.as_mut() else { return };
        loop {
            match reader.take_next_sample() {
                Ok(Some(s)) => {
                    for n in s.into_value().node_entities_info_seq {
                        let ns = n.node_namespace.trim_end_matches('/');
                        let fqn = format!("{ns}/{}", n.node_name);
                        for g in n.writer_gid_seq {
                            self.writers.insert(g, fqn.clone());
                        }
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    log::debug!("unreadable {} sample: {e:?}", ros_discovery::TOPIC_NAME);
                    break;
                }
            }
        }
    }

    /// The node of writer `gid`, as far as the graph knows.
    pub fn node_of(&self, gid: &Gid) -> Option<&str> {
        self.writers.get(gid).map(String::as_str)
    }

    /// Name writer `gid`'s node (tests, and nodes of this process).
    pub fn insert(&mut self, gid: Gid, fqn: &str) {
        self.writers.insert(gid, fqn.to_string());
    }
}

/// Whether `fqn` (`/ns/name`) is the node `source` names: `/ns/name` exactly, or a bare
/// `name` in any namespace.
pub fn names(source: &str, fqn: &str) -> bool {
    if source.starts_with('/') {
        source == fqn
    } else {
        fqn.rsplit('/').next() == Some(source)
    }
}

/// What a gate has seen of one writer.
struct Writer {
    /// Its node, once the graph named it.
    node: Option<String>,
    /// Wall time of its first and newest sample [ns].
    first_ns: i64,
    last_ns: i64,
    /// Its samples the gate ignored.
    ignored: u64,
    /// Logged as foreign (with its name), or as an unnamed writer.
    logged_named: bool,
    logged_unnamed: bool,
}

/// A writer never named by the graph is logged (without a name) after this long [ns].
const UNNAMED_AFTER_NS: i64 = 1_000_000_000;
/// Any source: two writers within this long of each other are warned about [ns].
const TWO_WRITERS_NS: i64 = 1_000_000_000;

/// The gate in front of one subscription (see the module documentation).
pub struct SourceGate {
    topic: String,
    /// The parameter that names the source, for the messages.
    param: String,
    source: String,
    gap_ns: i64,
    graph: NodeGraph,
    /// The accepted writer of the owning node and the wall time of its newest sample [ns].
    owner: Option<(Gid, i64)>,
    writers: HashMap<Gid, Writer>,
    ignored: Arc<AtomicU64>,
    /// Of those, the samples of writers named as another node than the source.
    foreign: Arc<AtomicU64>,
    warned_two: bool,
}

impl SourceGate {
    /// The gate of `topic` for the source `source` (a node name or [`ANY`]) set by the
    /// parameter `param`; a new writer of the owning node takes over after the current one
    /// was silent for `gap_ns`.
    pub fn new(topic: &str, param: &str, source: &str, gap_ns: i64, graph: NodeGraph) -> SourceGate {
        let source = source.trim();
        let source = if source.is_empty() { ANY } else { source };
        if source == ANY {
            log::info!("{topic}: accepting every writer ({param}: '*')");
        } else {
            log::info!("{topic}: accepting only node '{source}' ({param}); other writers are ignored and logged");
        }
        SourceGate {
            topic: topic.to_string(),
            param: param.to_string(),
            source: source.to_string(),
            gap_ns,
            graph,
            owner: None,
            writers: HashMap::new(),
            ignored: Arc::new(AtomicU64::new(0)),
            foreign: Arc::new(AtomicU64::new(0)),
            warned_two: false,
        }
    }

    /// The gate of `topic` in `context`'s participant, its source from parameter `param`.
    pub fn in_context(context: &Context, topic: &str, param: &str, source: &str, gap_ns: i64) -> Result<SourceGate, RosError> {
        Ok(SourceGate::new(topic, param, source, gap_ns, NodeGraph::new(context)?))
    }

    /// The samples ignored so far, for any reason (shared: the report reads it from another
    /// thread).
    pub fn ignored(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.ignored)
    }

    /// Of the ignored samples, those of writers the graph names as a node other than the
    /// source. A writer's samples that arrived before its name did are counted here once
    /// the name arrives and is not the source's; the owner's own samples from before its
    /// name arrived (refused: the gate fails closed) and a second writer of the owning
    /// node are ignored but not foreign.
    pub fn foreign(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.foreign)
    }

    /// The writers seen so far and the node each belongs to (`None`: not named yet).
    pub fn writers(&self) -> Vec<(Gid, Option<String>, u64)> {
        self.writers.iter().map(|(g, w)| (*g, w.node.clone(), w.ignored)).collect()
    }

    /// Whether the sample of writer `gid`, received at wall time `now_ns` [ns], is taken.
    /// The accepted writer's samples cost one comparison; a new writer one map entry.
    pub fn admit(&mut self, gid: Gid, now_ns: i64) -> bool {
        if let Some((g, last)) = self.owner.as_mut() {
            if *g == gid {
                *last = now_ns;
                return true;
            }
        }
        if !self.writers.contains_key(&gid) {
            self.graph.refresh();
            let node = self.graph.node_of(&gid).map(str::to_string);
            let w = Writer { node, first_ns: now_ns, last_ns: now_ns, ignored: 0, logged_named: false, logged_unnamed: false };
            self.writers.insert(gid, w);
        } else if self.writers[&gid].node.is_none() {
            self.graph.refresh();
            if let Some(n) = self.graph.node_of(&gid) {
                let n = n.to_string();
                if let Some(w) = self.writers.get_mut(&gid) {
                    if self.source != ANY && !names(&self.source, &n) {
                        // Its samples ignored while it was unnamed were a stranger's.
                        self.foreign.fetch_add(w.ignored, Ordering::Relaxed);
                    }
                    w.node = Some(n);
                }
            }
        }
        if self.source == ANY {
            return self.admit_any(gid, now_ns);
        }
        let owner = self.owner;
        let (source, topic, param, gap_ns) = (&self.source, &self.topic, &self.param, self.gap_ns);
        let Some(w) = self.writers.get_mut(&gid) else { return false };
        w.last_ns = now_ns;
        match w.node.as_deref() {
            Some(node) if names(source, node) => match owner {
                Some((_, last)) if now_ns - last <= gap_ns => {
                    w.ignored += 1;
                    self.ignored.fetch_add(1, Ordering::Relaxed);
                    if !w.logged_named {
                        w.logged_named = true;
                        log::warn!(
                            "{topic}: a second writer of node {node} (GID {gid:?}) while the first one is still publishing: ignored until the first has been silent for {} ms (are two processes running with the name {node}?)",
                            gap_ns / 1_000_000
                        );
                    }
                    false
                }
                _ => {
                    if owner.is_some() {
                        log::info!("{topic}: a new writer of {node} (GID {gid:?}) takes over after the previous one was silent for {} ms or more", gap_ns / 1_000_000);
                    } else {
                        log::info!("{topic}: accepting the writer of {node} (GID {gid:?})");
                    }
                    self.owner = Some((gid, now_ns));
                    true
                }
            },
            node => {
                w.ignored += 1;
                self.ignored.fetch_add(1, Ordering::Relaxed);
                if node.is_some() {
                    self.foreign.fetch_add(1, Ordering::Relaxed);
                }
                match node {
                    Some(node) if !w.logged_named => {
                        w.logged_named = true;
                        log::warn!(
                            "{topic}: ignoring the samples of node {node} (GID {gid:?}): only '{source}' may publish here ({param}); {} ignored so far from it. Stop that node, or set {param} to its name if it is meant to be the source",
                            w.ignored
                        );
                    }
                    None if !w.logged_unnamed && now_ns - w.first_ns >= UNNAMED_AFTER_NS => {
                        w.logged_unnamed = true;
                        log::warn!(
                            "{topic}: ignoring the samples of writer GID {gid:?}: no ROS node claims it (its participant publishes no ros_discovery_info), and only '{source}' may publish here ({param}); {} ignored so far from it",
                            w.ignored
                        );
                    }
                    _ => {}
                }
                false
            }
        }
    }

    fn admit_any(&mut self, gid: Gid, now_ns: i64) -> bool {
        if let Some(w) = self.writers.get_mut(&gid) {
            w.last_ns = now_ns;
        }
        if !self.warned_two {
            let live: Vec<String> = self
                .writers
                .iter()
                .filter(|(_, w)| now_ns - w.last_ns <= TWO_WRITERS_NS)
                .map(|(g, w)| w.node.clone().unwrap_or_else(|| format!("an unnamed writer (GID {g:?})")))
                .collect();
            if live.len() >= 2 {
                self.warned_two = true;
                log::warn!(
                    "{}: {} writers within one second: {}; all are accepted ({}: '*'); set {} to the one node that should publish here",
                    self.topic,
                    live.len(),
                    live.join(", "),
                    self.param,
                    self.param
                );
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    fn gid(n: u8) -> Gid {
        Gid::from([n; 16])
    }

    fn gate(source: &str, names: &[(u8, &str)]) -> SourceGate {
        let mut g = NodeGraph::detached();
        for (n, fqn) in names {
            g.insert(gid(*n), fqn);
        }
        SourceGate::new("/joint_effort_cmd", "command_source", source, 20 * MS, g)
    }

    #[test]
    fn names_match_a_bare_name_in_any_namespace_or_a_full_name_exactly() {
        assert!(names("friction_compensation", "/friction_compensation"));
        assert!(names("friction_compensation", "/arm1/friction_compensation"));
        assert!(!names("friction_compensation", "/friction_compensation_2"));
        assert!(names("/arm1/friction_compensation", "/arm1/friction_compensation"));
        assert!(!names("/arm1/friction_compensation", "/friction_compensation"));
    }

    #[test]
    fn only_the_owner_is_admitted_and_every_foreign_sample_is_counted() {
        let mut g = gate("friction_compensation", &[(1, "/friction_compensation"), (2, "/teleop")]);
        let (n, f) = (g.ignored(), g.foreign());
        let mut admitted = 0;
        for i in 0..1000 {
            let t = i * MS;
            admitted += g.admit(gid(1), t) as u64;
            admitted += g.admit(gid(2), t) as u64;
        }
        assert_eq!((admitted, n.load(Ordering::Relaxed), f.load(Ordering::Relaxed)), (1000, 1000, 1000));
        let w = g.writers();
        assert!(w.contains(&(gid(2), Some("/teleop".into()), 1000)), "{:?}", w.iter().map(|x| (&x.1, x.2)).collect::<Vec<_>>());
    }

    #[test]
    fn an_unnamed_writer_is_refused_until_the_graph_names_it() {
        // Fail closed: a writer whose node is not known yet is not the owner.
        let mut g = gate("friction_compensation", &[]);
        assert!(!g.admit(gid(1), 0));
        g.graph.insert(gid(1), "/friction_compensation");
        assert!(g.admit(gid(1), MS), "named now: the owner");
        assert_eq!(g.ignored().load(Ordering::Relaxed), 1);
        assert_eq!(g.foreign().load(Ordering::Relaxed), 0, "the owner's early sample is not foreign");
    }

    #[test]
    fn a_strangers_samples_from_before_its_name_count_as_foreign_once_named() {
        let mut g = gate("friction_compensation", &[]);
        assert!(!g.admit(gid(2), 0) && !g.admit(gid(2), MS));
        assert_eq!((g.ignored().load(Ordering::Relaxed), g.foreign().load(Ordering::Relaxed)), (2, 0));
        g.graph.insert(gid(2), "/teleop");
        assert!(!g.admit(gid(2), 2 * MS));
        assert_eq!((g.ignored().load(Ordering::Relaxed), g.foreign().load(Ordering::Relaxed)), (3, 3));
    }

    #[test]
    fn a_restarted_owner_takes_over_only_after_the_gap() {
        let mut g = gate("friction_compensation", &[(1, "/friction_compensation"), (3, "/friction_compensation")]);
        assert!(g.admit(gid(1), 0));
        assert!(g.admit(gid(1), 10 * MS));
        // A second writer of the same node while the first still writes: ignored.
        assert!(!g.admit(gid(3), 15 * MS));
        assert!(g.admit(gid(1), 20 * MS));
        assert!(!g.admit(gid(3), 40 * MS), "the first wrote 20 ms ago: not more than the gap");
        // The first falls silent (the process was restarted): the new writer takes over
        // once the gap has passed, and then the old one is the stranger.
        assert!(g.admit(gid(3), 41 * MS));
        assert!(!g.admit(gid(1), 42 * MS));
        assert!(g.admit(gid(3), 43 * MS));
        assert_eq!(g.ignored().load(Ordering::Relaxed), 3);
        assert_eq!(g.foreign().load(Ordering::Relaxed), 0, "the owning node's writers are not foreign");
    }

    #[test]
    fn any_source_admits_every_writer() {
        let mut g = gate("*", &[(1, "/a"), (2, "/b")]);
        assert!(g.admit(gid(1), 0) && g.admit(gid(2), MS) && g.admit(gid(9), 2 * MS));
        assert!(g.warned_two, "two writers within a second are warned about");
        assert_eq!(g.ignored().load(Ordering::Relaxed), 0);
        let mut g = gate("", &[]);
        assert!(g.admit(gid(1), 0), "empty means any");
    }

    #[test]
    fn the_owners_samples_do_not_allocate() {
        let mut g = gate("friction_compensation", &[(1, "/friction_compensation"), (2, "/teleop")]);
        g.admit(gid(1), 0);
        g.admit(gid(2), 0);
        let (_, n) = crate::alloc_check::counted(|| {
            for i in 1..100 {
                g.admit(gid(1), i * MS);
                g.admit(gid(2), i * MS);
            }
        });
        assert_eq!(n, 0, "allocations for known writers");
    }
}
