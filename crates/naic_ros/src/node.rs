//! [`RosNode`]: one ROS 2 node in its own DDS participant, with parameters served the
//! ROS way.
//!
//! ros2-client's built-in parameter services answer `describe_parameters` without
//! descriptions or ranges, and its spinner subscribes `/clock` as `builtin_interfaces/Time`
//! (rclpy publishes `rosgraph_msgs/Clock`). So the node is created with
//! `start_parameter_services(false)` and no spinner; this module serves
//! `get_parameters`, `get_parameter_types`, `set_parameters`, `set_parameters_atomically`,
//! `list_parameters` and `describe_parameters` from a [`ParamTable`] on a background
//! thread (mio poll, no busy wait) and publishes `/parameter_events` for every accepted
//! change, through ros2-client's own writer of the node (one publisher per node, as rclcpp).

use std::{
    collections::HashSet,
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc,
    },
    thread::JoinHandle,
    time::{Duration, Instant},
};

use ros2_client::{
    parameters::raw,
    qos::{History, Reliability, WhenFull},
    rcl_interfaces as rcl,
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    QosProfile, Server, ServiceMapping, ServiceTypeName, Subscription,
    service::request_id::RmwRequestId,
};
use serde::{de::DeserializeOwned, Serialize};

use crate::{
    args::RosArgs,
    context::{create_context_in, DdsSettings},
    params::{Changes, ParamSpec, ParamTable, SetCheck},
    reply::{self, Verdict},
    RosError,
};

/// QoS for the 1 kHz topics: reliable, keep last 10, never block the cycle when full.
pub const QOS_PUB: QosProfile = QosProfile::publisher_default()
    .reliability(Reliability::Reliable { when_full: WhenFull::Fail })
    .history(History::KeepLast { depth: 10 });
/// QoS for subscriptions: best effort, keep last 10 (matches reliable and best-effort writers).
pub const QOS_SUB: QosProfile = QosProfile::subscription_default().history(History::KeepLast { depth: 10 });
/// QoS for the lockstep command path: reliable, so no step is lost.
pub const QOS_SUB_RELIABLE: QosProfile = QosProfile::publisher_default()
    .reliability(Reliability::Reliable { when_full: WhenFull::Fail })
    .history(History::KeepLast { depth: 10 });

/// `/robot_description`'s QoS, as robot_state_publisher offers it: reliable, transient
/// local, keep last 1 (a late subscriber gets the description).
pub const QOS_LATCHED: QosProfile = QosProfile::publisher_default()
    .reliability(Reliability::Reliable { when_full: WhenFull::Fail })
    .durability(ros2_client::qos::Durability::TransientLocal)
    .history(History::KeepLast { depth: 1 });

/// ROS's sensor-data profile (`rmw_qos_profile_sensor_data`): best effort, keep last 5.
pub const QOS_SENSOR_DATA: QosProfile =
    QosProfile::publisher_default().reliability(Reliability::BestEffort).history(History::KeepLast { depth: 5 });

/// History depth of the reliable publishers in simulated time (`use_sim_time`, what
/// `naic launch --lockstep` sets on every node): 10 s of simulated time at 1 kHz. A lockstep
/// chain runs faster than real time, and an observer that falls behind on a loaded machine
/// finds the samples still there: RustDDS's reliable writer holds at most its history
/// depth of samples a matched reader has not acknowledged, and with depth 10 `naic record`
/// lost 28-47 % of `/naic/params` behind a lockstep chain under load (docs/bags.md). In
/// real time the depth stays 10: an observer that lags real time by seconds is behind
/// anyway, and the 1 kHz nodes keep their caches small.
pub const SIM_TIME_HISTORY: usize = 10_000;

