//! Full-sweep SAH builder: the references are sorted by centroid once per
//! axis, and every node sweeps all three orders to evaluate the SAH at every
//! split between neighbouring primitives. Children inherit sorted orders by a
//! stable partition, so the build is O(N log N) after the initial sorts.

use rayon::prelude::*;

use super::{append_subtree, BvhNode, BvhParams, Ref, FORCE_MEDIAN_DEPTH};
use crate::Aabb;

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
    let mut nodes = Vec::new();
    let depth = recurse(
        &data,
        [o0, o1, o2],
        0,
        0,
        params,
        &mut nodes,
        &mut Scratch::default(),
    );
    let order = orders[0].iter().map(|&i| refs[i as usize].id()).collect();
    (nodes, order, depth)
}

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
        out.push(BvhNode::leaf(&b, first, n));
        return depth;
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
    let me = out.len();
    out.push(BvhNode::interior(&b, 0));
    let [o0, o1, o2] = orders;
    let (l0, r0) = o0.split_at_mut(k);
    let (l1, r1) = o1.split_at_mut(k);
    let (l2, r2) = o2.split_at_mut(k);
    if n >= params.parallel_threshold {
        let ((lv, ld), (rv, rd)) = rayon::join(
            || {
                let mut v = Vec::new();
                let d = recurse(
                    data,
                    [l0, l1, l2],
                    first,
                    depth + 1,
                    params,
                    &mut v,
                    &mut Scratch::default(),
                );
                (v, d)
            },
            || {
                let mut v = Vec::new();
                let d = recurse(
                    data,
                    [r0, r1, r2],
                    first + k,
                    depth + 1,
                    params,
                    &mut v,
                    &mut Scratch::default(),
                );
                (v, d)
            },
        );
        append_subtree(out, lv);
        out[me].offset = out.len() as u32;
        append_subtree(out, rv);
        ld.max(rd)
    } else {
        let ld = recurse(data, [l0, l1, l2], first, depth + 1, params, out, scratch);
        out[me].offset = out.len() as u32;
        let rd = recurse(
            data,
            [r0, r1, r2],
            first + k,
            depth + 1,
            params,
            out,
            scratch,
        );
        ld.max(rd)
    }
}
