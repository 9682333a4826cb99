//! The O(N log N) SAH build (Wald and Havran, "On building fast kd-trees for
//! ray tracing, and on doing that in O(N log N)", 2006), written from the
//! paper's description.
//!
//! Every reference (a primitive with its box clipped to the node) contributes
//! per axis either a *planar* event (the box is flat on that axis) or a
//! *start* and an *end* event. The events of each axis are sorted once, at
//! the root. A node then
//!
//! 1. sweeps each axis' sorted events to find the cheapest SAH plane
//!    ([`find_split`], linear);
//! 2. classifies its references as below-only, above-only or straddling
//!    (linear);
//! 3. hands the events of one-sided references to the child they belong to,
//!    in order, so the children's lists stay sorted without sorting
//!    ([`split_node`], linear);
//! 4. clips each straddling reference to both child regions
//!    ([`Primitives::clipped_bounds`], "perfect splits"), generates events for
//!    the clipped boxes, sorts only those (few: on the order of the square root
//!    of the node's references for well-behaved input) and merges them in.
//!
//! Each level costs O(N), there are O(log N) levels, hence O(N log N).

use rayon::prelude::*;

use super::{KdNode, KdParams};
use crate::aabb::Aabb;
use crate::primitives::Primitives;

/// Event kinds, in the order they are sorted at equal positions: a reference
/// that ends at a plane is below it, one lying in it is decided by the
/// sweep, one that starts there is above it.
pub(super) const END: u32 = 0;
/// A reference whose box is flat on the axis.
pub(super) const PLANAR: u32 = 1;
/// Where a reference's box starts.
pub(super) const START: u32 = 2;

/// References per node are numbered in 30 bits (the kind takes the top two).
pub(super) const MAX_REFS: usize = 1 << 30;
const INDEX_MASK: u32 = (1 << 30) - 1;

/// One split candidate: where a reference's box starts, ends or lies flat
/// along one axis. 8 bytes, so that the root's 6N events of a million
/// triangles stay cache- and bandwidth-friendly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Event {
    /// The plane's position (never `-0.0`: normalised to `+0.0` so that the
    /// bit order agrees with `==`).
    pub pos: f32,
    /// `kind << 30 | index` of the reference within its node.
    pub word: u32,
}

impl Event {
    pub fn new(pos: f32, kind: u32, index: u32) -> Self {
        debug_assert!(index <= INDEX_MASK && kind <= START);
        Event {
            // -0.0 + 0.0 == +0.0; every other value is unchanged.
            pos: pos + 0.0,
            word: kind << 30 | index,
        }
    }

    #[inline(always)]
    pub fn kind(self) -> u32 {
        self.word >> 30
    }

    #[inline(always)]
    pub fn index(self) -> usize {
        (self.word & INDEX_MASK) as usize
    }

    /// Sort key: position, then kind, then reference. Keys are unique within
    /// a list, so any sorting algorithm gives the same order.
    #[inline(always)]
    pub fn key(self) -> u64 {
        let b = self.pos.to_bits();
        // Maps the float order of finite values onto the unsigned order.
        let ordered = if b >> 31 == 1 { !b } else { b | 0x8000_0000 };
        u64::from(ordered) << 32 | u64::from(self.word)
    }
}

/// Appends the events of box `b` on `axis` for reference `index`.
#[inline]
pub(super) fn push_events(out: &mut Vec<Event>, b: &Aabb, axis: usize, index: u32) {
    if b.min[axis] == b.max[axis] {
        out.push(Event::new(b.min[axis], PLANAR, index));
    } else {
        out.push(Event::new(b.min[axis], START, index));
        out.push(Event::new(b.max[axis], END, index));
    }
}

/// References to primitives: each primitive's id with its box clipped to
/// the region of the node that holds them.
pub(super) type Refs = Vec<(u32, Aabb)>;

/// A node under construction: its region, its references and, per axis,
/// the sorted events of their boxes.
pub(super) struct BuildNode {
    pub bounds: Aabb,
    pub refs: Refs,
    pub events: [Vec<Event>; 3],
}