/// [`QOS_PUB`] with the history for the node's time base (simulated: `use_sim_time`, or
/// the driver's `lockstep`: [`SIM_TIME_HISTORY`]): `/naic/params`, `/clock` and the
/// reliable data topics.
pub fn pub_qos(p: &crate::ParamView) -> QosProfile {
    let lockstep = matches!(p.get("lockstep"), Some(ParameterValue::Boolean(true)));
    if p.bool("use_sim_time") || lockstep {
        QOS_PUB.history(History::KeepLast { depth: SIM_TIME_HISTORY })
    } else {
        QOS_PUB
    }
}

/// The QoS of the chain's data topics from the node's `data_qos` parameter: (publishers,
/// the driver's command subscription). Reliable: [`pub_qos`] and [`QOS_SUB_RELIABLE`];
/// `sensor_data`: [`QOS_SENSOR_DATA`] for both (a reliable reader does not match a
/// best-effort writer). The other subscriptions are best effort either way ([`QOS_SUB`]).
pub fn data_qos(p: &crate::ParamView) -> (QosProfile, QosProfile) {
    if p.str("data_qos") == "sensor_data" {
        (QOS_SENSOR_DATA, QOS_SENSOR_DATA)
    } else {
        (pub_qos(p), QOS_SUB_RELIABLE)
    }
}

/// A node: DDS context + ros2-client node + parameter table + parameter services.
pub struct RosNode {
    pub args: RosArgs,
    pub context: Context,
    pub node: Node,
    pub params: Arc<ParamTable>,
    fqn: String,
    stop: Arc<AtomicBool>,
    service_thread: Option<JoinHandle<()>>,
}

impl RosNode {
    /// Build the node from the process arguments and environment.
    pub fn from_env(
        default_name: &str,
        specs: Vec<ParamSpec>,
        check: Option<SetCheck>,
    ) -> Result<RosNode, RosError> {
        let args = RosArgs::parse(std::env::args().skip(1))?;
        Self::new(args, default_name, specs, check)
    }

    pub fn new(
        args: RosArgs,
        default_name: &str,
        specs: Vec<ParamSpec>,
        check: Option<SetCheck>,
    ) -> Result<RosNode, RosError> {
        let name = args.node_name.clone().unwrap_or_else(|| default_name.to_string());
        crate::log::init(&name, args.log_level.as_deref());
        let params = ParamTable::new(specs, check, &args.overrides(default_name)?).map_err(RosError::Param)?;
        // Real-time scheduling before any thread exists, so the DDS threads inherit it.
        params.with(apply_scheduling);
        let enclave = crate::security::Enclave::from_env(args.enclave.as_deref())?;
        let context = create_context_in(&DdsSettings::from_env()?, enclave.as_ref())?;
        Self::build(args, default_name, params, context)
    }

    /// A node in an existing DDS participant (several nodes in one process, as a ROS 2
    /// component container has them). Scheduling (`realtime_priority`, `cpu_affinity`) is
    /// the process's, set by whoever created `context` ([`apply_scheduling`]).
    pub fn in_context(
        args: RosArgs,
        default_name: &str,
        specs: Vec<ParamSpec>,
        check: Option<SetCheck>,
        context: &Context,
    ) -> Result<RosNode, RosError> {
        let params = ParamTable::new(specs, check, &args.overrides(default_name)?).map_err(RosError::Param)?;
        Self::build(args, default_name, params, context.clone())
    }

