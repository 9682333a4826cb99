//! Parallel locally-ordered clustering (Meister and Bittner, "Parallel
//! Locally-Ordered Clustering for Bounding Volume Hierarchy Construction",
//! IEEE TVCG 2018).
//!
//! Primitives are sorted along a Morton curve; then, repeatedly, every
//! cluster finds its nearest neighbour (smallest union surface area) among
//! the `radius` clusters before and after it in that order, and mutual
//! nearest neighbours merge. Each pass is parallel and the Morton order keeps
//! the search local. The binary tree is then collapsed into leaves wherever
//! the SAH says a leaf is cheaper.

use rayon::prelude::*;

use super::topdown::{self, Median};
use super::{BvhNode, BvhParams, Ref, FORCE_MEDIAN_DEPTH};
use crate::aabb::Aabb;
use crate::morton::MortonGrid;

/// Marks a temporary node that is a single primitive.
const LEAF: u32 = u32::MAX;

/// A node of the binary clustering tree.
#[derive(Clone, Copy)]
struct Tmp {
    b: Aabb,
    left: u32,
    /// Child, or the reference index for a leaf.
    right: u32,
}

/// Builds the tree; returns nodes, primitive ids in leaf order and depth.
pub(super) fn build(refs: &[Ref], params: &BvhParams) -> (Vec<BvhNode>, Vec<u32>, usize) {
    let n = refs.len();
    let clusters = morton_order(refs);
    let mut tmp: Vec<Tmp> = refs
        .iter()
        .enumerate()
        .map(|(i, r)| Tmp {
            b: r.aabb(),
            left: LEAF,
            right: i as u32,
        })
        .collect();
    tmp.reserve(n);
    let root = cluster(&mut tmp, clusters, params);
    let collapse = sah_collapse(&tmp, params);
    emit(&tmp, &collapse, root, refs, params)
}

/// The reference indices sorted along a Morton curve of their centroids.
fn morton_order(refs: &[Ref]) -> Vec<u32> {
    let cb = refs.iter().fold(Aabb::EMPTY, |c, r| c.grow(r.centroid()));
    let grid = MortonGrid::new(&cb);
    let mut keyed: Vec<(u64, u32)> = refs
        .par_iter()
        .enumerate()
        .map(|(i, r)| (grid.code(r.centroid()), i as u32))
        .collect();
    // Keys are unique (the index breaks ties), so the order is deterministic.
    keyed.par_sort_unstable();
    keyed.iter().map(|&(_, i)| i).collect()
}

/// Merges `clusters` (nodes of `tmp`, in Morton order) pass after pass
/// until one is left, appending the merged nodes to `tmp`; returns the
/// root.
fn cluster(tmp: &mut Vec<Tmp>, mut clusters: Vec<u32>, params: &BvhParams) -> usize {
    let radius = params.ploc_radius.max(1);
    while clusters.len() > 1 {
        let nn = nearest_neighbours(tmp, &clusters, radius, params);
        let m = clusters.len();
        let mut next = Vec::with_capacity(m);
        for i in 0..m {
            let j = nn[i];
            if nn[j] == i {
                if i < j {
                    let (a, b) = (clusters[i], clusters[j]);
                    tmp.push(Tmp {
                        b: tmp[a as usize].b.union(&tmp[b as usize].b),
                        left: a,
                        right: b,
                    });
                    next.push((tmp.len() - 1) as u32);
                }
            } else {
                next.push(clusters[i]);
            }
        }
        clusters = next;
    }
    clusters[0] as usize
}

/// For every cluster, the position of its nearest neighbour (smallest
/// union surface area) among the `radius` clusters before and after it.
fn nearest_neighbours(
    tmp: &[Tmp],
    clusters: &[u32],
    radius: usize,
    params: &BvhParams,
) -> Vec<usize> {
    let m = clusters.len();
    let boxes: Vec<Aabb> = clusters.iter().map(|&c| tmp[c as usize].b).collect();
    // Distance between i and j, with the pair's indices as tie-breakers:
    // a symmetric total order, so the globally closest pair is always
    // mutual and every pass merges something.
    let key = |i: usize, j: usize| (boxes[i].union(&boxes[j]).surface_area(), i.min(j), i.max(j));
    let nearest = |i: usize| {
        let lo = i.saturating_sub(radius);
        let hi = (i + radius).min(m - 1);
        (lo..=hi)
            .filter(|&j| j != i)
            .map(|j| (key(i, j), j))
            .min_by(|(a, _), (b, _)| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))))
            .map_or(i, |(_, j)| j)
    };
    if m >= params.parallel_threshold {
        (0..m).into_par_iter().map(nearest).collect()
    } else {
        (0..m).map(nearest).collect()
    }
}

