//! The k-d tree: space split recursively by axis-aligned planes chosen with
//! the surface area heuristic; primitives are referenced from every leaf
//! they overlap.
//!
//! The build evaluates, per node and axis, every plane where a primitive's
//! clipped box starts or ends (an event sweep after sorting, as in Wald and
//! Havran, "On building fast kd-trees for ray tracing, and on doing that in
//! O(N log N)", 2006, but re-sorting per node: O(N log² N) overall).
//! Straddling primitives are clipped to each child with
//! [`Primitives::clipped_bounds`] ("perfect splits").

use crate::util::{offer_any, offer_closest, prepare, widen_down, widen_up, Mailbox};
use crate::{Aabb, AccelStats, Accelerator, Counters, Primitives, Ray};

/// Traversal stack entries; the depth limit stays below this.
const STACK_SIZE: usize = 64;

/// k-d tree build parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdParams {
    /// Cost of one traversal step. Default 1.
    pub traversal_cost: f32,
    /// Cost of one primitive test, relative to a traversal step. Default 80
    /// (as in pbrt), which favours splitting until leaves are nearly single
    /// primitives.
    pub intersection_cost: f32,
    /// Fraction of the cost waived for a split that cuts off empty space.
    /// Default 0.5.
    pub empty_bonus: f32,
    /// Deepest leaf; `None` for `round(8 + 1.3 log2 N)`. Capped at 60.
    pub max_depth: Option<usize>,
    /// Subtrees with at least this many references are built in parallel.
    /// Results do not depend on it. Default 1024.
    pub parallel_threshold: usize,
}

impl Default for KdParams {
    fn default() -> Self {
        KdParams {
            traversal_cost: 1.0,
            intersection_cost: 80.0,
            empty_bonus: 0.5,
            max_depth: None,
            parallel_threshold: 1024,
        }
    }
}

/// An 8-byte node. Interior: `a` holds the split position's bits and `b`
/// the above child's index shifted left by 2, or-ed with the axis (the below
/// child follows the node). Leaf: `a` is the first primitive slot and `b` the
/// count shifted left by 2, or-ed with 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KdNode {
    a: u32,
    b: u32,
}

impl KdNode {
    fn leaf(first: usize, count: usize) -> Self {
        KdNode {
            a: first as u32,
            b: (count as u32) << 2 | 3,
        }
    }

    fn interior(axis: usize, split: f32, above: usize) -> Self {
        KdNode {
            a: split.to_bits(),
            b: (above as u32) << 2 | axis as u32,
        }
    }

    #[inline(always)]
    fn is_leaf(&self) -> bool {
        self.b & 3 == 3
    }
}

/// A k-d tree over any [`Primitives`].
#[derive(Clone, Debug, Default)]
pub struct KdTree {
    bounds: Aabb,
    nodes: Vec<KdNode>,
    prims: Vec<u32>,
    unbounded: Vec<u32>,
    max_depth: usize,
    sah_cost: Option<f64>,
}

/// Everything a node's build needs besides its references.
struct Ctx<'a, P: ?Sized> {
    prims: &'a P,
    params: KdParams,
    max_depth: usize,
}

/// A built subtree: nodes (above-child indices relative to its first node)
/// and primitive slots (leaf offsets relative to its first slot).
#[derive(Default)]
struct Sub {
    nodes: Vec<KdNode>,
    prims: Vec<u32>,
    depth: usize,
}

impl Sub {
    /// Appends `other`, shifting its indices.
    fn append(&mut self, other: Sub) {
        let (nb, pb) = (self.nodes.len() as u32, self.prims.len() as u32);
        self.nodes.extend(other.nodes.into_iter().map(|mut n| {
            if n.is_leaf() {
                n.a += pb;
            } else {
                n.b += nb << 2;
            }
            n
        }));
        self.prims.extend(other.prims);
        self.depth = self.depth.max(other.depth);
    }
}

impl KdTree {
    /// Builds a tree over `prims`. Primitives with empty boxes are left out;
    /// those with NaN or infinite boxes are offered to every ray.
    pub fn build<P: Primitives + ?Sized>(prims: &P, params: &KdParams) -> Self {
        let prep = prepare(prims);
        let mut tree = KdTree {
            unbounded: prep.unbounded,
            ..KdTree::default()
        };
        if prep.refs.is_empty() {
            return tree;
        }
        let n = prep.refs.len();
        let auto = (8.0 + 1.3 * (n as f64).log2()).round() as usize;
        let ctx = Ctx {
            prims,
            params: *params,
            max_depth: params.max_depth.unwrap_or(auto).min(60),
        };
        let sub = build_node(&ctx, prep.bounds, prep.refs, 0, 0);
        tree.bounds = prep.bounds;
        tree.nodes = sub.nodes;
        tree.prims = sub.prims;
        tree.max_depth = sub.depth;
        tree.sah_cost = tree.compute_sah();
        tree
    }

