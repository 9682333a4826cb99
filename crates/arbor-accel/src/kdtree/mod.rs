//! The k-d tree: space split recursively by axis-aligned planes chosen with
//! the surface area heuristic; primitives are referenced from every leaf
//! they overlap.
//!
//! The build ([`build`]) is Wald and Havran's O(N log N) event sweep with
//! perfect splits: straddling primitives are clipped to each child with
//! [`Primitives::clipped_bounds`], so a leaf references a primitive only
//! where it really is. The traversal ([`traverse`]) walks the leaves front to
//! back with a short stack of conservative parameter intervals.

mod build;
mod traverse;

use crate::aabb::Aabb;
use crate::layout::{Layout, LayoutNode};
use crate::primitives::Primitives;
use crate::util::prepare;

/// Traversal stack entries. The build's depth limit stays below this (a
/// path pushes at most one entry per level).
const STACK_SIZE: usize = 64;

/// Deepest leaf the build may create, whatever the parameters say.
const DEPTH_CAP: usize = STACK_SIZE - 4;

/// k-d tree build parameters.
///
/// The SAH estimate of a split is `(1 - bonus) · (c_t + c_i · (A_b/A · N_b
/// + A_a/A · N_a))`, that of a leaf `c_i · N`; a node becomes a leaf when no
/// split is cheaper. Only the ratio `c_i / c_t` and the bonus matter for the
/// tree's shape. The defaults were chosen by measuring traversal cost and
/// memory on buddha100k's diffuse rays (`docs/acceleration.md`, "k-d tree").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdParams {
    /// Cost of one traversal step (`c_t`). Default 1.
    pub traversal_cost: f32,
    /// Cost of one primitive test relative to a traversal step (`c_i`).
    /// Default 1.5.
    pub intersection_cost: f32,
    /// Fraction of the cost waived for a split that leaves one side empty.
    /// Default 0.2.
    pub empty_bonus: f32,
    /// Deepest leaf; `None` for `round(8 + 1.3 log2 N)`. Capped at 60.
    pub max_depth: Option<usize>,
    /// Nodes with at least this many references are split with parallel
    /// passes and their children built in parallel. Results do not depend
    /// on it. Default 1024.
    pub parallel_threshold: usize,
}

impl Default for KdParams {
    fn default() -> Self {
        KdParams {
            traversal_cost: 1.0,
            intersection_cost: 1.5,
            empty_bonus: 0.2,
            max_depth: None,
            parallel_threshold: 1024,
        }
    }
}

