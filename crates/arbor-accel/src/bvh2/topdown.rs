//! Top-down builders that differ only in how they split one node: at the
//! centroid box's middle, at the median, or by binned SAH. Recursion,
//! parallelism and the depth guard are shared.

use rayon::prelude::*;

use glam::{Vec3, Vec4};

use super::{BvhNode, BvhParams, Ref, Subtree, FORCE_MEDIAN_DEPTH};

/// What the builders partition: a [`Ref`] alone, or one carried with the
/// primitive's geometry (spatial splits cut triangles without reading the
/// mesh again).
pub(super) trait Item: Copy + Send + Sync {
    /// The reference: id and box.
    fn reference(&self) -> &Ref;
}

impl Item for Ref {
    #[inline(always)]
    fn reference(&self) -> &Ref {
        self
    }
}
use crate::aabb::Aabb;

/// Chunk of references binned or bounded by one task in parallel loops.
pub(super) const CHUNK: usize = 1 << 14;

/// Box and centroid box of a node.
pub(super) type Bounds = (Aabb, Aabb);

/// The choice for one node.
pub(super) enum Split {
    /// Make a leaf.
    Leaf,
    /// The references were reordered so that `refs[..k]` form the left
    /// child; the children's bounds come along when the splitter knows them.
    At(usize, Option<[Bounds; 2]>),
}

/// One node's split decision.
pub(super) trait Splitter: Sync {
    /// Decides on `refs` (with box `bounds` and centroid box `cbounds`),
    /// partitioning them when splitting.
    fn split(&self, refs: &mut [Ref], bounds: &Aabb, cbounds: &Aabb, params: &BvhParams) -> Split;
}

/// Builds a tree over `refs`; returns the nodes, the primitive ids in leaf
/// order and the depth.
pub(super) fn build<S: Splitter>(
    s: &S,
    refs: &mut [Ref],
    params: &BvhParams,
) -> (Vec<BvhNode>, Vec<u32>, usize) {
    let bounds = bounds_of(refs);
    let (tree, depth) = recurse_par(s, refs, 0, 0, params, bounds);
    let nodes = tree.flatten();
    let order = if refs.len() > 2 * CHUNK {
        refs.par_iter().map(Ref::id).collect()
    } else {
        refs.iter().map(Ref::id).collect()
    };
    (nodes, order, depth)
}

/// Box and centroid box of `refs`; min and max are exact, so the parallel
/// reduction gives the same answer in any order.
pub(super) fn bounds_of<T: Item>(refs: &[T]) -> Bounds {
    let fold = |acc: [B4; 2], r: &T| {
        let r = r.reference();
        [acc[0].grow(r.min, r.max), acc[1].grow_point(r.centroid4())]
    };
    let merge = |a: [B4; 2], b: [B4; 2]| [a[0].union(&b[0]), a[1].union(&b[1])];
    let empty = [B4::EMPTY; 2];
    let [b, c] = if refs.len() > 2 * CHUNK {
        refs.par_chunks(CHUNK)
            .map(|c| c.iter().fold(empty, fold))
            .reduce(|| empty, merge)
    } else {
        refs.iter().fold(empty, fold)
    };
    (b.aabb(), c.aabb())
}

/// Decides one node: `None` for a leaf, else the split point (after
/// partitioning `refs`) and both children's bounds.
fn decide<S: Splitter>(
    s: &S,
    refs: &mut [Ref],
    depth: usize,
    params: &BvhParams,
    (b, cb): Bounds,
) -> Option<(usize, [Bounds; 2])> {
    let n = refs.len();
    let split = if n == 1 {
        Split::Leaf
    } else if depth >= FORCE_MEDIAN_DEPTH {
        // Past the depth guard: halve by count so depth stays bounded.
        if n <= params.max_leaf_size.max(params.leaf_size).max(1) {
            Split::Leaf
        } else {
            median_split(refs, cb.largest_axis())
        }
    } else {
        s.split(refs, &b, &cb, params)
    };
    let (k, child_bounds) = match split {
        Split::Leaf => return None,
        // A splitter that failed to separate anything falls back to halves.
        Split::At(k, _) if k == 0 || k >= n => (n / 2, None),
        Split::At(k, cb) => (k, cb),
    };
    let (left, right) = refs.split_at(k);
    Some((
        k,
        child_bounds.unwrap_or_else(|| [bounds_of(left), bounds_of(right)]),
    ))
}

