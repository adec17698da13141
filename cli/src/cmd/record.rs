//! `naic record` and `naic replay`: MCAP bags over DDS (issue 5 items 1–2).
//!
//! The recorder subscribes the naic topics with their known types, stamps each message
//! with its receive time (`log_time`) and the DDS source timestamp (`publish_time`, the
//! receive time when the writer sent none), and writes them with [`naic_bag::BagWriter`]
//! (flushed about every second, so a crash loses at most about a second) on a thread of
//! its own: a write that blocks on the disk never keeps the recorder from taking messages
//! out of its DDS readers before their history overflows. The replayer
//! publishes a bag's messages with their original spacing (scaled by `--rate`).
use super::{CliError, CliResult};
use naic_bag::{Bag, BagWriter, Qos, TopicId};
use naic_msgs::*;
use naic_ros::msgs as m;
use naic_ros::wait::Waiter;
use naic_ros::{RosArgs, RosNode};
use ros2_client::qos::{History, Reliability, WhenFull};
use ros2_client::{QosProfile, Subscription};
use std::collections::HashMap;
use std::hash::Hash;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The topics `naic record` takes by default, with their types.
pub const NAIC_TOPICS: [(&str, &str); 8] = [
    ("/joint_states", "sensor_msgs/msg/JointState"),
    ("/wrench", "geometry_msgs/msg/WrenchStamped"),
    ("/joint_effort_cmd", "std_msgs/msg/Float64MultiArray"),
    ("/naic/effort", "std_msgs/msg/Float64MultiArray"),
    ("/naic/params", "naic_msgs/msg/NaicParams"),
    ("/clock", "rosgraph_msgs/msg/Clock"),
    // The controller's reference topics (scenario none).
    ("/naic/target_pose", "geometry_msgs/msg/PoseStamped"),
    ("/naic/desired_wrench", "geometry_msgs/msg/WrenchStamped"),
];

#[derive(clap::Args)]
pub struct RecordArgs {
    /// Topics to record, space- or comma-separated (default: all naic topics).
    #[arg(long, num_args = 1.., value_delimiter = ',')]
    pub topics: Vec<String>,
    /// Output file (default: runs/naic_<UTC time>.mcap).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Topic type for topics outside the naic set, as TOPIC=pkg/msg/Type.
    #[arg(long = "type", value_name = "TOPIC=TYPE")]
    pub types: Vec<String>,
    /// Subscribe best-effort (needed for best-effort publishers; may drop under load).
    #[arg(long)]
    pub best_effort: bool,
}

#[derive(clap::Args)]
pub struct ReplayArgs {
    pub file: PathBuf,
    /// Speed factor (2 = twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Only these topics, space- or comma-separated (default: all topics of known types).
    #[arg(long, num_args = 1.., value_delimiter = ',')]
    pub topics: Vec<String>,
    /// Start over when the end is reached, until Ctrl-C.
    #[arg(long = "loop")]
    pub looped: bool,
    /// Skip the first S seconds of the bag.
    #[arg(long, default_value_t = 0.0)]
    pub start: f64,
    /// Wait this long before the first message so subscribers can discover the publishers [s].
    #[arg(long, default_value_t = 1.0)]
    pub delay: f64,
}

fn ros_err(e: naic_ros::RosError) -> CliError {
    if e.exit_code() == 2 {
        CliError::usage(e.to_string())
    } else {
        CliError::failure(e.to_string())
    }
}

fn bag_err(e: naic_bag::BagError) -> CliError {
    CliError::failure(e.to_string())
}

/// Subscription QoS for recording: reliable (lost UDP packets are resent while the writer
/// still holds them) with a deep history so a burst is not overwritten before it is taken:
/// 10 s at 1 kHz per topic, as deep as the nodes' history in simulated time
/// (`naic_ros::node::SIM_TIME_HISTORY`). With 1000 (1 s) a recorder starved of CPU at load
/// 7-9 behind a lockstep chain lost 28-47 % of `/naic/params` (docs/bags.md).
/// A reliable reader does not match best-effort writers: `--best-effort` records those.
const RECORD_HISTORY: usize = naic_ros::node::SIM_TIME_HISTORY;
const QOS_RECORD: QosProfile = QosProfile::subscription_default()
    .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_millis(10)) })
    .history(History::KeepLast { depth: RECORD_HISTORY });
const QOS_RECORD_BEST_EFFORT: QosProfile = QosProfile::subscription_default()
    .reliability(Reliability::BestEffort)
    .history(History::KeepLast { depth: RECORD_HISTORY });