impl BuildNode {
    /// The root: events of all references, sorted once.
    pub fn root(bounds: Aabb, refs: Refs) -> Self {
        assert!(
            refs.len() <= MAX_REFS,
            "the k-d tree indexes at most 2^30 primitives"
        );
        let axis_events = |axis: usize| {
            let mut ev = Vec::with_capacity(2 * refs.len());
            for (i, (_, b)) in refs.iter().enumerate() {
                push_events(&mut ev, b, axis, i as u32);
            }
            ev.par_sort_unstable_by_key(|e| e.key());
            ev
        };
        let (x, (y, z)) = rayon::join(
            || axis_events(0),
            || rayon::join(|| axis_events(1), || axis_events(2)),
        );
        BuildNode {
            bounds,
            refs,
            events: [x, y, z],
        }
    }
}

/// The chosen plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Split {
    /// Estimated cost of splitting here (same units as `c_i · N` for a leaf).
    pub cost: f32,
    pub axis: usize,
    pub pos: f32,
    /// Whether references lying in the plane go below it.
    pub planar_below: bool,
}

/// The cheapest plane strictly inside `bounds`, by one sweep per axis over
/// the sorted events, or `None` when there is no candidate (every box spans
/// the whole node on every axis, or lies on its faces).
///
/// The SAH estimate of a split is
/// `(1 - bonus) · (c_t + c_i · (A_b/A · N_b + A_a/A · N_a))`, with the bonus
/// when one side is empty (Wald and Havran's form: the bonus scales the
/// whole cost, so cutting off a sliver of empty space is never worth it). References lying in the plane are counted on
/// whichever side is cheaper. Ties go to the first candidate found (lowest
/// axis, lowest position), so the choice is deterministic.
pub(super) fn find_split(node: &BuildNode, params: &KdParams) -> Option<Split> {
    let n = node.refs.len();
    let sweep = |axis: usize| sweep_axis(&node.events[axis], axis, n, &node.bounds, params);
    let per_axis: [Option<Split>; 3] = if n >= params.parallel_threshold {
        let (x, (y, z)) = rayon::join(|| sweep(0), || rayon::join(|| sweep(1), || sweep(2)));
        [x, y, z]
    } else {
        [sweep(0), sweep(1), sweep(2)]
    };
    per_axis
        .into_iter()
        .flatten()
        .fold(None, |best: Option<Split>, s| match best {
            Some(b) if b.cost <= s.cost => Some(b),
            _ => Some(s),
        })
}

fn sweep_axis(
    events: &[Event],
    axis: usize,
    n: usize,
    bounds: &Aabb,
    params: &KdParams,
) -> Option<Split> {
    let (ct, ci) = (params.traversal_cost, params.intersection_cost);
    let ext = bounds.extent();
    let (o1, o2) = ((axis + 1) % 3, (axis + 2) % 3);
    // A child's area is `cap + perim · length along the axis`.
    let cap = 2.0 * ext[o1] * ext[o2];
    let perim = 2.0 * (ext[o1] + ext[o2]);
    let inv_area = 1.0 / bounds.surface_area();
    let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
    let mut best: Option<Split> = None;
    // References entirely below / entirely above the current position.
    let (mut nb, mut na) = (0usize, n);
    let mut i = 0;
    while i < events.len() {
        let pos = events[i].pos;
        let (mut ends, mut planars, mut starts) = (0usize, 0usize, 0usize);
        while i < events.len() && events[i].pos == pos && events[i].kind() == END {
            ends += 1;
            i += 1;
        }
        while i < events.len() && events[i].pos == pos && events[i].kind() == PLANAR {
            planars += 1;
            i += 1;
        }
        while i < events.len() && events[i].pos == pos && events[i].kind() == START {
            starts += 1;
            i += 1;
        }
        na -= ends + planars;
        if pos > lo && pos < hi {
            let ab = (cap + perim * (pos - lo)) * inv_area;
            let aa = (cap + perim * (hi - pos)) * inv_area;
            // With no planar references both assignments cost the same.
            let choices: &[bool] = if planars == 0 {
                &[true]
            } else {
                &[true, false]
            };
            for &planar_below in choices {
                let (b, a) = if planar_below {
                    (nb + planars, na)
                } else {
                    (nb, na + planars)
                };
                let bonus = if b == 0 || a == 0 {
                    params.empty_bonus
                } else {
                    0.0
                };
                let cost = (1.0 - bonus) * (ct + ci * (ab * b as f32 + aa * a as f32));
                let better = match best {
                    None => cost.is_finite(),
                    Some(s) => cost < s.cost,
                };
                if better {
                    best = Some(Split {
                        cost,
                        axis,
                        pos,
                        planar_below,
                    });
                }
            }
        }
        nb += starts + planars;
    }
    best
}

