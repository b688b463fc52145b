//! The system's pages of freshly allocated arrays, mapped in one call instead of one page
//! fault each (issue 20, session 42).
//!
//! A grid hierarchy's arrays, when they are first allocated (a process's or a thread's
//! first solve on a grid), lie on pages the process has never touched: the system maps
//! each one on its first write, a page fault per 4 KiB. At 128 × 32 that is ~110 faults,
//! ~1.7 µs each on the 2-core VM of BENCHMARKS.md (a fresh state's solve: 0.32 ms cold
//! against 0.06 ms once its arrays exist). `MADV_POPULATE_WRITE` (Linux 5.14) maps a range's
//! pages in one system call, ~1.1 µs per page there, the same zero pages. Pages already
//! mapped (memory the allocator had, e.g. after the lanes' calibration freed its solver)
//! are skipped by asking `mincore` first: asked again, they cost about as much as the faults
//! saved. The values in the arrays are not changed: this only decides when the system
//! does its part.

/// Size of a page as the mapping is done, bytes (x86-64 and aarch64 Linux: 4 KiB; a larger
/// page only makes a range's rounded ends cover more than needed, never less).
const PAGE: usize = 4096;

/// The byte range `[start, end)` of `v`'s allocation (its capacity, not only its length;
/// empty for an unallocated vector).
pub(crate) fn range_of<T>(v: &Vec<T>) -> (usize, usize) {
    let start = v.as_ptr() as usize;
    (start, start + v.capacity() * std::mem::size_of::<T>())
}

/// Maps the pages of `ranges` (byte ranges `[start, end)` of live allocations, in any
/// order; empty ones ignored) for writing, in one system call per run of ranges that lie
/// within a page of each other (the arrays of one allocation burst sit end to end, a
/// header apart). Sorts `ranges`. Returns whether the system did it (false: not Linux, or
/// a kernel without `MADV_POPULATE_WRITE`; the pages are then mapped by their first
/// writes, as without this call). Only pages `mincore` does not report mapped are asked
/// for (all of them where it fails).
pub(crate) fn populate(ranges: &mut [(usize, usize)]) -> bool {
    ranges.sort_unstable();
    let mut done = true;
    let mut run: Option<(usize, usize)> = None;
    for &(start, end) in ranges.iter().filter(|r| r.1 > r.0) {
        match run {
            Some((a, b)) if start <= b + PAGE => run = Some((a, b.max(end))),
            _ => {
                if let Some((a, b)) = run {
                    done &= populate_run(a, b);
                }
                run = Some((start, end));
            }
        }
    }
    if let Some((a, b)) = run {
        done &= populate_run(a, b);
    }
    done
}

/// One run: its pages from the one holding `start` to the one holding `end − 1`. The gap
/// between two arrays of a run belongs to the allocator (a chunk header): mapping it for
/// writing changes nothing there either.
#[cfg(target_os = "linux")]
fn populate_run(start: usize, end: usize) -> bool {
    let first = start & !(PAGE - 1);
    let last = (end + PAGE - 1) & !(PAGE - 1);
    let mut done = true;
    let mut at = first;
    while at < last {
        let pages = ((last - at) / PAGE).min(RESIDENT_CHUNK);
        let mut resident = [0u8; RESIDENT_CHUNK];
        // SAFETY: `[at, at + pages·PAGE)` lies in `[first, last)`, pages of the process's
        // own heap allocations (live `Vec`s, see `populate`); `mincore` writes one byte per
        // page into `resident`, which has room for `RESIDENT_CHUNK`.
        let known =
            unsafe { libc::mincore(at as *mut libc::c_void, pages * PAGE, resident.as_mut_ptr()) }
                == 0;
        // Only the pages not yet mapped: asking again for mapped ones costs as much as
        // the faults saved where the allocator hands out memory it already had (a solver
        // after the lanes' calibration; issue 20, session 42).
        let mut k = 0;
        while k < pages {
            if known && resident[k] & 1 == 1 {
                k += 1;
                continue;
            }
            let from = k;
            while k < pages && !(known && resident[k] & 1 == 1) {
                k += 1;
            }
            // SAFETY: as above; MADV_POPULATE_WRITE only maps the pages (as a write would,
            // without writing) and never changes their contents.
            done &= unsafe {
                libc::madvise(
                    (at + from * PAGE) as *mut libc::c_void,
                    (k - from) * PAGE,
                    libc::MADV_POPULATE_WRITE,
                )
            } == 0;
        }
        at += pages * PAGE;
    }
    done
}

