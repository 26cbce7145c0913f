//! The planner binary's global allocator: counts the service thread's calls
//! into the system allocator and serves its small blocks from a pool reserved
//! at start-up.
//!
//! Why a pool: iceoryx2 0.10's `Publisher::loan_uninit` allocates one 48 B
//! `Rc` per call (measured, see `ipc-NOTES`; 0.9.3 did not). The planner must
//! publish without calling the system allocator in steady state, so blocks up
//! to [`BLOCK_BYTES`] requested by the *watched* thread come from a fixed
//! pool of [`POOL_BLOCKS`] blocks carved once by [`reserve_pool`]. Nothing is
//! hidden: pool blocks are counted separately ([`AllocCounters`]
//! `pool_allocs_steady`, high-water mark, misses) and published with the
//! system-allocator counts.
//!
//! Contract:
//! - Only the thread that called [`watch_this_thread`] is counted and pooled;
//!   other threads (progress bar, log writer) go straight to the system
//!   allocator, uncounted.
//! - A pool block is returned to the pool whichever thread frees it.
//! - Requests the pool cannot serve (too large, over-aligned, pool empty) go to
//!   the system allocator and are counted both as system calls and as misses.
//! - [`begin_steady_state`] starts the steady-state counters (after warm-up).
//!
//! The state lives in one static ([`STATE`]); [`PoolAlloc`] is the zero-sized
//! handle a binary installs with `#[global_allocator]`. Tests drive a private
//! [`PoolState`] directly.

use core::alloc::{GlobalAlloc, Layout};
use core::cell::UnsafeCell;
use core::ptr;
use core::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering};
use std::alloc::System;

use crate::msg::AllocCounters;

/// Size (and alignment) of a pool block: holds the 48 B iceoryx2 loan state
/// with room to spare, at cache-line alignment.
pub const BLOCK_BYTES: usize = 64;

/// Pool blocks reserved at start-up: 64 KiB. A loan's block is freed when its
/// sample is sent, so fewer than 10 are ever in use at once; the margin
/// covers any other small steady-state request of the service thread.
pub const POOL_BLOCKS: usize = 1024;

/// Allocator state: pool, free list and counters.
pub struct PoolState {
    /// Token of the watched thread (0: none).
    watched: AtomicUsize,
    /// Start of the pool region (null until reserved).
    base: AtomicPtr<u8>,
    blocks: AtomicUsize,
    /// Spin lock over `free`.
    lock: AtomicBool,
    /// Head of the intrusive free list (each free block stores the next pointer).
    free: UnsafeCell<*mut u8>,
    steady: AtomicBool,
    /// The steady state began and ended.
    ended: AtomicBool,
    sys_allocs_total: AtomicU64,
    sys_allocs_steady: AtomicU64,
    sys_frees_steady: AtomicU64,
    pool_allocs_steady: AtomicU64,
    pool_in_use: AtomicU64,
    pool_high_water: AtomicU64,
    pool_misses: AtomicU64,
}

// SAFETY: `free` is only touched while `lock` is held; everything else is atomic.
unsafe impl Sync for PoolState {}
// SAFETY: the raw pointers point into the process-wide pool, not thread-local data.
unsafe impl Send for PoolState {}

impl PoolState {
    /// Empty state: no pool, nothing watched.
    pub const fn new() -> Self {
        Self {
            watched: AtomicUsize::new(0),
            base: AtomicPtr::new(ptr::null_mut()),
            blocks: AtomicUsize::new(0),
            lock: AtomicBool::new(false),
            free: UnsafeCell::new(ptr::null_mut()),
            steady: AtomicBool::new(false),
            ended: AtomicBool::new(false),
            sys_allocs_total: AtomicU64::new(0),
            sys_allocs_steady: AtomicU64::new(0),
            sys_frees_steady: AtomicU64::new(0),
            pool_allocs_steady: AtomicU64::new(0),
            pool_in_use: AtomicU64::new(0),
            pool_high_water: AtomicU64::new(0),
            pool_misses: AtomicU64::new(0),
        }
    }

    /// Makes the calling thread the watched one.
    pub fn watch_this_thread(&self) {
        self.watched.store(thread_token(), Ordering::SeqCst);
    }