/// Which child a reference goes to.
const BELOW: u8 = 1;
const ABOVE: u8 = 2;
const BOTH: u8 = 3;

/// The side of `split` a box lies on (`BOTH` when it straddles the plane).
#[inline]
fn side_of(b: &Aabb, split: &Split) -> u8 {
    let (lo, hi) = (b.min[split.axis], b.max[split.axis]);
    if lo == split.pos && hi == split.pos {
        if split.planar_below {
            BELOW
        } else {
            ABOVE
        }
    } else if hi <= split.pos {
        BELOW
    } else if lo >= split.pos {
        ABOVE
    } else {
        BOTH
    }
}

/// Appends `e` to `out`, after the events of `new[*next..]` (sorted by
/// [`Event::key`]) that sort before it.
#[inline(always)]
fn push_merged(out: &mut Vec<Event>, new: &[Event], next: &mut usize, e: Event) {
    let key = e.key();
    while *next < new.len() && new[*next].key() < key {
        out.push(new[*next]);
        *next += 1;
    }
    out.push(e);
}

/// Splits `node` at `split` into its below and above children, keeping every
/// event list sorted in linear time (plus sorting the straddlers' new
/// events).
///
/// References keep their relative order in each child, and their indices
/// are renumbered monotonically, so a kept event's key order is unchanged.
/// A straddling reference is clipped to each child's region and kept only in
/// the children it really reaches, with the clipped box (intersected with
/// its old box, so a box never grows).
pub(super) fn split_node<P: Primitives + ?Sized>(
    prims: &P,
    node: BuildNode,
    split: &Split,
    params: &KdParams,
) -> (BuildNode, BuildNode) {
    let BuildNode {
        bounds,
        refs,
        events,
    } = node;
    let parallel = refs.len() >= params.parallel_threshold;
    let (mut below_box, mut above_box) = (bounds, bounds);
    below_box.max[split.axis] = split.pos;
    above_box.min[split.axis] = split.pos;
    let (partition, below_refs, above_refs) =
        Partition::new(prims, &refs, split, [&below_box, &above_box], parallel);
    let [ex, ey, ez] = events;
    let ((bx, ax), ((by, ay), (bz, az))) = if parallel {
        rayon::join(
            || partition.split_axis(0, ex),
            || {
                rayon::join(
                    || partition.split_axis(1, ey),
                    || partition.split_axis(2, ez),
                )
            },
        )
    } else {
        (
            partition.split_axis(0, ex),
            (partition.split_axis(1, ey), partition.split_axis(2, ez)),
        )
    };
    (
        BuildNode {
            bounds: below_box,
            refs: below_refs,
            events: [bx, by, bz],
        },
        BuildNode {
            bounds: above_box,
            refs: above_refs,
            events: [ax, ay, az],
        },
    )
}

/// Where a node's references go when it is split: the side of each, the
/// straddlers' boxes clipped to each child, and each reference's new index
/// in each child.
struct Partition {
    sides: Vec<u8>,
    /// The straddling references, in order.
    straddlers: Vec<usize>,
    /// Per straddler, its box clipped to the below and the above child
    /// (`None`: it does not reach that child).
    clipped: Vec<(Option<Aabb>, Option<Aabb>)>,
    /// New indices in each child (`u32::MAX`: not there).
    below_index: Vec<u32>,
    above_index: Vec<u32>,
}