/// Builds the subtree over `refs` (which occupy primitive slots from
/// `first`) in parallel while it is large, as a [`Subtree`] so that the
/// final layout copies every node once.
fn recurse_par<S: Splitter>(
    s: &S,
    refs: &mut [Ref],
    first: usize,
    depth: usize,
    params: &BvhParams,
    bounds: Bounds,
) -> (Subtree, usize) {
    if refs.len() < params.parallel_threshold.max(2) {
        // Rarely more than 2n nodes; reserving avoids regrowth copies.
        let mut v = Vec::with_capacity(2 * refs.len());
        let d = recurse(s, refs, first, depth, params, &mut v, bounds);
        return (Subtree::Flat(v), d);
    }
    let Some((k, [lb, rb])) = decide(s, refs, depth, params, bounds) else {
        return (
            Subtree::Flat(vec![BvhNode::leaf(&bounds.0, first, refs.len())]),
            depth,
        );
    };
    let (left, right) = refs.split_at_mut(k);
    let ((l, ld), (r, rd)) = rayon::join(
        || recurse_par(s, left, first, depth + 1, params, lb),
        || recurse_par(s, right, first + k, depth + 1, params, rb),
    );
    (Subtree::Split(bounds.0, Box::new((l, r))), ld.max(rd))
}

/// Builds the subtree over `refs` (which occupy primitive slots from
/// `first`, with the given bounds) into `out`, sequentially; returns the
/// subtree's depth.
pub(super) fn recurse<S: Splitter>(
    s: &S,
    refs: &mut [Ref],
    first: usize,
    depth: usize,
    params: &BvhParams,
    out: &mut Vec<BvhNode>,
    bounds: Bounds,
) -> usize {
    let Some((k, [lb, rb])) = decide(s, refs, depth, params, bounds) else {
        out.push(BvhNode::leaf(&bounds.0, first, refs.len()));
        return depth;
    };
    let me = out.len();
    out.push(BvhNode::interior(&bounds.0, 0));
    let (left, right) = refs.split_at_mut(k);
    let ld = recurse(s, left, first, depth + 1, params, out, lb);
    out[me].offset = out.len() as u32;
    let rd = recurse(s, right, first + k, depth + 1, params, out, rb);
    ld.max(rd)
}

/// Splits into halves by count along `axis`, ties broken by id so the result
/// is the same however the references arrived.
pub(super) fn median_split<T: Item>(refs: &mut [T], axis: usize) -> Split {
    let k = refs.len() / 2;
    refs.select_nth_unstable_by(k, |a, b| {
        let (a, b) = (a.reference(), b.reference());
        a.centroid()[axis]
            .total_cmp(&b.centroid()[axis])
            .then(a.id().cmp(&b.id()))
    });
    Split::At(k, None)
}