    /// Carves the pool (once; later calls do nothing). Returns whether a pool exists.
    pub fn reserve(&self, blocks: usize) -> bool {
        if !self.base.load(Ordering::Acquire).is_null() {
            return true;
        }
        let Ok(layout) = Layout::from_size_align(BLOCK_BYTES * blocks.max(1), BLOCK_BYTES) else {
            return false;
        };
        // SAFETY: non-zero size, valid alignment.
        let base = unsafe { System.alloc(layout) };
        if base.is_null() {
            return false;
        }
        self.lock();
        // SAFETY: lock held; the region is ours and each block is large and
        // aligned enough to hold a pointer.
        unsafe {
            let mut head: *mut u8 = ptr::null_mut();
            for i in (0..blocks.max(1)).rev() {
                let b = base.add(i * BLOCK_BYTES);
                (b as *mut *mut u8).write(head);
                head = b;
            }
            *self.free.get() = head;
        }
        self.blocks.store(blocks.max(1), Ordering::Release);
        self.base.store(base, Ordering::Release);
        self.unlock();
        true
    }

    /// Starts the steady-state counters.
    pub fn begin_steady_state(&self) {
        self.steady.store(true, Ordering::SeqCst);
    }

    /// Ends the steady state (before tear-down, which allocates and frees
    /// by design); the steady counters keep their values.
    pub fn end_steady_state(&self) {
        if self.steady.swap(false, Ordering::SeqCst) {
            self.ended.store(true, Ordering::SeqCst);
        }
    }

    /// The counters now.
    pub fn counters(&self) -> AllocCounters {
        AllocCounters {
            sys_allocs_total: self.sys_allocs_total.load(Ordering::Relaxed),
            sys_allocs_steady: self.sys_allocs_steady.load(Ordering::Relaxed),
            sys_frees_steady: self.sys_frees_steady.load(Ordering::Relaxed),
            pool_allocs_steady: self.pool_allocs_steady.load(Ordering::Relaxed),
            pool_high_water: self.pool_high_water.load(Ordering::Relaxed),
            pool_capacity: self.blocks.load(Ordering::Relaxed) as u64,
            pool_misses: self.pool_misses.load(Ordering::Relaxed),
            steady: u64::from(self.steady.load(Ordering::Relaxed) || self.ended.load(Ordering::Relaxed)),
        }
    }

    #[inline]
    fn lock(&self) {
        while self
            .lock
            .compare_exchange_weak(false, true, Ordering::Acquire, Ordering::Relaxed)
            .is_err()
        {
            core::hint::spin_loop();
        }
    }

    #[inline]
    fn unlock(&self) {
        self.lock.store(false, Ordering::Release);
    }

    #[inline]
    fn in_pool(&self, p: *mut u8) -> bool {
        let base = self.base.load(Ordering::Acquire);
        if base.is_null() {
            return false;
        }
        let start = base as usize;
        let end = start + self.blocks.load(Ordering::Acquire) * BLOCK_BYTES;
        (start..end).contains(&(p as usize))
    }

    #[inline]
    fn is_watched(&self) -> bool {
        let w = self.watched.load(Ordering::Relaxed);
        w != 0 && w == thread_token()
    }

    fn pool_take(&self) -> *mut u8 {
        self.lock();
        // SAFETY: lock held; every block on the list stores the next pointer.
        let b = unsafe {
            let head = *self.free.get();
            if !head.is_null() {
                *self.free.get() = (head as *mut *mut u8).read();
            }
            head
        };
        self.unlock();
        if !b.is_null() {
            let n = self.pool_in_use.fetch_add(1, Ordering::Relaxed) + 1;
            self.pool_high_water.fetch_max(n, Ordering::Relaxed);
        }
        b
    }

    fn pool_give(&self, b: *mut u8) {
        self.lock();
        // SAFETY: lock held; `b` is a block of the pool no longer in use.
        unsafe {
            (b as *mut *mut u8).write(*self.free.get());
            *self.free.get() = b;
        }
        self.unlock();
        self.pool_in_use.fetch_sub(1, Ordering::Relaxed);
    }

