//! The nodes' allocation check of the 1 kHz path: [`check`] runs a node core's step and
//! logs, in debug builds, if it allocated. The counter is `naic_core::alloc_count` (one
//! implementation for the workspace); release builds use the system allocator directly:
//! [`CountingAlloc`] is installed by the node binaries only under `cfg(debug_assertions)`
//! and by the core's unit tests.

pub use naic_core::alloc_count::{count, counted, CountingAlloc};

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
