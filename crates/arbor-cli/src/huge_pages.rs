//! The command's allocator: the system's, with large blocks advised to use
//! transparent huge pages (Linux's `MADV_HUGEPAGE`).
//!
//! Why: a render or a trace touches tens of megabytes of fresh memory
//! (the model's text, its primitives, the structures' build buffers and
//! nodes, the film), and in a virtual machine each 4 KiB first touch is a
//! costly page fault; a 2 MiB page takes one fault where 512 were.
//! Measured in `docs/perf-log/2026-12-03-render-fixed-costs.md`. Elsewhere,
//! or where the kernel does not honour the advice, this is the system
//! allocator unchanged.

use std::alloc::{GlobalAlloc, Layout, System};

/// The size of a huge page, and the smallest block that is advised: a
/// smaller one could not hold a whole huge page.
const HUGE_PAGE: usize = 2 << 20;

/// The system allocator, advising blocks of at least [`HUGE_PAGE`] bytes to
/// use huge pages.
pub struct HugePageAlloc;

/// Advises the whole huge pages inside `[ptr, ptr + size)`.
fn advise(ptr: *mut u8, size: usize) {
    if size < HUGE_PAGE || ptr.is_null() {
        return;
    }
    let start = (ptr as usize).next_multiple_of(HUGE_PAGE);
    let end = (ptr as usize + size) / HUGE_PAGE * HUGE_PAGE;
    if end > start {
        // SAFETY: the range lies inside a block the allocator just handed
        // out; the advice changes how its pages are backed, never their
        // contents. A refusal (an old kernel, huge pages off) is harmless.
        #[cfg(target_os = "linux")]
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

/// The layout a block is really allocated with: a large one starts on a
/// huge page boundary, so all of it but its tail can be huge pages (a
/// system block starts 16 bytes past a page boundary, which would leave
/// up to a huge page unadvised at each end). The same layout for the same
/// request, so `dealloc` frees what `alloc` allocated.
fn real(layout: Layout) -> Layout {
    if layout.size() >= HUGE_PAGE {
        layout.align_to(HUGE_PAGE).unwrap_or(layout)
    } else {
        layout
    }
}

// SAFETY: every call is the system allocator's, with `real`'s layout for
// both ends of a block's life; `advise` only adds advice.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let ptr = unsafe { System.alloc(real(layout)) };
        advise(ptr, layout.size());
        ptr
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let ptr = unsafe { System.alloc_zeroed(real(layout)) };
        advise(ptr, layout.size());
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, real(layout)) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = real(layout);
        // SAFETY (of the layout): the caller guarantees `new_size` with
        // `layout`'s alignment is a valid layout.
        let new = real(unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) });
        if old.align() == new.align() {
            let ptr = unsafe { System.realloc(ptr, old, new_size) };
            advise(ptr, new_size);
            return ptr;
        }
        // The alignment changes across the threshold: move the block.
        let moved =
            unsafe { self.alloc(Layout::from_size_align_unchecked(new_size, layout.align())) };
        if !moved.is_null() {
            unsafe {
                std::ptr::copy_nonoverlapping(ptr, moved, layout.size().min(new_size));
                self.dealloc(ptr, layout);
            }
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    /// The `VmFlags` line of the mapping in `/proc/self/smaps` that holds
    /// address `at`.
    #[cfg(target_os = "linux")]
    fn vm_flags_of(at: usize) -> Option<String> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let range = |line: &str| {
            let (lo, hi) = line.split_once(' ')?.0.split_once('-')?;
            Some(usize::from_str_radix(lo, 16).ok()?..usize::from_str_radix(hi, 16).ok()?)
        };
        let mut inside = false;
        for line in smaps.lines() {
            if let Some(r) = range(line) {
                inside = r.contains(&at);
            } else if let Some(flags) = line.strip_prefix("VmFlags:").filter(|_| inside) {
                return Some(flags.to_string());
            }
        }
        None
    }

    /// The block of a large vector is advised: its mapping in
    /// `/proc/self/smaps` carries the `hg` flag (where the kernel has
    /// transparent huge pages at all); its contents survive growth.
    #[test]
    fn large_blocks_are_advised_and_keep_their_contents() {
        let mut v: Vec<u64> = (0..1_000_000).collect();
        v.reserve(3_000_000);
        assert!(v.iter().enumerate().all(|(i, &x)| x == i as u64));
        #[cfg(target_os = "linux")]
        if std::path::Path::new("/sys/kernel/mm/transparent_hugepage/enabled").exists() {
            let at = v.as_ptr() as usize + v.capacity() * 8 / 2;
            let flags = vm_flags_of(at).expect("the vector's mapping is in smaps");
            assert!(
                flags.split_whitespace().any(|f| f == "hg"),
                "flags: {flags}"
            );
        }
    }
}
