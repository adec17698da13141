//! Allocation check of the 1 kHz path: a counting global allocator (debug builds and
//! tests) and [`check`], which runs a node core's step and reports whether it allocated.
//!
//! The `assert_no_alloc` crate does the same, but it is not in this project's dependency
//! set and its check aborts the process; here the count is per thread (other threads,
//! e.g. RustDDS's, may allocate freely), costs one thread-local increment per
//! allocation, and a debug node logs the offending count instead of dying. Release builds
//! use the system allocator directly: [`CountingAlloc`] is installed by the node binaries
//! only under `cfg(debug_assertions)` and by the core's unit tests.

use std::{
    alloc::{GlobalAlloc, Layout, System},
    cell::Cell,
};

thread_local! {
    static COUNT: Cell<u64> = const { Cell::new(0) };
}

/// The system allocator, counting allocations (and reallocations) per thread.
pub struct CountingAlloc;

// SAFETY: forwards to `System`; the counter is a const-initialised thread-local `Cell`,
// which never allocates itself.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        System.alloc(l)
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        System.alloc_zeroed(l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        System.realloc(p, l, n)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l)
    }
}

/// Allocations on this thread so far (0 forever unless [`CountingAlloc`] is the global
/// allocator).
pub fn count() -> u64 {
    COUNT.with(|c| c.get())
}

/// Run `f` and return its result with the number of allocations it made on this thread.
pub fn counted<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let before = count();
    let r = f();
    (r, count() - before)
}

/// Run a node core's `step` under the allocation check: in debug builds an allocation is
/// logged (rate-limited by the caller's `warned` flag: once per process); release builds
/// run `f` only.
pub fn check<R>(what: &str, warned: &mut bool, f: impl FnOnce() -> R) -> R {
    if cfg!(debug_assertions) {
        let (r, n) = counted(f);
        if n > 0 && !*warned {
            *warned = true;
            log::error!("{what}: {n} heap allocations in the 1 kHz step (should be none)");
        }
        r
    } else {
        f()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_counter_sees_an_allocation() {
        let (v, n) = counted(|| vec![1u8; 16]);
        assert_eq!(v.len(), 16);
        assert!(n >= 1, "the counting allocator is not installed: every no-allocation test would pass vacuously");
        let (_, n) = counted(|| [0u8; 16].iter().sum::<u8>());
        assert_eq!(n, 0);
    }
}
