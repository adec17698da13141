//! Minimal stderr logger: `[LEVEL] [node]: message`, node crates at the `--log-level`
//! (default info), ros2-client/RustDDS internals at warn (error unless debugging).

use std::sync::OnceLock;

use log::{Level, LevelFilter, Log, Metadata, Record};

struct Logger {
    node: String,
    level: LevelFilter,
}

static LOGGER: OnceLock<Logger> = OnceLock::new();

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
