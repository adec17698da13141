//! Minimal stderr logger: `[LEVEL] [node]: message`, node crates at the `--log-level`
//! (default info), ros2-client/RustDDS internals at warn (error unless debugging).
//!
//! Every line of the node's own crates also goes to `/rosout` (`rcl_interfaces/msg/Log`:
//! stamp, level, node name, message, file, function, line) once the node has attached its
//! rosout writer ([`attach_rosout`]), as rclcpp's logging does: `ros2 topic echo /rosout`
//! and rqt_console show them. `function` is the Rust module path (the `log` crate has no
//! function name). stderr stays as it is.

use std::{
    cell::Cell,
    sync::{Mutex, OnceLock},
};

use log::{Level, LevelFilter, Log, Metadata, Record};
use ros2_client::{log::LogLevel, rosout::RosoutRaw, NodeLoggingHandle};

struct Logger {
    node: String,
    level: LevelFilter,
}

static LOGGER: OnceLock<Logger> = OnceLock::new();

/// The process's node's `/rosout` writer (the first node that attached one).
static ROSOUT: Mutex<Option<NodeLoggingHandle>> = Mutex::new(None);

thread_local! {
    /// Set while this thread publishes a line on `/rosout`: what DDS logs meanwhile goes to
    /// stderr only (no recursion).
    static IN_ROSOUT: Cell<bool> = const { Cell::new(false) };
}

/// From now on the log lines also go to `/rosout` through `handle` (the first call wins: a
/// process of several nodes, `naic launch --composed`, keeps one).
pub fn attach_rosout(handle: NodeLoggingHandle) {
    if let Ok(mut r) = ROSOUT.lock() {
        r.get_or_insert(handle);
    }
}

fn rosout_level(l: Level) -> LogLevel {
    match l {
        Level::Error => LogLevel::Error,
        Level::Warn => LogLevel::Warn,
        Level::Info => LogLevel::Info,
        Level::Debug | Level::Trace => LogLevel::Debug,
    }
}

fn publish_rosout(node: &str, r: &Record) {
    if IN_ROSOUT.with(|f| f.replace(true)) {
        return;
    }
    if let Ok(guard) = ROSOUT.try_lock() {
        if let Some(h) = guard.as_ref() {
            h.rosout_raw(
                ros2_client::builtin_interfaces::Time::now(),
                rosout_level(r.level()),
                node,
                &r.args().to_string(),
                r.file().unwrap_or(""),
                r.module_path().unwrap_or(""),
                r.line().unwrap_or(0),
            );
        }
    }
    IN_ROSOUT.with(|f| f.set(false));
}

impl Log for Logger {
    fn enabled(&self, m: &Metadata) -> bool {
        let ours = m.target().starts_with("naic") || m.target().starts_with("jk5")
            || m.target().starts_with("friction");
        if ours {
            m.level() <= self.level
        } else if crate::shutdown_requested() {
            false // RustDDS complains about sockets while tearing down: not news.
        } else {
            // DDS internals: only errors, unless the user asked for debug.
            m.level() <= if self.level >= LevelFilter::Debug { Level::Warn } else { Level::Error }
        }
    }
    fn log(&self, r: &Record) {
        if self.enabled(r.metadata()) {
            eprintln!("[{}] [{}]: {}", r.level(), self.node, r.args());
            let t = r.target();
            if t.starts_with("naic") || t.starts_with("jk5") || t.starts_with("friction") {
                publish_rosout(&self.node, r);
            }
        }
    }
    fn flush(&self) {}
}

/// Install the logger once per process (later calls are ignored).
pub fn init(node: &str, level: Option<&str>) {
    let level = match level.unwrap_or("info") {
        "debug" => LevelFilter::Debug,
        "warn" => LevelFilter::Warn,
        "error" | "fatal" => LevelFilter::Error,
        _ => LevelFilter::Info,
    };
    let l = LOGGER.get_or_init(|| Logger { node: node.to_string(), level });
    if log::set_logger(l).is_ok() {
        log::set_max_level(level);
    }
}
