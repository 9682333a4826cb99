//! Full-sweep SAH builder: the references are sorted by centroid once per
//! axis, and every node sweeps all three orders to evaluate the SAH at every
//! split between neighbouring primitives. Children inherit sorted orders by a
//! stable partition, so the build is O(N log N) after the initial sorts.

use rayon::prelude::*;

use super::{BvhNode, BvhParams, Ref, Subtree, FORCE_MEDIAN_DEPTH};
use crate::aabb::Aabb;

/// Shared, read-only per-reference data; orders hold indices into it.
struct Data<'a> {
    refs: &'a [Ref],
    centroids: Vec<glam::Vec3>,
}

impl Data<'_> {
    /// The sort key along `axis`: centroid, then index for a total order.
    #[inline(always)]
    fn less(&self, axis: usize, a: u32, b: u32) -> bool {
        let (ca, cb) = (
            self.centroids[a as usize][axis],
            self.centroids[b as usize][axis],
        );
        match ca.total_cmp(&cb) {
            std::cmp::Ordering::Less => true,
            std::cmp::Ordering::Greater => false,
            std::cmp::Ordering::Equal => a < b,
        }
    }
}

/// Scratch buffers of one sequential subtree.
#[derive(Default)]
struct Scratch {
    area: Vec<f32>,
    idx: Vec<u32>,
}

/// Builds the tree; returns nodes, primitive ids in leaf order and depth.
pub(super) fn build(refs: &[Ref], params: &BvhParams) -> (Vec<BvhNode>, Vec<u32>, usize) {
    let data = Data {
        refs,
        centroids: refs.iter().map(Ref::centroid).collect(),
    };
    let n = refs.len() as u32;
    let mut orders: [Vec<u32>; 3] = std::array::from_fn(|axis| {
        let mut o: Vec<u32> = (0..n).collect();
        o.par_sort_unstable_by(|&a, &b| {
            data.centroids[a as usize][axis]
                .total_cmp(&data.centroids[b as usize][axis])
                .then(a.cmp(&b))
        });
        o
    });
    let [o0, o1, o2] = &mut orders;
    let (tree, depth) = recurse_par(&data, [o0, o1, o2], 0, 0, params);
    let nodes = tree.flatten();
    let order = orders[0].iter().map(|&i| refs[i as usize].id()).collect();
    (nodes, order, depth)
}

/// Decides one node over `orders` (the same set in each axis' order):
/// returns the node's box and, unless it becomes a leaf, the split position
/// after stably partitioning all three orders.
fn decide(
    data: &Data,
    orders: &mut [&mut [u32]; 3],
    depth: usize,
    params: &BvhParams,
    scratch: &mut Scratch,
) -> (Aabb, Option<usize>) {
    let n = orders[0].len();
    let b = orders[0]
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.union(&data.refs[i as usize].aabb()));
    let area = b.surface_area();
    let (ct, ci) = (params.traversal_cost, params.intersection_cost);
    let mut best: Option<(f32, usize, usize)> = None;
    if n > 1 && depth < FORCE_MEDIAN_DEPTH {
        scratch.area.resize(n, 0.0);
        for (axis, order) in orders.iter().enumerate() {
            // Right-to-left: area of everything from position i on.
            let mut acc = Aabb::EMPTY;
            for i in (1..n).rev() {
                acc = acc.union(&data.refs[order[i] as usize].aabb());
                scratch.area[i] = acc.surface_area();
            }
            let mut left = Aabb::EMPTY;
            for i in 1..n {
                left = left.union(&data.refs[order[i - 1] as usize].aabb());
                let cost = left.surface_area() * i as f32 + scratch.area[i] * (n - i) as f32;
                let better = match best {
                    None => cost.is_finite(),
                    Some((c, _, _)) => cost < c,
                };
                if better {
                    best = Some((cost, axis, i));
                }
            }
        }
    }
    let split = match best {
        _ if n == 1 => None,
        Some((cost, axis, k)) => {
            let leaf = n <= params.max_leaf_size && ci * n as f32 * area <= ct * area + ci * cost;
            (!leaf).then_some((axis, k))
        }
        None if n <= params.max_leaf_size.max(1) => None,
        // Past the depth guard or without a finite cost: halve the longest
        // order, which is as valid a split as any.
        None => {
            let cb = orders[0]
                .iter()
                .fold(Aabb::EMPTY, |c, &i| c.grow(data.centroids[i as usize]));
            Some((cb.largest_axis(), n / 2))
        }
    };
    let Some((axis, k)) = split else {
        return (b, None);
    };
    // Stable partition of the other two orders: the left side is exactly the
    // references that sort before the first right one along `axis`.
    let pivot = orders[axis][k];
    for (a, order) in orders.iter_mut().enumerate() {
        if a == axis {
            continue;
        }
        scratch.idx.clear();
        let mut w = 0;
        for i in 0..n {
            let e = order[i];
            if data.less(axis, e, pivot) {
                order[w] = e;
                w += 1;
            } else {
                scratch.idx.push(e);
            }
        }
        debug_assert_eq!(w, k);
        order[w..].copy_from_slice(&scratch.idx);
    }
    (b, Some(k))
}

type Orders<'a> = [&'a mut [u32]; 3];

/// Splits three orders at `k`.
fn split_orders(orders: Orders<'_>, k: usize) -> (Orders<'_>, Orders<'_>) {
    let [o0, o1, o2] = orders;
    let (l0, r0) = o0.split_at_mut(k);
    let (l1, r1) = o1.split_at_mut(k);
    let (l2, r2) = o2.split_at_mut(k);
    ([l0, l1, l2], [r0, r1, r2])
}

/// Parallel recursion over large subtrees, as a [`Subtree`].
fn recurse_par(
    data: &Data,
    mut orders: [&mut [u32]; 3],
    first: usize,
    depth: usize,
    params: &BvhParams,
) -> (Subtree, usize) {
    let n = orders[0].len();
    if n < params.parallel_threshold.max(2) {
        let mut v = Vec::new();
        let d = recurse(
            data,
            orders,
            first,
            depth,
            params,
            &mut v,
            &mut Scratch::default(),
        );
        return (Subtree::Flat(v), d);
    }
    let (b, split) = decide(data, &mut orders, depth, params, &mut Scratch::default());
    let Some(k) = split else {
        return (Subtree::Flat(vec![BvhNode::leaf(&b, first, n)]), depth);
    };
    let (l, r) = split_orders(orders, k);
    let ((lt, ld), (rt, rd)) = rayon::join(
        || recurse_par(data, l, first, depth + 1, params),
        || recurse_par(data, r, first + k, depth + 1, params),
    );
    (Subtree::Split(b, Box::new((lt, rt))), ld.max(rd))
}

/// Sequential recursion into `out`.
fn recurse(
    data: &Data,
    mut orders: [&mut [u32]; 3],
    first: usize,
    depth: usize,
    params: &BvhParams,
    out: &mut Vec<BvhNode>,
    scratch: &mut Scratch,
) -> usize {
    let n = orders[0].len();
    let (b, split) = decide(data, &mut orders, depth, params, scratch);
    let Some(k) = split else {
        out.push(BvhNode::leaf(&b, first, n));
        return depth;
    };
    let me = out.len();
    out.push(BvhNode::interior(&b, 0));
    let (l, r) = split_orders(orders, k);
    let ld = recurse(data, l, first, depth + 1, params, out, scratch);
    out[me].offset = out.len() as u32;
    let rd = recurse(data, r, first + k, depth + 1, params, out, scratch);
    ld.max(rd)
}