    fn count_sys_alloc(&self) {
        self.sys_allocs_total.fetch_add(1, Ordering::Relaxed);
        if self.steady.load(Ordering::Relaxed) {
            self.sys_allocs_steady.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// `GlobalAlloc::alloc` on this state.
    ///
    /// # Safety
    /// As `GlobalAlloc::alloc`.
    pub unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if self.is_watched() {
            if layout.size() <= BLOCK_BYTES
                && layout.align() <= BLOCK_BYTES
                && !self.base.load(Ordering::Relaxed).is_null()
            {
                let b = self.pool_take();
                if !b.is_null() {
                    if self.steady.load(Ordering::Relaxed) {
                        self.pool_allocs_steady.fetch_add(1, Ordering::Relaxed);
                    }
                    return b;
                }
            }
            if self.steady.load(Ordering::Relaxed) {
                self.pool_misses.fetch_add(1, Ordering::Relaxed);
            }
            self.count_sys_alloc();
        }
        // SAFETY: forwarded contract.
        unsafe { System.alloc(layout) }
    }

    /// `GlobalAlloc::dealloc` on this state.
    ///
    /// # Safety
    /// As `GlobalAlloc::dealloc`.
    pub unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        if self.in_pool(p) {
            self.pool_give(p);
            return;
        }
        if self.is_watched() && self.steady.load(Ordering::Relaxed) {
            self.sys_frees_steady.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: `p` did not come from the pool, so it came from System.
        unsafe { System.dealloc(p, layout) }
    }

    /// `GlobalAlloc::realloc` on this state.
    ///
    /// # Safety
    /// As `GlobalAlloc::realloc`.
    pub unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if self.in_pool(p) {
            if new_size <= BLOCK_BYTES {
                return p;
            }
            // SAFETY: the new layout is valid (GlobalAlloc::realloc contract).
            let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
            // SAFETY: forwarded contract; copy the old contents, then free the block.
            unsafe {
                let q = self.alloc(new_layout);
                if !q.is_null() {
                    ptr::copy_nonoverlapping(p, q, layout.size());
                    self.pool_give(p);
                }
                return q;
            }
        }
        if self.is_watched() {
            self.count_sys_alloc();
        }
        // SAFETY: `p` came from System.
        unsafe { System.realloc(p, layout, new_size) }
    }
}

impl Default for PoolState {
    fn default() -> Self {
        Self::new()
    }
}

/// A per-thread identity that needs no allocation: the address of a
/// thread-local byte (distinct for every live thread).
#[inline]
fn thread_token() -> usize {
    thread_local! {
        static MARK: u8 = const { 0 };
    }
    MARK.try_with(|m| m as *const u8 as usize).unwrap_or(0)
}

/// The process-wide state behind [`PoolAlloc`].
pub static STATE: PoolState = PoolState::new();

/// Zero-sized global allocator handle over [`STATE`]. Install in a binary:
/// `#[global_allocator] static A: planner::service::alloc::PoolAlloc = PoolAlloc;`
pub struct PoolAlloc;

// SAFETY: forwards to PoolState, which upholds the GlobalAlloc contract by
// returning either System's memory or exclusive, aligned pool blocks.
unsafe impl GlobalAlloc for PoolAlloc {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded.
        unsafe { STATE.alloc(layout) }
    }
    #[inline]
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        // SAFETY: forwarded.
        unsafe { STATE.dealloc(p, layout) }
    }
    #[inline]
    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded.
        unsafe { STATE.realloc(p, layout, new_size) }
    }
}

/// Whether this process runs on [`PoolAlloc`] (a binary sets this when it
/// installs it, so the service can tell counted zeros from "not measured").
pub static INSTALLED: AtomicBool = AtomicBool::new(false);

/// Marks [`PoolAlloc`] as the global allocator of this process (call first in `main`).
pub fn mark_installed() {
    INSTALLED.store(true, Ordering::SeqCst);
}

/// Whether [`mark_installed`] was called.
pub fn installed() -> bool {
    INSTALLED.load(Ordering::SeqCst)
}

/// Watches the calling thread (see module docs).
pub fn watch_this_thread() {
    STATE.watch_this_thread();
}