/// Publisher QoS for replay: reliable, deep history so a slow subscriber can catch up; when
/// the send window is full, wait (up to 1 s) rather than drop the message.
const QOS_REPLAY: QosProfile = QosProfile::publisher_default()
    .reliability(Reliability::Reliable { when_full: WhenFull::Wait(Duration::from_secs(1)) })
    .history(History::KeepLast { depth: 1000 });

/// One recorded topic: its subscription and where it goes in the bag.
enum Sub {
    Js(Subscription<JointState>, TopicId),
    Ws(Subscription<WrenchStamped>, TopicId),
    Fa(Subscription<Float64MultiArray>, TopicId),
    Np(Subscription<NaicParams>, TopicId),
    Ck(Subscription<Clock>, TopicId),
    Ps(Subscription<PoseStamped>, TopicId),
}

fn ros_type(type_name: &str) -> Option<(&'static str, &'static str)> {
    Some(match type_name {
        "sensor_msgs/msg/JointState" => m::JOINT_STATE,
        "geometry_msgs/msg/WrenchStamped" => m::WRENCH_STAMPED,
        "std_msgs/msg/Float64MultiArray" => m::FLOAT64_MULTI_ARRAY,
        "naic_msgs/msg/NaicParams" => m::NAIC_PARAMS,
        "rosgraph_msgs/msg/Clock" => m::CLOCK,
        "geometry_msgs/msg/PoseStamped" => m::POSE_STAMPED,
        _ => return None,
    })
}

const KNOWN_TYPES: &str = "sensor_msgs/msg/JointState, geometry_msgs/msg/WrenchStamped, \
     geometry_msgs/msg/PoseStamped, std_msgs/msg/Float64MultiArray, naic_msgs/msg/NaicParams, \
     rosgraph_msgs/msg/Clock";

fn default_out() -> PathBuf {
    let ns = naic_ros::time::wall_ns();
    let (y, mo, d, hh, mm, ss) = super::utc_civil(ns / 1_000_000_000);
    PathBuf::from(format!(
        "runs/naic_{y:04}{mo:02}{d:02}_{hh:02}{mm:02}{ss:02}.mcap"
    ))
}