impl Partition {
    /// The partition of `refs` by `split` into the child regions
    /// `[below, above]`, with the children's references.
    fn new<P: Primitives + ?Sized>(
        prims: &P,
        refs: &[(u32, Aabb)],
        split: &Split,
        [below_box, above_box]: [&Aabb; 2],
        parallel: bool,
    ) -> (Partition, Refs, Refs) {
        let n = refs.len();
        let sides: Vec<u8> = refs.iter().map(|(_, b)| side_of(b, split)).collect();
        let straddlers: Vec<usize> = (0..n).filter(|&i| sides[i] == BOTH).collect();
        let clip = |&i: &usize| {
            let (id, b) = refs[i];
            let part = |region: &Aabb| {
                prims
                    .clipped_bounds(id, region)
                    .map(|c| c.intersection(&b))
                    .filter(|c| !c.is_empty())
            };
            (part(below_box), part(above_box))
        };
        let clipped: Vec<(Option<Aabb>, Option<Aabb>)> = if parallel {
            straddlers.par_iter().map(clip).collect()
        } else {
            straddlers.iter().map(clip).collect()
        };

        let mut below_index = vec![u32::MAX; n];
        let mut above_index = vec![u32::MAX; n];
        let mut below_refs = Vec::new();
        let mut above_refs = Vec::new();
        let mut next_clipped = clipped.iter();
        for (i, &(id, b)) in refs.iter().enumerate() {
            let (to_below, to_above) = match sides[i] {
                BELOW => (Some(b), None),
                ABOVE => (None, Some(b)),
                _ => *next_clipped.next().expect("one clip per straddler"),
            };
            if let Some(c) = to_below {
                below_index[i] = below_refs.len() as u32;
                below_refs.push((id, c));
            }
            if let Some(c) = to_above {
                above_index[i] = above_refs.len() as u32;
                above_refs.push((id, c));
            }
        }
        let partition = Partition {
            sides,
            straddlers,
            clipped,
            below_index,
            above_index,
        };
        (partition, below_refs, above_refs)
    }

    /// The below and above children's sorted events on `axis`, from the
    /// parent's sorted `events` of that axis.
    fn split_axis(&self, axis: usize, events: Vec<Event>) -> (Vec<Event>, Vec<Event>) {
        let (sides, below_index, above_index) = (&self.sides, &self.below_index, &self.above_index);
        // Events of the clipped straddlers, sorted (there are few).
        let mut new_below = Vec::new();
        let mut new_above = Vec::new();
        for (&i, (cb, ca)) in self.straddlers.iter().zip(&self.clipped) {
            if let Some(c) = cb {
                push_events(&mut new_below, c, axis, below_index[i]);
            }
            if let Some(c) = ca {
                push_events(&mut new_above, c, axis, above_index[i]);
            }
        }
        new_below.sort_unstable_by_key(|e| e.key());
        new_above.sort_unstable_by_key(|e| e.key());
        // One pass over the parent's events: those of one-sided references
        // go to their child, in order and renumbered, with the new events
        // merged in as they come. (Capacity beyond what is written is never
        // touched, so over-reserving costs address space, not memory.)
        let mut below = Vec::with_capacity(events.len() + new_below.len());
        let mut above = Vec::with_capacity(events.len() + new_above.len());
        let (mut nb, mut na) = (0, 0);
        for e in events {
            let i = e.index();
            match sides[i] {
                BELOW => {
                    let e = Event::new(e.pos, e.kind(), below_index[i]);
                    push_merged(&mut below, &new_below, &mut nb, e);
                }
                ABOVE => {
                    let e = Event::new(e.pos, e.kind(), above_index[i]);
                    push_merged(&mut above, &new_above, &mut na, e);
                }
                _ => {}
            }
        }
        below.extend_from_slice(&new_below[nb..]);
        above.extend_from_slice(&new_above[na..]);
        (below, above)
    }
}

