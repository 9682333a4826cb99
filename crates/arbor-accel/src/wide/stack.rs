//! The wide traversals' stacks, and how a node's entered children go onto
//! them without sorting.
//!
//! The closest-hit walk pushes the children a ray enters in the node's
//! precomputed order for the ray's octant ([`Node8::set_orders`]): farthest
//! first, so the nearest ends on top. With AVX2 that is a handful of
//! vector operations whatever the number of children: the octant's slot
//! numbers are read out of the node in one shift, the entered lanes are
//! compacted by a permutation from a 256-entry table ([`COMPRESS`]), and the
//! children, counts and entry distances are written with three vector
//! stores; the stack then grows by the number entered. The portable form
//! loops over the positions and pushes the same entries in the same order.
//!
//! The any-hit walk needs no order: [`LaneStack`] takes the entered lanes
//! in lane order, as the walk always has.
//!
//! Both stacks are arrays left uninitialised (zeroing them per ray cost
//! more than the box tests, docs/perf-log/2026-11-23-first-round.md) with
//! [`WIDTH`] slots of slack above their capacity, which the vector stores
//! may write beyond the entries they push.

use std::mem::MaybeUninit;

use super::lanes::{Node8, Order, COUNT_MASK, WIDTH};
use super::WIDE_STACK;

/// Slots of a stack: the capacity, plus one vector store's slack.
const SLOTS: usize = WIDE_STACK + WIDTH;

/// For every 8-bit mask, the positions of its set bits in increasing
/// order, three bits each, the first in the lowest bits.
const COMPRESS: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut packed, mut k, mut bit) = (0u32, 0, 0);
        while bit < WIDTH {
            if mask >> bit & 1 == 1 {
                packed |= (bit as u32) << (3 * k);
                k += 1;
            }
            bit += 1;
        }
        table[mask] = packed;
        mask += 1;
    }
    table
};

/// The lane compaction of `mask` (at most eight bits): lane `k` holds the
/// position of its `k`-th set bit, from [`COMPRESS`].
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn compaction(mask: usize) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 is available (the caller's contract).
    unsafe {
        let packed = _mm256_set1_epi32(COMPRESS[mask & 0xff] as i32);
        _mm256_and_si256(
            _mm256_srlv_epi32(packed, _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21)),
            _mm256_set1_epi32(7),
        )
    }
}

/// The any-hit walk's stack, and the core of [`OrderedStack`]: per entry a
/// child reference and its meta word (the leaf count in [`COUNT_MASK`]).
pub(crate) struct LaneStack {
    child: [MaybeUninit<u32>; SLOTS],
    meta: [MaybeUninit<u32>; SLOTS],
    len: usize,
}