/// Bottom-up SAH: for every node of `tmp`, whether its subtree becomes one
/// leaf. Children precede parents in `tmp`, so one forward pass.
fn sah_collapse(tmp: &[Tmp], params: &BvhParams) -> Vec<bool> {
    let (ct, ci) = (
        f64::from(params.traversal_cost),
        f64::from(params.intersection_cost),
    );
    let mut count = vec![1u32; tmp.len()];
    let mut cost = vec![0f64; tmp.len()];
    let mut collapse = vec![true; tmp.len()];
    for (k, t) in tmp.iter().enumerate() {
        let a = f64::from(t.b.surface_area());
        if t.left == LEAF {
            cost[k] = ci * a;
            continue;
        }
        let (l, r) = (t.left as usize, t.right as usize);
        count[k] = count[l] + count[r];
        let split = ct * a + cost[l] + cost[r];
        let leaf = ci * a * f64::from(count[k]);
        collapse[k] = count[k] as usize <= params.max_leaf_size && leaf <= split;
        cost[k] = if collapse[k] { leaf } else { split };
    }
    collapse
}

/// Depth-first emission of the tree below `root` into the compact layout;
/// returns nodes, primitive ids in leaf order and depth.
fn emit(
    tmp: &[Tmp],
    collapse: &[bool],
    root: usize,
    refs: &[Ref],
    params: &BvhParams,
) -> (Vec<BvhNode>, Vec<u32>, usize) {
    let n = refs.len();
    let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * n);
    let mut order: Vec<Ref> = Vec::with_capacity(n);
    let mut max_depth = 0;
    // (tmp node, depth, parent slot to patch with the right child's index)
    let mut stack: Vec<(usize, usize, Option<usize>)> = vec![(root, 0, None)];
    let mut leaf_refs = Vec::new();
    while let Some((k, depth, patch)) = stack.pop() {
        if let Some(p) = patch {
            nodes[p] = BvhNode::interior(&nodes[p].aabb(), nodes.len());
        }
        let t = tmp[k];
        if collapse[k] {
            leaf_refs.clear();
            gather(tmp, k, &mut leaf_refs);
            nodes.push(BvhNode::leaf(&t.b, order.len(), leaf_refs.len()));
            order.extend(leaf_refs.iter().map(|&i| refs[i as usize]));
            max_depth = max_depth.max(depth);
        } else if depth >= FORCE_MEDIAN_DEPTH {
            // Clustering can produce long chains; rebuild such a deep subtree
            // by halving so traversal's fixed stack always suffices.
            leaf_refs.clear();
            gather(tmp, k, &mut leaf_refs);
            let mut sub: Vec<Ref> = leaf_refs.iter().map(|&i| refs[i as usize]).collect();
            let first = order.len();
            let bounds = topdown::bounds_of(&sub);
            let d = topdown::recurse(&Median, &mut sub, first, depth, params, &mut nodes, bounds);
            order.extend(sub);
            max_depth = max_depth.max(d);
        } else {
            let me = nodes.len();
            nodes.push(BvhNode::interior(&t.b, 0));
            stack.push((t.right as usize, depth + 1, Some(me)));
            stack.push((t.left as usize, depth + 1, None));
        }
    }
    (nodes, order.iter().map(Ref::id).collect(), max_depth)
}

/// Appends the reference indices of the leaves below `k`.
fn gather(tmp: &[Tmp], k: usize, out: &mut Vec<u32>) {
    let mut stack = vec![k];
    while let Some(k) = stack.pop() {
        let t = tmp[k];
        if t.left == LEAF {
            out.push(t.right);
        } else {
            stack.push(t.right as usize);
            stack.push(t.left as usize);
        }
    }
}
