//! The wide BVH (`bvh-wide`): the binned-SAH binary tree collapsed into
//! 4-ary nodes whose four child boxes are tested at once in SIMD lanes.
//!
//! Why it is faster than the binary [`Bvh`] it is built from, trick by trick:
//!
//! * **Collapsing**: every 4-ary node replaces (up to) three binary interior
//!   nodes, so a ray visits about a third as many nodes and the traversal
//!   loop's branches and stack operations shrink accordingly. A node takes
//!   the children of its binary node and keeps opening the child with the
//!   largest surface area (the one rays most likely enter) until it holds
//!   four; leaves stay the binary tree's leaves, primitive order included.
//! * **SoA node layout**: a node stores its four children's boxes as six
//!   4-lane vectors (`min x`, `min y`, ... each for children 0..3) followed by
//!   the child references: 128 bytes, two cache lines, aligned to 64. The
//!   slab test of all four children is then 6 subtractions and
//!   multiplications, 6 min/max and a handful of compares on 128-bit
//!   registers (`glam::Vec4` is SSE on x86-64, NEON on aarch64; no
//!   `unsafe`, no runtime feature detection needed).
//! * **Ordered traversal with a short stack**: the children a ray enters are
//!   pushed farthest first with their entry distance, so the nearest is
//!   visited next and a popped entry beyond the current closest hit is
//!   dropped without touching its node.
//! * **Early-out occlusion**: shadow rays skip the ordering and stop at the
//!   first blocker.
//!
//! Correctness is the binary tree's: the lane arithmetic is, operation for
//! operation, that of [`crate::Aabb::intersect`] (entry `max(near, tmin)`,
//! exit `far * SLAB_TFAR_SCALE` capped by a `tmax` widened by the slab
//! rounding bound, a slab with `0 * inf = NaN` counted as `(-inf, inf)`), so
//! a box the exact ray touches is never rejected, and every child box is
//! the binary tree's box of that subtree.

use std::mem::MaybeUninit;

use glam::{BVec4A, Vec4};

use super::{Bvh, BvhBuilder, BvhParams, STACK_SIZE};
use crate::aabb::SLAB_TFAR_SCALE;
use crate::util::{offer_any, offer_closest, widen_up};
use crate::{AccelStats, Accelerator, Counters, Primitives, Ray};

/// Child slot holding nothing.
const EMPTY: u32 = u32::MAX;

/// Stack entries: each visited node pushes at most three siblings beyond
/// the one it continues with, one node per level of a tree whose depth is
/// bounded by the binary tree's.
const WIDE_STACK: usize = 3 * STACK_SIZE;

/// Four children: their boxes in lanes, then what each child is.
/// `child[i]` is a node index (`count[i] == 0`), the first primitive slot of
/// a leaf (`count[i] > 0` primitives), or [`EMPTY`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Node4 {
    min: [Vec4; 3],
    max: [Vec4; 3],
    child: [u32; 4],
    count: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Node4>() == 128);

impl Node4 {
    const EMPTY: Node4 = Node4 {
        min: [Vec4::ZERO; 3],
        max: [Vec4::ZERO; 3],
        child: [EMPTY; 4],
        count: [0; 4],
    };
}

/// A 4-wide BVH over any [`Primitives`], built by collapsing the binned-SAH
/// binary [`Bvh`].
#[derive(Clone, Debug, Default)]
pub struct WideBvh {
    nodes: Vec<Node4>,
    prims: Vec<u32>,
    unbounded: Vec<u32>,
    max_depth: usize,
    sah_cost: Option<f64>,
}

/// The ray in lanes.
struct Lanes {
    origin: [Vec4; 3],
    inv: [Vec4; 3],
    tmin: Vec4,
}

impl Lanes {
    fn new(ray: &Ray) -> Self {
        let inv = ray.inv_dir();
        Lanes {
            origin: [
                Vec4::splat(ray.origin.x),
                Vec4::splat(ray.origin.y),
                Vec4::splat(ray.origin.z),
            ],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            tmin: Vec4::splat(ray.tmin),
        }
    }