/// Pages asked about per `mincore` call (its answer a byte each, on the stack).
#[cfg(target_os = "linux")]
const RESIDENT_CHUNK: usize = 256;

#[cfg(not(target_os = "linux"))]
fn populate_run(_start: usize, _end: usize) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// This thread's minor page faults so far (`/proc/thread-self/stat`, field 10: the
    /// test harness's other threads fault on their own), None where there is no such file.
    fn thread_faults() -> Option<u64> {
        let s = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
        let rest = &s[s.rfind(')')? + 2..];
        rest.split_whitespace().nth(7)?.parse().ok()
    }

    /// 64 pages mapped afresh (an anonymous mapping of their own, not the allocator's,
    /// whose heap may hand back pages it mapped before: the premise failed that way in a
    /// full `cargo test` run), or None where mapping fails.
    #[cfg(target_os = "linux")]
    fn fresh_pages(bytes: usize) -> Option<&'static mut [f64]> {
        // SAFETY: a new private anonymous mapping of `bytes`, read and written only as the
        // slice returned, and unmapped by `unmap` below.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if p == libc::MAP_FAILED {
            return None;
        }
        // SAFETY: the mapping is `bytes` long, page-aligned and zero-filled: valid f64s.
        Some(unsafe { std::slice::from_raw_parts_mut(p.cast::<f64>(), bytes / 8) })
    }

    #[cfg(target_os = "linux")]
    fn unmap(v: &mut [f64]) {
        // SAFETY: `v` is a whole mapping from `fresh_pages`, not used after this.
        unsafe { libc::munmap(v.as_mut_ptr().cast(), v.len() * 8) };
    }

    /// Fresh pages: once populated, writing every page costs at most a few faults, where
    /// unpopulated it costs one per page; the values written and read back are unchanged;
    /// empty and overlapping ranges are accepted.
    #[cfg(target_os = "linux")]
    #[test]
    fn populated_pages_take_no_faults_and_keep_their_values() {
        const BYTES: usize = 64 * PAGE;
        let (Some(fresh), Some(other)) = (fresh_pages(BYTES), fresh_pages(BYTES)) else {
            eprintln!("anonymous mapping failed: not tested");
            return;
        };
        let r = (fresh.as_ptr() as usize, fresh.as_ptr() as usize + BYTES);
        let mut ranges = [r, (r.0, r.0), (r.0 + 8, r.0 + 16), (0, 0)];
        let done = populate(&mut ranges);
        let count = |v: &mut [f64]| {
            let before = thread_faults();
            v.iter_mut().for_each(|x| *x = 1.5);
            Some(thread_faults()? - before?)
        };
        let (populated, plain) = (count(fresh), count(other));
        let values_kept = fresh.iter().all(|&x| x == 1.5) && other.iter().all(|&x| x == 1.5);
        unmap(fresh);
        unmap(other);
        assert!(values_kept, "values written and read back differ");
        let (Some(populated), Some(plain)) = (populated, plain) else {
            eprintln!("no /proc/thread-self/stat: faults not counted");
            return;
        };
        if !done {
            eprintln!("MADV_POPULATE_WRITE not done here (populated {populated}, plain {plain})");
            return;
        }
        // 64 pages: a fault per page unpopulated (fault-around is for files, not for
        // anonymous memory; transparent huge pages would map them at once, hence the
        // premise's half), at most 2 populated.
        assert!(
            populated <= 2,
            "faults writing populated pages: actual {populated}, expected <= 2 (unpopulated: {plain})"
        );
        assert!(
            plain >= 32,
            "faults writing fresh pages: actual {plain}, expected >= 32 of 64 (the premise)"
        );
    }
}