/// An 8-byte node.
///
/// Interior: `a` holds the split position's bits, `b` the index of the
/// first of its two adjacent children (below, then above) shifted left by 2,
/// or-ed with the axis. Leaf: `b` is the primitive count shifted left by 2,
/// or-ed with 3; `a` is the primitive itself when the count is 1 (no
/// indirection), otherwise the first slot in the primitive list.
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

    fn interior(axis: usize, split: f32, children: usize) -> Self {
        KdNode {
            a: split.to_bits(),
            b: (children as u32) << 2 | axis as u32,
        }
    }

    #[inline(always)]
    fn is_leaf(&self) -> bool {
        self.b & 3 == 3
    }

    #[inline(always)]
    fn count(&self) -> usize {
        (self.b >> 2) as usize
    }

    #[inline(always)]
    fn axis(&self) -> usize {
        (self.b & 3) as usize
    }

    #[inline(always)]
    fn split(&self) -> f32 {
        f32::from_bits(self.a)
    }

    #[inline(always)]
    fn children(&self) -> u32 {
        self.b >> 2
    }

    /// A leaf's primitives (`a` itself for a single one).
    #[inline(always)]
    fn leaf_prims<'a>(&'a self, prims: &'a [u32]) -> &'a [u32] {
        if self.count() == 1 {
            std::slice::from_ref(&self.a)
        } else {
            &prims[self.a as usize..self.a as usize + self.count()]
        }
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

impl KdTree {
    /// The nodes for drawing, numbered as traversal reports them; a node's
    /// box is its region of space (the tree's box cut by the splits above).
    pub fn layout(&self) -> Layout {
        let mut nodes = vec![LayoutNode::default(); self.nodes.len()];
        let mut todo = if self.nodes.is_empty() {
            vec![]
        } else {
            vec![(0usize, self.bounds, 0u32)]
        };
        while let Some((i, b, depth)) = todo.pop() {
            let n = self.nodes[i];
            let out = &mut nodes[i];
            (out.bounds, out.depth) = (b, depth);
            if n.is_leaf() {
                out.primitives = n.count() as u32;
                continue;
            }
            let (axis, split, c) = (n.axis(), n.split(), n.children());
            out.split = Some((axis as u8, split));
            out.children = vec![c, c + 1];
            let (mut below, mut above) = (b, b);
            below.max[axis] = split;
            above.min[axis] = split;
            todo.push((c as usize, below, depth + 1));
            todo.push((c as usize + 1, above, depth + 1));
        }
        Layout::Tree {
            nodes,
            leaf_slots: Vec::new(),
            leaf_base: 0,
        }
    }
}

impl KdTree {
    /// Builds a tree over `prims`. Primitives with empty boxes are left out;
    /// those with NaN or infinite boxes are offered to every ray. The same
    /// input always gives the same tree, whatever the thread count.
    ///
    /// # Panics
    ///
    /// With more than 2^30 primitives (events number references in 30 bits).
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
        let ctx = build::Ctx {
            prims,
            params: *params,
            max_depth: params.max_depth.unwrap_or(auto).min(DEPTH_CAP),
        };
        let root = build::BuildNode::root(prep.bounds, prep.refs);
        let mut sub = build::Sub {
            nodes: vec![KdNode::leaf(0, 0)],
            prims: Vec::new(),
            depth: 0,
        };
        build::build_into(&ctx, root, 0, &mut sub, 0);
        tree.bounds = prep.bounds;
        tree.nodes = sub.nodes;
        tree.prims = sub.prims;
        tree.max_depth = sub.depth;
        tree.sah_cost = tree.compute_sah();
        tree
    }

    /// Every leaf with its region, depth first (for tests).
    #[cfg(test)]
    fn leaves(&self) -> Vec<(Aabb, &[u32])> {
        let mut out = Vec::new();
        if self.nodes.is_empty() {
            return out;
        }
        let mut stack = vec![(0usize, self.bounds)];
        while let Some((i, b)) = stack.pop() {
            let n = &self.nodes[i];
            if n.is_leaf() {
                out.push((b, n.leaf_prims(&self.prims)));
            } else {
                let (mut lo, mut hi) = (b, b);
                lo.max[n.axis()] = n.split();
                hi.min[n.axis()] = n.split();
                let c = n.children() as usize;
                stack.push((c + 1, hi));
                stack.push((c, lo));
            }
        }
        out
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
                sum += a * n.count() as f64;
            } else {
                sum += a;
                let (mut lo, mut hi) = (b, b);
                lo.max[n.axis()] = n.split();
                hi.min[n.axis()] = n.split();
                let c = n.children() as usize;
                stack.push((c, lo));
                stack.push((c + 1, hi));
            }
        }
        Some(sum / root)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accelerator;
    use crate::counters::NoCounters;
    use crate::list::List;
    use crate::ray::Ray;
    use crate::test_meshes::{assert_agrees_with_list, offered};
    use crate::triangle::mesh::TriangleMesh;
    use glam::Vec3;

    fn soup() -> TriangleMesh {
        crate::test_meshes::soup(400)
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
            assert_agrees_with_list(&kd, &list, &m, &r, &format!("ray {k}"));
        }
    }

    #[test]
    fn perfect_splits_place_triangles_only_where_they_are() {
        let m = soup();
        let kd = KdTree::build(&m, &KdParams::default());
        for (b, prims) in kd.leaves() {
            for &p in prims {
                assert!(m.clipped_bounds(p, &b).is_some());
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
        assert_eq!(offered(&t, &r).len(), 50);
        // Flat boxes in one plane, and a ray inside that plane.
        let flat: Vec<Aabb> = (0..40)
            .map(|i| {
                let x = i as f32;
                Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.5, 1.0, 0.0))
            })
            .collect();
        let t = KdTree::build(&flat, &KdParams::default());
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.0), Vec3::X, 0.0, f32::INFINITY);
        assert_eq!(offered(&t, &r).len(), 40);
    }
}
