//! Allocation counting for the no-allocation checks of the 1 kHz path: a counting global
//! allocator ([`CountingAlloc`], installed by the node binaries in debug builds and by the
//! tests that check the path) and [`counted`], the allocations a closure made.
//!
//! One implementation for the whole workspace (the dynamics, the simulator and the node
//! cores are checked with it). Not the `assert_no_alloc` crate: its check aborts the process
//! (or, with `warn_*`, prints), and its violation count is one global counter for every
//! thread, so the test harness's other threads and RustDDS's would count too. Here the count
//! is per thread and costs one thread-local increment per allocation.

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

#[cfg(test)]
mod tests {
    use super::*;

    #[global_allocator]
    static A: CountingAlloc = CountingAlloc;

    #[test]
    fn the_counter_sees_an_allocation() {
        let (v, n) = counted(|| vec![1u8; 16]);
        assert_eq!(v.len(), 16);
        assert!(n >= 1, "the counting allocator is not installed: every no-allocation test would pass vacuously");
        let (_, n) = counted(|| [0u8; 16].iter().sum::<u8>());
        assert_eq!(n, 0);
    }
}