/// A built subtree: nodes with the subtree's root at index 0 (child indices
/// relative to this vector) and leaf primitive lists (offsets relative to
/// this vector).
#[derive(Default)]
pub(super) struct Sub {
    pub nodes: Vec<KdNode>,
    pub prims: Vec<u32>,
    pub depth: usize,
}

impl Sub {
    /// Moves `other` (a subtree rooted at its index 0) into `self`, its root
    /// into slot `slot` and the rest at the end, shifting indices.
    fn graft(&mut self, slot: usize, other: Sub) {
        // other's node j >= 1 lands at base + j - 1.
        let base = self.nodes.len() as u32;
        let pbase = self.prims.len() as u32;
        let shift = |mut n: KdNode| {
            if n.is_leaf() {
                if n.count() != 1 {
                    n.a += pbase;
                }
            } else {
                n.b += (base - 1) << 2;
            }
            n
        };
        let mut it = other.nodes.into_iter();
        self.nodes[slot] = shift(it.next().expect("a subtree has a root"));
        self.nodes.extend(it.map(shift));
        self.prims.extend(other.prims);
        self.depth = self.depth.max(other.depth);
    }
}

/// Everything a node's build needs besides the node.
pub(super) struct Ctx<'a, P: ?Sized> {
    pub prims: &'a P,
    pub params: KdParams,
    pub max_depth: usize,
}

