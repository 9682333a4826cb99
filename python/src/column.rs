//! Result columns in recycled memory. A column handed to NumPy is owned by
//! a small Python object; when NumPy lets go of the last array over it,
//! its memory goes back to a pool, and the next query's column of about
//! that size is taken from there. Fresh memory costs the kernel a zeroed
//! page per fault (on buddha100k's 786,432 camera rays, `intersect` into
//! fresh columns took twice as long as into reused ones, a third of it in
//! the kernel's page clearing); recycled memory is already mapped. In a
//! loop `r = mesh.intersect(...)`, call `k` reuses call `k - 2`'s columns
//! (call `k - 1`'s are still held by `r` while `k` runs).

use std::marker::PhantomData;
use std::mem::MaybeUninit;
use std::sync::Mutex;

use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{Element, PyArray1, PyArray2};
use pyo3::prelude::*;

/// Buffers smaller than this come and go through the allocator (cheap).
const POOLED_FROM: usize = 1 << 20;

/// At most this much memory waits in the pool; beyond it the oldest
/// buffers are freed.
const POOL_LIMIT: usize = 512 << 20;

/// Freed buffers, oldest first.
static POOL: Mutex<Vec<Vec<u64>>> = Mutex::new(Vec::new());

/// A buffer of at least `words` 8-byte words: the smallest pooled one that
/// holds them, if it is at most twice that size (so that the columns of one
/// call each find their own size again, and a small column does not pin a
/// large buffer), else a fresh one.
fn take(words: usize) -> Vec<u64> {
    if words * 8 >= POOLED_FROM {
        let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
        let best = (0..pool.len())
            .filter(|&i| (words..=2 * words).contains(&pool[i].capacity()))
            .min_by_key(|&i| pool[i].capacity());
        if let Some(i) = best {
            return pool.remove(i);
        }
    }
    fresh(words)
}

/// Returns `buffer` to the pool (or frees it, if small or the pool full).
fn give_back(mut buffer: Vec<u64>) {
    if buffer.capacity() * 8 < POOLED_FROM {
        return;
    }
    buffer.clear();
    let mut pool = POOL.lock().unwrap_or_else(|e| e.into_inner());
    pool.push(buffer);
    let mut held: usize = pool.iter().map(|b| b.capacity() * 8).sum();
    while held > POOL_LIMIT {
        held -= pool.remove(0).capacity() * 8;
    }
}

/// The Python object that owns a column's memory while NumPy arrays
/// look at it.
#[pyclass(frozen)]
struct ColumnMemory {
    words: Vec<u64>,
}

impl Drop for ColumnMemory {
    fn drop(&mut self) {
        give_back(std::mem::take(&mut self.words));
    }
}

/// `n` entries of `T` (a number, or `[E; 3]` rows of one), not yet written.
pub struct Column<T> {
    words: Vec<u64>,
    n: usize,
    entry: PhantomData<T>,
}

impl<T: Copy> Column<T> {
    /// Room for `n` entries, from the pool when it has a buffer that fits.
    pub fn uninit(n: usize) -> Self {
        // Every entry type here has an alignment of at most 8.
        const { assert!(std::mem::align_of::<T>() <= 8) };
        let words = take((n * std::mem::size_of::<T>()).div_ceil(8));
        Column {
            words,
            n,
            entry: PhantomData,
        }
    }

    /// The `n` slots.
    pub fn slots(&mut self) -> &mut [MaybeUninit<T>] {
        let spare = self.words.spare_capacity_mut();
        // SAFETY: the buffer holds at least `n * size_of::<T>()` bytes,
        // 8-byte aligned (enough for `T`); uninitialised slots are what
        // `MaybeUninit` allows.
        unsafe { std::slice::from_raw_parts_mut(spare.as_mut_ptr().cast(), self.n) }
    }

    /// Hands the memory to a Python owner; its pointer, still valid (the
    /// heap buffer does not move with the vector).
    fn into_owner(self, py: Python<'_>) -> PyResult<(Bound<'_, PyAny>, *const T)> {
        let ptr = self.words.as_ptr().cast::<T>();
        let owner = Bound::new(py, ColumnMemory { words: self.words })?;
        Ok((owner.into_any(), ptr))
    }
}

impl<E: Element + Copy> Column<E> {
    /// The column as a `(n,)` array.
    ///
    /// # Safety
    /// Every slot must have been written.
    pub unsafe fn into_array(self, py: Python<'_>) -> PyResult<Bound<'_, PyArray1<E>>> {
        let n = self.n;
        let (owner, ptr) = self.into_owner(py)?;
        // SAFETY: `n` written entries at `ptr`, kept alive by `owner`, the
        // array's base, and never reallocated.
        unsafe {
            let view = ArrayView1::from_shape_ptr(n, ptr);
            Ok(PyArray1::borrow_from_array(&view, owner))
        }
    }
}

impl<E: Element + Copy> Column<[E; 3]> {
    /// The column as a `(n, 3)` array.
    ///
    /// # Safety
    /// Every slot must have been written.
    pub unsafe fn into_rows(self, py: Python<'_>) -> PyResult<Bound<'_, PyArray2<E>>> {
        let n = self.n;
        let (owner, ptr) = self.into_owner(py)?;
        // SAFETY: as in `into_array`; `[E; 3]` is three `E`s in a row.
        unsafe {
            let view = ArrayView2::from_shape_ptr((n, 3), ptr.cast::<E>());
            Ok(PyArray2::borrow_from_array(&view, owner))
        }
    }
}

/// An empty vector with room for `n` values, whose memory the kernel is
/// asked to back with transparent huge pages (Linux, when it spans one):
/// a result column is written once and handed to NumPy, so its every 4 KB
/// page would otherwise cost a page fault, and faults taken by both
/// threads at once serialise in the kernel. On buddha100k's 786,432 camera
/// rays that was most of the binding's time beyond the traversal.
fn fresh<T>(n: usize) -> Vec<T> {
    let column = Vec::with_capacity(n);
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let start = column.as_ptr() as usize;
        let end = start + column.capacity() * std::mem::size_of::<T>();
        let (lo, hi) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
        if hi > lo {
            // SAFETY: advice only, on whole pages inside the vector's own
            // allocation; nothing is read or written. A refusal (THP off,
            // an old kernel) leaves ordinary pages, so the result is unused.
            unsafe { libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE) };
        }
    }
    column
}