    /// Whether [`Lanes::hit`] needs its NaN fix-up for `ray`.
    fn needs_nan_care(ray: &Ray) -> bool {
        !(ray.origin.is_finite() && ray.dir.is_finite() && ray.inv_dir().is_finite())
    }

    /// Entry distances of the four children and which of them the ray
    /// touches before `tmax` (already widened by the caller).
    ///
    /// `NAN_SAFE = false` is the fast path for rays whose origin and
    /// direction are finite and whose direction has no zero component:
    /// then `(bound - origin) * inv` is never NaN (no `0 * inf`, and `inv`
    /// is never 0), so the on-plane fix-up (four of every thirteen lane
    /// operations) can be skipped with the same results.
    #[inline(always)]
    fn hit<const NAN_SAFE: bool>(&self, n: &Node4, tmax: f32) -> (Vec4, BVec4A) {
        let mut near = self.tmin;
        let mut far = Vec4::INFINITY;
        for a in 0..3 {
            let t0 = (n.min[a] - self.origin[a]) * self.inv[a];
            let t1 = (n.max[a] - self.origin[a]) * self.inv[a];
            let (lo, hi) = if NAN_SAFE {
                let on_plane = t0.is_nan_mask() | t1.is_nan_mask();
                (
                    Vec4::select(on_plane, Vec4::NEG_INFINITY, t0.min(t1)),
                    Vec4::select(on_plane, Vec4::INFINITY, t0.max(t1)),
                )
            } else {
                (t0.min(t1), t0.max(t1))
            };
            near = near.max(lo);
            far = far.min(hi);
        }
        let exit = (far * SLAB_TFAR_SCALE).min(Vec4::splat(tmax));
        (near, near.cmple(exit))
    }
}

impl WideBvh {
    /// Builds the binned-SAH binary tree with `params` and collapses it.
    pub fn build<P: Primitives + ?Sized>(prims: &P, params: &BvhParams) -> Self {
        let bin = Bvh::build(prims, BvhBuilder::BinnedSah, params);
        let sah_cost = bin.sah_cost(1.0, 1.0);
        let mut wide = WideBvh {
            nodes: Vec::new(),
            prims: bin.prims,
            unbounded: bin.unbounded,
            max_depth: 0,
            sah_cost,
        };
        let bn = &bin.nodes;
        if bn.is_empty() {
            return wide;
        }
        wide.nodes.reserve(bn.len() / 2 + 1);
        // (binary node whose children fill the wide node, wide node, depth)
        let mut todo = vec![(0usize, 0usize, 0usize)];
        wide.nodes.push(Node4::EMPTY);
        while let Some((b, w, depth)) = todo.pop() {
            wide.max_depth = wide.max_depth.max(depth);
            // Up to four children in a fixed array (no allocation per node).
            let mut kids = [0usize; 4];
            let mut len = if bn[b].is_leaf() {
                // Only a root leaf gets here: one child, itself.
                kids[0] = b;
                1
            } else {
                kids[0] = b + 1;
                kids[1] = bn[b].offset as usize;
                2
            };
            while len < 4 {
                let mut open = None;
                let mut best = f32::NEG_INFINITY;
                for (i, &k) in kids[..len].iter().enumerate() {
                    if !bn[k].is_leaf() {
                        let area = bn[k].aabb().surface_area();
                        if area > best || open.is_none() {
                            (open, best) = (Some(i), area);
                        }
                    }
                }
                let Some(i) = open else { break };
                let k = kids[i];
                kids[i] = k + 1;
                kids[len] = bn[k].offset as usize;
                len += 1;
            }
            let kids = &kids[..len];
            let mut node = Node4::EMPTY;
            for (lane, &k) in kids.iter().enumerate() {
                let n = &bn[k];
                for a in 0..3 {
                    node.min[a][lane] = n.min[a];
                    node.max[a][lane] = n.max[a];
                }
                if n.is_leaf() {
                    node.child[lane] = n.offset;
                    node.count[lane] = n.count;
                    wide.max_depth = wide.max_depth.max(depth + 1);
                } else {
                    let index = wide.nodes.len();
                    wide.nodes.push(Node4::EMPTY);
                    node.child[lane] = index as u32;
                    todo.push((k, index, depth + 1));
                }
            }
            wide.nodes[w] = node;
        }
        wide
    }
}