    fn build(args: RosArgs, default_name: &str, params: ParamTable, context: Context) -> Result<RosNode, RosError> {
        let name = args.node_name.clone().unwrap_or_else(|| default_name.to_string());
        let ns = args.namespace.clone().unwrap_or_else(|| "/".to_string());
        let fqn = args.fqn(default_name);
        let settings = DdsSettings::from_env()?;
        let node_name = NodeName::new(&ns, &name)
            .map_err(|e| RosError::Args(format!("bad node name '{ns}/{name}': {e:?}")))?;
        let mut node = context
            .new_node(node_name, NodeOptions::new().enable_rosout(true).start_parameter_services(false))
            .map_err(|e| RosError::Dds(format!("cannot create node {fqn}: {e}")))?;

        // Log lines to /rosout from now on (rclcpp's behaviour), stderr kept.
        crate::log::attach_rosout(node.logging_handle());
        let params = Arc::new(params);
        let stop = Arc::new(AtomicBool::new(false));
        // Under DDS Security the participant keeps ros2-client's single ros_discovery_info
        // writer: RustDDS's crypto plugin keys a matched remote endpoint by (local
        // endpoint, remote participant), so a second writer of one topic in a participant
        // collides with the first at every secured reader (its samples fail to decode, the
        // reader's key material is confused; vendored rustdds PATCHED.md). The re-publication
        // exists for unsecured Fast DDS peers, which cannot join a secured domain.
        let secured = crate::security::Enclave::from_env(args.enclave.as_deref()).ok().flatten().is_some();
        let services = ParamServices::new(&mut node, &context, &fqn, !secured)?;
        // Announce the declared parameters, as rclcpp does on declaration.
        services.publish_event(&fqn, params.all(), true);
        let service_thread = {
            let params = Arc::clone(&params);
            let stop = Arc::clone(&stop);
            let fqn = fqn.clone();
            std::thread::Builder::new()
                .name("param-services".into())
                .spawn(move || services.run(&params, &stop, &fqn))
                .map_err(|e| RosError::Node(format!("cannot start parameter thread: {e}")))?
        };
        log::info!(
            "started {fqn} on ROS_DOMAIN_ID={}{}",
            settings.domain_id,
            if settings.localhost_only { " (localhost only)" } else { "" }
        );
        Ok(RosNode { args, context, node, params, fqn, stop, service_thread: Some(service_thread) })
    }

    /// Fully qualified node name, `/ns/name`.
    pub fn fqn(&self) -> &str {
        &self.fqn
    }

    fn topic(
        &self,
        topic: &str,
        ty: (&str, &str),
        qos: &QosProfile,
    ) -> Result<ros2_client::dds::rustdds::Topic, RosError> {
        let topic = self.args.remap_topic(topic);
        // Resolve relative names in the node namespace here: ros2-client would join
        // namespace "/" and "name" into "//name".
        let resolved;
        let topic = if topic.starts_with('/') {
            topic
        } else {
            let ns = self.node.namespace().trim_end_matches('/');
            resolved = format!("{ns}/{topic}");
            resolved.as_str()
        };
        let name = Name::parse(topic)
            .map_err(|e| RosError::Args(format!("bad topic name '{topic}': {e:?}")))?;
        self.node
            .create_topic(&name, MessageTypeName::new(ty.0, ty.1), qos)
            .map_err(|e| RosError::Dds(format!("cannot create topic {topic}: {e:?}")))
    }

    /// A publisher on `topic` (relative names resolve in the node namespace) of ROS type
    /// `ty = (package, Type)`.
    pub fn publisher<M: Serialize>(
        &mut self,
        topic: &str,
        ty: (&str, &str),
        qos: QosProfile,
    ) -> Result<Publisher<M>, RosError> {
        let t = self.topic(topic, ty, &qos)?;
        self.node
            .create_publisher(&t, Some(qos))
            .map_err(|e| RosError::Dds(format!("cannot publish {topic}: {e:?}")))
    }

    pub fn subscription<M: DeserializeOwned + 'static>(
        &mut self,
        topic: &str,
        ty: (&str, &str),
        qos: QosProfile,
    ) -> Result<Subscription<M>, RosError> {
        let t = self.topic(topic, ty, &qos)?;
        self.node
            .create_subscription(&t, Some(qos))
            .map_err(|e| RosError::Dds(format!("cannot subscribe {topic}: {e:?}")))
    }
}

impl Drop for RosNode {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.service_thread.take() {
            let _ = t.join();
        }
    }
}

