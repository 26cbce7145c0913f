//! A counting global allocator, for proving that hot paths do not allocate.
//!
//! Contract: [`CountingAllocator`] forwards every call to
//! [`std::alloc::System`] and counts it twice: per thread (const-initialised
//! thread-local `Cell`s, so parallel test threads do not see each other's
//! allocations, and reading them never allocates) and process-wide (relaxed
//! atomics, for a service to publish). It counts only once a binary or test
//! installs it:
//!
//! ```ignore
//! #[global_allocator]
//! static ALLOC: planner::alloc_counter::CountingAllocator = planner::alloc_counter::CountingAllocator;
//! ```
//!
//! Without that, every count stays 0; [`installed`] tells the two apart.
//! An allocation is a call to `alloc`, `alloc_zeroed` or `realloc` (a
//! `realloc` can move a block, so it counts as one); a deallocation is a
//! call to `dealloc`. House style §4: allocate in `new`, prove `step` does
//! not, with a count over many steady-state iterations after a warm-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

/// Allocation counts, per thread or per process.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AllocCounts {
    /// Calls to `alloc`, `alloc_zeroed` and `realloc`.
    pub allocations: u64,
    /// Calls to `dealloc`.
    pub deallocations: u64,
    /// Bytes requested by those allocations (a `realloc` counts its new size).
    pub bytes: u64,
}

impl AllocCounts {
    /// What happened between `earlier` and `self` (counters only grow).
    pub fn since(self, earlier: Self) -> Self {
        Self {
            allocations: self.allocations - earlier.allocations,
            deallocations: self.deallocations - earlier.deallocations,
            bytes: self.bytes - earlier.bytes,
        }
    }
}

thread_local! {
    // Const-initialised and without destructors: access compiles to a plain
    // thread-local slot, never allocates, and works during thread teardown.
    static THREAD_ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    static THREAD_DEALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    static THREAD_BYTES: Cell<u64> = const { Cell::new(0) };
}

static TOTAL_ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static TOTAL_DEALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static TOTAL_BYTES: AtomicU64 = AtomicU64::new(0);

fn bump(cell: &'static std::thread::LocalKey<Cell<u64>>, by: u64) {
    // `try_with` rather than `with`: never panic inside the allocator.
    let _ = cell.try_with(|c| c.set(c.get().wrapping_add(by)));
}

fn record_allocation(size: usize) {
    bump(&THREAD_ALLOCATIONS, 1);
    bump(&THREAD_BYTES, size as u64);
    TOTAL_ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    TOTAL_BYTES.fetch_add(size as u64, Ordering::Relaxed);
}

fn record_deallocation() {
    bump(&THREAD_DEALLOCATIONS, 1);
    TOTAL_DEALLOCATIONS.fetch_add(1, Ordering::Relaxed);
}

/// The system allocator with counters (see the module notes).
#[derive(Clone, Copy, Debug, Default)]
pub struct CountingAllocator;

// SAFETY: every method forwards to `System` with the caller's arguments
// unchanged; the counting touches only atomics and destructor-free
// thread-locals, which neither allocate nor unwind.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record_allocation(layout.size());
        // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        record_allocation(layout.size());
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record_allocation(new_size);
        // SAFETY: the caller upholds `GlobalAlloc::realloc`'s contract.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        record_deallocation();
        // SAFETY: the caller upholds `GlobalAlloc::dealloc`'s contract.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// This thread's counts since it started (all 0 when the allocator is not
/// installed). Does not allocate.
pub fn thread_counts() -> AllocCounts {
    AllocCounts {
        allocations: THREAD_ALLOCATIONS.try_with(Cell::get).unwrap_or(0),
        deallocations: THREAD_DEALLOCATIONS.try_with(Cell::get).unwrap_or(0),
        bytes: THREAD_BYTES.try_with(Cell::get).unwrap_or(0),
    }
}

/// Counts over the whole process, every thread together. Does not allocate.
pub fn total_counts() -> AllocCounts {
    AllocCounts {
        allocations: TOTAL_ALLOCATIONS.load(Ordering::Relaxed),
        deallocations: TOTAL_DEALLOCATIONS.load(Ordering::Relaxed),
        bytes: TOTAL_BYTES.load(Ordering::Relaxed),
    }
}

/// Allocations made by the whole process so far (what the planner service
/// publishes). Does not allocate.
pub fn total_allocations() -> u64 {
    TOTAL_ALLOCATIONS.load(Ordering::Relaxed)
}

/// Runs `f` and returns its result with the allocations this thread made
/// meanwhile.
pub fn count<T>(f: impl FnOnce() -> T) -> (T, AllocCounts) {
    let before = thread_counts();
    let out = f();
    (out, thread_counts().since(before))
}

/// Whether [`CountingAllocator`] is the global allocator: makes one small
/// allocation on purpose and sees if it was counted.
pub fn installed() -> bool {
    let (_, counts) = count(|| std::hint::black_box(Box::new(0u64)));
    counts.allocations > 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_subtract_field_by_field() {
        let a = AllocCounts {
            allocations: 5,
            deallocations: 3,
            bytes: 100,
        };
        let b = AllocCounts {
            allocations: 9,
            deallocations: 4,
            bytes: 164,
        };
        assert_eq!(
            b.since(a),
            AllocCounts {
                allocations: 4,
                deallocations: 1,
                bytes: 64
            }
        );
    }

    #[test]
    fn without_installation_nothing_is_counted_and_that_is_detectable() {
        // This unit-test binary does not install the allocator (the
        // integration test `no_alloc` does), so counts stay 0.
        assert!(!installed());
        let (_, c) = count(|| vec![1u8; 1000]);
        assert_eq!(c, AllocCounts::default());
    }
}
