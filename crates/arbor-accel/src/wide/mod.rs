//! The wide BVH (`bvh-wide`): the binned-SAH binary tree collapsed into
//! 8-ary nodes whose eight child boxes are tested at once in SIMD lanes.
//!
//! Why it is faster than the binary [`Bvh`] it is built from, trick by trick:
//!
//! * **Collapsing**: every 8-ary node replaces (up to) seven binary interior
//!   nodes, so a ray visits far fewer nodes and the traversal loop's
//!   branches and stack operations shrink accordingly. A node takes the
//!   children of its binary node and keeps opening the child with the
//!   largest surface area (the one rays most likely enter) until it holds
//!   eight; leaves stay the binary tree's leaves, primitive order included.
//! * **SoA node layout**: a node stores its eight children's boxes as six
//!   8-lane rows (`min x`, `min y`, ... each for children 0..7) followed by
//!   the child references: 256 bytes, four cache lines, aligned to 64. The
//!   slab test of all eight children is then 6 subtractions and
//!   multiplications, 6 min/max and a handful of compares on 256-bit AVX2
//!   registers (`lanes.rs`: chosen at run time when the CPU has AVX2, with
//!   the same arithmetic on two 4-lane `glam::Vec4` halves otherwise).
//! * **Ordered traversal with a short stack**: the children a ray enters are
//!   pushed with their entry distance in the node's precomputed order for
//!   the ray's octant, farthest first, without sorting (`stack.rs`), so the
//!   nearest is visited next and a popped entry beyond the current closest
//!   hit is dropped without touching its node.
//! * **Early-out occlusion**: shadow rays skip the ordering and stop at the
//!   first blocker.
//! * **The root's box first**: a ray from outside that misses the whole
//!   tree's box (most camera rays of a framed model) returns before the
//!   lanes are set up ([`WideBvh::entered`]).
//!
//! Correctness is the binary tree's: the lane arithmetic (either
//! implementation) is, operation for operation, that of
//! [`crate::aabb::Aabb::intersect`] (entry `max(near, tmin)`,
//! exit `far * SLAB_TFAR_SCALE` capped by a `tmax` widened by the slab
//! rounding bound, a slab with `0 * inf = NaN` counted as `(-inf, inf)`), so
//! a box the exact ray touches is never rejected, and every child box is
//! the binary tree's box of that subtree.

pub(crate) mod lanes;
pub(crate) mod packet;
pub(crate) mod stack;

use glam::Vec3A;
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::accel::{AccelStats, Accelerator};
use crate::bvh2::{Bvh, BvhBuilder, BvhParams, RayBox, STACK_SIZE};
use crate::counters::Counters;
use crate::counters::{count_node, skip_node};
use crate::layout::{Layout, LayoutNode};
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;
use crate::util::{offer_any, offer_closest, prefetch_ptr, widen_up};
use glam::Vec3;
use lanes::{needs_slow_path, BoxLanes, Node8, Order, Portable, MAX, MIN, WIDTH};
use stack::{LaneStack, OrderedStack};

/// Stack entries: each visited node pushes at most seven siblings beyond
/// the one it continues with, one node per level of a tree whose depth is
/// bounded by the binary tree's.
pub(super) const WIDE_STACK: usize = (WIDTH - 1) * STACK_SIZE;

/// An 8-wide BVH over any [`Primitives`], built by collapsing the binned-SAH
/// binary [`Bvh`].
#[derive(Clone, Debug, Default)]
pub struct WideBvh {
    pub(super) nodes: Vec<Node8>,
    prims: Vec<u32>,
    unbounded: Vec<u32>,
    /// The root's box, the union of all others: a ray that misses it (most
    /// primary rays of a framed model) is turned away before the
    /// traversal's set-up.
    pub(super) bounds: Aabb,
    max_depth: usize,
    sah_cost: Option<f64>,
    /// Whether a primitive sits in more than one leaf ([`Bvh::has_repeats`]).
    repeats: bool,
}