/// One parameter service: its server, and the replies held until their clients can receive
/// them ([`crate::reply`]).
struct Srv<Req: ros2_client::Message, Resp: ros2_client::Message> {
    server: Server<Req, Resp>,
    /// The DDS topic the replies go out on.
    reply_topic: String,
    held: Vec<(RmwRequestId, Resp, Instant)>,
}

impl<Req: ros2_client::Message + 'static, Resp: ros2_client::Message + 'static> Srv<Req, Resp> {
    fn receive(&self) -> Option<(RmwRequestId, Req)> {
        match self.server.receive_request() {
            Ok(r) => r,
            Err(e) => {
                log::warn!("{}: unreadable request: {e:?}", self.reply_topic);
                None
            }
        }
    }

    fn reply(&mut self, id: RmwRequestId, resp: Resp) {
        self.held.push((id, resp, Instant::now()));
    }

    /// Send the held replies whose clients can receive them; drop those given up (warned).
    fn flush(&mut self, sightings: &mut reply::Sightings, readers: &HashSet<(String, reply::Participant)>, now: Instant) {
        for (id, resp, requested) in std::mem::take(&mut self.held) {
            let client = reply::participant_of(&id);
            let known = readers.contains(&(self.reply_topic.clone(), client));
            match sightings.verdict(&self.reply_topic, client, known, requested, now) {
                Verdict::Send => {
                    if let Err(e) = self.server.send_response(id, resp) {
                        log::warn!("{}: cannot send the reply: {e:?}", self.reply_topic);
                    }
                }
                Verdict::Hold => self.held.push((id, resp, requested)),
                Verdict::GiveUp => log::warn!(
                    "{}: dropped the reply to request {} of client {:?}: this node never discovered the \
                     client's reply reader within {} s (DDS discovery between the two participants failed)",
                    self.reply_topic,
                    id.sequence_number,
                    id.writer_gid,
                    reply::GIVE_UP.as_secs()
                ),
            }
        }
    }
}

struct ParamServices {
    get: Srv<rcl::GetParametersRequest, rcl::GetParametersResponse>,
    types: Srv<rcl::GetParameterTypesRequest, rcl::GetParameterTypesResponse>,
    set: Srv<rcl::SetParametersRequest, rcl::SetParametersResponse>,
    set_atomic: Srv<rcl::SetParametersRequest, rcl::SetParametersAtomicallyResponse>,
    list: Srv<rcl::ListParametersRequest, rcl::ListParametersResponse>,
    describe: Srv<rcl::DescribeParametersRequest, rcl::DescribeParametersResponse>,
    context: Context,
    sightings: reply::Sightings,
    /// The node's one `/parameter_events` writer, ros2-client's (rclcpp's QoS: reliable,
    /// volatile, keep last 1000; crates/vendor/ros2-client/PATCHED.md).
    events: Arc<Publisher<raw::ParameterEvent>>,
    /// Re-announces this participant's nodes on `ros_discovery_info` (see [`Rediscovery`]).
    rediscovery: Option<Rediscovery>,
}

/// Periodic re-publication of the participant's `ros_discovery_info`.
///
/// ros2-client publishes it only when the node set changes; the sample is transient-local,
/// but a Fast DDS (rclpy) participant that discovers ours later sometimes never receives
/// it, and then lists none of our nodes. Publishing the same information again every
/// second (as a second writer of this participant) closes that gap.
struct Rediscovery {
    context: Context,
    writer: ros2_client::dds::rustdds::no_key::DataWriterCdr<ros2_client::entities_info::ParticipantEntitiesInfo>,
    last: std::time::Instant,
}

