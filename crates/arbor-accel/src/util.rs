//! Helpers shared by the builders and traversals.
#![allow(dead_code)] // Used by the structures added next.

use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::aabb::SLAB_TFAR_SCALE;
use crate::counters::count_test;
use crate::counters::Counters;
use crate::primitives::Primitives;
use crate::ray::Ray;

/// Relative widening that covers the three roundings of a slab distance
/// `(plane - origin) * inv_dir` (see [`SLAB_TFAR_SCALE`]).
const REL: f32 = SLAB_TFAR_SCALE - 1.0;

/// A value at least as large as the exact quantity that `t` approximates
/// with three roundings; infinities stay put.
#[inline(always)]
pub(crate) fn widen_up(t: f32) -> f32 {
    t + t.abs() * REL
}

/// Asks the CPU to start loading `value` into the cache: a hint, which
/// lets the cache misses of nodes a traversal will visit soon overlap with
/// the work at hand (memory latency, not arithmetic, bounds incoherent
/// rays on large structures).
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    prefetch_ptr(value as *const T);
}

/// [`prefetch`] of the `T` at `ptr`, which need not point at anything:
/// a prefetch never faults, so a traversal can hint at a child's address
/// without the bounds check of indexing.
#[inline(always)]
pub(crate) fn prefetch_ptr<T>(ptr: *const T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start: *const i8 = ptr.cast();
        let mut offset = 0;
        while offset < std::mem::size_of::<T>() {
            // SAFETY: prefetching never faults and changes no memory.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
            offset += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = ptr;
}

/// A value at most as large as the exact quantity that `t` approximates
/// with three roundings; infinities stay put.
#[inline(always)]
pub(crate) fn widen_down(t: f32) -> f32 {
    t - t.abs() * REL
}

/// The primitives a structure indexes, sorted into those with a usable box
/// and those whose box is not finite.
pub(crate) struct Prepared {
    /// `(primitive, box)` for every primitive with a finite, non-empty box.
    pub refs: Vec<(u32, Aabb)>,
    /// Primitives with NaN or infinite bounds: no structure can place them,
    /// so they are offered to every ray (conservative, never wrong).
    pub unbounded: Vec<u32>,
    /// Union of the boxes in `refs`.
    pub bounds: Aabb,
}

/// How a structure treats a primitive's box: 0 = empty (the primitive
/// cannot be hit and is dropped), 1 = usable, 2 = NaN or infinite (unknown
/// extent: offered to every ray).
fn classify(b: &Aabb) -> u8 {
    if b.min.is_nan() || b.max.is_nan() {
        2
    } else if b.is_empty() {
        0
    } else if !(b.min.is_finite() && b.max.is_finite()) {
        2
    } else {
        1
    }
}

/// Maps every primitive with a usable box through `f` (in index order, in
/// parallel) and lists those whose box is not finite.
pub(crate) fn prepare_map<P, T, F>(prims: &P, f: F) -> (Vec<T>, Vec<u32>)
where
    P: Primitives + ?Sized,
    T: Send,
    F: Fn(u32, Aabb) -> T + Sync + Send,
{
    let n = u32::try_from(prims.len()).expect("more than 2^32 primitives");
    // An indexed map writes straight into place (and keeps the order, so
    // results are deterministic); the rare unusable boxes are filtered after.
    let (items, kinds): (Vec<T>, Vec<u8>) = (0..n)
        .into_par_iter()
        .map(|i| {
            let b = prims.bounds(i);
            (f(i, b), classify(&b))
        })
        .unzip();
    if kinds.iter().all(|&k| k == 1) {
        return (items, Vec::new());
    }
    let unbounded = (0..n).filter(|&i| kinds[i as usize] == 2).collect();
    let items = items
        .into_iter()
        .zip(&kinds)
        .filter(|&(_, &k)| k == 1)
        .map(|(t, _)| t)
        .collect();
    (items, unbounded)
}

/// Sorts primitives by the usability of their boxes (see [`prepare_map`]).
pub(crate) fn prepare<P: Primitives + ?Sized>(prims: &P) -> Prepared {
    let (refs, unbounded) = prepare_map(prims, |i, b| (i, b));
    let bounds = refs.iter().fold(Aabb::EMPTY, |acc, (_, b)| acc.union(b));
    Prepared {
        refs,
        unbounded,
        bounds,
    }
}

/// Primitive ids already handed to the caller during one query, so that a
/// primitive stored in several cells or leaves (grid, k-d tree) is tested at
/// most once per ray.
///
/// Per call and on the stack, so concurrent queries share nothing and "at
/// most once" is exact. The first [`Mailbox::INLINE`] ids sit in a fixed
/// array that is compared whole, with no data-dependent branch (the
/// compiler turns it into a few vector compares); unused slots hold
/// `u32::MAX`, never an id (structures index fewer primitives). Later ids
/// spill into a hash set, allocated only then (almost all rays stop
/// before). The set's hasher has fixed keys: the ids are indices, not
/// chosen by anyone, and a fixed hasher makes a query take the same path
/// every run (fuzzing steers by that path).
pub(crate) struct Mailbox {
    ids: [u32; Mailbox::INLINE],
    len: usize,
    spill: Option<std::collections::HashSet<u32, FixedHasher>>,
}

/// std's hasher with fixed keys.
type FixedHasher = std::hash::BuildHasherDefault<std::collections::hash_map::DefaultHasher>;

impl Mailbox {
    /// Ids kept without allocating.
    pub const INLINE: usize = 32;

    #[inline(always)]
    pub fn new() -> Self {
        Mailbox {
            ids: [u32::MAX; Mailbox::INLINE],
            len: 0,
            spill: None,
        }
    }

    /// Records `id`; returns whether it was new.
    #[inline(always)]
    pub fn insert(&mut self, id: u32) -> bool {
        if self.ids.iter().fold(false, |seen, &x| seen | (x == id)) {
            return false;
        }
        if self.len < Mailbox::INLINE {
            self.ids[self.len] = id;
            self.len += 1;
            return true;
        }
        self.spill.get_or_insert_with(Default::default).insert(id)
    }

    /// [`offer_closest`] for the primitives of `prims` not offered before.
    #[inline(always)]
    pub(crate) fn offer_closest<C, F>(
        &mut self,
        prims: &[u32],
        ray: &mut Ray,
        counters: &mut C,
        hit: &mut F,
    ) where
        C: Counters,
        F: FnMut(u32, &Ray) -> Option<f32>,
    {
        for &p in prims {
            if self.insert(p) {
                count_test(counters, p);
                if let Some(t) = hit(p, ray) {
                    ray.tmax = ray.tmax.min(t);
                }
            }
        }
    }

    /// [`offer_any`] for the primitives of `prims` not offered before.
    #[inline(always)]
    pub(crate) fn offer_any<C, F>(
        &mut self,
        prims: &[u32],
        ray: &Ray,
        counters: &mut C,
        hit: &mut F,
    ) -> bool
    where
        C: Counters,
        F: FnMut(u32, &Ray) -> bool,
    {
        prims.iter().any(|&p| {
            self.insert(p) && {
                count_test(counters, p);
                hit(p, ray)
            }
        })
    }
}

/// Offers each primitive of `prims` to the caller's exact test, shrinking
/// `ray.tmax` to every hit it reports: what every structure does in a leaf
/// and with its list of primitives that have no finite box.
#[inline(always)]
pub(crate) fn offer_closest<C, F>(prims: &[u32], ray: &mut Ray, counters: &mut C, hit: &mut F)
where
    C: Counters,
    F: FnMut(u32, &Ray) -> Option<f32>,
{
    for &p in prims {
        count_test(counters, p);
        if let Some(t) = hit(p, ray) {
            ray.tmax = ray.tmax.min(t);
        }
    }
}

/// Whether the caller's test reports any primitive of `prims`; stops at the
/// first.
#[inline(always)]
pub(crate) fn offer_any<C, F>(prims: &[u32], ray: &Ray, counters: &mut C, hit: &mut F) -> bool
where
    C: Counters,
    F: FnMut(u32, &Ray) -> bool,
{
    prims.iter().any(|&p| {
        count_test(counters, p);
        hit(p, ray)
    })
}

/// A deterministic sequence of numbers in `[0, 1)` for unit tests (a
/// 64-bit linear congruential generator, its top 24 bits).
#[cfg(test)]
pub(crate) fn unit_sequence(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mailbox_remembers_beyond_inline() {
        let mut m = Mailbox::new();
        for i in 0..100 {
            assert!(m.insert(i));
        }
        for i in 0..100 {
            assert!(!m.insert(i));
        }
    }

    #[test]
    fn widening() {
        assert!(widen_up(1.0) > 1.0 && widen_down(1.0) < 1.0);
        assert!(widen_up(-1.0) > -1.0 && widen_down(-1.0) < -1.0);
        assert_eq!(widen_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(widen_down(0.0), 0.0);
    }
}