impl WideBvh {
    /// Builds the binned-SAH binary tree with `params` and collapses it.
    pub fn build<P: Primitives + ?Sized>(prims: &P, params: &BvhParams) -> Self {
        let mut bin = Bvh::build(prims, BvhBuilder::BinnedSah, &WideBvh::params(params));
        let mut wide = WideBvh::collapse(&bin);
        wide.prims = std::mem::take(&mut bin.prims);
        wide
    }

    /// `params` with leaves no larger than a wide node can count
    /// ([`lanes::MAX_LEAF_COUNT`]), for the binary tree to collapse.
    pub(crate) fn params(params: &BvhParams) -> BvhParams {
        BvhParams {
            leaf_size: params.leaf_size.min(lanes::MAX_LEAF_COUNT),
            max_leaf_size: params.max_leaf_size.min(lanes::MAX_LEAF_COUNT),
            ..*params
        }
    }

    /// The wide tree of the binary tree `bin`, whose leaves it keeps, but
    /// without its primitive slots ([`WideBvh::prims`] is empty): for the
    /// build above, and for a caller that stores the leaves' primitives its
    /// own way.
    pub(crate) fn collapse(bin: &Bvh) -> Self {
        let mut wide = WideBvh {
            nodes: Vec::new(),
            prims: Vec::new(),
            unbounded: bin.unbounded.clone(),
            bounds: Aabb::EMPTY,
            max_depth: 0,
            sah_cost: bin.sah_cost(1.0, 1.0),
            repeats: bin.has_repeats(),
        };
        let bn = &bin.nodes;
        if bn.is_empty() {
            return wide;
        }
        wide.bounds = bn[0].aabb();
        wide.nodes.reserve(bn.len() / 4 + 1);
        // (binary node whose children fill the wide node, wide node, depth)
        let mut todo = vec![(0usize, 0usize, 0usize)];
        wide.nodes.push(Node8::EMPTY);
        while let Some((b, w, depth)) = todo.pop() {
            wide.max_depth = wide.max_depth.max(depth);
            // Up to eight children in a fixed array (no allocation per node).
            let mut kids = [0usize; WIDTH];
            let mut len = if bn[b].is_leaf() {
                // Only a root leaf gets here: one child, itself.
                kids[0] = b;
                1
            } else {
                kids[0] = b + 1;
                kids[1] = bn[b].offset as usize;
                2
            };
            while len < WIDTH {
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
            let mut node = Node8::EMPTY;
            for (lane, &k) in kids.iter().enumerate() {
                let n = &bn[k];
                for a in 0..3 {
                    node.bounds[MIN + a][lane] = n.min[a];
                    node.bounds[MAX + a][lane] = n.max[a];
                }
                if n.is_leaf() {
                    node.child[lane] = n.offset;
                    node.set_count(lane, n.count);
                    wide.max_depth = wide.max_depth.max(depth + 1);
                } else {
                    let index = wide.nodes.len();
                    wide.nodes.push(Node8::EMPTY);
                    node.child[lane] = index as u32;
                    todo.push((k, index, depth + 1));
                }
            }
            node.set_orders();
            wide.nodes[w] = node;
        }
        wide
    }
}

impl WideBvh {
    /// The tree for drawing: the 8-wide nodes first (node `i` is
    /// `nodes[i]`, its box the union of its children's), then the leaves in
    /// the order of their primitive slots. A visit of an 8-wide node is one
    /// step of traversal that tests its (up to) eight child boxes at once; a
    /// visit of a leaf is one step that tests its primitives.
    pub fn layout(&self) -> Layout {
        let base = self.nodes.len() as u32;
        let mut leaf_slots: Vec<u32> = self
            .nodes
            .iter()
            .flat_map(|n| (0..WIDTH).filter(|&i| n.count(i) > 0).map(|i| n.child[i]))
            .collect();
        leaf_slots.sort_unstable();
        let mut nodes = vec![LayoutNode::default(); self.nodes.len() + leaf_slots.len()];
        if self.nodes.is_empty() {
            return Layout::Tree {
                nodes,
                leaf_slots,
                leaf_base: base,
            };
        }
        nodes[0].bounds = self.bounds;
        // (node, depth), parents before children.
        let mut todo = vec![(0usize, 0u32)];
        while let Some((i, depth)) = todo.pop() {
            let n = &self.nodes[i];
            nodes[i].depth = depth;
            for lane in (0..WIDTH).filter(|&l| n.child[l] != lanes::EMPTY) {
                let b = Aabb::new(
                    Vec3::from_array(std::array::from_fn(|a| n.bounds[MIN + a][lane])),
                    Vec3::from_array(std::array::from_fn(|a| n.bounds[MAX + a][lane])),
                );
                let k = if n.count(lane) > 0 {
                    let k = base + leaf_slots.partition_point(|&s| s < n.child[lane]) as u32;
                    nodes[k as usize].primitives = n.count(lane);
                    nodes[k as usize].depth = depth + 1;
                    k
                } else {
                    todo.push((n.child[lane] as usize, depth + 1));
                    n.child[lane]
                };
                nodes[k as usize].bounds = b;
                nodes[i].children.push(k);
            }
        }
        Layout::Tree {
            nodes,
            leaf_slots,
            leaf_base: base,
        }
    }
}

impl Accelerator for WideBvh {
    fn unbounded(&self) -> &[PrimitiveId] {
        &self.unbounded
    }

