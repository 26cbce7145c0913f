//! The planner binary's global allocator: counts the service thread's calls
//! into the system allocator and serves its small blocks from a pool reserved
//! at start-up.
//!
//! Why a pool: iceoryx2 0.10's `Publisher::loan_uninit` allocates one 48 B
//! `Rc` per call (measured, see `ipc-NOTES`; 0.9.3 did not), and connecting a
//! restarted peer allocates about 50 blocks of 65–512 B (measured on the
//! service thread after vehicle restarts). The planner must run without
//! calling the system allocator in steady state, so blocks requested by the
//! *watched* thread come from a fixed pool carved once by [`reserve_pool`],
//! in the size classes of [`POOL_CLASSES`]. Nothing is hidden: pool blocks
//! are counted separately ([`AllocCounters`] `pool_allocs_steady`,
//! high-water mark, misses) and published with the system-allocator counts.
//!
//! Contract:
//! - Only the thread that called [`watch_this_thread`] is counted and pooled;
//!   other threads (progress bar, log writer) go straight to the system
//!   allocator, uncounted.
//! - A request takes a block of the smallest class that fits and has one
//!   free, else of a larger class.
//! - A pool block is returned to its class whichever thread frees it. No
//!   locks: the watched thread (SCHED_FIFO in the service) must never spin
//!   on a lock held by a preempted thread of lower priority. Its own frees go
//!   to its class's free list; other threads push theirs onto the class's
//!   lock-free remote list, which the watched thread takes over whole when
//!   its own list runs dry.
//! - Requests the pool cannot serve (larger than the largest class,
//!   over-aligned, no block left) go to the system allocator and are counted
//!   both as system calls and as misses.
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

use auv_messages::msg::AllocCounters;

/// Alignment of every pool block (class sizes are multiples of it).
pub const BLOCK_ALIGN: usize = 64;

/// Pool size classes, smallest first: (block bytes, blocks reserved); 320
/// KiB in all. 64 B: the loan state of every publish (fewer than 10 in use
/// at once) with margin for other small requests. 128–512 B: a restarted
/// peer's connection (about 50 blocks each; the dead peer's are freed when
/// its node is cleaned up), room for several restarts in flight.
pub const POOL_CLASSES: [(usize, usize); 4] = [(64, 1024), (128, 512), (256, 512), (512, 128)];

/// Most size classes a [`PoolState`] holds.
const MAX_CLASSES: usize = POOL_CLASSES.len();

/// One size class: its blocks' size, its address range inside the pool and
/// its free lists (intrusive: each free block stores the next pointer).
struct Class {
    bytes: AtomicUsize,
    start: AtomicUsize,
    end: AtomicUsize,
    /// Blocks freed by the watched thread (or never used); only the watched
    /// thread touches it.
    free: UnsafeCell<*mut u8>,
    /// Blocks freed by other threads: pushed with compare-and-swap, taken
    /// whole (a swap to null) by the watched thread, so no ABA.
    remote: AtomicPtr<u8>,
}

impl Class {
    const fn new() -> Self {
        Self {
            bytes: AtomicUsize::new(0),
            start: AtomicUsize::new(0),
            end: AtomicUsize::new(0),
            free: UnsafeCell::new(ptr::null_mut()),
            remote: AtomicPtr::new(ptr::null_mut()),
        }
    }

    fn holds(&self, p: usize) -> bool {
        (self.start.load(Ordering::Acquire)..self.end.load(Ordering::Acquire)).contains(&p)
    }
}