impl Accelerator for WideBvh {
    fn closest<C, F>(&self, ray: &Ray, counters: &mut C, mut hit: F)
    where
        C: Counters,
        F: FnMut(u32, &Ray) -> Option<f32>,
    {
        let mut ray = *ray;
        offer_closest(&self.unbounded, &mut ray, counters, &mut hit);
        self.closest_leaves(ray, counters, |first, count, ray, counters| {
            offer_closest(&self.prims[first..first + count], ray, counters, &mut hit);
        });
    }

    fn occluded<C, F>(&self, ray: &Ray, counters: &mut C, mut hit: F) -> bool
    where
        C: Counters,
        F: FnMut(u32, &Ray) -> bool,
    {
        if offer_any(&self.unbounded, ray, counters, &mut hit) {
            return true;
        }
        self.occluded_leaves(ray, counters, |first, count, ray, counters| {
            offer_any(&self.prims[first..first + count], ray, counters, &mut hit)
        })
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            nodes: self.nodes.len(),
            leaves: self
                .nodes
                .iter()
                .flat_map(|n| n.count.iter())
                .filter(|&&c| c > 0)
                .count(),
            max_depth: self.max_depth,
            memory_bytes: std::mem::size_of::<Self>()
                + self.nodes.len() * std::mem::size_of::<Node4>()
                + (self.prims.len() + self.unbounded.len()) * 4,
            sah_cost: self.sah_cost,
        }
    }
}

impl WideBvh {
    /// The primitive slots, in leaf order: leaf `(first, count)` holds
    /// `prims()[first..first + count]`.
    pub(crate) fn prims(&self) -> &[u32] {
        &self.prims
    }

    /// Primitives without a finite box, which every ray must be offered.
    pub(crate) fn unbounded(&self) -> &[u32] {
        &self.unbounded
    }

    /// Closest-hit traversal (the unbounded primitives are the caller's):
    /// calls `leaf(first, count, ray, counters)` for every leaf the ray
    /// enters, nearest first; `leaf` shrinks `ray.tmax` to the hits it finds.
    #[inline(always)]
    pub(crate) fn closest_leaves<C, L>(&self, ray: Ray, counters: &mut C, leaf: L)
    where
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
    {
        if self.nodes.is_empty() {
            return;
        }
        if Lanes::needs_nan_care(&ray) {
            self.closest_in::<true, C, L>(ray, counters, leaf);
        } else {
            self.closest_in::<false, C, L>(ray, counters, leaf);
        }
    }

    /// Any-hit traversal (the unbounded primitives are the caller's): calls
    /// `leaf(first, count, ray, counters)` for leaves the ray enters until
    /// one returns `true`.
    #[inline(always)]
    pub(crate) fn occluded_leaves<C, L>(&self, ray: &Ray, counters: &mut C, leaf: L) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
    {
        if self.nodes.is_empty() {
            return false;
        }
        if Lanes::needs_nan_care(ray) {
            self.occluded_in::<true, C, L>(ray, counters, leaf)
        } else {
            self.occluded_in::<false, C, L>(ray, counters, leaf)
        }
    }

    #[inline(always)]
    fn closest_in<const NAN_SAFE: bool, C, L>(&self, mut ray: Ray, counters: &mut C, mut leaf: L)
    where
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
    {
        let lanes = Lanes::new(&ray);
        // (child, count, entry distance), as in the node's slots.
        let mut stack = Stack::<(u32, u32, f32)>::new();
        let (mut child, mut count) = (0u32, 0u32);
        loop {
            counters.node();
            if count > 0 {
                leaf(child as usize, count as usize, &mut ray, counters);
            } else {
                let n = &self.nodes[child as usize];
                let (tnear, mask) = lanes.hit::<NAN_SAFE>(n, widen_up(ray.tmax));
                let bits = mask.bitmask() & valid_mask(n);
                if bits.is_power_of_two() {
                    // One child entered (the common case deep in the tree):
                    // go there without touching the stack.
                    let lane = bits.trailing_zeros() as usize;
                    (child, count) = (n.child[lane], n.count[lane]);
                    continue;
                }
                if bits != 0 {
                    // Push the entered children farthest first, so the
                    // nearest ends on top: insertion sort of at most four
                    // entries on the stack itself.
                    let base = stack.len();
                    let t = tnear.to_array();
                    let mut b = bits;
                    while b != 0 {
                        let lane = b.trailing_zeros() as usize;
                        b &= b - 1;
                        stack.insert_sorted(base, (n.child[lane], n.count[lane], t[lane]));
                    }
                }
            }
            // The nearest pending child not beyond the closest hit.
            loop {
                let Some((c, k, tenter)) = stack.pop() else {
                    return;
                };
                if tenter <= widen_up(ray.tmax) {
                    (child, count) = (c, k);
                    break;
                }
            }
        }
    }