/// Builds the subtree of `node` into `out`, writing its root at `slot`
/// (already reserved). Children are reserved as an adjacent pair.
pub(super) fn build_into<P: Primitives + ?Sized>(
    ctx: &Ctx<P>,
    node: BuildNode,
    depth: usize,
    out: &mut Sub,
    slot: usize,
) {
    out.depth = out.depth.max(depth);
    let n = node.refs.len();
    let leaf = |out: &mut Sub, node: BuildNode| {
        out.nodes[slot] = if n == 1 {
            // A single primitive is stored in the node itself: no
            // indirection through the primitive list.
            KdNode::leaf(node.refs[0].0 as usize, 1)
        } else {
            let first = out.prims.len();
            out.prims.extend(node.refs.iter().map(|r| r.0));
            KdNode::leaf(first, n)
        };
    };
    if n <= 1 || depth >= ctx.max_depth {
        return leaf(out, node);
    }
    let Some(split) = find_split(&node, &ctx.params) else {
        return leaf(out, node);
    };
    // Automatic termination (Wald and Havran): a leaf as soon as no split is
    // estimated cheaper than testing every reference. (pbrt's tolerance of a
    // few costlier splits in a row made trees about 2x bigger for no measurable
    // speed-up with perfect splits.)
    if split.cost >= ctx.params.intersection_cost * n as f32 {
        return leaf(out, node);
    }
    let (below, above) = split_node(ctx.prims, node, &split, &ctx.params);
    let children = out.nodes.len();
    out.nodes[slot] = KdNode::interior(split.axis, split.pos, children);
    out.nodes.push(KdNode::leaf(0, 0));
    out.nodes.push(KdNode::leaf(0, 0));
    if n >= ctx.params.parallel_threshold {
        let sub = |node: BuildNode| {
            let mut s = Sub {
                nodes: vec![KdNode::leaf(0, 0)],
                prims: Vec::new(),
                depth: 0,
            };
            build_into(ctx, node, depth + 1, &mut s, 0);
            s
        };
        let (b, a) = rayon::join(|| sub(below), || sub(above));
        out.graft(children, b);
        out.graft(children + 1, a);
    } else {
        build_into(ctx, below, depth + 1, out, children);
        build_into(ctx, above, depth + 1, out, children + 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangle::mesh::TriangleMesh;
    use crate::util::prepare;
    use glam::Vec3;

    /// 300 triangles of assorted sizes and slopes, some axis-aligned (flat
    /// boxes give planar events), a few sharing the same planes.
    fn mesh() -> TriangleMesh {
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..300u32 {
            let f = i as f32;
            let c = crate::test_meshes::scattered(i) * 8.0 - 2.0;
            let s = 0.2 + 2.0 * (f * 0.37).fract();
            let (a, b) = if i % 7 == 0 {
                // Flat in z, on a shared plane.
                (Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, s, 0.0))
            } else {
                (
                    Vec3::new(s, (f * 1.3).sin() * s, 0.4 * s),
                    Vec3::new((f * 0.7).cos() * s, s, -0.6 * s),
                )
            };
            let c = if i % 7 == 0 {
                Vec3::new(c.x, c.y, 1.0)
            } else {
                c
            };
            v.extend([c, c + a, c + b]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        TriangleMesh::new(v, t)
    }

    fn root(m: &TriangleMesh) -> BuildNode {
        let prep = prepare(m);
        BuildNode::root(prep.bounds, prep.refs)
    }

    /// The events a node's references should have, freshly generated.
    fn expected_events(node: &BuildNode, axis: usize) -> Vec<Event> {
        let mut ev = Vec::new();
        for (i, (_, b)) in node.refs.iter().enumerate() {
            push_events(&mut ev, b, axis, i as u32);
        }
        ev.sort_unstable_by_key(|e| e.key());
        ev
    }

    /// Splits `node` down `levels` levels, calling `check` on every child.
    fn descend(
        m: &TriangleMesh,
        node: BuildNode,
        levels: usize,
        params: &KdParams,
        check: &mut dyn FnMut(&BuildNode, &BuildNode),
    ) {
        if levels == 0 || node.refs.len() < 2 {
            return;
        }
        let Some(split) = find_split(&node, params) else {
            return;
        };
        let parent_bounds = node.bounds;
        let (b, a) = split_node(m, node, &split, params);
        assert_eq!(b.bounds.max[split.axis], split.pos);
        assert_eq!(a.bounds.min[split.axis], split.pos);
        assert!(parent_bounds.contains_box(&b.bounds) && parent_bounds.contains_box(&a.bounds));
        let parent = BuildNode {
            bounds: parent_bounds,
            refs: Vec::new(),
            events: [Vec::new(), Vec::new(), Vec::new()],
        };
        check(&parent, &b);
        check(&parent, &a);
        descend(m, b, levels - 1, params, check);
        descend(m, a, levels - 1, params, check);
    }

    /// [`descend`] from `m`'s root with the default parameters.
    fn descend_from_root(
        m: &TriangleMesh,
        levels: usize,
        check: &mut dyn FnMut(&BuildNode, &BuildNode),
    ) {
        descend(m, root(m), levels, &KdParams::default(), check);
    }

    #[test]
    fn event_keys_order_like_positions_then_kinds() {
        let ps = [-3.0f32, -1e-30, -0.0, 0.0, 1e-30, 2.0, f32::MAX];
        let mut evs = Vec::new();
        for (i, &p) in ps.iter().enumerate() {
            for kind in [START, END, PLANAR] {
                evs.push(Event::new(p, kind, i as u32));
            }
        }
        evs.sort_unstable_by_key(|e| e.key());
        for w in evs.windows(2) {
            let (x, y) = (w[0], w[1]);
            assert!(x.pos <= y.pos, "{x:?} {y:?}");
            if x.pos == y.pos {
                // -0.0 and 0.0 are one position: normalised, so kinds order.
                assert_eq!(x.pos.to_bits(), y.pos.to_bits());
                assert!((x.kind(), x.index()) < (y.kind(), y.index()), "{x:?} {y:?}");
            }
        }
        assert_eq!(Event::new(-0.0, END, 0).pos.to_bits(), 0.0f32.to_bits());
    }

    #[test]
    fn splitting_keeps_event_lists_sorted_and_exact() {
        let m = mesh();
        let mut nodes = 0;
        descend_from_root(&m, 6, &mut |_, child| {
            nodes += 1;
            for axis in 0..3 {
                let ev = &child.events[axis];
                // Strictly increasing keys: sorted, no duplicates.
                assert!(ev.windows(2).all(|w| w[0].key() < w[1].key()));
                // Exactly the events of the child's references (so none was
                // lost, duplicated or left with a stale index or position).
                assert_eq!(*ev, expected_events(child, axis));
            }
            // References keep the parent's relative order.
            let ids: Vec<u32> = child.refs.iter().map(|r| r.0).collect();
            assert!(ids.windows(2).all(|w| w[0] < w[1]));
        });
        assert!(nodes > 20, "only {nodes} nodes");
    }

    #[test]
    fn merging_new_events_keeps_order() {
        let kept: Vec<Event> = [0.0, 1.0, 1.0, 3.0]
            .iter()
            .enumerate()
            .map(|(i, &p)| Event::new(p, START, i as u32))
            .collect();
        let new = vec![
            Event::new(-1.0, END, 9),
            Event::new(1.0, END, 7),
            Event::new(1.0, START, 8),
            Event::new(4.0, PLANAR, 6),
        ];
        let (mut out, mut next) = (Vec::new(), 0);
        for &e in &kept {
            push_merged(&mut out, &new, &mut next, e);
        }
        out.extend_from_slice(&new[next..]);
        let mut want = [kept, new].concat();
        want.sort_unstable_by_key(|e| e.key());
        assert_eq!(out, want);
    }

    /// Points of triangle `tri` on a barycentric lattice, in f64.
    fn samples(tri: [Vec3; 3]) -> Vec<glam::DVec3> {
        let [a, b, c] = tri.map(|p| p.as_dvec3());
        let k = 24;
        let mut out = Vec::new();
        for i in 0..=k {
            for j in 0..=k - i {
                let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
                out.push(a + (b - a) * u + (c - a) * v);
            }
        }
        out
    }

    fn inside(b: &Aabb, p: glam::DVec3) -> bool {
        (0..3).all(|k| f64::from(b.min[k]) <= p[k] && p[k] <= f64::from(b.max[k]))
    }

    fn strictly_inside(b: &Aabb, p: glam::DVec3) -> bool {
        (0..3).all(|k| f64::from(b.min[k]) < p[k] && p[k] < f64::from(b.max[k]))
    }

    #[test]
    fn clipped_boxes_contain_the_triangle_inside_the_child() {
        let m = mesh();
        let mut checked = 0;
        descend_from_root(&m, 7, &mut |_, child| {
            let present: Vec<u32> = child.refs.iter().map(|r| r.0).collect();
            for (id, b) in &child.refs {
                assert!(child.bounds.contains_box(b), "box leaves the node");
                for p in samples(m.triangle(*id)) {
                    if inside(&child.bounds, p) {
                        assert!(inside(b, p), "triangle {id}: {p} outside {b:?}");
                        checked += 1;
                    }
                }
            }
            // No triangle reaching into the child's interior was dropped (one
            // that only touches a face may live on the other side only).
            for id in 0..m.triangles.len() as u32 {
                if samples(m.triangle(id))
                    .into_iter()
                    .any(|p| strictly_inside(&child.bounds, p))
                {
                    assert!(present.contains(&id), "triangle {id} dropped");
                }
            }
        });
        assert!(checked > 1000, "only {checked} sample points checked");
    }

    #[test]
    fn build_is_deterministic_across_threads_and_thresholds() {
        let m = mesh();
        let build = |threads: usize, threshold: usize| {
            let params = KdParams {
                parallel_threshold: threshold,
                ..KdParams::default()
            };
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| super::super::KdTree::build(&m, &params))
        };
        let reference = build(1, usize::MAX);
        assert!(reference.nodes.len() > 100);
        for (threads, threshold) in [(1, 8), (4, 2), (3, 64), (4, usize::MAX)] {
            let t = build(threads, threshold);
            assert_eq!(t.nodes, reference.nodes, "{threads} threads, {threshold}");
            assert_eq!(t.prims, reference.prims, "{threads} threads, {threshold}");
        }
    }
}
