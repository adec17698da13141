//! A node's own services of type `std_srvs/srv/Trigger` (e.g. the controller's
//! `~/reset_force_limit`), served from the node's loop: the shell takes the requests,
//! hands each to its core (a field of the core's inbox) and answers with what the core
//! said. Replies wait for the client's reply reader as the parameter services' do
//! (`reply.rs`).

use std::time::Instant;

use ros2_client::{service::request_id::RmwRequestId, Name, Server, ServiceMapping, ServiceTypeName};
use serde::{Deserialize, Serialize};

use crate::{reply, RosError, RosNode};

/// `std_srvs/srv/Trigger` request (empty: rosidl gives it one placeholder byte).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TriggerRequest {
    pub structure_needs_at_least_one_member: u8,
}

/// `std_srvs/srv/Trigger` response.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TriggerResponse {
    pub success: bool,
    pub message: String,
}

impl ros2_client::Message for TriggerRequest {}
impl ros2_client::Message for TriggerResponse {}

/// A `std_srvs/srv/Trigger` server at `<node>/<name>` (ROS's `~/<name>`).
pub struct TriggerServer {
    server: Server<TriggerRequest, TriggerResponse>,
    reply_topic: String,
    /// The service name, for log lines (`/naic_controller/reset_force_limit`).
    pub name: String,
    held: Vec<(RmwRequestId, TriggerResponse, Instant)>,
    sightings: reply::Sightings,
}

impl TriggerServer {
    /// Create `~/<name>` on `node`.
    pub fn new(node: &mut RosNode, name: &str) -> Result<TriggerServer, RosError> {
        let fqn = node.fqn().to_string();
        let qos = ros2_client::QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 10 });
        let n = Name::new(&fqn, name).map_err(|e| RosError::Dds(format!("service name {fqn}/{name}: {e:?}")))?;
        let server = node
            .node
            .create_server(ServiceMapping::Enhanced, &n, &ServiceTypeName::new("std_srvs", "Trigger"), qos.clone(), qos)
            .map_err(|e| RosError::Dds(format!("cannot create service {fqn}/{name}: {e:?}")))?;
        let full = format!("{}/{name}", fqn.trim_end_matches('/'));
        Ok(TriggerServer { server, reply_topic: reply::reply_topic(&fqn, name), name: full, held: Vec::new(), sightings: Default::default() })
    }

    /// The next request, if one is waiting (an unreadable one is logged and skipped).
    pub fn take(&mut self) -> Option<RmwRequestId> {
        loop {
            match self.server.receive_request() {
                Ok(Some((id, _))) => return Some(id),
                Ok(None) => return None,
                Err(e) => log::warn!("{}: unreadable request: {e:?}", self.name),
            }
        }
    }

    /// Answer request `id` (sent by [`TriggerServer::flush`] once the client can receive it).
    pub fn answer(&mut self, id: RmwRequestId, success: bool, message: &str) {
        self.held.push((id, TriggerResponse { success, message: message.to_string() }, Instant::now()));
    }

    /// Send the held answers whose clients can receive them; cheap when none is held.
    pub fn flush(&mut self, node: &RosNode) {
        if self.held.is_empty() {
            return;
        }
        let readers = reply::discovered_readers(&node.context);
        let now = Instant::now();
        for (id, resp, requested) in std::mem::take(&mut self.held) {
            let client = reply::participant_of(&id);
            let known = readers.contains(&(self.reply_topic.clone(), client));
            match self.sightings.verdict(&self.reply_topic, client, known, requested, now) {
                reply::Verdict::Send => {
                    if let Err(e) = self.server.send_response(id, resp) {
                        log::warn!("{}: cannot send the reply: {e:?}", self.name);
                    }
                }
                reply::Verdict::Hold => self.held.push((id, resp, requested)),
                reply::Verdict::GiveUp => log::warn!(
                    "{}: dropped the reply to request {}: the client's reply reader was never discovered within {} s",
                    self.name,
                    id.sequence_number,
                    reply::GIVE_UP.as_secs()
                ),
            }
        }
        self.sightings.forget_gone(&readers);
    }
}
