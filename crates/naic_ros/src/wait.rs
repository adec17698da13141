//! Waiting for DDS data without busy loops: a mio poll over subscriptions.

use std::time::Duration;

use mio::{Events, Interest, Poll, Token};

/// Blocks until one of the registered sources is readable (or the timeout passes).
pub struct Waiter {
    poll: Poll,
    events: Events,
}

impl Waiter {
    pub fn new() -> std::io::Result<Waiter> {
        Ok(Waiter { poll: Poll::new()?, events: Events::with_capacity(16) })
    }

    /// Register a subscription (or any mio source) under `token`.
    pub fn add<S: mio::event::Source>(&mut self, s: &mut S, token: usize) -> std::io::Result<()> {
        self.poll.registry().register(s, Token(token), Interest::READABLE)
    }

    /// Wait for readiness; returns the ready tokens' bitmask (bit i for token i < 64).
    /// Note: epoll timeouts have millisecond granularity; readiness wakes immediately.
    pub fn wait(&mut self, timeout: Option<Duration>) -> u64 {
        if let Err(e) = self.poll.poll(&mut self.events, timeout) {
            if e.kind() != std::io::ErrorKind::Interrupted {
                log::warn!("poll failed: {e}");
            }
            return 0;
        }
        let mut mask = 0u64;
        for ev in self.events.iter() {
            if ev.token().0 < 64 {
                mask |= 1 << ev.token().0;
            }
        }
        mask
    }
}

/// Take the samples of `sub` as they arrive, handing each to `on`, until `on` returns true
/// (got the one it waited for) or the wall clock passes `deadline_ns`; returns whether `on`
/// said so. Polls every 50 µs: for short waits on a sample known to be on its way (the
/// lockstep loop pairing messages of the same stamp).
pub fn take_until<M: serde::de::DeserializeOwned + 'static>(
    sub: &ros2_client::Subscription<M>,
    deadline_ns: i64,
    mut on: impl FnMut(M) -> bool,
) -> bool {
    while crate::time::wall_ns() < deadline_ns {
        match sub.take() {
            Ok(Some((m, _))) => {
                if on(m) {
                    return true;
                }
            }
            _ => std::thread::sleep(Duration::from_micros(50)),
        }
    }
    false
}

/// The newest sample waiting on `sub` (older ones are taken and dropped), or `None`.
pub fn take_newest<M: serde::de::DeserializeOwned + 'static>(sub: &ros2_client::Subscription<M>) -> Option<M> {
    let mut newest = None;
    while let Ok(Some((m, _))) = sub.take() {
        newest = Some(m);
    }
    newest
}

/// The newest sample waiting on `sub` whose writer `admit` takes (see
/// [`crate::source::SourceGate`]; older ones and refused ones are taken and dropped), or
/// `None`.
pub fn take_newest_admitted<M: serde::de::DeserializeOwned + 'static>(
    sub: &ros2_client::Subscription<M>,
    mut admit: impl FnMut(&ros2_client::MessageInfo) -> bool,
) -> Option<M> {
    let mut newest = None;
    while let Ok(Some((m, info))) = sub.take() {
        if admit(&info) {
            newest = Some(m);
        }
    }
    newest
}

/// Start a thread named `name` that wakes on each sample of `sub` and hands it with its
/// sample information (the writer: [`crate::source`]) to `on`, until shutdown is requested
/// (a driver's receive thread: it stamps each command's arrival as it comes, whatever the
/// main loop is doing).
pub fn spawn_receiver<M: serde::de::DeserializeOwned + 'static>(
    name: &str,
    mut sub: ros2_client::Subscription<M>,
    mut on: impl FnMut(M, ros2_client::MessageInfo) + Send + 'static,
) -> std::io::Result<()>
where
    ros2_client::Subscription<M>: Send,
{
    let mut waiter = Waiter::new()?;
    waiter.add(&mut sub, 0)?;
    std::thread::Builder::new().name(name.into()).spawn(move || {
        while !crate::shutdown_requested() {
            waiter.wait(Some(Duration::from_millis(50)));
            while let Ok(Some((m, info))) = sub.take() {
                on(m, info);
            }
        }
    })?;
    Ok(())
}