impl Rediscovery {
    fn new(context: &Context) -> Option<Rediscovery> {
        use ros2_client::{builtin_topics::ros_discovery as rd, dds::rustdds::TopicKind};
        let dp = context.domain_participant();
        let topic = dp.create_topic(rd::TOPIC_NAME.to_string(), rd::TYPE_NAME.to_string(), &rd::QOS_PUB, TopicKind::NoKey).ok()?;
        let publisher = dp.create_publisher(&rd::QOS_PUB).ok()?;
        let writer = publisher.create_datawriter_no_key_cdr(&topic, None).ok()?;
        Some(Rediscovery { context: context.clone(), writer, last: std::time::Instant::now() })
    }

    fn tick(&mut self) {
        if self.last.elapsed() >= Duration::from_secs(1) {
            self.last = std::time::Instant::now();
            let _ = self.writer.write(self.context.participant_entities_info(), None);
        }
    }
}

fn server<Req, Resp>(node: &mut Node, fqn: &str, srv: &str, ty: &str) -> Result<Srv<Req, Resp>, RosError>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let qos = QosProfile::publisher_default().history(History::KeepLast { depth: 10 });
    let name = Name::new(fqn, srv).map_err(|e| RosError::Dds(format!("service name {fqn}/{srv}: {e:?}")))?;
    let server = node
        .create_server(ServiceMapping::Enhanced, &name, &ServiceTypeName::new("rcl_interfaces", ty), qos.clone(), qos)
        .map_err(|e| RosError::Dds(format!("cannot create service {fqn}/{srv}: {e:?}")))?;
    Ok(Srv { server, reply_topic: reply::reply_topic(fqn, srv), held: Vec::new() })
}

impl ParamServices {
    fn new(node: &mut Node, context: &Context, fqn: &str, rediscover: bool) -> Result<Self, RosError> {
        let events = node.parameter_events_publisher();
        Ok(ParamServices {
            get: server(node, fqn, "get_parameters", "GetParameters")?,
            types: server(node, fqn, "get_parameter_types", "GetParameterTypes")?,
            set: server(node, fqn, "set_parameters", "SetParameters")?,
            set_atomic: server(node, fqn, "set_parameters_atomically", "SetParametersAtomically")?,
            list: server(node, fqn, "list_parameters", "ListParameters")?,
            describe: server(node, fqn, "describe_parameters", "DescribeParameters")?,
            context: context.clone(),
            sightings: reply::Sightings::default(),
            events,
            rediscovery: if !rediscover {
                None
            } else {
                let r = Rediscovery::new(context);
                if r.is_none() {
                    log::warn!("cannot re-announce nodes on ros_discovery_info; late rclpy peers may not list this node");
                }
                r
            },
        })
    }

    fn publish_event(&self, fqn: &str, changes: Changes, new: bool) {
        if changes.is_empty() {
            return;
        }
        let ps: Vec<raw::Parameter> = changes
            .into_iter()
            .map(|(name, v)| raw::Parameter { name, value: v.into() })
            .collect();
        let (new_parameters, changed_parameters) = if new { (ps, vec![]) } else { (vec![], ps) };
        let ev = raw::ParameterEvent {
            stamp: ros2_client::builtin_interfaces::Time::now(),
            node: fqn.to_string(),
            new_parameters,
            changed_parameters,
            deleted_parameters: vec![],
        };
        if let Err(e) = self.events.publish(ev) {
            log::warn!("cannot publish /parameter_events: {e:?}");
        }
    }