    #[inline(always)]
    fn occluded_in<const NAN_SAFE: bool, C, L>(
        &self,
        ray: &Ray,
        counters: &mut C,
        mut leaf: L,
    ) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
    {
        let lanes = Lanes::new(ray);
        let wide = widen_up(ray.tmax);
        let mut stack = Stack::<(u32, u32)>::new();
        let (mut child, mut count) = (0u32, 0u32);
        loop {
            counters.node();
            if count > 0 {
                if leaf(child as usize, count as usize, ray, counters) {
                    return true;
                }
            } else {
                let n = &self.nodes[child as usize];
                let (_, mask) = lanes.hit::<NAN_SAFE>(n, wide);
                let mut bits = mask.bitmask() & valid_mask(n);
                // Any order will do: the first blocker ends the query.
                while bits != 0 {
                    let lane = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    stack.push((n.child[lane], n.count[lane]));
                }
            }
            let Some(next) = stack.pop() else {
                return false;
            };
            (child, count) = next;
        }
    }
}

/// Bit `i` set when slot `i` holds a child: empty slots have no meaningful
/// box (an inverted box would pass the slab test), so they are masked out.
#[inline(always)]
fn valid_mask(n: &Node4) -> u32 {
    u32::from(n.child[0] != EMPTY)
        | u32::from(n.child[1] != EMPTY) << 1
        | u32::from(n.child[2] != EMPTY) << 2
        | u32::from(n.child[3] != EMPTY) << 3
}

/// The traversal stack: a fixed array left uninitialised. Zeroing a
/// 2.3 KB array per ray was a fifth of all instructions of a diffuse-ray
/// trace (callgrind: `memset` 231 M of 1116 M), more than the box tests.
struct Stack<T: Copy> {
    items: [MaybeUninit<T>; WIDE_STACK],
    len: usize,
}

impl<T: Copy + Entry> Stack<T> {
    #[inline(always)]
    fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; WIDE_STACK],
            len: 0,
        }
    }

    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }

    /// Pushes `e`; panics (bounds check) beyond the capacity, which the
    /// depth bound of the builders rules out.
    #[inline(always)]
    fn push(&mut self, e: T) {
        self.items[self.len] = MaybeUninit::new(e);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push` or
        // `insert_sorted`, and `T: Copy`.
        Some(unsafe { self.items[self.len].assume_init() })
    }

    /// Pushes `e` so that the entries from `base` up stay sorted by
    /// decreasing entry distance (the nearest on top).
    #[inline(always)]
    fn insert_sorted(&mut self, base: usize, e: T) {
        let mut j = self.len;
        while j > base {
            // SAFETY: `base <= j - 1 < len`, a written slot.
            let prev = unsafe { self.items[j - 1].assume_init() };
            if prev.dist() >= e.dist() {
                break;
            }
            self.items[j] = MaybeUninit::new(prev);
            j -= 1;
        }
        self.items[j] = MaybeUninit::new(e);
        self.len += 1;
    }
}

/// A stack entry's entry distance, for sorting.
trait Entry {
    fn dist(&self) -> f32;
}

impl Entry for (u32, u32, f32) {
    #[inline(always)]
    fn dist(&self) -> f32 {
        self.2
    }
}

impl Entry for (u32, u32) {
    fn dist(&self) -> f32 {
        0.0
    }
}