pub fn record(a: RecordArgs) -> CliResult {
    if let Some(d) = a.duration {
        if !(d > 0.0 && d.is_finite()) {
            return Err(CliError::usage(format!("--duration must be a positive number of seconds, got {d}")));
        }
    }
    // topic -> type
    let mut wanted: Vec<(String, String)> = Vec::new();
    let extra: Vec<(String, String)> = a
        .types
        .iter()
        .map(|s| {
            s.split_once('=')
                .map(|(t, ty)| (t.to_string(), ty.to_string()))
                .ok_or_else(|| CliError::usage(format!("--type wants TOPIC=pkg/msg/Type, got {s:?}")))
        })
        .collect::<Result<_, _>>()?;
    let topics: Vec<String> =
        if a.topics.is_empty() { NAIC_TOPICS.iter().map(|(t, _)| t.to_string()).collect() } else { a.topics.clone() };
    for t in topics {
        let ty = extra
            .iter()
            .find(|(x, _)| *x == t)
            .map(|(_, ty)| ty.clone())
            .or_else(|| NAIC_TOPICS.iter().find(|(x, _)| *x == t).map(|(_, ty)| ty.to_string()))
            .ok_or_else(|| {
                CliError::usage(format!("unknown type for topic {t}: add --type {t}=pkg/msg/Type (one of {KNOWN_TYPES})"))
            })?;
        if ros_type(&ty).is_none() {
            return Err(CliError::usage(format!("naic record cannot record {ty} (topic {t}); known types: {KNOWN_TYPES}")));
        }
        wanted.push((t, ty));
    }
    let out = a.out.clone().unwrap_or_else(default_out);

    let args = RosArgs::parse(std::iter::empty::<String>()).map_err(ros_err)?;
    let mut node = RosNode::new(args, "naic_recorder", Vec::new(), None).map_err(ros_err)?;
    let mut w = BagWriter::create(&out).map_err(bag_err)?;
    let mut subs = Vec::new();
    let qos = if a.best_effort { QOS_RECORD_BEST_EFFORT } else { QOS_RECORD };
    let mut waiter = Waiter::new().map_err(|e| CliError::failure(format!("poll: {e}")))?;
    for (i, (topic, ty)) in wanted.iter().enumerate() {
        let rt = ros_type(ty).expect("checked above");
        macro_rules! sub {
            ($M:ty, $V:ident) => {{
                let mut s = node.subscription::<$M>(topic, rt, qos.clone()).map_err(ros_err)?;
                waiter.add(&mut s, i).map_err(|e| CliError::failure(format!("poll: {e}")))?;
                let id = w.add_topic::<$M>(topic, Qos::default()).map_err(bag_err)?;
                Sub::$V(s, id)
            }};
        }
        subs.push(match ty.as_str() {
            "sensor_msgs/msg/JointState" => sub!(JointState, Js),
            "geometry_msgs/msg/WrenchStamped" => sub!(WrenchStamped, Ws),
            "std_msgs/msg/Float64MultiArray" => sub!(Float64MultiArray, Fa),
            "naic_msgs/msg/NaicParams" => sub!(NaicParams, Np),
            "geometry_msgs/msg/PoseStamped" => sub!(PoseStamped, Ps),
            _ => sub!(Clock, Ck),
        });
    }
    let (tx, writer) = spawn_writer(w)?;
    naic_ros::install_signal_handlers(); // Ctrl-C / SIGTERM: finish the bag, then exit
    eprintln!(
        "naic record: recording {} to {} ({})",
        wanted.iter().map(|(t, _)| t.as_str()).collect::<Vec<_>>().join(" "),
        out.display(),
        match a.duration {
            Some(d) => format!("for {d} s"),
            None => "Ctrl-C to stop".into(),
        }
    );
    let t0 = Instant::now();
    let deadline = a.duration.map(Duration::from_secs_f64);
    let mut gaps = SeqGaps::new(subs.len());
    // On Ctrl-C or at the deadline the recorder catches up with the moment it was asked to
    // stop ([`CatchUp`]): a recorder behind a lockstep chain on a loaded machine holds
    // seconds of messages in its readers, and reliable repairs of the last ones are still in
    // flight. Past CATCH_UP_MAX it stops writing and counts what it still finds from before
    // the stop as lost (for at most COUNT_MAX more), so nothing is left behind unreported.
    const CATCH_UP_MAX: Duration = Duration::from_secs(30);
    const COUNT_MAX: Duration = Duration::from_secs(5);
    let mut catch_up = CatchUp::new(subs.len());
    let mut counting_only = false;
    'run: loop {
        let stop = naic_ros::shutdown_requested() || deadline.is_some_and(|d| t0.elapsed() >= d);
        if stop && !catch_up.stopping() {
            catch_up.stop(naic_ros::time::wall_ns().max(0) as u64, Instant::now());
        }
        waiter.wait(Some(Duration::from_millis(if catch_up.stopping() { 20 } else { 50 })));
        for (i, s) in subs.iter().enumerate() {
            macro_rules! drain {
                ($sub:expr, $id:expr) => {
                    while let Ok(Some((msg, info))) = $sub.take() {
                        if gaps.see(i, info.publisher_gid(), info.sequence_number()) {
                            // As rosbag2 says what it subscribed to: a restarted node is a
                            // new publisher, and rediscovering it can take seconds under load.
                            eprintln!("naic record: {}: receiving from a new publisher ({:?})", wanted[i].0, info.publisher_gid());
                        }
                        let recv = naic_ros::time::wall_ns().max(0) as u64;
                        let publ = info.source_timestamp().map(|t| t.to_nanos().max(0) as u64).unwrap_or(recv);
                        let before_stop = catch_up.saw(i, publ, recv, Instant::now());
                        if counting_only {
                            gaps.lost[i] += u64::from(before_stop);
                            continue;
                        }
                        let mut cdr = Vec::with_capacity(256);
                        naic_msgs::cdr::encode_into(&msg, &mut cdr);
                        if tx.send(Taken { topic: $id, cdr, recv, publ }).is_err() {
                            break 'run; // the writer stopped on an error: reported below
                        }
                    }
                };
            }
            match s {
                Sub::Js(s, id) => drain!(s, *id),
                Sub::Ws(s, id) => drain!(s, *id),
                Sub::Fa(s, id) => drain!(s, *id),
                Sub::Np(s, id) => drain!(s, *id),
                Sub::Ck(s, id) => drain!(s, *id),
                Sub::Ps(s, id) => drain!(s, *id),
            }
        }
        let now = Instant::now();
        if let Some(waited) = catch_up.since_stop(now) {
            if catch_up.finished(now) {
                break;
            }
            if !counting_only && waited >= CATCH_UP_MAX {
                counting_only = true;
                for ((topic, _), done) in wanted.iter().zip(&catch_up.done) {
                    if !*done {
                        eprintln!(
                            "naic record: {topic}: not caught up {} s after the stop; what it still holds from before \
                             the stop is counted as lost, not written",
                            CATCH_UP_MAX.as_secs()
                        );
                    }
                }
            }
            if waited >= CATCH_UP_MAX + COUNT_MAX {
                break;
            }
        }
    }
    if let Some(waited) = catch_up.since_stop(Instant::now()) {
        eprintln!("naic record: stopped; took what was published before the stop for {:.1} s after it", waited.as_secs_f64());
        for ((topic, _), q) in wanted.iter().zip(catch_up.quiet_report()) {
            if let Some(line) = q {
                eprintln!("naic record: {topic}: {line}");
            }
        }
    }
    drop(tx); // the writer drains what it was given, then finishes the bag
    let written = writer.join().unwrap_or_else(|_| Err(CliError::failure("naic record: the bag writer thread panicked")));
    naic_ros::request_shutdown(); // the run is over: RustDDS's teardown complaints are not news
    drop(subs);
    drop(node);
    let n = written?;
    eprintln!("naic record: wrote {n} messages to {}", out.display());
    for ((topic, _), lost) in wanted.iter().zip(&gaps.lost) {
        if *lost > 0 {
            eprintln!(
                "naic record: {topic}: {lost} messages published but not recorded (gaps in the publisher's sequence \
                 numbers: the recorder fell behind the publisher's history; record fewer topics, or on a less loaded machine)"
            );
        }
    }
    Ok(())
}