    fn run(self, params: &ParamTable, stop: &AtomicBool, fqn: &str) {
        use mio::{Events, Interest, Poll, Token};
        let mut poll = match Poll::new() {
            Ok(p) => p,
            Err(e) => {
                log::error!("parameter services disabled: cannot create poll: {e}");
                return;
            }
        };
        let mut s = self;
        let reg = poll.registry();
        let ok = reg.register(&mut s.get.server, Token(0), Interest::READABLE).is_ok()
            & reg.register(&mut s.types.server, Token(1), Interest::READABLE).is_ok()
            & reg.register(&mut s.set.server, Token(2), Interest::READABLE).is_ok()
            & reg.register(&mut s.set_atomic.server, Token(3), Interest::READABLE).is_ok()
            & reg.register(&mut s.list.server, Token(4), Interest::READABLE).is_ok()
            & reg.register(&mut s.describe.server, Token(5), Interest::READABLE).is_ok();
        if !ok {
            log::warn!("parameter services: poll registration failed; falling back to 10 ms polling");
        }
        let mut events = Events::with_capacity(16);
        while !stop.load(Ordering::Relaxed) {
            // Held replies are re-checked every 10 ms.
            let timeout = if ok && !s.holds_replies() { Duration::from_millis(100) } else { Duration::from_millis(10) };
            let _ = poll.poll(&mut events, Some(timeout));
            // Serve every pending request on every service (cheap when idle).
            s.serve_all(params, fqn);
            if let Some(r) = s.rediscovery.as_mut() {
                r.tick();
            }
        }
    }

    fn holds_replies(&self) -> bool {
        !(self.get.held.is_empty()
            && self.types.held.is_empty()
            && self.set.held.is_empty()
            && self.set_atomic.held.is_empty()
            && self.list.held.is_empty()
            && self.describe.held.is_empty())
    }

    /// Answer every pending request, then send the replies their clients can receive.
    fn serve_all(&mut self, params: &ParamTable, fqn: &str) {
        self.answer_all(params, fqn);
        if self.holds_replies() {
            let readers = reply::discovered_readers(&self.context);
            let now = Instant::now();
            let sg = &mut self.sightings;
            self.get.flush(sg, &readers, now);
            self.types.flush(sg, &readers, now);
            self.set.flush(sg, &readers, now);
            self.set_atomic.flush(sg, &readers, now);
            self.list.flush(sg, &readers, now);
            self.describe.flush(sg, &readers, now);
            sg.forget_gone(&readers);
        }
    }

    fn answer_all(&mut self, params: &ParamTable, fqn: &str) {
        while let Some((id, req)) = self.get.receive() {
            let values = params.with(|v| {
                req.names
                    .iter()
                    .map(|n| raw::ParameterValue::from(v.get(n).cloned().unwrap_or(ParameterValue::NotSet)))
                    .collect()
            });
            self.get.reply(id, rcl::GetParametersResponse { values });
        }
        while let Some((id, req)) = self.types.receive() {
            let values = params.with(|v| {
                req.names
                    .iter()
                    .map(|n| v.get(n).map(|x| x.to_parameter_type() as u8).unwrap_or(0))
                    .collect()
            });
            self.types.reply(id, rcl::GetParameterTypesResponse { values });
        }
        while let Some((id, req)) = self.set.receive() {
            // One result per parameter, each applied on its own (rclcpp semantics).
            let results = req
                .parameter
                .into_iter()
                .map(|p| {
                    let name = p.name.clone();
                    let v: ParameterValue = p.value.into();
                    match params.set_atomically(&[(name.clone(), v)]) {
                        Ok(ch) => {
                            log::info!("parameter {name} set to {:?}", ch[0].1);
                            self.publish_event(fqn, ch, false);
                            raw::SetParametersResult { successful: true, reason: String::new() }
                        }
                        Err(e) => {
                            log::warn!("rejected set of {name}: {e}");
                            raw::SetParametersResult { successful: false, reason: e.to_string() }
                        }
                    }
                })
                .collect();
            self.set.reply(id, rcl::SetParametersResponse { results });
        }
        while let Some((id, req)) = self.set_atomic.receive() {
            let ps: Vec<(String, ParameterValue)> =
                req.parameter.into_iter().map(|p| (p.name, p.value.into())).collect();
            let result = match params.set_atomically(&ps) {
                Ok(ch) => {
                    self.publish_event(fqn, ch, false);
                    raw::SetParametersResult { successful: true, reason: String::new() }
                }
                Err(e) => {
                    log::warn!("rejected atomic set: {e}");
                    raw::SetParametersResult { successful: false, reason: e.to_string() }
                }
            };
            self.set_atomic.reply(id, rcl::SetParametersAtomicallyResponse { result });
        }
        while let Some((id, req)) = self.list.receive() {
            let (names, prefixes) = params.list(&req.prefixes, req.depth);
            self.list.reply(id, rcl::ListParametersResponse { result: rcl::ListParametersResult { names, prefixes } });
        }
        while let Some((id, req)) = self.describe.receive() {
            let values = req
                .names
                .iter()
                .map(|n| match params.specs().iter().find(|s| &s.name == n) {
                    Some(s) => s.descriptor(),
                    // Unknown names: an empty descriptor (type NOT_SET), as rclcpp would
                    // throw; rclpy clients see type 0.
                    None => raw::ParameterDescriptor {
                        name: n.clone(),
                        r#type: 0,
                        description: String::new(),
                        additional_constraints: String::new(),
                        read_only: false,
                        dynamic_typing: false,
                        integer_range: vec![],
                        floating_point_range: vec![],
                    },
                })
                .collect();
            self.describe.reply(id, rcl::DescribeParametersResponse { values });
        }
    }
}