    fn closest_bounded<C, F>(&self, ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        self.closest_leaves(
            ray,
            counters,
            |first, count, ray, counters| {
                offer_closest(&self.prims[first..first + count], ray, counters, hit);
            },
            |_| {},
        );
    }

    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        self.occluded_leaves(
            ray,
            counters,
            |first, count, ray, counters| {
                offer_any(&self.prims[first..first + count], ray, counters, hit)
            },
            |_| {},
        )
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            nodes: self.nodes.len(),
            leaves: self
                .nodes
                .iter()
                .flat_map(|n| (0..WIDTH).map(move |i| n.count(i)))
                .filter(|&c| c > 0)
                .count(),
            max_depth: self.max_depth,
            memory_bytes: std::mem::size_of::<Self>()
                + self.nodes.len() * std::mem::size_of::<Node8>()
                + (self.prims.len() + self.unbounded.len()) * 4,
            sah_cost: self.sah_cost,
        }
    }
}

impl WideBvh {
    /// Whether a primitive sits in more than one leaf ([`Bvh::has_repeats`]).
    pub(crate) fn has_repeats(&self) -> bool {
        self.repeats
    }

    /// Re-points every leaf of a tree from [`WideBvh::collapse`] (which has
    /// no primitive slots): `first` becomes `f(first)`, for a caller that
    /// stores the leaves' primitives its own way.
    pub(crate) fn into_leaf_storage(mut self, f: impl Fn(u32) -> u32 + Sync) -> Self {
        debug_assert!(self.prims.is_empty(), "the slots would no longer match");
        self.nodes.par_iter_mut().for_each(|n| {
            for i in 0..WIDTH {
                if n.count(i) > 0 {
                    n.child[i] = f(n.child[i]);
                }
            }
        });
        self
    }