/// The recorder's catching up after a stop. Each topic is done once it has delivered a
/// message published after the stop, or once it is quiet: nothing taken for `QUIET`, and at
/// least its lag plus `QUIET` since the stop, where the lag is how late its last message
/// came (receive minus publish time). A recorder seconds behind a chain whose deliveries
/// pause (a starved process, or repairs after lost packets) still has the messages published
/// before the stop coming; a topic whose publisher stopped before the stop has none. `QUIET`
/// is longer than the writers' slow heartbeat (1 s, `HEARTBEAT_PERIOD_SLOW` in RustDDS), after
/// which a reader learns of a lost last sample and has it repaired. (A 0.2 s quiet with no
/// lag ended a loaded run's recording while messages 4.6 s old were still on their way:
/// docs/bags.md.)
struct CatchUp {
    /// The stop [ns, wall clock: the publishers' source timestamps are compared with it] and
    /// when it was asked; `None` while recording.
    stop: Option<(u64, Instant)>,
    done: Vec<bool>,
    last_taken: Vec<Option<Instant>>,
    /// Receive minus publish time of each topic's last message.
    lag: Vec<Duration>,
    /// Publish time [ns, wall clock] of each topic's last message.
    last_publ: Vec<Option<u64>>,
}

impl CatchUp {
    const QUIET: Duration = Duration::from_millis(1200);

    fn new(topics: usize) -> Self {
        CatchUp {
            stop: None,
            done: vec![false; topics],
            last_taken: vec![None; topics],
            lag: vec![Duration::ZERO; topics],
            last_publ: vec![None; topics],
        }
    }

    fn stop(&mut self, stop_ns: u64, now: Instant) {
        self.stop = Some((stop_ns, now));
    }

    fn stopping(&self) -> bool {
        self.stop.is_some()
    }

    fn since_stop(&self, now: Instant) -> Option<Duration> {
        self.stop.map(|(_, asked)| now.saturating_duration_since(asked))
    }

    /// A message of `topic` was taken at `now` (`recv`, wall clock [ns]), published at
    /// `publ`. Returns whether it was published at or before the stop (always while recording).
    fn saw(&mut self, topic: usize, publ: u64, recv: u64, now: Instant) -> bool {
        self.last_taken[topic] = Some(now);
        self.lag[topic] = Duration::from_nanos(recv.saturating_sub(publ));
        self.last_publ[topic] = Some(publ);
        let after = self.stop.is_some_and(|(stop_ns, _)| publ > stop_ns);
        self.done[topic] |= after;
        !after
    }

    fn quiet(&self, topic: usize, now: Instant) -> bool {
        let Some((_, asked)) = self.stop else { return false };
        let silent_since = self.last_taken[topic].map_or(asked, |t| t.max(asked));
        now.saturating_duration_since(silent_since) >= Self::QUIET
            && now.saturating_duration_since(asked) >= self.lag[topic] + Self::QUIET
    }

    fn finished(&self, now: Instant) -> bool {
        self.stop.is_some() && (0..self.done.len()).all(|i| self.done[i] || self.quiet(i, now))
    }