/// Reserves the pool of [`POOL_BLOCKS`] blocks.
pub fn reserve_pool() -> bool {
    STATE.reserve(POOL_BLOCKS)
}

/// Starts the steady-state counters.
pub fn begin_steady_state() {
    STATE.begin_steady_state();
}

/// Ends the steady state (see [`PoolState::end_steady_state`]).
pub fn end_steady_state() {
    STATE.end_steady_state();
}

/// The counters now.
pub fn counters() -> AllocCounters {
    STATE.counters()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn l(size: usize) -> Layout {
        Layout::from_size_align(size, 8).unwrap()
    }

    #[test]
    fn watched_small_blocks_come_from_the_pool_and_are_counted_separately() {
        let s = PoolState::new();
        s.watch_this_thread();
        assert!(s.reserve(4));
        s.begin_steady_state();
        unsafe {
            let a = s.alloc(l(48));
            let b = s.alloc(l(48));
            assert!(s.in_pool(a) && s.in_pool(b) && a != b);
            s.dealloc(a, l(48));
            s.dealloc(b, l(48));
            let big = s.alloc(l(4096));
            assert!(!s.in_pool(big));
            s.dealloc(big, l(4096));
        }
        s.end_steady_state();
        unsafe {
            let after = s.alloc(l(4096));
            s.dealloc(after, l(4096));
        }
        let c = s.counters();
        assert_eq!(c.steady, 1, "the counters still say a steady state was measured");
        assert_eq!(c.pool_allocs_steady, 2);
        assert_eq!(c.pool_high_water, 2);
        assert_eq!(c.sys_allocs_steady, 1, "the 4 KiB block went to the system allocator");
        assert_eq!(c.sys_frees_steady, 1);
        assert_eq!(c.pool_misses, 1, "misses count in steady state only");
        assert_eq!(c.pool_capacity, 4);
    }

    #[test]
    fn an_exhausted_pool_falls_back_to_the_system_and_says_so() {
        let s = PoolState::new();
        s.watch_this_thread();
        s.reserve(1);
        s.begin_steady_state();
        unsafe {
            let a = s.alloc(l(16));
            let b = s.alloc(l(16));
            assert!(s.in_pool(a));
            assert!(!s.in_pool(b));
            s.dealloc(b, l(16));
            s.dealloc(a, l(16));
            // Freed block is reused.
            let c = s.alloc(l(16));
            assert_eq!(c, a);
            s.dealloc(c, l(16));
        }
        let c = s.counters();
        assert_eq!(c.pool_misses, 1);
        assert_eq!(c.sys_allocs_steady, 1);
        assert_eq!(c.pool_allocs_steady, 2);
    }

    #[test]
    fn other_threads_are_neither_counted_nor_pooled_but_may_free_pool_blocks() {
        let s = std::sync::Arc::new(PoolState::new());
        s.watch_this_thread();
        s.reserve(8);
        s.begin_steady_state();
        let block = unsafe { s.alloc(l(32)) } as usize;
        let s2 = s.clone();
        std::thread::spawn(move || unsafe {
            let p = s2.alloc(l(32));
            assert!(!s2.in_pool(p));
            s2.dealloc(p, l(32));
            s2.dealloc(block as *mut u8, l(32));
        })
        .join()
        .unwrap();
        let c = s.counters();
        assert_eq!(c.sys_allocs_steady, 0);
        assert_eq!(c.pool_allocs_steady, 1);
        assert_eq!(s.pool_in_use.load(Ordering::Relaxed), 0);
    }

    #[test]
    fn realloc_out_of_the_pool_keeps_the_contents() {
        let s = PoolState::new();
        s.watch_this_thread();
        s.reserve(2);
        unsafe {
            let a = s.alloc(l(8));
            a.write_bytes(7, 8);
            let same = s.realloc(a, l(8), 40);
            assert_eq!(same, a);
            let big = s.realloc(a, l(40), 200);
            assert!(!s.in_pool(big));
            assert_eq!(*big.add(7), 7);
            s.dealloc(big, l(200));
        }
        assert_eq!(s.pool_in_use.load(Ordering::Relaxed), 0);
    }
}