    /// `(Σ_interior A(n) + Σ_leaf A(l)·|l|) / A(root)`: the same normalised
    /// SAH as the BVHs report (traversal and intersection cost 1), counting
    /// a primitive once per leaf that references it.
    fn compute_sah(&self) -> Option<f64> {
        let root = f64::from(self.bounds.surface_area());
        if !(root > 0.0 && root.is_finite()) {
            return None;
        }
        let mut sum = 0.0;
        let mut stack = vec![(0usize, self.bounds)];
        while let Some((i, b)) = stack.pop() {
            let n = self.nodes[i];
            let a = f64::from(b.surface_area());
            if n.is_leaf() {
                sum += a * f64::from(n.b >> 2);
            } else {
                sum += a;
                let axis = (n.b & 3) as usize;
                let split = f32::from_bits(n.a);
                let (mut lo, mut hi) = (b, b);
                lo.max[axis] = split;
                hi.min[axis] = split;
                stack.push((i + 1, lo));
                stack.push(((n.b >> 2) as usize, hi));
            }
        }
        Some(sum / root)
    }
}

/// Builds the subtree for `items` (primitive, box clipped to `bounds`).
fn build_node<P: Primitives + ?Sized>(
    ctx: &Ctx<P>,
    bounds: Aabb,
    items: Vec<(u32, Aabb)>,
    depth: usize,
    bad_refines: u32,
) -> Sub {
    let n = items.len();
    let leaf = |items: Vec<(u32, Aabb)>| Sub {
        nodes: vec![KdNode::leaf(0, items.len())],
        prims: items.into_iter().map(|(id, _)| id).collect(),
        depth,
    };
    if n <= 1 || depth >= ctx.max_depth {
        return leaf(items);
    }
    let p = &ctx.params;
    let (ct, ci) = (p.traversal_cost, p.intersection_cost);
    let area = bounds.surface_area();
    let inv_area = 1.0 / area;
    let ext = bounds.extent();
    // (cost, axis, position, planar primitives go left)
    let mut best: Option<(f32, usize, f32, bool)> = None;
    let mut events: Vec<(f32, u8)> = Vec::with_capacity(2 * n);
    for axis in 0..3 {
        events.clear();
        for (_, b) in &items {
            if b.min[axis] == b.max[axis] {
                events.push((b.min[axis], 1));
            } else {
                events.push((b.min[axis], 2));
                events.push((b.max[axis], 0));
            }
        }
        // Ends before planars before starts at equal positions.
        events.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
        let cap = 2.0 * ext[o1] * ext[o2];
        let perim = 2.0 * (ext[o1] + ext[o2]);
        let (mut nl, mut nr) = (0usize, n);
        let mut i = 0;
        while i < events.len() {
            let pos = events[i].0;
            let (mut pe, mut pp, mut ps) = (0, 0, 0);
            while i < events.len() && events[i].0 == pos {
                match events[i].1 {
                    0 => pe += 1,
                    1 => pp += 1,
                    _ => ps += 1,
                }
                i += 1;
            }
            nr -= pe + pp;
            if pos > bounds.min[axis] && pos < bounds.max[axis] {
                let al = (cap + perim * (pos - bounds.min[axis])) * inv_area;
                let ar = (cap + perim * (bounds.max[axis] - pos)) * inv_area;
                for planar_left in [true, false] {
                    let (l, r) = if planar_left {
                        (nl + pp, nr)
                    } else {
                        (nl, nr + pp)
                    };
                    let bonus = if l == 0 || r == 0 { p.empty_bonus } else { 0.0 };
                    let cost = ct + ci * (1.0 - bonus) * (al * l as f32 + ar * r as f32);
                    let better = match best {
                        None => cost.is_finite(),
                        Some((c, ..)) => cost < c,
                    };
                    if better {
                        best = Some((cost, axis, pos, planar_left));
                    }
                }
            }
            nl += ps + pp;
        }
    }
    let leaf_cost = ci * n as f32;
    let Some((cost, axis, pos, planar_left)) = best else {
        return leaf(items);
    };
    let bad_refines = bad_refines + u32::from(cost > leaf_cost);
    if (cost > 4.0 * leaf_cost && n < 16) || bad_refines >= 3 {
        return leaf(items);
    }
    let (mut below_box, mut above_box) = (bounds, bounds);
    below_box.max[axis] = pos;
    above_box.min[axis] = pos;
    let mut below = Vec::new();
    let mut above = Vec::new();
    for (id, b) in items {
        let (lo, hi) = (b.min[axis], b.max[axis]);
        if lo == pos && hi == pos {
            if planar_left {
                below.push((id, b));
            } else {
                above.push((id, b));
            }
        } else if hi <= pos {
            below.push((id, b));
        } else if lo >= pos {
            above.push((id, b));
        } else {
            // Straddles: keep only where the primitive really is.
            for (side, cb) in [(&mut below, &below_box), (&mut above, &above_box)] {
                if let Some(c) = ctx.prims.clipped_bounds(id as usize, cb) {
                    let c = c.intersection(&b);
                    if !c.is_empty() {
                        side.push((id, c));
                    }
                }
            }
        }
    }
    let (l, r) = if n >= ctx.params.parallel_threshold {
        rayon::join(
            || build_node(ctx, below_box, below, depth + 1, bad_refines),
            || build_node(ctx, above_box, above, depth + 1, bad_refines),
        )
    } else {
        (
            build_node(ctx, below_box, below, depth + 1, bad_refines),
            build_node(ctx, above_box, above, depth + 1, bad_refines),
        )
    };
    let mut sub = Sub {
        nodes: vec![KdNode::interior(axis, pos, 0)],
        prims: Vec::new(),
        depth,
    };
    sub.append(l);
    let above_index = sub.nodes.len();
    sub.nodes[0] = KdNode::interior(axis, pos, above_index);
    sub.append(r);
    sub
}

