//! Publishing from a real-time loop without waiting on DDS.
//!
//! The loop hands its newest messages to a publisher thread, which publishes them; the loop
//! never blocks on the publisher thread or on DDS. This is ros2_control's
//! `realtime_tools::RealtimePublisher`: the real-time side takes the slot with a
//! `try_lock` (never a wait) and copies into preallocated messages
//! ([`naic_msgs::CopyFrom`]: no allocation once the buffers have their size); the
//! publisher thread swaps the slot with its own copy (a pointer swap under the lock) and
//! publishes outside the lock.
//!
//! Real time ([`Handoff::offer`]): the newest value wins. A value the publisher thread had
//! not taken yet when the next one came is overwritten, and a value offered while the
//! publisher thread held the lock is skipped; both are counted ([`Handoff::dropped`]) and
//! the caller reports them, so observers may miss samples but never silently.
//! Lockstep ([`Handoff::offer_every`]): the loop waits until the previous value was
//! taken, so every value is published.

use std::{
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc, Condvar, Mutex, TryLockError,
    },
    thread::JoinHandle,
};

use naic_msgs::CopyFrom;

struct Slot<T> {
    value: T,
    /// `value` has not been taken by the publisher thread yet.
    fresh: bool,
    stop: bool,
}

struct Shared<T> {
    slot: Mutex<Slot<T>>,
    cv: Condvar,
    overwritten: AtomicU64,
    busy: AtomicU64,
}

/// A value handed from a real-time loop to a publisher thread.
pub struct Handoff<T: Send + 'static> {
    shared: Arc<Shared<T>>,
    thread: Option<JoinHandle<()>>,
}

impl<T: CopyFrom + Clone + Send + 'static> Handoff<T> {
    /// Starts the publisher thread `name`, which calls `publish` on every value it takes.
    /// `template` gives the buffers their size (e.g. six joint names); the thread is
    /// created with the caller's scheduling, so create it before raising the loop's.
    pub fn spawn(name: &str, template: T, mut publish: impl FnMut(&T) + Send + 'static) -> std::io::Result<Handoff<T>> {
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot { value: template.clone(), fresh: false, stop: false }),
            cv: Condvar::new(),
            overwritten: AtomicU64::new(0),
            busy: AtomicU64::new(0),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new().name(name.into()).spawn(move || {
            let mut local = template;
            loop {
                {
                    let mut g = s.slot.lock().unwrap_or_else(|p| p.into_inner());
                    while !g.fresh && !g.stop {
                        g = s.cv.wait(g).unwrap_or_else(|p| p.into_inner());
                    }
                    if !g.fresh {
                        return; // stopped, everything taken
                    }
                    std::mem::swap(&mut g.value, &mut local);
                    g.fresh = false;
                }
                s.cv.notify_all();
                publish(&local);
            }
        })?;
        Ok(Handoff { shared, thread: Some(thread) })
    }

    /// Real time: copy `value` into the slot unless the publisher thread holds it (never
    /// waits). Returns whether it was taken.
    pub fn offer(&self, value: &T) -> bool {
        let mut g = match self.shared.slot.try_lock() {
            Ok(g) => g,
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
            Err(TryLockError::WouldBlock) => {
                self.shared.busy.fetch_add(1, Ordering::Relaxed);
                return false;
            }
        };
        if g.fresh {
            self.shared.overwritten.fetch_add(1, Ordering::Relaxed);
        }
        g.value.copy_from(value);
        g.fresh = true;
        drop(g);
        self.shared.cv.notify_all();
        true
    }

    /// Lockstep: wait until the previous value was taken, then hand `value` over (every
    /// value is published).
    pub fn offer_every(&self, value: &T) {
        let g = self.shared.slot.lock().unwrap_or_else(|p| p.into_inner());
        let mut g = self.shared.cv.wait_while(g, |s| s.fresh && !s.stop).unwrap_or_else(|p| p.into_inner());
        g.value.copy_from(value);
        g.fresh = true;
        drop(g);
        self.shared.cv.notify_all();
    }

    /// Values that were never published: overwritten before the publisher thread took
    /// them, or skipped because it held the slot.
    pub fn dropped(&self) -> u64 {
        self.shared.overwritten.load(Ordering::Relaxed) + self.shared.busy.load(Ordering::Relaxed)
    }
}

impl<T: Send + 'static> Drop for Handoff<T> {
    /// Publishes what is still in the slot, then ends the thread.
    fn drop(&mut self) {
        self.shared.slot.lock().unwrap_or_else(|p| p.into_inner()).stop = true;
        self.shared.cv.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::mpsc;

    use naic_msgs::JointState;

    use super::*;
    use crate::alloc_check::counted;

    fn js(i: usize) -> JointState {
        JointState { name: vec!["joint1".into(), "joint2".into()], position: vec![i as f64, -(i as f64)], ..Default::default() }
    }

    #[test]
    fn lockstep_publishes_every_value_in_order() {
        let (tx, rx) = mpsc::channel();
        let h = Handoff::spawn("test-pub", js(0), move |m: &JointState| tx.send(m.position[0] as usize).unwrap()).unwrap();
        for i in 1..=500 {
            h.offer_every(&js(i));
        }
        drop(h);
        let got: Vec<usize> = rx.iter().collect();
        assert_eq!(got, (1..=500).collect::<Vec<_>>());
    }

    #[test]
    fn real_time_never_waits_and_counts_what_it_drops() {
        // The publisher thread is stuck in `publish` until released: every offer must
        // still return at once, the newest value must win, and every loss is counted.
        let (release_tx, release_rx) = mpsc::channel::<()>();
        let (tx, rx) = mpsc::channel();
        let h = Handoff::spawn("test-pub", js(0), move |m: &JointState| {
            tx.send(m.position[0] as usize).unwrap();
            release_rx.recv().unwrap();
        })
        .unwrap();
        assert!(h.offer(&js(1)));
        assert_eq!(rx.recv().unwrap(), 1, "taken and being published");
        for i in 2..=100 {
            h.offer(&js(i));
        }
        // 2..=99 were overwritten (or skipped) while 1 was being published; 100 is waiting.
        assert_eq!(h.dropped(), 98);
        release_tx.send(()).unwrap();
        assert_eq!(rx.recv().unwrap(), 100, "the newest value wins");
        release_tx.send(()).unwrap();
        drop(h);
        assert!(rx.try_recv().is_err(), "nothing else was published");
    }

    #[test]
    fn offering_a_value_of_the_same_shape_does_not_allocate() {
        let h = Handoff::spawn("test-pub", js(0), |_: &JointState| {}).unwrap();
        let v = js(7);
        h.offer_every(&v); // both buffers of the same shape from here on
        h.offer_every(&v);
        let (_, n) = counted(|| {
            for _ in 0..100 {
                h.offer(&v);
            }
        });
        assert_eq!(n, 0, "allocations on the real-time side");
    }
}