/// Publisher alias used by the nodes.
pub type Pub<M> = Publisher<M>;

/// The calling thread's scheduling from a node's `realtime_priority` and `cpu_affinity`
/// (call it before any thread exists: the threads created afterwards inherit it).
pub fn apply_scheduling(p: &crate::ParamView) {
    let prio = p.i64("realtime_priority");
    if prio > 0 {
        match set_realtime(prio as i32) {
            Ok(()) => log::info!("running with {REALTIME_POLICY} priority {prio}"),
            Err(e) => log::warn!("realtime_priority {prio}: cannot use {REALTIME_POLICY} ({e}); running with normal scheduling"),
        }
    }
    let cpu = p.i64("cpu_affinity");
    if cpu >= 0 {
        let n = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
        match pin_to_cpu(cpu as usize) {
            Ok(()) => log::info!("pinned to CPU {cpu}"),
            Err(e) => log::warn!(
                "cpu_affinity {cpu}: cannot pin to that CPU ({e}; this machine has {n} CPUs, 0..{}); running unpinned",
                n.saturating_sub(1)
            ),
        }
    }
}

/// The real-time policy of `realtime_priority`, as messages name it.
pub const REALTIME_POLICY: &str = "SCHED_RR";

/// Pin the calling thread (and the threads it creates afterwards) to one CPU
/// (`cpu` < 1024 = CPU_SETSIZE, else an error).
pub fn pin_to_cpu(cpu: usize) -> std::io::Result<()> {
    if cpu >= 1024 {
        return Err(std::io::Error::from_raw_os_error(libc::EINVAL));
    }
    // SAFETY: a zeroed cpu_set_t is a valid empty set; CPU_SET stays within its bounds
    // (cpu < 1024 = CPU_SETSIZE, checked above).
    let r = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if r != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// SCHED_RR at `priority` for the calling thread (and the threads it creates afterwards).
///
/// Round-robin, not FIFO: for threads that block every cycle (all of a node's) the two are
/// the same, since a policy only differs for a thread that runs a whole time slice
/// (`/proc/sys/kernel/sched_rr_timeslice_ms`, 100 ms) without blocking. Under FIFO such a
/// thread keeps its CPU from every other thread of its priority for ever, and RT throttling
/// gives the CPU's 5 % to normal threads only: a chain pinned to one CPU at one priority
/// froze that way once while starting (docs/notes/2026-12-dds-test-forensics.md, "A start-up freeze"), the driver's
/// watchdog and hold with it. Under RR the others get the CPU every time slice, so the
/// driver's hold still runs.
pub fn set_realtime(priority: i32) -> std::io::Result<()> {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: valid sched_param for the calling thread (pid 0).
    if unsafe { libc::sched_setscheduler(0, libc::SCHED_RR, &param) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}
