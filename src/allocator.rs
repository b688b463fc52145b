//! The `bearing-sweep` binary's global allocator: the system allocator, until a batch
//! command switches new allocations to mimalloc ([`use_huge_pages`]).
//!
//! Why: a batch run stores tens of MB of samples, written once, one page after another.
//! From glibc's heap each 4 KiB page is a first-touch page fault (~16 000 on spin256,
//! ~43 ms of kernel time, ~7 % of the run); mimalloc backs its large reservations with
//! transparent huge pages, ~200 faults (BENCHMARKS.md "Issue 28, seventeenth pass").
//! Why not always: mimalloc keeps freed memory in its threads' heaps, where
//! `malloc_trim` cannot hand it back, and the service must give memory back after large
//! requests (`service::limits::trim_heap`, `tests/service_attack.rs`). So `serve`,
//! `worker` and everything else keep the system allocator; only the batch commands switch.
//!
//! Memory is always freed by the allocator that made it: once switched, a pointer is
//! mimalloc's exactly when it lies in mimalloc's page map (`mi_is_in_heap_region`, a
//! lookup), the rule mimalloc's own `free` override uses for foreign pointers.

use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::c_void;
use std::sync::atomic::{AtomicBool, Ordering};

use libmimalloc_sys as mi;

/// New allocations go to mimalloc (set once, never cleared).
static HUGE_PAGES: AtomicBool = AtomicBool::new(false);

/// From now on new allocations come from mimalloc (huge pages for large reservations);
/// memory allocated before stays the system allocator's and is freed by it. For batch
/// commands only (see the module's doc). Has an effect only in a binary whose global
/// allocator is [`Allocator`].
pub fn use_huge_pages() {
    HUGE_PAGES.store(true, Ordering::Release);
}

/// Whether [`use_huge_pages`] was called.
pub fn huge_pages() -> bool {
    HUGE_PAGES.load(Ordering::Acquire)
}

/// The global allocator of the `bearing-sweep` binary (declared in `src/main.rs`, and in
/// `benches/workloads.rs` so that its timings are the command's; the library itself
/// declares none).
pub struct Allocator;

impl Allocator {
    /// Whether `p` (allocated by this allocator) is mimalloc's.
    #[inline]
    fn is_mimalloc(p: *mut u8) -> bool {
        // Before the switch no pointer is mimalloc's (and its page map is never read).
        huge_pages() && unsafe { mi::mi_is_in_heap_region(p as *const c_void) }
    }
}

// SAFETY: each block is freed and resized by the allocator that made it (module doc);
// both allocators meet `GlobalAlloc`'s contract for size and alignment.
unsafe impl GlobalAlloc for Allocator {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if huge_pages() {
            mi::mi_malloc_aligned(layout.size(), layout.align()) as *mut u8
        } else {
            System.alloc(layout)
        }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if huge_pages() {
            mi::mi_zalloc_aligned(layout.size(), layout.align()) as *mut u8
        } else {
            System.alloc_zeroed(layout)
        }
    }

    #[inline]
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        if Self::is_mimalloc(p) {
            mi::mi_free(p as *mut c_void)
        } else {
            System.dealloc(p, layout)
        }
    }

    #[inline]
    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // A block stays with the allocator that made it.
        if Self::is_mimalloc(p) {
            mi::mi_realloc_aligned(p as *mut c_void, new_size, layout.align()) as *mut u8
        } else {
            System.realloc(p, layout, new_size)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of the system allocator made before the switch are still the system's
    /// after it (freed and resized by it), new ones are mimalloc's; every block keeps
    /// its contents through `realloc` and meets its alignment.
    #[test]
    fn blocks_stay_with_the_allocator_that_made_them_across_the_switch() {
        let a = Allocator;
        let layouts = [
            Layout::from_size_align(24, 8).unwrap(),
            Layout::from_size_align(8 << 10, 64).unwrap(),
            Layout::from_size_align(3 << 20, 4096).unwrap(),
        ];
        unsafe {
            // Only this test switches; other tests in this binary use the system
            // allocator directly (this type is not the test binary's global allocator).
            let before: Vec<*mut u8> = layouts.iter().map(|&l| a.alloc(l)).collect();
            for (&p, l) in before.iter().zip(&layouts) {
                assert!(!p.is_null() && (p as usize).is_multiple_of(l.align()));
                assert!(!mi::mi_is_in_heap_region(p as *const c_void));
                p.write_bytes(0xa5, l.size());
            }
            use_huge_pages();
            assert!(huge_pages());
            let after: Vec<*mut u8> = layouts.iter().map(|&l| a.alloc_zeroed(l)).collect();
            for (&p, l) in after.iter().zip(&layouts) {
                assert!(
                    !p.is_null() && (p as usize).is_multiple_of(l.align()),
                    "{l:?}"
                );
                assert!(Allocator::is_mimalloc(p), "{l:?} not from mimalloc");
                assert!(std::slice::from_raw_parts(p, l.size())
                    .iter()
                    .all(|&b| b == 0));
                p.write_bytes(0x5a, l.size());
            }
            for (&p, l) in before.iter().zip(&layouts) {
                assert!(
                    !Allocator::is_mimalloc(p),
                    "{l:?}: a system block taken for mimalloc's"
                );
                let q = a.realloc(p, *l, 2 * l.size());
                assert!(!q.is_null() && (q as usize).is_multiple_of(l.align()));
                assert!(!Allocator::is_mimalloc(q), "{l:?}: resized into mimalloc");
                assert!(std::slice::from_raw_parts(q, l.size())
                    .iter()
                    .all(|&b| b == 0xa5));
                a.dealloc(q, Layout::from_size_align(2 * l.size(), l.align()).unwrap());
            }
            for (&p, l) in after.iter().zip(&layouts) {
                let q = a.realloc(p, *l, 2 * l.size());
                assert!(!q.is_null() && (q as usize).is_multiple_of(l.align()));
                assert!(Allocator::is_mimalloc(q), "{l:?}: resized out of mimalloc");
                assert!(std::slice::from_raw_parts(q, l.size())
                    .iter()
                    .all(|&b| b == 0x5a));
                a.dealloc(q, Layout::from_size_align(2 * l.size(), l.align()).unwrap());
            }
        }
    }
}