impl KdTree {
    /// Walks the leaves the ray passes, front to back, calling `visit` with
    /// each leaf's primitives and the current ray (which `visit` may shrink)
    /// until it returns `true`. Subtrees entered beyond `ray.tmax` are culled.
    ///
    /// Each node's parameter interval is widened by the rounding bound of
    /// the split distance, so every leaf's interval contains the exact one
    /// and culling against the exact hit distance never drops a closer hit.
    #[inline(always)]
    fn walk<C: Counters>(
        &self,
        ray: &mut Ray,
        counters: &mut C,
        mut visit: impl FnMut(&[u32], &mut Ray, &mut C) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = ray.inv_dir();
        let wide = Ray {
            tmax: widen_up(ray.tmax),
            ..*ray
        };
        let Some((t0, t1)) = self.bounds.intersect(&wide, inv) else {
            return;
        };
        let mut stack = [(0u32, 0f32, 0f32); STACK_SIZE];
        let mut sp = 0;
        let (mut node, mut ta, mut tb) = (0usize, widen_down(t0), t1);
        loop {
            if ta <= ray.tmax {
                counters.node();
                let n = self.nodes[node];
                if n.is_leaf() {
                    let first = n.a as usize;
                    let prims = &self.prims[first..first + (n.b >> 2) as usize];
                    if visit(prims, ray, counters) {
                        return;
                    }
                } else {
                    let axis = (n.b & 3) as usize;
                    let split = f32::from_bits(n.a);
                    let (below, above) = (node + 1, (n.b >> 2) as usize);
                    let ts = (split - ray.origin[axis]) * inv[axis];
                    let (first, second, i1, i2) = if ts.is_nan() {
                        // The ray runs inside the split plane: both sides.
                        (below, above, (ta, tb), (ta, tb))
                    } else {
                        let (lo, hi) = (widen_down(ts), widen_up(ts));
                        let near = (ta, tb.min(hi));
                        let far = (ta.max(lo), tb);
                        if inv[axis] >= 0.0 {
                            (below, above, near, far)
                        } else {
                            (above, below, near, far)
                        }
                    };
                    let go_first = i1.0 <= i1.1;
                    if i2.0 <= i2.1 {
                        if go_first {
                            stack[sp] = (second as u32, i2.0, i2.1);
                            sp += 1;
                        } else {
                            node = second;
                            (ta, tb) = i2;
                            continue;
                        }
                    }
                    if go_first {
                        node = first;
                        (ta, tb) = i1;
                        continue;
                    }
                }
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            let (nd, a, b) = stack[sp];
            node = nd as usize;
            (ta, tb) = (a, b);
        }
    }
}

impl Accelerator for KdTree {
    fn closest<C, F>(&self, ray: &Ray, counters: &mut C, mut hit: F)
    where
        C: Counters,
        F: FnMut(u32, &Ray) -> Option<f32>,
    {
        let mut ray = *ray;
        offer_closest(&self.unbounded, &mut ray, counters, &mut hit);
        let mut mailbox = Mailbox::new();
        // A hit found here may lie beyond this leaf (the primitive reaches
        // into later leaves); the walk's culling by `tmax` only stops once
        // every remaining node starts beyond it, so no early exit is needed.
        self.walk(&mut ray, counters, |prims, ray, counters| {
            for &p in prims {
                if mailbox.insert(p) {
                    counters.test();
                    if let Some(t) = hit(p, ray) {
                        ray.tmax = ray.tmax.min(t);
                    }
                }
            }
            false
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
        let mut found = false;
        let mut mailbox = Mailbox::new();
        let mut walk_ray = *ray;
        self.walk(&mut walk_ray, counters, |prims, r, counters| {
            for &p in prims {
                if mailbox.insert(p) {
                    counters.test();
                    if hit(p, r) {
                        found = true;
                        return true;
                    }
                }
            }
            false
        });
        found
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            nodes: self.nodes.len(),
            leaves: self.nodes.iter().filter(|n| n.is_leaf()).count(),
            max_depth: self.max_depth,
            memory_bytes: std::mem::size_of::<Self>()
                + self.nodes.len() * std::mem::size_of::<KdNode>()
                + (self.prims.len() + self.unbounded.len()) * 4,
            sah_cost: self.sah_cost,
        }
    }
}

/// The box of node `index`'s region is not stored; this helper exists for
/// tests that check every primitive is referenced where it lies.
#[cfg(test)]
fn leaves_with_boxes(t: &KdTree) -> Vec<(Aabb, Vec<u32>)> {
    let mut out = Vec::new();
    let mut stack = vec![(0usize, t.bounds)];
    while let Some((i, b)) = stack.pop() {
        let n = t.nodes[i];
        if n.is_leaf() {
            let f = n.a as usize;
            out.push((b, t.prims[f..f + (n.b >> 2) as usize].to_vec()));
        } else {
            let axis = (n.b & 3) as usize;
            let s = f32::from_bits(n.a);
            let (mut lo, mut hi) = (b, b);
            lo.max[axis] = s;
            hi.min[axis] = s;
            stack.push((i + 1, lo));
            stack.push(((n.b >> 2) as usize, hi));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{List, NoCounters, TriangleMesh, Vec3};

    fn soup() -> TriangleMesh {
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..400u32 {
            let f = i as f32;
            let c = Vec3::new(
                (f * 0.618).fract(),
                (f * 0.414).fract(),
                (f * 0.732).fract(),
            ) * 10.0;
            v.push(c);
            v.push(c + Vec3::new((f * 1.3).sin(), 0.5, (f * 0.7).cos()));
            v.push(c + Vec3::new(0.3, (f * 2.1).cos(), 0.8));
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        TriangleMesh::new(v, t)
    }

    #[test]
    fn kdtree_matches_list() {
        let m = soup();
        let kd = KdTree::build(&m, &KdParams::default());
        let s = kd.stats();
        assert!(s.leaves > 100 && s.max_depth <= 60, "{s:?}");
        let list = List::build(&m);
        for k in 0..400 {
            let f = k as f32;
            let o = Vec3::new(
                (f * 0.11).fract() * 14.0 - 2.0,
                -3.0,
                (f * 0.91).fract() * 12.0,
            );
            let d = Vec3::new((f * 0.7).sin(), 1.0, (f * 0.3).cos());
            let r = Ray::new(o, d, 0.0, f32::INFINITY);
            let mut best = [f32::INFINITY; 2];
            kd.closest(&r, &mut NoCounters, |p, ray| {
                let t = m.intersect(p as usize, ray)?.t;
                best[0] = best[0].min(t);
                Some(t)
            });
            list.closest(&r, &mut NoCounters, |p, ray| {
                let t = m.intersect(p as usize, ray)?.t;
                best[1] = best[1].min(t);
                Some(t)
            });
            assert_eq!(best[0], best[1], "ray {k}");
            let test = |p: u32, ray: &Ray| m.intersect(p as usize, ray).is_some();
            assert_eq!(
                kd.occluded(&r, &mut NoCounters, test),
                list.occluded(&r, &mut NoCounters, test)
            );
        }
    }

    #[test]
    fn perfect_splits_place_triangles_only_where_they_are() {
        let m = soup();
        let kd = KdTree::build(&m, &KdParams::default());
        for (b, prims) in leaves_with_boxes(&kd) {
            for p in prims {
                assert!(m.clipped_bounds(p as usize, &b).is_some());
            }
        }
    }

    #[test]
    fn degenerate_inputs() {
        let none: Vec<Aabb> = Vec::new();
        let t = KdTree::build(&none, &KdParams::default());
        let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0);
        assert!(!t.occluded(&r, &mut NoCounters, |_, _| true));
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 50];
        let t = KdTree::build(&same, &KdParams::default());
        let mut n = 0;
        t.closest(&r, &mut NoCounters, |_, _| {
            n += 1;
            None
        });
        assert_eq!(n, 50);
        // Flat boxes in one plane, and a ray inside that plane.
        let flat: Vec<Aabb> = (0..40)
            .map(|i| {
                let x = i as f32;
                Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.5, 1.0, 0.0))
            })
            .collect();
        let t = KdTree::build(&flat, &KdParams::default());
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.0), Vec3::X, 0.0, f32::INFINITY);
        let mut n = 0;
        t.closest(&r, &mut NoCounters, |_, _| {
            n += 1;
            None
        });
        assert_eq!(n, 40);
    }
}