/// Allocator state: pool, free list and counters.
pub struct PoolState {
    /// Token of the watched thread (0: none).
    watched: AtomicUsize,
    /// Start of the pool region (null until reserved).
    base: AtomicPtr<u8>,
    /// Bytes of the pool region.
    bytes: AtomicUsize,
    /// Blocks of all classes.
    blocks: AtomicUsize,
    classes: [Class; MAX_CLASSES],
    /// Classes in use (a prefix of `classes`).
    class_count: AtomicUsize,
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

// SAFETY: each class's `free` list is only touched by the watched thread (and
// by `reserve` before anything is handed out); everything else is atomic.
unsafe impl Sync for PoolState {}
// SAFETY: the raw pointers point into the process-wide pool, not thread-local data.
unsafe impl Send for PoolState {}

impl PoolState {
    /// Empty state: no pool, nothing watched.
    pub const fn new() -> Self {
        Self {
            watched: AtomicUsize::new(0),
            base: AtomicPtr::new(ptr::null_mut()),
            bytes: AtomicUsize::new(0),
            blocks: AtomicUsize::new(0),
            classes: [const { Class::new() }; MAX_CLASSES],
            class_count: AtomicUsize::new(0),
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

    /// Carves the pool (once; later calls do nothing) in `classes` (block
    /// bytes, blocks), smallest block first, each size a multiple of
    /// [`BLOCK_ALIGN`]; at most [`POOL_CLASSES`]`.len()` classes. Returns
    /// whether a pool exists.
    pub fn reserve(&self, classes: &[(usize, usize)]) -> bool {
        if !self.base.load(Ordering::Acquire).is_null() {
            return true;
        }
        let valid = !classes.is_empty()
            && classes.len() <= MAX_CLASSES
            && classes
                .iter()
                .all(|&(b, n)| b > 0 && b.is_multiple_of(BLOCK_ALIGN) && n > 0)
            && classes.windows(2).all(|w| w[0].0 < w[1].0);
        if !valid {
            return false;
        }
        let total: usize = classes.iter().map(|&(b, n)| b * n).sum();
        let Ok(layout) = Layout::from_size_align(total, BLOCK_ALIGN) else {
            return false;
        };
        // SAFETY: non-zero size, valid alignment.
        let base = unsafe { System.alloc(layout) };
        if base.is_null() {
            return false;
        }
        let mut offset = 0;
        for (class, &(bytes, blocks)) in self.classes.iter().zip(classes) {
            // SAFETY: nothing is handed out before `base` is published below;
            // the region is ours, and each block lies inside it, aligned and
            // large enough to hold a pointer.
            unsafe {
                let start = base.add(offset);
                let mut head: *mut u8 = ptr::null_mut();
                for i in (0..blocks).rev() {
                    let b = start.add(i * bytes);
                    (b as *mut *mut u8).write(head);
                    head = b;
                }
                *class.free.get() = head;
                class.bytes.store(bytes, Ordering::Release);
                class.start.store(start as usize, Ordering::Release);
                class.end.store(start as usize + bytes * blocks, Ordering::Release);
            }
            offset += bytes * blocks;
        }
        self.class_count.store(classes.len(), Ordering::Release);
        self.blocks
            .store(classes.iter().map(|&(_, n)| n).sum(), Ordering::Release);
        self.bytes.store(total, Ordering::Release);
        self.base.store(base, Ordering::Release);
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
    fn in_pool(&self, p: *mut u8) -> bool {
        let base = self.base.load(Ordering::Acquire);
        if base.is_null() {
            return false;
        }
        let start = base as usize;
        (start..start + self.bytes.load(Ordering::Acquire)).contains(&(p as usize))
    }

    /// The classes in use.
    fn classes(&self) -> &[Class] {
        &self.classes[..self.class_count.load(Ordering::Acquire)]
    }

    /// The class of a pool block (None for memory outside the pool).
    fn class_of(&self, p: *mut u8) -> Option<&Class> {
        if !self.in_pool(p) {
            return None;
        }
        self.classes().iter().find(|c| c.holds(p as usize))
    }

    #[inline]
    fn is_watched(&self) -> bool {
        let w = self.watched.load(Ordering::Relaxed);
        w != 0 && w == thread_token()
    }

    /// A block of at least `size` bytes: of the smallest class that fits
    /// and has one free (null if none). Watched thread only.
    fn pool_take(&self, size: usize) -> *mut u8 {
        let mut b = ptr::null_mut();
        for class in self.classes() {
            if class.bytes.load(Ordering::Relaxed) < size {
                continue;
            }
            // SAFETY: only the watched thread touches `free`; every block on
            // either list stores the next pointer (the remote list's pushes
            // are published by the Release of their CAS, taken by this Acquire).
            unsafe {
                let mut head = *class.free.get();
                if head.is_null() {
                    head = class.remote.swap(ptr::null_mut(), Ordering::Acquire);
                }
                if !head.is_null() {
                    *class.free.get() = (head as *mut *mut u8).read();
                    b = head;
                    break;
                }
            }
        }
        if !b.is_null() {
            let n = self.pool_in_use.fetch_add(1, Ordering::Relaxed) + 1;
            self.pool_high_water.fetch_max(n, Ordering::Relaxed);
        }
        b
    }

    /// Returns block `b` of `class`: onto its own list from the watched
    /// thread, onto the remote list from any other.
    fn pool_give(&self, class: &Class, b: *mut u8) {
        if self.is_watched() {
            // SAFETY: only the watched thread touches `free`; `b` is a block
            // of this class no longer in use.
            unsafe {
                (b as *mut *mut u8).write(*class.free.get());
                *class.free.get() = b;
            }
        } else {
            let mut head = class.remote.load(Ordering::Relaxed);
            loop {
                // SAFETY: `b` is a block of this class no longer in use, ours to write.
                unsafe { (b as *mut *mut u8).write(head) };
                match class
                    .remote
                    .compare_exchange_weak(head, b, Ordering::Release, Ordering::Relaxed)
                {
                    Ok(_) => break,
                    Err(now) => head = now,
                }
            }
        }
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
        // SAFETY: forwarded contract.
        unsafe { self.alloc_maybe_zeroed(layout, false) }
    }

    /// `GlobalAlloc::alloc_zeroed` on this state: System's own zeroed
    /// allocation outside the pool, so a large zeroed buffer (a snapshot's
    /// edge buffer) stays untouched pages until it is written, instead of
    /// being zeroed byte by byte.
    ///
    /// # Safety
    /// As `GlobalAlloc::alloc_zeroed`.
    pub unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded contract.
        unsafe { self.alloc_maybe_zeroed(layout, true) }
    }

    /// # Safety
    /// As `GlobalAlloc::alloc`.
    unsafe fn alloc_maybe_zeroed(&self, layout: Layout, zeroed: bool) -> *mut u8 {
        if self.is_watched() {
            if layout.align() <= BLOCK_ALIGN && !self.base.load(Ordering::Relaxed).is_null() {
                let b = self.pool_take(layout.size());
                if !b.is_null() {
                    if self.steady.load(Ordering::Relaxed) {
                        self.pool_allocs_steady.fetch_add(1, Ordering::Relaxed);
                    }
                    if zeroed {
                        // SAFETY: the block holds at least `layout.size()` bytes.
                        unsafe { core::ptr::write_bytes(b, 0, layout.size()) };
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
        unsafe {
            if zeroed {
                System.alloc_zeroed(layout)
            } else {
                System.alloc(layout)
            }
        }
    }

    /// `GlobalAlloc::dealloc` on this state.
    ///
    /// # Safety
    /// As `GlobalAlloc::dealloc`.
    pub unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        if let Some(class) = self.class_of(p) {
            self.pool_give(class, p);
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
        if let Some(class) = self.class_of(p) {
            if new_size <= class.bytes.load(Ordering::Relaxed) {
                return p;
            }
            // SAFETY: the new layout is valid (GlobalAlloc::realloc contract).
            let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
            // SAFETY: forwarded contract; copy the old contents, then free the block.
            unsafe {
                let q = self.alloc(new_layout);
                if !q.is_null() {
                    ptr::copy_nonoverlapping(p, q, layout.size().min(new_size));
                    self.pool_give(class, p);
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
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded.
        unsafe { STATE.alloc_zeroed(layout) }
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

/// Reserves the pool in the classes of [`POOL_CLASSES`].
pub fn reserve_pool() -> bool {
    STATE.reserve(&POOL_CLASSES)
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
        assert!(s.reserve(&[(64, 4)]));
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
    fn zeroed_blocks_are_zero_from_the_pool_and_from_the_system() {
        let s = PoolState::new();
        s.watch_this_thread();
        assert!(s.reserve(&[(64, 1)]));
        unsafe {
            // A used pool block, written to, comes back zeroed.
            let a = s.alloc(l(64));
            core::ptr::write_bytes(a, 0xAB, 64);
            s.dealloc(a, l(64));
            let z = s.alloc_zeroed(l(64));
            assert!(s.in_pool(z));
            assert!(core::slice::from_raw_parts(z, 64).iter().all(|&b| b == 0));
            // Beyond the pool: System's zeroed memory.
            let big = s.alloc_zeroed(l(1 << 20));
            assert!(!s.in_pool(big));
            assert!(core::slice::from_raw_parts(big, 1 << 20).iter().all(|&b| b == 0));
            s.dealloc(big, l(1 << 20));
            s.dealloc(z, l(64));
        }
    }

    #[test]
    fn an_exhausted_pool_falls_back_to_the_system_and_says_so() {
        let s = PoolState::new();
        s.watch_this_thread();
        s.reserve(&[(64, 1)]);
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
        s.reserve(&[(64, 1)]);
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
        // The block freed by the other thread serves the watched one again.
        let again = unsafe { s.alloc(l(32)) };
        assert_eq!(again as usize, block);
        unsafe { s.dealloc(again, l(32)) };
        let c = s.counters();
        assert_eq!(c.sys_allocs_steady, 0);
        assert_eq!(c.pool_allocs_steady, 2);
        assert_eq!(c.pool_misses, 0);
        assert_eq!(s.pool_in_use.load(Ordering::Relaxed), 0);
    }

    #[test]
    fn blocks_freed_by_many_threads_at_once_all_come_back() {
        const BLOCKS: usize = 64;
        let s = std::sync::Arc::new(PoolState::new());
        s.watch_this_thread();
        s.reserve(&[(64, BLOCKS)]);
        for _round in 0..20 {
            let blocks: Vec<usize> = (0..BLOCKS).map(|_| unsafe { s.alloc(l(64)) } as usize).collect();
            assert!(blocks.iter().all(|&b| s.in_pool(b as *mut u8)));
            let handles: Vec<_> = blocks
                .chunks(BLOCKS / 4)
                .map(|chunk| {
                    let (s, chunk) = (s.clone(), chunk.to_vec());
                    std::thread::spawn(move || {
                        for b in chunk {
                            unsafe { s.dealloc(b as *mut u8, l(64)) };
                        }
                    })
                })
                .collect();
            for h in handles {
                h.join().unwrap();
            }
            assert_eq!(s.pool_in_use.load(Ordering::Relaxed), 0);
        }
        assert_eq!(s.counters().pool_high_water, BLOCKS as u64);
        assert_eq!(s.counters().sys_allocs_total, 0, "every round was served by the pool");
    }

    #[test]
    fn realloc_out_of_the_pool_keeps_the_contents() {
        let s = PoolState::new();
        s.watch_this_thread();
        s.reserve(&[(64, 2)]);
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

    #[test]
    fn each_request_takes_the_smallest_class_with_a_free_block() {
        let s = PoolState::new();
        s.watch_this_thread();
        assert!(s.reserve(&[(64, 1), (256, 1), (512, 1)]));
        s.begin_steady_state();
        unsafe {
            let small = s.alloc(l(48));
            let mid = s.alloc(l(200));
            // 256 B is taken: the next 200 B request moves up a class.
            let up = s.alloc(l(200));
            let none = s.alloc(l(100));
            let big = s.alloc(l(513));
            assert_eq!(s.class_of(small).map(|c| c.bytes.load(Ordering::Relaxed)), Some(64));
            assert_eq!(s.class_of(mid).map(|c| c.bytes.load(Ordering::Relaxed)), Some(256));
            assert_eq!(s.class_of(up).map(|c| c.bytes.load(Ordering::Relaxed)), Some(512));
            assert!(!s.in_pool(none) && !s.in_pool(big));
            // Blocks go back to their own class: the next 200 B request gets `mid` again.
            s.dealloc(mid, l(200));
            let again = s.alloc(l(200));
            assert_eq!(again, mid);
            // Growing inside its block keeps it; past it, the block moves.
            mid.write_bytes(9, 200);
            assert_eq!(s.realloc(mid, l(200), 256), mid);
            s.dealloc(up, l(200));
            let moved = s.realloc(mid, l(256), 300);
            assert_eq!(moved, up, "the 512 B block was free again");
            assert_eq!(*moved.add(199), 9);
            for (p, size) in [(small, 48), (moved, 300), (none, 100), (big, 513)] {
                s.dealloc(p, l(size));
            }
        }
        let c = s.counters();
        assert_eq!(c.pool_capacity, 3);
        assert_eq!(c.pool_high_water, 3);
        assert_eq!(c.pool_misses, 2);
        assert_eq!(c.sys_allocs_steady, 2);
        assert_eq!(s.pool_in_use.load(Ordering::Relaxed), 0);
    }

    #[test]
    fn a_bad_class_list_reserves_nothing() {
        for classes in [&[][..], &[(48, 4)], &[(128, 4), (64, 4)], &[(64, 0)]] {
            let s = PoolState::new();
            assert!(!s.reserve(classes), "{classes:?}");
            assert_eq!(s.counters().pool_capacity, 0);
        }
        let s = PoolState::new();
        assert!(s.reserve(&POOL_CLASSES));
        assert_eq!(s.counters().pool_capacity, 2176);
    }
}