    /// Closest-hit traversal (the unbounded primitives are the caller's):
    /// calls `leaf(first, count, ray, counters)` for every leaf the ray
    /// enters, nearest first; `leaf` shrinks `ray.tmax` to the hits it finds.
    #[inline(always)]
    pub(crate) fn closest_leaves<C, L, P>(
        &self,
        ray: Ray,
        counters: &mut C,
        leaf: L,
        prefetch_leaf: P,
    ) where
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
        P: Fn(usize),
    {
        if self.nodes.is_empty() {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if lanes::has_avx2() {
            // SAFETY: the CPU has AVX2.
            unsafe { self.closest_avx2(ray, counters, leaf, prefetch_leaf) };
            return;
        }
        self.closest_portable(ray, counters, leaf, prefetch_leaf);
    }

    /// [`WideBvh::closest_leaves`] without AVX2, out of line: inlined, its
    /// stack (kilobytes) and set-up weighed on every call of the AVX2 path.
    #[inline(never)]
    #[cold]
    fn closest_portable<C, L, P>(&self, ray: Ray, counters: &mut C, leaf: L, prefetch_leaf: P)
    where
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
        P: Fn(usize),
    {
        self.closest_in::<Portable, C, L, P>(ray, counters, leaf, prefetch_leaf);
    }

    /// Any-hit traversal (the unbounded primitives are the caller's): calls
    /// `leaf(first, count, ray, counters)` for leaves the ray enters until
    /// one returns `true`.
    #[inline(always)]
    pub(crate) fn occluded_leaves<C, L, P>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: L,
        prefetch_leaf: P,
    ) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
        P: Fn(usize),
    {
        if self.nodes.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if lanes::has_avx2() {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.occluded_avx2(ray, counters, leaf, prefetch_leaf) };
        }
        self.occluded_portable(ray, counters, leaf, prefetch_leaf)
    }

    /// [`WideBvh::occluded_leaves`] without AVX2, out of line (see
    /// [`WideBvh::closest_portable`]).
    #[inline(never)]
    #[cold]
    fn occluded_portable<C, L, P>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: L,
        prefetch_leaf: P,
    ) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
        P: Fn(usize),
    {
        self.occluded_in::<Portable, C, L, P>(ray, counters, leaf, prefetch_leaf)
    }

    /// [`WideBvh::closest_leaves`] compiled for AVX2: the whole traversal,
    /// the caller's leaf test included, so that the lane test inlines.
    ///
    /// # Safety
    /// The CPU must support AVX2 ([`lanes::has_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt")]
    unsafe fn closest_avx2<C, L, P>(&self, ray: Ray, counters: &mut C, leaf: L, prefetch_leaf: P)
    where
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
        P: Fn(usize),
    {
        use lanes::Avx2;
        self.closest_in::<Avx2, C, L, P>(ray, counters, leaf, prefetch_leaf);
    }

    /// [`WideBvh::occluded_leaves`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must support AVX2 ([`lanes::has_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt")]
    unsafe fn occluded_avx2<C, L, P>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: L,
        prefetch_leaf: P,
    ) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
        P: Fn(usize),
    {
        use lanes::Avx2;
        self.occluded_in::<Avx2, C, L, P>(ray, counters, leaf, prefetch_leaf)
    }

    /// `ray.inv_dir()` unless the ray misses the root's box (then `None`,
    /// as for an empty tree). Every child box lies inside the root's, and the
    /// slab arithmetic is monotone in the planes, so a ray turned away here
    /// would have entered no child: the answers do not change, only the
    /// cost of a miss (no set-up of the lanes, no node loaded).
    #[inline(always)]
    fn entered(&self, ray: &Ray) -> Option<Vec3> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = ray.inv_dir();
        // A ray starting inside the box (every secondary ray) skips the
        // test: skipping is always correct, and these rays would pay for a
        // test that cannot turn them away (unless `tmin` or `tmax` clip
        // them off, which the traversal finds out as well).
        let origin = Vec3A::from(ray.origin);
        if (origin.cmpge(self.bounds.min.into()) & origin.cmple(self.bounds.max.into())).all() {
            return Some(inv);
        }
        RayBox::with_inv_dir(ray, inv)
            .hit_box(&self.bounds, widen_up(ray.tmax))
            .map(|_| inv)
    }

    /// The traversal number of a child slot: its node's index for a node,
    /// `nodes.len()` plus its first primitive slot for a leaf (unique, as
    /// leaves own disjoint slots; [`crate::layout::Layout::index`] makes it dense).
    #[inline(always)]
    fn slot_number(&self, child: u32, count: u32) -> u32 {
        if count > 0 {
            self.nodes.len() as u32 + child
        } else {
            child
        }
    }

    /// Records (when `C` records) the root as skipped: the ray misses it.
    #[inline(always)]
    fn skip_root<C: Counters>(&self, counters: &mut C) {
        if C::RECORDS && !self.nodes.is_empty() {
            skip_node(counters, 0);
        }
    }

    /// Records (when `C` records) the children of `n` whose box test
    /// failed: the valid slots not in `entered`.
    #[inline(always)]
    fn skip_missed<C: Counters>(&self, counters: &mut C, n: &Node8, entered: u32) {
        if C::RECORDS {
            let mut missed = n.valid() & !entered;
            while missed != 0 {
                let lane = missed.trailing_zeros() as usize;
                missed &= missed - 1;
                skip_node(counters, self.slot_number(n.child[lane], n.count(lane)));
            }
        }
    }

    /// Node `i`, which a traversal reached through a child reference.
    #[inline(always)]
    fn node(&self, i: u32) -> &Node8 {
        debug_assert!((i as usize) < self.nodes.len());
        // SAFETY: child references name nodes of this tree: `collapse`
        // writes each node's children after pushing them, and nothing
        // changes node references afterwards (`into_leaf_storage` rewrites
        // leaf references only).
        unsafe { self.nodes.get_unchecked(i as usize) }
    }

    /// The closest-hit traversal with the box lanes `B`, on the fast path
    /// when the ray allows it (see [`BoxLanes::hit`]).
    #[inline(always)]
    fn closest_in<B, C, L, P>(&self, ray: Ray, counters: &mut C, leaf: L, prefetch_leaf: P)
    where
        B: BoxLanes,
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
        P: Fn(usize),
    {
        let Some(inv) = self.entered(&ray) else {
            self.skip_root(counters);
            return;
        };
        if needs_slow_path(&ray, inv) {
            self.closest_with::<true, B, C, L, P>(ray, inv, counters, leaf, prefetch_leaf);
        } else {
            self.closest_with::<false, B, C, L, P>(ray, inv, counters, leaf, prefetch_leaf);
        }
    }

    /// The any-hit traversal with the box lanes `B`, on the fast path when
    /// the ray allows it.
    #[inline(always)]
    fn occluded_in<B, C, L, P>(
        &self,
        ray: &Ray,
        counters: &mut C,
        leaf: L,
        prefetch_leaf: P,
    ) -> bool
    where
        B: BoxLanes,
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
        P: Fn(usize),
    {
        let Some(inv) = self.entered(ray) else {
            self.skip_root(counters);
            return false;
        };
        if needs_slow_path(ray, inv) {
            self.occluded_with::<true, B, C, L, P>(ray, inv, counters, leaf, prefetch_leaf)
        } else {
            self.occluded_with::<false, B, C, L, P>(ray, inv, counters, leaf, prefetch_leaf)
        }
    }

    #[inline(always)]
    fn closest_with<const NAN_SAFE: bool, B, C, L, P>(
        &self,
        mut ray: Ray,
        inv: Vec3,
        counters: &mut C,
        mut leaf: L,
        prefetch_leaf: P,
    ) where
        B: BoxLanes,
        C: Counters,
        L: FnMut(usize, usize, &mut Ray, &mut C),
        P: Fn(usize),
    {
        let lanes = B::new(&ray, inv);
        let order = Order::of(inv);
        let mut stack = OrderedStack::new();
        let (mut child, mut count) = (0u32, 0u32);
        // The culling distance, recomputed only when a leaf may have
        // shrunk `tmax`.
        let mut cull = widen_up(ray.tmax);
        loop {
            count_node(counters, self.slot_number(child, count));
            if count > 0 {
                leaf(child as usize, count as usize, &mut ray, counters);
                cull = widen_up(ray.tmax);
            } else {
                let n = self.node(child);
                let (tnear, bits) = lanes.hit::<NAN_SAFE>(n, cull);
                self.skip_missed(counters, n, bits);
                if bits.is_power_of_two() {
                    // One child entered (the common case deep in the tree):
                    // go there without touching the stack.
                    let lane = bits.trailing_zeros() as usize;
                    (child, count) = (n.child[lane], n.count(lane));
                    continue;
                }
                if bits != 0 {
                    // Several: pushed in the node's order for this octant,
                    // farthest first, and the nearest (on top) visited now.
                    // It was entered just now, so it needs no distance check.
                    B::push_ordered(&mut stack, n, &tnear, bits, order);
                    // SAFETY: `bits` named at least two children, all pushed.
                    (child, count) = unsafe { stack.pop_pushed() };
                    self.prefetch_next(stack.peek(), &prefetch_leaf);
                    continue;
                }
            }
            // The nearest pending child not beyond the closest hit.
            loop {
                let Some((c, k, tenter)) = stack.pop() else {
                    return;
                };
                if tenter <= cull {
                    (child, count) = (c, k);
                    break;
                }
                // Entered when pushed, but beyond the closest hit by now.
                skip_node(counters, self.slot_number(c, k));
            }
        }
    }

    #[inline(always)]
    fn occluded_with<const NAN_SAFE: bool, B, C, L, P>(
        &self,
        ray: &Ray,
        inv: Vec3,
        counters: &mut C,
        mut leaf: L,
        prefetch_leaf: P,
    ) -> bool
    where
        B: BoxLanes,
        C: Counters,
        L: FnMut(usize, usize, &Ray, &mut C) -> bool,
        P: Fn(usize),
    {
        let lanes = B::new(ray, inv);
        let wide = widen_up(ray.tmax);
        let mut stack = LaneStack::new();
        let (mut child, mut count) = (0u32, 0u32);
        loop {
            count_node(counters, self.slot_number(child, count));
            if count > 0 {
                if leaf(child as usize, count as usize, ray, counters) {
                    return true;
                }
            } else {
                let n = self.node(child);
                let (_, bits) = lanes.hit::<NAN_SAFE>(n, wide);
                self.skip_missed(counters, n, bits);
                if bits.is_power_of_two() {
                    // One child entered: go there without the stack.
                    let lane = bits.trailing_zeros() as usize;
                    (child, count) = (n.child[lane], n.count(lane));
                    continue;
                }
                if bits != 0 {
                    // Any order will do: the first blocker ends the query.
                    B::push_lanes(&mut stack, n, bits);
                    // SAFETY: `bits` named at least two children, all pushed.
                    (child, count) = unsafe { stack.pop_pushed() };
                    self.prefetch_next(stack.peek(), &prefetch_leaf);
                    continue;
                }
            }
            let Some(next) = stack.pop() else {
                return false;
            };
            (child, count) = next;
        }
    }

    /// Starts loading `next`, the child on top of the stack (the one
    /// visited after the current subtree, unless a hit culls it): its node,
    /// or through `prefetch_leaf` its first primitives. One prefetch per
    /// node with several entered children: prefetching every pushed child
    /// cost about 100 instructions a ray (buddha100k diffuse) for no
    /// measurable time.
    #[inline(always)]
    fn prefetch_next(&self, next: Option<(u32, u32)>, prefetch_leaf: &impl Fn(usize)) {
        if let Some((child, count)) = next {
            if count == 0 {
                prefetch_ptr(self.nodes.as_ptr().wrapping_add(child as usize));
            } else {
                prefetch_leaf(child as usize);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::counters::RayCounts;
    use crate::test_meshes::bumpy_grid;
    use crate::triangle::watertight::{intersect_triangle_sheared, RayShear};
    use glam::Vec3;

    /// The root-box test turns a ray away only when the root node's lane
    /// test would have entered none of its children, for rays from outside
    /// and inside, along the box's faces and edges, with zero direction
    /// components (the NaN-safe slab path) and clipped by `tmin`/`tmax`.
    #[test]
    fn the_root_box_turns_away_only_rays_that_enter_no_child() {
        let mesh = bumpy_grid(12);
        let bvh = WideBvh::build(&mesh, &BvhParams::default());
        let (lo, hi) = (bvh.bounds.min, bvh.bounds.max);
        let coords = |a: usize| {
            [
                lo[a] - 0.5,
                lo[a],
                0.5 * (lo[a] + hi[a]),
                hi[a],
                hi[a] + 0.5,
            ]
        };
        let dirs = [-1.0, -0.3, 0.0, 0.3, 1.0];
        let (mut turned_away, mut let_in) = (0, 0);
        for &x in &coords(0) {
            for &y in &coords(1) {
                for &z in &coords(2) {
                    for &dx in &dirs {
                        for &dy in &dirs {
                            for &dz in &dirs {
                                for (tmin, tmax) in [(0.0, f32::INFINITY), (0.0, 0.25), (2.0, 9.0)]
                                {
                                    let origin = Vec3::new(x, y, z);
                                    let dir = Vec3::new(dx, dy, dz);
                                    let ray = Ray::new(origin, dir, tmin, tmax);
                                    let inv = ray.inv_dir();
                                    let lanes = Portable::new(&ray, inv);
                                    let root = &bvh.nodes[0];
                                    let cull = widen_up(ray.tmax);
                                    let (_, bits) = if needs_slow_path(&ray, inv) {
                                        lanes.hit::<true>(root, cull)
                                    } else {
                                        lanes.hit::<false>(root, cull)
                                    };
                                    match bvh.entered(&ray) {
                                        None => {
                                            assert_eq!(bits, 0, "{ray:?}");
                                            turned_away += 1;
                                        }
                                        Some(got) => {
                                            assert_eq!(got.to_array(), inv.to_array());
                                            let_in += 1;
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(
            turned_away > 10_000 && let_in > 10_000,
            "{turned_away} / {let_in}"
        );
    }

    /// The AVX2 and portable traversals visit the same nodes and offer the
    /// same triangles in the same order (the property tests, on an AVX2
    /// machine, only see the AVX2 one).
    #[test]
    fn avx2_and_portable_traversals_agree() {
        let mesh = bumpy_grid(40);
        let bvh = WideBvh::build(&mesh, &BvhParams::default());
        assert!(bvh.nodes.len() > 10);
        let trace = |portable: bool, ray: &Ray| {
            let shear = RayShear::new(ray);
            let mut offered = Vec::new();
            let mut counts = RayCounts::default();
            let leaf = |first: usize, count: usize, r: &mut Ray, c: &mut RayCounts| {
                for &p in &bvh.prims[first..first + count] {
                    c.test();
                    offered.push(p);
                    let [a, b, cc] = mesh.triangle(p);
                    if let Some(h) = intersect_triangle_sheared(r, &shear, a, b, cc) {
                        r.tmax = r.tmax.min(h.t);
                    }
                }
            };
            if portable {
                bvh.closest_in::<Portable, _, _, _>(*ray, &mut counts, leaf, |_| {});
            } else {
                bvh.closest_leaves(*ray, &mut counts, leaf, |_| {});
            }
            (offered, counts)
        };
        let mut offered = 0;
        for k in 0..2000u32 {
            let f = k as f32;
            let origin = Vec3::new(0.5 + (f * 0.37).sin(), 0.5 + (f * 0.73).cos(), 2.0);
            let target = Vec3::new((f * 0.013) % 1.0, (f * 0.029) % 1.0, 0.1);
            let mut dir = target - origin;
            if k % 7 == 0 {
                dir.x = 0.0; // a zero component: the NaN-safe path
            }
            let ray = Ray::new(origin, dir, 0.0, f32::INFINITY);
            let a = trace(true, &ray);
            let b = trace(false, &ray);
            assert_eq!(a, b, "{ray:?}");
            offered += a.0.len();
        }
        assert!(offered > 2000, "only {offered} triangles offered");
    }
}
