//! Top-down builders that differ only in how they split one node: at the
//! centroid box's middle, at the median, or by binned SAH. Recursion,
//! parallelism and the depth guard are shared.

use rayon::prelude::*;

use super::{append_subtree, BvhNode, BvhParams, Ref, FORCE_MEDIAN_DEPTH};
use crate::Aabb;

/// Chunk of references binned or bounded by one task in parallel loops.
const CHUNK: usize = 1 << 14;

/// The choice for one node.
pub(super) enum Split {
    /// Make a leaf.
    Leaf,
    /// The references were reordered so that `refs[..k]` form the left child.
    At(usize),
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
    let mut nodes = Vec::with_capacity(2 * refs.len() / params.leaf_size.max(1) + 1);
    let depth = recurse(s, refs, 0, 0, params, &mut nodes);
    let order = refs.iter().map(|r| r.id).collect();
    (nodes, order, depth)
}

/// Box and centroid box of `refs`; min and max are exact, so the parallel
/// reduction gives the same answer in any order.
pub(super) fn bounds_of(refs: &[Ref]) -> (Aabb, Aabb) {
    let fold = |(b, c): (Aabb, Aabb), r: &Ref| (b.union(&r.b), c.grow(r.centroid()));
    let merge = |(b0, c0): (Aabb, Aabb), (b1, c1): (Aabb, Aabb)| (b0.union(&b1), c0.union(&c1));
    let empty = (Aabb::EMPTY, Aabb::EMPTY);
    if refs.len() > 2 * CHUNK {
        refs.par_chunks(CHUNK)
            .map(|c| c.iter().fold(empty, fold))
            .reduce(|| empty, merge)
    } else {
        refs.iter().fold(empty, fold)
    }
}

/// Builds the subtree over `refs` (which occupy primitive slots from
/// `first`) into `out`; returns the subtree's depth below `depth`.
pub(super) fn recurse<S: Splitter>(
    s: &S,
    refs: &mut [Ref],
    first: usize,
    depth: usize,
    params: &BvhParams,
    out: &mut Vec<BvhNode>,
) -> usize {
    let n = refs.len();
    let (b, cb) = bounds_of(refs);
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
    let k = match split {
        Split::Leaf => {
            out.push(BvhNode::leaf(&b, first, n));
            return depth;
        }
        // A splitter that failed to separate anything falls back to halves.
        Split::At(k) if k == 0 || k >= n => n / 2,
        Split::At(k) => k,
    };
    let me = out.len();
    out.push(BvhNode::interior(&b, 0));
    let (left, right) = refs.split_at_mut(k);
    if n >= params.parallel_threshold {
        let ((lv, ld), (rv, rd)) = rayon::join(
            || {
                let mut v = Vec::new();
                let d = recurse(s, left, first, depth + 1, params, &mut v);
                (v, d)
            },
            || {
                let mut v = Vec::new();
                let d = recurse(s, right, first + k, depth + 1, params, &mut v);
                (v, d)
            },
        );
        append_subtree(out, lv);
        out[me].offset = out.len() as u32;
        append_subtree(out, rv);
        ld.max(rd)
    } else {
        let ld = recurse(s, left, first, depth + 1, params, out);
        out[me].offset = out.len() as u32;
        let rd = recurse(s, right, first + k, depth + 1, params, out);
        ld.max(rd)
    }
}

/// Splits into halves by count along `axis`, ties broken by id so the result
/// is the same however the references arrived.
pub(super) fn median_split(refs: &mut [Ref], axis: usize) -> Split {
    let k = refs.len() / 2;
    refs.select_nth_unstable_by(k, |a, b| {
        a.centroid()[axis]
            .total_cmp(&b.centroid()[axis])
            .then(a.id.cmp(&b.id))
    });
    Split::At(k)
}

/// Moves the references satisfying `left` to the front; returns how many.
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
        Split::At(partition(refs, |r| r.centroid()[axis] < mid))
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
const MAX_BINS: usize = 64;

/// Per-axis bins: box and count of the references whose centroid falls in.
#[derive(Clone, Copy)]
struct Bins {
    b: [[Aabb; MAX_BINS]; 3],
    n: [[u32; MAX_BINS]; 3],
}

impl Bins {
    fn new() -> Self {
        Bins {
            b: [[Aabb::EMPTY; MAX_BINS]; 3],
            n: [[0; MAX_BINS]; 3],
        }
    }