impl LaneStack {
    /// An empty stack.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        LaneStack {
            child: [const { MaybeUninit::uninit() }; SLOTS],
            meta: [const { MaybeUninit::uninit() }; SLOTS],
            len: 0,
        }
    }

    /// Entry `i` as `(child, leaf count)`.
    ///
    /// # Safety
    /// `i < len`: a slot written by a push.
    #[inline(always)]
    unsafe fn entry(&self, i: usize) -> (u32, u32) {
        // SAFETY: the caller's contract.
        unsafe {
            (
                self.child.get_unchecked(i).assume_init(),
                self.meta.get_unchecked(i).assume_init() & COUNT_MASK,
            )
        }
    }

    /// The top entry as `(child, leaf count)`, removed; `None` when empty.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<(u32, u32)> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: the slot at the old `len - 1` was written by a push.
        Some(unsafe { self.entry(self.len) })
    }

    /// [`LaneStack::pop`] right after a push of at least one entry.
    ///
    /// # Safety
    /// The stack must not be empty.
    #[inline(always)]
    pub(crate) unsafe fn pop_pushed(&mut self) -> (u32, u32) {
        debug_assert!(self.len > 0);
        self.len -= 1;
        // SAFETY: the caller pushed the entry at the old `len - 1`.
        unsafe { self.entry(self.len) }
    }

    /// The top entry's `(child, leaf count)`, left in place.
    #[inline(always)]
    pub(crate) fn peek(&self) -> Option<(u32, u32)> {
        let i = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` was written by a push.
        Some(unsafe { self.entry(i) })
    }

    /// Pushes slot `slot` of `n`.
    #[inline(always)]
    fn push_slot(&mut self, n: &Node8, slot: usize) {
        assert!(self.len < WIDE_STACK, "wide traversal stack overflow");
        self.child[self.len] = MaybeUninit::new(n.child[slot]);
        self.meta[self.len] = MaybeUninit::new(n.meta[slot]);
        self.len += 1;
    }

    /// Pushes the slots of `n` set in `entered` in slot order (the last
    /// slot on top); the portable form.
    #[inline(always)]
    pub(crate) fn push_portable(&mut self, n: &Node8, entered: u32) {
        let mut bits = entered;
        while bits != 0 {
            let slot = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            self.push_slot(n, slot);
        }
    }

    /// Writes the children and meta words of the slots `lanes` of `n`
    /// (lane `k` naming the `k`-th slot to push) from `len` on and grows
    /// the stack by `count`.
    ///
    /// # Safety
    /// The CPU must support AVX2, and `len < WIDE_STACK`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn store_permuted(&mut self, n: &Node8, lanes: std::arch::x86_64::__m256i, count: u32) {
        use std::arch::x86_64::*;
        // SAFETY: AVX2 is available; the loads read whole 32-byte rows of
        // `n`; the stores write eight slots from `len`, inside the arrays
        // since `len < WIDE_STACK` and `SLOTS = WIDE_STACK + 8`.
        unsafe {
            let at = self.len;
            _mm256_storeu_si256(
                self.child.as_mut_ptr().add(at).cast(),
                _mm256_permutevar8x32_epi32(_mm256_loadu_si256(n.child.as_ptr().cast()), lanes),
            );
            _mm256_storeu_si256(
                self.meta.as_mut_ptr().add(at).cast(),
                _mm256_permutevar8x32_epi32(_mm256_loadu_si256(n.meta.as_ptr().cast()), lanes),
            );
            self.len = at + count as usize;
        }
    }

    /// [`LaneStack::push_portable`] in AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn push_avx2(&mut self, n: &Node8, entered: u32) {
        assert!(self.len < WIDE_STACK, "wide traversal stack overflow");
        // SAFETY: AVX2 is available and `len < WIDE_STACK`.
        unsafe { self.store_permuted(n, compaction(entered as usize), entered.count_ones()) }
    }
}

/// The closest-hit walk's stack: a [`LaneStack`] with each entry's entry
/// distance beside it, in a third array so that a node's children go on
/// with vector stores.
pub(crate) struct OrderedStack {
    refs: LaneStack,
    dist: [MaybeUninit<f32>; SLOTS],
}

impl OrderedStack {
    /// An empty stack.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        OrderedStack {
            refs: LaneStack::new(),
            dist: [const { MaybeUninit::uninit() }; SLOTS],
        }
    }

    /// The top entry as `(child, leaf count, entry distance)`, removed;
    /// `None` when empty.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<(u32, u32, f32)> {
        let (child, count) = self.refs.pop()?;
        // SAFETY: every push writes the distance beside the entry.
        let dist = unsafe { self.dist.get_unchecked(self.refs.len).assume_init() };
        Some((child, count, dist))
    }

    /// [`OrderedStack::pop`] right after a push of at least one entry,
    /// without the distance.
    ///
    /// # Safety
    /// The stack must not be empty.
    #[inline(always)]
    pub(crate) unsafe fn pop_pushed(&mut self) -> (u32, u32) {
        // SAFETY: the caller's contract.
        unsafe { self.refs.pop_pushed() }
    }

    /// The top entry's `(child, leaf count)`, left in place.
    #[inline(always)]
    pub(crate) fn peek(&self) -> Option<(u32, u32)> {
        self.refs.peek()
    }

    /// Pushes the slots of `n` set in `entered` in the node's `order`,
    /// with their entry distances from `near`; the portable form.
    #[inline(always)]
    pub(crate) fn push_portable(
        &mut self,
        n: &Node8,
        near: &[f32; WIDTH],
        entered: u32,
        order: Order,
    ) {
        for position in 0..WIDTH {
            let slot = n.slot_at(order, position);
            if entered >> slot & 1 == 1 {
                assert!(self.refs.len < WIDE_STACK, "wide traversal stack overflow");
                self.dist[self.refs.len] = MaybeUninit::new(near[slot]);
                self.refs.push_slot(n, slot);
            }
        }
    }

    /// [`OrderedStack::push_portable`] in AVX2: the same entries in the
    /// same order.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn push_avx2(
        &mut self,
        n: &Node8,
        near: &[f32; WIDTH],
        entered: u32,
        order: Order,
    ) {
        use std::arch::x86_64::*;
        assert!(self.refs.len < WIDE_STACK, "wide traversal stack overflow");
        // SAFETY: AVX2 is available; the loads read whole 32-byte rows of
        // `n` and `near`; the stores write eight slots from `len`, inside
        // the arrays since `len < WIDE_STACK` and `SLOTS = WIDE_STACK + 8`.
        unsafe {
            let meta = _mm256_loadu_si256(n.meta.as_ptr().cast());
            // Position `p` read from lane `p ^ flip`: one permutation, no
            // branch on the octant.
            let stored = _mm256_xor_si256(
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
                _mm256_set1_epi32(order.flip as i32),
            );
            let slots = _mm256_and_si256(
                _mm256_srlv_epi32(
                    _mm256_permutevar8x32_epi32(meta, stored),
                    _mm256_set1_epi32(order.shift as i32),
                ),
                _mm256_set1_epi32(7),
            );
            // Which positions hold an entered slot.
            let bit = _mm256_sllv_epi32(_mm256_set1_epi32(1), slots);
            let hit = _mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32(entered as i32), bit),
                bit,
            );
            let positions = _mm256_movemask_ps(_mm256_castsi256_ps(hit)) as usize;
            let lanes = _mm256_permutevar8x32_epi32(slots, compaction(positions));
            _mm256_storeu_ps(
                self.dist.as_mut_ptr().add(self.refs.len).cast(),
                _mm256_permutevar8x32_ps(_mm256_loadu_ps(near.as_ptr()), lanes),
            );
            self.refs.store_permuted(n, lanes, entered.count_ones());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wide::lanes::{MAX, MIN};

    /// A node of seven children spread over a cube, slot 7 empty, with
    /// leaf counts in some slots.
    fn node() -> Node8 {
        let mut n = Node8::EMPTY;
        for i in 0..7 {
            let f = i as f32;
            let centre = [(f * 1.7).sin(), (f * 2.3).cos(), (f * 0.9).sin()];
            for (a, c) in centre.into_iter().enumerate() {
                n.bounds[MIN + a][i] = c - 0.1;
                n.bounds[MAX + a][i] = c + 0.1;
            }
            n.child[i] = 100 + i as u32;
            n.set_count(i, if i % 2 == 0 { i as u32 + 1 } else { 0 });
        }
        n.set_orders();
        n
    }

    fn drain(s: &mut OrderedStack) -> Vec<(u32, u32, f32)> {
        std::iter::from_fn(|| s.pop()).collect()
    }

    /// Every octant's order pops the entered children nearest first along
    /// the octant's direction, and the x-negative octants walk the opposite
    /// octant's order backwards.
    #[test]
    fn children_pop_nearest_first_along_the_octant() {
        let n = node();
        let near: [f32; WIDTH] = std::array::from_fn(|i| i as f32 * 0.5);
        for negative in 0..8u32 {
            let order = Order::for_signs(negative);
            let d = [0, 1, 2].map(|a| if negative >> a & 1 == 1 { -1.0f32 } else { 1.0 });
            let along = |slot: u32| -> f32 {
                let i = (slot - 100) as usize;
                (0..3)
                    .map(|a| d[a] * (n.bounds[MIN + a][i] + n.bounds[MAX + a][i]))
                    .sum()
            };
            for entered in 0..128u32 {
                let mut s = OrderedStack::new();
                s.push_portable(&n, &near, entered, order);
                let popped = drain(&mut s);
                assert_eq!(popped.len(), entered.count_ones() as usize);
                for w in popped.windows(2) {
                    assert!(
                        along(w[0].0) <= along(w[1].0),
                        "octant {negative} {entered:b}"
                    );
                }
                for &(child, count, dist) in &popped {
                    let i = (child - 100) as usize;
                    assert!(entered >> i & 1 == 1);
                    assert_eq!(count, n.count(i));
                    assert_eq!(dist, near[i]);
                }
            }
        }
    }

    /// The AVX2 pushes write the portable pushes' entries in their order.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_pushes_match_the_portable_ones() {
        if !crate::wide::lanes::has_avx2() {
            eprintln!("skipped: this CPU has no AVX2");
            return;
        }
        let n = node();
        let near: [f32; WIDTH] = std::array::from_fn(|i| 1.0 + i as f32);
        for negative in 0..8u32 {
            let order = Order::for_signs(negative);
            for entered in 0..128u32 {
                let (mut a, mut b) = (OrderedStack::new(), OrderedStack::new());
                // A first entry below, so the pushes start mid-stack.
                a.push_portable(&n, &near, 1, order);
                b.push_portable(&n, &near, 1, order);
                a.push_portable(&n, &near, entered, order);
                // SAFETY: the CPU has AVX2.
                unsafe { b.push_avx2(&n, &near, entered, order) };
                assert_eq!(
                    drain(&mut a),
                    drain(&mut b),
                    "octant {negative} {entered:b}"
                );
            }
        }
        for entered in 0..128u32 {
            let (mut a, mut b) = (LaneStack::new(), LaneStack::new());
            a.push_portable(&n, entered);
            // SAFETY: the CPU has AVX2.
            unsafe { b.push_avx2(&n, entered) };
            let drain = |s: &mut LaneStack| std::iter::from_fn(|| s.pop()).collect::<Vec<_>>();
            let got = drain(&mut b);
            assert_eq!(drain(&mut a), got, "{entered:b}");
            assert_eq!(got.len(), entered.count_ones() as usize);
        }
    }
}
