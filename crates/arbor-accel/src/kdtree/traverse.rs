//! Front-to-back traversal of the k-d tree.

use std::mem::MaybeUninit;

use super::{KdNode, KdTree, STACK_SIZE};
use crate::accel::{AccelStats, Accelerator};
use crate::counters::Counters;
use crate::counters::{count_node, skip_node};
use crate::primitives::PrimitiveId;
use crate::ray::Ray;
use crate::util::{widen_down, widen_up, Mailbox};

/// The smaller of `a` and `b`, or `a` when `b` is NaN: one `minss`
/// (`f32::min` also handles a NaN `a`, which never occurs here, at the cost
/// of several instructions on the hottest path).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

/// The larger of `a` and `b`, or `a` when `b` is NaN (see [`min`]).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// `if c { a } else { b }` without a branch.
#[inline(always)]
fn select_u32(c: bool, a: u32, b: u32) -> u32 {
    let mask = u32::from(c).wrapping_neg();
    (a & mask) | (b & !mask)
}

/// `if c { a } else { b }` without a branch (bit-exact, NaN included).
#[inline(always)]
fn select_f32(c: bool, a: f32, b: f32) -> f32 {
    f32::from_bits(select_u32(c, a.to_bits(), b.to_bits()))
}

impl KdTree {
    /// Walks the leaves the ray passes, front to back, calling `visit` with
    /// each leaf's primitives and the current ray (which `visit` may shrink)
    /// until it returns `true`. Nodes that begin beyond `ray.tmax` are
    /// skipped, so once a hit is found only the regions that can still hold
    /// a closer one are visited.
    ///
    /// Each node's parameter interval is widened by the rounding bound of
    /// the split distance, so every node's interval contains the exact one
    /// and culling against the exact hit distance never drops a closer hit.
    #[inline(always)]
    // `!(a < b)` is meant: it is true when either side is NaN.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
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
        let Some((t0, t1)) = self.bounds.intersect_widened(ray, inv) else {
            return;
        };
        // Per ray, once: origin and reciprocal direction as arrays (indexed
        // by the node's axis without a match), and which child comes first
        // along each axis (0 = below, 1 = above).
        let origin = ray.origin.to_array();
        let inv = inv.to_array();
        let first_offset = inv.map(|d| u32::from(d < 0.0));
        // Uninitialised: zeroing 768 bytes per ray would cost more than
        // most traversals (entries are written before they are read).
        // One spare entry: the unconditional write happens at `sp` even when
        // the path is as deep as the build allows.
        let mut stack = [MaybeUninit::<(u32, f32, f32)>::uninit(); STACK_SIZE + 1];
        let mut sp = 0;
        let nodes = &self.nodes[..];
        let (mut node, mut ta, mut tb) = (0usize, widen_down(t0), t1);
        loop {
            count_node(counters, node as u32);
            let n = nodes[node];
            if !n.is_leaf() {
                let axis = n.axis();
                let ts = (n.split() - origin[axis]) * inv[axis];
                let (lo, hi) = (widen_down(ts), widen_up(ts));
                let off = first_offset[axis];
                let children = n.children();
                // The near child's interval is [ta, min(tb, hi)], the far
                // child's [max(ta, lo), tb]. A ray inside the split plane
                // (ts NaN) fails both negated tests and visits both children
                // with the whole interval (`min`/`max` ignore a NaN second
                // argument; `ta`, `tb` and `tmax` are never NaN).
                let near = !(hi < ta);
                let far = !(lo > min(tb, ray.tmax));
                // Which side the ray starts on is a coin toss for rays that
                // begin inside the tree, so the choice is made without
                // branches: the far child is written to the stack always and
                // kept only when both children are entered; the next node and
                // its interval are selected. (If neither test passes, which
                // only rounding at the root can cause, the far child is
                // visited needlessly, never wrongly.)
                let (first, second) = (children + off, children + (off ^ 1));
                if C::RECORDS {
                    // A child the ray's interval does not reach is skipped.
                    // (Without `near` the second child is visited anyway.)
                    if !near {
                        skip_node(counters, first);
                    } else if !far {
                        skip_node(counters, second);
                    }
                }
                let far_ta = max(ta, lo);
                stack[sp] = MaybeUninit::new((second, far_ta, tb));
                sp += usize::from(near & far);
                node = select_u32(near, first, second) as usize;
                ta = select_f32(near, ta, far_ta);
                tb = select_f32(near, min(tb, hi), tb);
                continue;
            }
            let prims = n.leaf_prims(&self.prims);
            if !prims.is_empty() && visit(prims, ray, counters) {
                return;
            }
            // Next stacked node that may still hold a closer hit.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written before `sp` passed them.
                let (nd, a, b) = unsafe { stack[sp].assume_init() };
                if a <= ray.tmax {
                    (node, ta, tb) = (nd as usize, a, b);
                    break;
                }
                skip_node(counters, nd);
            }
        }
    }
}

impl Accelerator for KdTree {
    fn unbounded(&self) -> &[PrimitiveId] {
        &self.unbounded
    }

    fn closest_bounded<C, F>(&self, mut ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        // A primitive reaches into several leaves; the mailbox tests it once.
        // A hit found in one leaf may lie beyond it, in a later leaf: that is
        // fine, the walk only skips nodes that begin beyond `tmax`, so it
        // stops exactly when no unvisited region can hold a closer hit.
        let mut mailbox = Mailbox::new();
        self.walk(&mut ray, counters, |prims, ray, counters| {
            mailbox.offer_closest(prims, ray, counters, hit);
            false
        });
    }

    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        let mut found = false;
        let mut mailbox = Mailbox::new();
        let mut walk_ray = *ray;
        self.walk(&mut walk_ray, counters, |prims, r, counters| {
            found = mailbox.offer_any(prims, r, counters, hit);
            found
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