    fn merge(mut self, o: &Bins, bins: usize) -> Self {
        for a in 0..3 {
            for i in 0..bins {
                self.b[a][i] = self.b[a][i].union(&o.b[a][i]);
                self.n[a][i] += o.n[a][i];
            }
        }
        self
    }
}

/// Maps centroids to bins along each axis.
#[derive(Clone, Copy)]
struct Binner {
    origin: glam::Vec3,
    scale: glam::Vec3,
    last: usize,
}

impl Binner {
    #[inline(always)]
    fn bin(&self, c: glam::Vec3, axis: usize) -> usize {
        // Float-to-int casts saturate (NaN gives 0), so this never leaves range.
        (((c[axis] - self.origin[axis]) * self.scale[axis]) as usize).min(self.last)
    }
}

/// Binned SAH over all three axes (Wald 2007): centroids are dropped into
/// `params.bins` equal-width bins per axis, and only the `bins - 1` planes
/// between bins are evaluated, making each node linear in its size.
pub(super) struct Binned;

impl Splitter for Binned {
    fn split(&self, refs: &mut [Ref], b: &Aabb, cb: &Aabb, params: &BvhParams) -> Split {
        let n = refs.len();
        let bins = params.bins.clamp(2, MAX_BINS);
        let ext = cb.max - cb.min;
        let scale = glam::Vec3::select(
            ext.cmpgt(glam::Vec3::ZERO),
            glam::Vec3::splat(bins as f32) / ext,
            glam::Vec3::ZERO,
        );
        let binner = Binner {
            origin: cb.min,
            scale,
            last: bins - 1,
        };
        let fill = |mut acc: Bins, chunk: &[Ref]| {
            for r in chunk {
                let c = r.centroid();
                for a in 0..3 {
                    let i = binner.bin(c, a);
                    acc.b[a][i] = acc.b[a][i].union(&r.b);
                    acc.n[a][i] += 1;
                }
            }
            acc
        };
        let acc = if n > 2 * CHUNK {
            refs.par_chunks(CHUNK)
                .map(|c| fill(Bins::new(), c))
                .reduce(Bins::new, |x, y| x.merge(&y, bins))
        } else {
            fill(Bins::new(), refs)
        };
        let (ct, ci) = (params.traversal_cost, params.intersection_cost);
        // Costs are compared unnormalised: multiplied through by A(node).
        let mut best: Option<(f32, usize, usize)> = None;
        for a in 0..3 {
            if scale[a] == 0.0 {
                continue;
            }
            let mut right_area = [0f32; MAX_BINS];
            let mut acc_b = Aabb::EMPTY;
            for i in (1..bins).rev() {
                acc_b = acc_b.union(&acc.b[a][i]);
                right_area[i] = acc_b.surface_area();
            }
            let mut left = Aabb::EMPTY;
            let mut nl = 0u32;
            #[allow(clippy::needless_range_loop)] // three arrays, one index
            for i in 1..bins {
                left = left.union(&acc.b[a][i - 1]);
                nl += acc.n[a][i - 1];
                let nr = n as u32 - nl;
                if nl == 0 || nr == 0 {
                    continue;
                }
                let cost = left.surface_area() * nl as f32 + right_area[i] * nr as f32;
                if best.is_none_or_gt(cost) {
                    best = Some((cost, a, i));
                }
            }
        }
        let area = b.surface_area();
        let leaf_cost = ci * n as f32 * area;
        match best {
            Some((cost, a, i)) => {
                if n <= params.max_leaf_size && leaf_cost <= ct * area + ci * cost {
                    return Split::Leaf;
                }
                Split::At(partition(refs, |r| binner.bin(r.centroid(), a) < i))
            }
            None if n <= params.max_leaf_size => Split::Leaf,
            None => median_split(refs, cb.largest_axis()),
        }
    }
}

/// `Option::is_none_or` with a strict comparison, spelled out for the MSRV.
trait BestCost {
    fn is_none_or_gt(&self, cost: f32) -> bool;
}

impl BestCost for Option<(f32, usize, usize)> {
    #[inline(always)]
    fn is_none_or_gt(&self, cost: f32) -> bool {
        match self {
            None => cost.is_finite(),
            Some((c, _, _)) => cost < *c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