    /// For each topic that ended quiet rather than past the stop: how long before the stop
    /// its last message was published (or that it had none), so that a stream whose end is
    /// missing is not silent.
    fn quiet_report(&self) -> Vec<Option<String>> {
        let stop_ns = self.stop.map_or(0, |(s, _)| s);
        (0..self.done.len())
            .map(|i| {
                (!self.done[i]).then(|| match self.last_publ[i] {
                    None => "nothing received".to_string(),
                    Some(p) => format!(
                        "nothing published after {:.3} s before the stop reached the recorder (its publishers \
                         stopped, or the end of its stream is missing)",
                        stop_ns.saturating_sub(p) as f64 * 1e-9
                    ),
                })
            })
            .collect()
    }
}

/// A message the recorder took, serialized, on its way to the bag writer.
struct Taken {
    topic: TopicId,
    cdr: Vec<u8>,
    recv: u64,
    publ: u64,
}

/// The bag writer's thread: writes what the recorder takes (flushing about every second,
/// also when nothing comes) until the sender is dropped, then finishes the bag. Returns the
/// number of messages written, or the first write error (the recorder then stops: its next
/// send fails).
#[allow(clippy::type_complexity)]
fn spawn_writer(
    mut w: BagWriter,
) -> Result<(std::sync::mpsc::Sender<Taken>, std::thread::JoinHandle<Result<u64, CliError>>), CliError> {
    let (tx, rx) = std::sync::mpsc::channel::<Taken>();
    let handle = std::thread::Builder::new()
        .name("bag-writer".into())
        .spawn(move || {
            use std::sync::mpsc::RecvTimeoutError;
            loop {
                match rx.recv_timeout(Duration::from_millis(100)) {
                    Ok(t) => w.write_cdr(t.topic, &t.cdr, t.recv, t.publ).map_err(bag_err)?,
                    Err(RecvTimeoutError::Timeout) => w.flush_if_due().map_err(bag_err)?,
                    Err(RecvTimeoutError::Disconnected) => break,
                }
            }
            let n = w.message_count();
            w.finish().map_err(bag_err)?;
            Ok(n)
        })
        .map_err(|e| CliError::failure(format!("naic record: cannot start the bag writer thread: {e}")))?;
    Ok((tx, handle))
}

/// Messages a publisher sent that never reached the recorder, per topic: gaps in each
/// publisher's sequence numbers. A reliable writer keeps only its last samples (history
/// depth 10 for the nodes), so a recorder that falls further behind loses the older ones;
/// this makes the loss visible instead of silent.
struct SeqGaps<G> {
    last: HashMap<(usize, G), i64>,
    lost: Vec<u64>,
}

impl<G: Hash + Eq> SeqGaps<G> {
    fn new(topics: usize) -> Self {
        SeqGaps { last: HashMap::new(), lost: vec![0; topics] }
    }