/// Moves the items satisfying `left` to the front; returns how many.
pub(super) fn partition<T>(items: &mut [T], mut left: impl FnMut(&T) -> bool) -> usize {
    let mut i = 0;
    let mut j = items.len();
    loop {
        while i < j && left(&items[i]) {
            i += 1;
        }
        while i < j && !left(&items[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        items.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// A box in SIMD lanes (`w` ignored), for the inner loops.
#[derive(Clone, Copy, Debug)]
pub(super) struct B4 {
    min: Vec4,
    max: Vec4,
}

impl B4 {
    const EMPTY: B4 = B4 {
        min: Vec4::splat(f32::INFINITY),
        max: Vec4::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    fn grow(&self, min: Vec4, max: Vec4) -> B4 {
        B4 {
            min: self.min.min(min),
            max: self.max.max(max),
        }
    }

    #[inline(always)]
    fn grow_point(&self, p: Vec4) -> B4 {
        self.grow(p, p)
    }

    #[inline(always)]
    fn union(&self, o: &B4) -> B4 {
        self.grow(o.min, o.max)
    }

    #[inline(always)]
    fn area(&self) -> f32 {
        // Empty boxes have negative extents; clamping gives them zero area
        // without a branch.
        let e = (self.max - self.min).max(Vec4::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    pub(super) fn aabb(&self) -> Aabb {
        Aabb::new(self.min.truncate(), self.max.truncate())
    }
}

/// Split at the middle of the centroid box's largest axis.
pub(super) struct Center;

impl Splitter for Center {
    fn split(&self, refs: &mut [Ref], _: &Aabb, cb: &Aabb, params: &BvhParams) -> Split {
        if refs.len() <= params.leaf_size.max(1) {
            return Split::Leaf;
        }
        let axis = cb.largest_axis();
        let mid = cb.min[axis] * 0.5 + cb.max[axis] * 0.5;
        if cb.max[axis] <= cb.min[axis] || !mid.is_finite() {
            // All centroids coincide along every axis: any halving will do.
            return median_split(refs, axis);
        }
        Split::At(partition(refs, |r| r.centroid()[axis] < mid), None)
    }
}

/// Equal counts along the centroid box's largest axis.
pub(super) struct Median;

impl Splitter for Median {
    fn split(&self, refs: &mut [Ref], _: &Aabb, cb: &Aabb, params: &BvhParams) -> Split {
        if refs.len() <= params.leaf_size.max(1) {
            return Split::Leaf;
        }
        median_split(refs, cb.largest_axis())
    }
}

/// Most bins supported.
const MAX_BINS: usize = 32;

/// Nodes this small are binned with 8 bins whatever `params.bins` says:
/// clearing and sweeping more bins costs more than it gains here
/// (docs/perf-log/2026-12-01-intel-build.md keeps the measurement).
pub(super) const SMALL: usize = 256;

/// Nodes from this size on bin a 1-in-4 sample.
const SAMPLE_FROM: usize = 1 << 12;

/// Per-axis bins: box and count of the references whose centroid falls in.
#[derive(Clone, Copy)]
struct Bins<const B: usize> {
    b: [[B4; B]; 3],
    n: [[u32; B]; 3],
}

impl<const B: usize> Bins<B> {
    fn new() -> Self {
        Bins {
            b: [[B4::EMPTY; B]; 3],
            n: [[0; B]; 3],
        }
    }

    fn merge(mut self, o: &Self) -> Self {
        for a in 0..3 {
            for i in 0..B {
                self.b[a][i] = self.b[a][i].union(&o.b[a][i]);
                self.n[a][i] += o.n[a][i];
            }
        }
        self
    }
}

/// Maps centroids to `B` bins along each axis (`B` a power of two).
#[derive(Clone, Copy)]
struct Binner<const B: usize> {
    origin: Vec4,
    scale: Vec4,
}

impl<const B: usize> Binner<B> {
    /// Bin coordinates along x, y, z, clamped to `[0, B - 1]`; the bin is the
    /// integer part. Comparing the unfloored value with an integer bin
    /// boundary `i` gives the same answer as comparing its floor, so the
    /// partition can skip the rounding.
    #[inline(always)]
    fn bins(&self, c: Vec4) -> Vec4 {
        // Clamping in float keeps NaN (0 * inf) out of the index: `max`
        // returns the non-NaN operand.
        ((c - self.origin) * self.scale)
            .max(Vec4::ZERO)
            .min(Vec4::splat((B - 1) as f32))
    }

    /// Bin indices along x, y, z.
    #[inline(always)]
    fn indices(&self, c: Vec4) -> [usize; 3] {
        let k = truncate(self.bins(c));
        // The clamp above keeps every index below `B` already; the mask
        // (a no-op on such values) lets the compiler drop the bounds checks
        // of the bin arrays.
        [
            k[0] as usize & (B - 1),
            k[1] as usize & (B - 1),
            k[2] as usize & (B - 1),
        ]
    }
}

/// Truncates non-negative, in-range lanes to integers with one SIMD
/// conversion (Rust's `as` casts add saturation checks per lane).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn truncate(v: Vec4) -> [i32; 4] {
    use std::arch::x86_64::{__m128, _mm_cvttps_epi32};
    let m: __m128 = v.into();
    // SAFETY: SSE2 is part of the x86_64 baseline, so the instruction exists.
    let i = unsafe { _mm_cvttps_epi32(m) };
    // SAFETY: `__m128i` and `[i32; 4]` have the same size and any bits are
    // valid for both.
    unsafe { std::mem::transmute::<std::arch::x86_64::__m128i, [i32; 4]>(i) }
}

/// Portable fallback of the SIMD truncation.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn truncate(v: Vec4) -> [i32; 4] {
    [v.x as i32, v.y as i32, v.z as i32, v.w as i32]
}

/// Binned SAH over all three axes (Wald 2007): centroids are dropped into
/// equal-width bins per axis (`params.bins` rounded up to 8, 16 or 32; 8 for
/// nodes of at most 256 references), and only the planes between bins are
/// evaluated, making each node linear in its size.
pub(super) struct Binned;

impl Splitter for Binned {
    fn split(&self, refs: &mut [Ref], b: &Aabb, cb: &Aabb, params: &BvhParams) -> Split {
        if refs.len() <= 3 {
            return tiny(refs, b, params);
        }
        let bins = if refs.len() <= SMALL {
            8
        } else {
            params.bins.clamp(2, MAX_BINS)
        };
        match bins {
            0..=8 => binned::<8>(refs, b, cb, params),
            9..=16 => binned::<16>(refs, b, cb, params),
            _ => binned::<32>(refs, b, cb, params),
        }
    }
}

/// Exact SAH for two or three references: every split separates one
/// reference from the rest, so all candidates are enumerated directly,
/// cheaper than clearing bins and better than binning.
pub(super) fn tiny<T: Item>(refs: &mut [T], b: &Aabb, params: &BvhParams) -> Split {
    let n = refs.len();
    let tests = |n: usize| leaf_tests(n as u32, params);
    let mut best = (f32::INFINITY, 0);
    for i in 0..n {
        let rest = refs
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .fold(B4::EMPTY, |acc, (_, r)| {
                acc.grow(r.reference().min, r.reference().max)
            });
        let one = B4::EMPTY.grow(refs[i].reference().min, refs[i].reference().max);
        let cost = one.area() + rest.area() * tests(n - 1);
        if cost < best.0 {
            best = (cost, i);
        }
    }
    let (cost, i) = best;
    if !cost.is_finite() {
        return if n <= params.max_leaf_size {
            Split::Leaf
        } else {
            median_split(refs, b.largest_axis())
        };
    }
    if leaf_is_cheaper(n, b, cost, params) {
        return Split::Leaf;
    }
    refs.swap(0, i);
    Split::At(1, None)
}

/// Tests a leaf or split side of `n` primitives costs:
/// `ceil(n / leaf_block)` (see [`BvhParams::leaf_block`]). Evaluated twice
/// per SAH candidate, so the usual power-of-two block is a shift, not an
/// integer division (tens of cycles each).
#[inline(always)]
pub(super) fn leaf_tests(n: u32, params: &BvhParams) -> f32 {
    let block = params.leaf_block.max(1) as u32;
    let tests = if block.is_power_of_two() {
        (n >> block.trailing_zeros()) + u32::from(n & (block - 1) != 0)
    } else {
        n.div_ceil(block)
    };
    tests as f32
}

fn binned<const B: usize>(refs: &mut [Ref], b: &Aabb, cb: &Aabb, params: &BvhParams) -> Split {
    let n = refs.len();
    // Large nodes bin every 4th reference only: the SAH over a sample of
    // thousands picks practically the same plane, and binning is the
    // costliest pass.
    let stride = if n >= SAMPLE_FROM { 4 } else { 1 };
    let Some(plan) = object_plan::<B, _>(refs, cb, params, stride) else {
        return if n <= params.max_leaf_size {
            Split::Leaf
        } else {
            median_split(refs, cb.largest_axis())
        };
    };
    // Sampled nodes are far above any leaf size, so only full bins are
    // weighed against a leaf.
    if stride == 1 && leaf_is_cheaper(n, b, plan.cost, params) {
        return Split::Leaf;
    }
    // A sampled reference on each side guarantees both sides are non-empty.
    let (k, [lb, lc, rb, rc]) = partition_bounds(refs, |c| plan.goes_left(c));
    Split::At(k, Some([(lb.aabb(), lc.aabb()), (rb.aabb(), rc.aabb())]))
}

/// Whether a leaf of `n` references in box `b` costs no more than a split
/// of (unnormalised) SAH cost `split_cost`; only nodes of at most
/// `params.max_leaf_size` references may become leaves.
pub(super) fn leaf_is_cheaper(n: usize, b: &Aabb, split_cost: f32, params: &BvhParams) -> bool {
    let (ct, ci) = (params.traversal_cost, params.intersection_cost);
    let area = b.surface_area();
    n <= params.max_leaf_size
        && ci * leaf_tests(n as u32, params) * area <= ct * area + ci * split_cost
}

/// The best centroid-binned object split of a node: where it cuts and
/// what it costs.
pub(super) struct ObjectPlan {
    /// SAH cost multiplied through by the node's area:
    /// `A(left) tests(left) + A(right) tests(right)`.
    pub cost: f32,
    /// Boxes of the two sides (of the binned references).
    pub left: Aabb,
    pub right: Aabb,
    axis: usize,
    /// The first bin of the right side.
    split: f32,
    origin: Vec4,
    scale: Vec4,
    last_bin: f32,
}

impl ObjectPlan {
    /// Whether a reference with centroid `c` belongs to the left side
    /// (the same arithmetic as the binning, so the sides are as planned).
    #[inline(always)]
    pub fn goes_left(&self, c: Vec4) -> bool {
        let bins = ((c - self.origin) * self.scale)
            .max(Vec4::ZERO)
            .min(Vec4::splat(self.last_bin));
        bins[self.axis] < self.split
    }
}

/// Bins every `stride`-th reference's centroid into `B` bins per axis and
/// sweeps the planes between bins for the cheapest SAH split; `None` when
/// no plane separates anything (all centroids in one bin on every axis).
pub(super) fn object_plan<const B: usize, T: Item>(
    refs: &[T],
    cb: &Aabb,
    params: &BvhParams,
    stride: usize,
) -> Option<ObjectPlan> {
    let n = refs.len();
    let ext = cb.max - cb.min;
    let scale = Vec3::select(
        ext.cmpgt(Vec3::ZERO),
        Vec3::splat(B as f32) / ext,
        Vec3::ZERO,
    );
    let binner = Binner::<B> {
        origin: cb.min.extend(0.0),
        scale: scale.extend(0.0),
    };
    // The sample is fixed by index (chunks start at multiples of 4), so it
    // does not depend on the thread count. Bins are filled in place: passed
    // and returned by value, they were copied (a kilobyte or two) twice per
    // node.
    let fill = |acc: &mut Bins<B>, chunk: &[T]| {
        for r in chunk.iter().step_by(stride) {
            let r = r.reference();
            let k = binner.indices(r.centroid4());
            for (a, &i) in k.iter().enumerate() {
                acc.b[a][i] = acc.b[a][i].grow(r.min, r.max);
                acc.n[a][i] += 1;
            }
        }
    };
    let mut acc = Bins::new();
    if n > 2 * CHUNK {
        acc = refs
            .par_chunks(CHUNK)
            .map(|c| {
                let mut part = Bins::new();
                fill(&mut part, c);
                part
            })
            .reduce(Bins::new, |x, y| x.merge(&y));
    } else {
        fill(&mut acc, refs);
    }
    let tests = |n: u32| leaf_tests(n, params);
    // Costs are compared unnormalised: multiplied through by A(node). The
    // three axes are swept side by side so their dependency chains overlap.
    let mut right_area = [[0f32; 3]; B];
    let mut racc = [B4::EMPTY; 3];
    for i in (1..B).rev() {
        for a in 0..3 {
            racc[a] = racc[a].union(&acc.b[a][i]);
            right_area[i][a] = racc[a].area();
        }
    }
    let total: u32 = acc.n[0].iter().sum();
    let mut best: Option<(f32, usize, usize)> = None;
    let mut best_cost = f32::INFINITY;
    let mut lacc = [B4::EMPTY; 3];
    let mut nl = [0u32; 3];
    #[allow(clippy::needless_range_loop)] // parallel arrays, one index
    for i in 1..B {
        for a in 0..3 {
            lacc[a] = lacc[a].union(&acc.b[a][i - 1]);
            nl[a] += acc.n[a][i - 1];
            let nr = total - nl[a];
            let cost = lacc[a].area() * tests(nl[a]) + right_area[i][a] * tests(nr);
            // Empty sides and flat axes are no split; strict `<` keeps the
            // first of equal candidates, so the choice is deterministic.
            if nl[a] != 0 && nr != 0 && scale[a] != 0.0 && cost < best_cost {
                best_cost = cost;
                best = Some((cost, a, i));
            }
        }
    }
    let (cost, axis, i) = best?;
    let side = |bins: &[B4]| bins.iter().fold(B4::EMPTY, |acc, b| acc.union(b)).aabb();
    Some(ObjectPlan {
        cost,
        left: side(&acc.b[axis][..i]),
        right: side(&acc.b[axis][i..]),
        axis,
        split: i as f32,
        origin: binner.origin,
        scale: binner.scale,
        last_bin: (B - 1) as f32,
    })
}

/// [`partition`] by centroid, also returning both sides' boxes and
/// centroid boxes: `[left box, left centroids, right box, right centroids]`.
pub(super) fn partition_bounds<T: Item>(
    refs: &mut [T],
    left: impl Fn(Vec4) -> bool,
) -> (usize, [B4; 4]) {
    let mut acc = [B4::EMPTY; 4];
    let add = |acc: &mut [B4; 4], side: usize, r: &T, c: Vec4| {
        let r = r.reference();
        acc[2 * side] = acc[2 * side].grow(r.min, r.max);
        acc[2 * side + 1] = acc[2 * side + 1].grow_point(c);
    };
    let mut i = 0;
    let mut j = refs.len();
    loop {
        while i < j {
            let c = refs[i].reference().centroid4();
            if !left(c) {
                break;
            }
            add(&mut acc, 0, &refs[i], c);
            i += 1;
        }
        while i < j {
            let c = refs[j - 1].reference().centroid4();
            if left(c) {
                break;
            }
            add(&mut acc, 1, &refs[j - 1], c);
            j -= 1;
        }
        if i >= j {
            return (i, acc);
        }
        // refs[i] belongs right and refs[j - 1] left: swap and account.
        refs.swap(i, j - 1);
        add(&mut acc, 0, &refs[i], refs[i].reference().centroid4());
        add(
            &mut acc,
            1,
            &refs[j - 1],
            refs[j - 1].reference().centroid4(),
        );
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_tests_is_a_ceiling_division_for_every_block() {
        // The shift path (powers of two) and the division path must agree
        // with `div_ceil`, including at the multiples and next to them.
        for block in 0..=9 {
            let params = BvhParams {
                leaf_block: block,
                ..BvhParams::default()
            };
            for n in (0..200).chain([u32::MAX - 1, u32::MAX]) {
                let want = n.div_ceil(block.max(1) as u32) as f32;
                assert_eq!(leaf_tests(n, &params), want, "n {n}, block {block}");
            }
        }
    }

    #[test]
    fn partition_moves_matches_first() {
        let mut v: Vec<u32> = (0..100).rev().collect();
        let k = partition(&mut v, |x| x % 3 == 0);
        assert_eq!(k, 34);
        assert!(v[..k].iter().all(|x| x % 3 == 0));
        assert!(v[k..].iter().all(|x| x % 3 != 0));
        let mut e: Vec<u32> = Vec::new();
        assert_eq!(partition(&mut e, |_| true), 0);
    }
}