    /// Returns whether this is the first message of `publisher` on `topic`.
    fn see(&mut self, topic: usize, publisher: G, seq: i64) -> bool {
        match self.last.insert((topic, publisher), seq) {
            Some(prev) => {
                if seq > prev + 1 {
                    self.lost[topic] += (seq - prev - 1) as u64;
                }
                false
            }
            None => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{CatchUp, RecordArgs, SeqGaps};
    use clap::Parser;
    use std::time::{Duration, Instant};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        a: RecordArgs,
    }

    #[test]
    fn topics_may_be_given_with_spaces_or_commas() {
        let topics = |args: &[&str]| Cli::try_parse_from(args).map(|c| c.a.topics).map_err(|e| e.to_string());
        let want = vec!["/naic/params".to_string(), "/joint_effort_cmd".into()];
        assert_eq!(topics(&["naic", "--topics", "/naic/params", "/joint_effort_cmd"]), Ok(want.clone()));
        assert_eq!(topics(&["naic", "--topics", "/naic/params,/joint_effort_cmd"]), Ok(want));
    }

    #[test]
    fn gaps_are_counted_per_topic_and_publisher() {
        let mut g = SeqGaps::new(2);
        let firsts = |g: &mut SeqGaps<char>, topic, p, seqs: &[i64]| -> Vec<bool> {
            seqs.iter().map(|&s| g.see(topic, p, s)).collect()
        };
        // 4, 5, 6 lost; only the first message is a new publisher's
        assert_eq!(firsts(&mut g, 0, 'a', &[1, 2, 3, 7, 8]), [true, false, false, false, false]);
        // a second publisher starts at its own number: nothing lost
        assert_eq!(firsts(&mut g, 0, 'b', &[10, 11, 12]), [true, false, false]);
        // same publisher id on another topic: its own sequence
        assert_eq!(firsts(&mut g, 1, 'a', &[1, 3]), [true, false]);
        assert_eq!(g.lost, vec![3, 1]);
        assert!(!g.see(0, 'a', 8)); // a repeat is not a loss
        assert_eq!(g.lost, vec![3, 1]);
    }

    #[test]
    fn catching_up_ends_when_every_topic_is_past_the_stop_or_quiet() {
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        let mut c = CatchUp::new(2);
        assert!(c.saw(0, 500, 600, t0), "while recording every message is from before the stop");
        assert!(!c.finished(t0), "not stopping yet");
        c.stop(1_000, t0);
        assert!(!c.finished(t0), "nothing taken since the stop, not quiet yet");
        assert!(c.saw(0, 900, 1_100, t0), "from before the stop: more may follow");
        assert!(!c.saw(1, 1_001, 1_100, t0));
        assert!(!c.finished(t0));
        assert!(c.saw(0, 1_000, 1_100, t0), "published at the stop is not after it");
        assert!(!c.finished(t0));
        c.saw(0, 1_500, 1_600, t0);
        assert!(c.finished(t0));
        assert_eq!(c.quiet_report(), vec![None, None]);
        // A topic that went silent is done after QUIET.
        let mut c = CatchUp::new(2);
        c.saw(0, 0, 1_000, t0); // 1 us late
        c.stop(1_000, t0);
        c.saw(1, 2_000, 2_000, t0);
        assert!(!c.finished(ms(1_100)));
        assert!(!c.finished(ms(1_200)), "topic 0's lag (1 us) is part of its quiet time");
        assert!(c.finished(ms(1_201)));
        let r = c.quiet_report();
        assert!(r[0].as_deref().is_some_and(|l| l.contains("0.000 s before the stop")), "{r:?}");
        assert_eq!(r[1], None);
        // A topic 4.6 s behind is not quiet after QUIET: what was published before the stop
        // is still on its way (the loaded run of docs/bags.md); it is after its lag + QUIET.
        let mut c = CatchUp::new(1);
        c.saw(0, 182_380_000_000, 186_960_000_000, t0);
        c.stop(187_700_000_000, ms(740));
        assert!(!c.finished(ms(740 + 1_200)), "quiet for longer than QUIET, but 4.6 s behind");
        assert!(!c.finished(ms(740 + 4_580 + 1_100)));
        assert!(c.finished(ms(740 + 4_580 + 1_200)));
        // ... and anything it takes meanwhile restarts the quiet time.
        c.saw(0, 183_000_000_000, 187_700_000_000, ms(5_000));
        assert!(!c.finished(ms(6_000)));
        assert!(c.finished(ms(740 + 4_700 + 1_200).max(ms(6_200))));
    }
}

pub fn replay(a: ReplayArgs) -> CliResult {
    if !(a.rate > 0.0 && a.rate.is_finite()) {
        return Err(CliError::usage(format!("--rate must be a positive number, got {}", a.rate)));
    }
    if !(a.start >= 0.0 && a.start.is_finite() && a.delay >= 0.0 && a.delay.is_finite()) {
        return Err(CliError::usage("--start and --delay must be non-negative seconds"));
    }
    let bag = Bag::open(&a.file).map_err(|e| CliError::usage(e.to_string()))?;
    for d in bag.damage() {
        eprintln!("naic replay: {}: {d}", a.file.display());
    }
    let topics = bag.topics();
    for t in &a.topics {
        if !topics.iter().any(|x| &x.topic == t) {
            return Err(CliError::usage(format!(
                "topic {t} is not in {}; it has: {}",
                a.file.display(),
                topics.iter().map(|x| x.topic.as_str()).collect::<Vec<_>>().join(", ")
            )));
        }
    }
    let selected: Vec<&naic_bag::TopicInfo> = topics
        .iter()
        .filter(|t| a.topics.is_empty() || a.topics.contains(&t.topic))
        .filter(|t| {
            let ok = ros_type(&t.type_name).is_some();
            if !ok {
                eprintln!("naic replay: skipping {} ({} is not a type naic can publish)", t.topic, t.type_name);
            }
            ok
        })
        .collect();
    if selected.is_empty() {
        return Err(CliError::usage("nothing to replay: no selected topic has a type naic can publish"));
    }
    let args = RosArgs::parse(std::iter::empty::<String>()).map_err(ros_err)?;
    let mut node = RosNode::new(args, "naic_player", Vec::new(), None).map_err(ros_err)?;
    enum Pub {
        Js(ros2_client::Publisher<JointState>),
        Ws(ros2_client::Publisher<WrenchStamped>),
        Fa(ros2_client::Publisher<Float64MultiArray>),
        Np(ros2_client::Publisher<NaicParams>),
        Ck(ros2_client::Publisher<Clock>),
        Ps(ros2_client::Publisher<PoseStamped>),
    }
    let mut pubs: std::collections::HashMap<u16, Pub> = Default::default();
    for t in &selected {
        let rt = ros_type(&t.type_name).expect("filtered");
        let p = match t.type_name.as_str() {
            "sensor_msgs/msg/JointState" => Pub::Js(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
            "geometry_msgs/msg/WrenchStamped" => Pub::Ws(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
            "std_msgs/msg/Float64MultiArray" => Pub::Fa(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
            "naic_msgs/msg/NaicParams" => Pub::Np(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
            "geometry_msgs/msg/PoseStamped" => Pub::Ps(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
            _ => Pub::Ck(node.publisher(&t.topic, rt, QOS_REPLAY).map_err(ros_err)?),
        };
        pubs.insert(t.channel_id, p);
    }
    // Decode once up front (a 60 s, 4-topic bag is ~240k messages), then publish on time.
    let Some((first, _)) = bag.time_bounds() else {
        return Err(CliError::usage(format!("{} has no messages", a.file.display())));
    };
    let from = first.saturating_add((a.start * 1e9) as u64);
    let msgs = bag.decode_all(from..);
    let msgs: Vec<_> = msgs.into_iter().filter(|m| pubs.contains_key(&m.channel_id)).collect();
    if msgs.is_empty() {
        return Err(CliError::usage(format!("no messages to replay after --start {} s", a.start)));
    }
    naic_ros::install_signal_handlers(); // Ctrl-C / SIGTERM: finish the bag, then exit
    eprintln!(
        "naic replay: {} messages on {} topic(s) at {}x{}",
        msgs.len(),
        pubs.len(),
        a.rate,
        if a.looped { ", looping" } else { "" }
    );
    std::thread::sleep(Duration::from_secs_f64(a.delay));
    let t_first = msgs[0].log_time;
    let mut errors = 0u64;
    loop {
        let t0 = Instant::now();
        for msg in &msgs {
            if naic_ros::shutdown_requested() {
                break;
            }
            let due = Duration::from_secs_f64((msg.log_time - t_first) as f64 * 1e-9 / a.rate);
            sleep_until(t0 + due);
            let p = &pubs[&msg.channel_id];
            let r = match (p, &msg.msg) {
                (Pub::Js(p), naic_bag::AnyMessage::JointState(x)) => p.publish(x.clone()).is_ok(),
                (Pub::Ws(p), naic_bag::AnyMessage::WrenchStamped(x)) => p.publish(x.clone()).is_ok(),
                (Pub::Fa(p), naic_bag::AnyMessage::Float64MultiArray(x)) => p.publish(x.clone()).is_ok(),
                (Pub::Np(p), naic_bag::AnyMessage::NaicParams(x)) => p.publish(x.clone()).is_ok(),
                (Pub::Ck(p), naic_bag::AnyMessage::Clock(x)) => p.publish(x.clone()).is_ok(),
                (Pub::Ps(p), naic_bag::AnyMessage::PoseStamped(x)) => p.publish(x.clone()).is_ok(),
                _ => false,
            };
            if !r {
                errors += 1;
            }
        }
        if !a.looped || naic_ros::shutdown_requested() {
            break;
        }
    }
    // Let reliable writers deliver the tail before the participant goes away.
    std::thread::sleep(Duration::from_millis(300));
    naic_ros::request_shutdown();
    drop(pubs);
    drop(node);
    if errors > 0 {
        return Err(CliError::failure(format!(
            "{errors} message(s) could not be published (send window stayed full: a subscriber is too slow)"
        )));
    }
    Ok(())
}

/// Sleeps until `t`: the OS sleep for all but the last ~0.2 ms, then yields (timing well
/// under a millisecond without burning a core for the whole wait).
fn sleep_until(t: Instant) {
    loop {
        let now = Instant::now();
        if now >= t {
            return;
        }
        let left = t - now;
        if left > Duration::from_micros(300) {
            std::thread::sleep(left - Duration::from_micros(200));
        } else {
            std::thread::yield_now();
        }
    }
}

/// `naic bench record`: a generated 1 kHz, 4-topic bag of `seconds` is replayed over DDS
/// (`naic replay`, its own process) and recorded (`naic record`, another process); reports
/// dropped messages and how well the recorded timing matches the original (|delay − median
/// delay| per message, median / p99 / max).
pub fn bench_record(json: bool, seconds: f64) -> CliResult {
    if !(seconds > 0.0 && seconds.is_finite()) {
        return Err(CliError::usage("--seconds must be positive"));
    }
    let dir = std::env::temp_dir().join(format!("naic_bench_record_{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| CliError::failure(format!("temp dir: {e}")))?;
    let src = dir.join("src.mcap");
    let rec = dir.join("rec.mcap");
    let cycles = (seconds * 1000.0).round() as u64;
    naic_bag::sample::write_sample(&src, cycles, 1000.0, |_| {}).map_err(bag_err)?;
    let exe = std::env::current_exe().map_err(|e| CliError::failure(format!("current exe: {e}")))?;
    let topics = ["/joint_states", "/wrench", "/joint_effort_cmd", "/naic/params"];
    // Both processes discover each other on loopback only, on a private domain unless one is set.
    let domain = std::env::var("ROS_DOMAIN_ID").unwrap_or_else(|_| format!("{}", 101 + std::process::id() % 131));
    let child = |c: &mut std::process::Command| {
        c.env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST").env("ROS_DOMAIN_ID", &domain).env_remove("ROS_LOCALHOST_ONLY");
    };
    let mut rec_cmd = std::process::Command::new(&exe);
    child(&mut rec_cmd);
    let mut rep_cmd = std::process::Command::new(&exe);
    child(&mut rep_cmd);
    let mut recorder = rec_cmd
        .args(["record", "--out"])
        .arg(&rec)
        .args(["--duration", &format!("{}", seconds + 6.0), "--topics"])
        .args(topics)
        .spawn()
        .map_err(|e| CliError::failure(format!("cannot start naic record: {e}")))?;
    std::thread::sleep(Duration::from_secs(2));
    let st = rep_cmd
        .arg("replay")
        .arg(&src)
        .args(["--delay", "2"])
        .status()
        .map_err(|e| CliError::failure(format!("cannot start naic replay: {e}")))?;
    let rs = recorder.wait().map_err(|e| CliError::failure(format!("naic record: {e}")))?;
    if !st.success() || !rs.success() {
        return Err(CliError::failure(format!("replay exited with {st}, record with {rs}")));
    }
    let a = Bag::open(&src).map_err(bag_err)?;
    let b = Bag::open(&rec).map_err(bag_err)?;
    let mut report = Vec::new();
    let mut all_err = Vec::new();
    let mut total_dropped = 0usize;
    for t in topics {
        let times = |bag: &Bag| -> Result<Vec<u64>, CliError> {
            let ch = bag.channel_by_topic(t).map_err(bag_err)?;
            let mut v = Vec::new();
            bag.for_each_message(Some(&[ch]), naic_bag::TimeRange::ALL, |m| v.push(m.log_time));
            Ok(v)
        };
        let (ta, tb) = (times(&a)?, times(&b).unwrap_or_default());
        let dropped = ta.len().saturating_sub(tb.len());
        total_dropped += dropped;
        // Timing error: each message's delay (recorded log time - original log time) minus
        // the median delay, i.e. how far the replayed spacing departs from the original.
        // Valid when nothing was dropped (messages then pair up in order).
        let mut err: Vec<f64> = if dropped == 0 && !tb.is_empty() {
            let mut d: Vec<f64> = ta.iter().zip(&tb).map(|(x, y)| *y as f64 - *x as f64).collect();
            let mut s = d.clone();
            s.sort_by(f64::total_cmp);
            let med = s[s.len() / 2];
            d.iter_mut().for_each(|v| *v = (*v - med).abs() * 1e-6);
            d
        } else {
            Vec::new()
        };
        all_err.extend_from_slice(&err);
        err.sort_by(f64::total_cmp);
        let q = |p: f64| if err.is_empty() { f64::NAN } else { err[((err.len() - 1) as f64 * p) as usize] };
        report.push(serde_json::json!({"topic": t, "sent": ta.len(), "recorded": tb.len(), "dropped": dropped,
            "spacing_error_ms": {"median": q(0.5), "p99": q(0.99), "max": q(1.0)}}));
    }
    all_err.sort_by(f64::total_cmp);
    let q = |p: f64| if all_err.is_empty() { f64::NAN } else { all_err[((all_err.len() - 1) as f64 * p) as usize] };
    let _ = std::fs::remove_dir_all(&dir);
    let v = serde_json::json!({
        "bench": "record_over_dds",
        "seconds": seconds, "rate_hz": 1000, "topics": report,
        "dropped": total_dropped,
        "spacing_error_ms": {"median": q(0.5), "p99": q(0.99), "max": q(1.0)},
    });
    if json {
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
    } else {
        println!("recorded {} s at 1 kHz on 4 topics: {total_dropped} dropped; spacing error median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
            seconds, q(0.5), q(0.99), q(1.0));
    }
    Ok(())
}
