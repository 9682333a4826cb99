//! Bounding volume hierarchies: one node layout and traversal, five builders.
//!
//! Nodes live in one depth-first array of 32-byte [`BvhNode`]s: an interior
//! node's left child directly follows it and its `offset` names the right
//! child, so a node needs no second child pointer and the left child shares
//! its cache line more often than not. Leaves name a contiguous run of the
//! primitive index array.

mod ploc;
mod spatial;
mod sweep;
mod topdown;

use std::mem::MaybeUninit;

use glam::{BVec4A, Vec3, Vec3A, Vec4};

use crate::aabb::widen_exit;
use crate::aabb::Aabb;
use crate::accel::{AccelStats, Accelerator};
use crate::counters::Counters;
use crate::counters::{count_node, skip_node};
use crate::layout::{Layout, LayoutNode};
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;
use crate::util::{offer_any, offer_closest, prepare_map, widen_up};

/// Depth from which every builder stops optimising and splits by count, so
/// that no tree is deeper than `FORCE_MEDIAN_DEPTH + 32` levels whatever the
/// input and the fixed traversal stack always suffices.
pub(crate) const FORCE_MEDIAN_DEPTH: usize = 30;

/// Entries of the traversal stack: one per level at most.
pub(crate) const STACK_SIZE: usize = 64;

/// One node: its box, and either its right child (interior, `count == 0`;
/// the left child is the next node) or its primitives
/// `prim_indices[offset..offset + count]` (leaf, `count > 0`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct BvhNode {
    /// Lower corner of the box.
    pub min: Vec3,
    /// Right child (interior) or first primitive slot (leaf).
    pub offset: u32,
    /// Upper corner of the box.
    pub max: Vec3,
    /// Number of primitives; 0 for interior nodes.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

impl BvhNode {
    /// A leaf over `count` primitive slots from `first`.
    pub(crate) fn leaf(b: &Aabb, first: usize, count: usize) -> Self {
        BvhNode {
            min: b.min,
            offset: first as u32,
            max: b.max,
            count: count as u32,
        }
    }

    /// An interior node whose right child is node `right`.
    pub(crate) fn interior(b: &Aabb, right: usize) -> Self {
        BvhNode {
            min: b.min,
            offset: right as u32,
            max: b.max,
            count: 0,
        }
    }

    /// The node's box.
    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(self.min, self.max)
    }

    /// Whether the node is a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// How a [`Bvh`] is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BvhBuilder {
    /// Top-down: split at the middle of the centroid box's largest axis.
    Center,
    /// Top-down: split into equal halves by count along the centroid box's
    /// largest axis.
    Median,
    /// Top-down binned surface area heuristic over all three axes.
    BinnedSah,
    /// Top-down full-sweep SAH over presorted centroids: every split between
    /// two primitives on every axis is evaluated. The quality reference.
    SweepSah,
    /// Bottom-up parallel locally-ordered clustering (PLOC).
    Ploc,
}

/// Build parameters shared by the builders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhParams {
    /// Center/median builders: nodes with at most this many primitives become
    /// leaves. Default 4.
    pub leaf_size: usize,
    /// SAH-driven builders (binned, sweep, PLOC's leaf collapsing): the
    /// largest leaf; below it the SAH decides whether to split. Default 8.
    pub max_leaf_size: usize,
    /// SAH cost of visiting a node, relative to `intersection_cost`.
    /// Default 1.
    pub traversal_cost: f32,
    /// SAH cost of one primitive test. Default 1.
    pub intersection_cost: f32,
    /// Primitives a leaf tests together (the binned SAH builder): a leaf or
    /// split side of `n` primitives costs `ceil(n / leaf_block)` tests, as
    /// for `bvh-wide` over triangles, which tests four triangles for the price
    /// of one. Default 1 (one test per primitive).
    pub leaf_block: usize,
    /// Bins per axis of the binned SAH builder, rounded up to 8, 16 or 32
    /// (nodes of at most 256 primitives use 8). Default 16.
    pub bins: usize,
    /// PLOC's nearest-neighbour search radius in Morton order. Default 16.
    pub ploc_radius: usize,
    /// Subtrees with at least this many primitives are built in parallel.
    /// Results do not depend on it or on the thread count. Default 4096.
    pub parallel_threshold: usize,
    /// The binned SAH builder with spatial splits (SBVH): the extra
    /// references splits may add, as a fraction of the primitive count.
    /// 0 (the default) builds without; [`BvhParams::HIGH_QUALITY_SPATIAL_SPLITS`]
    /// is the high-quality build's. Trees with repeats answer the same
    /// queries (counts drop the repeats) and are slower to build.
    pub spatial_splits: f32,
}

impl BvhParams {
    /// The extra references the high-quality build allows (`spatial_splits`).
    pub const HIGH_QUALITY_SPATIAL_SPLITS: f32 = 0.1;

    /// These parameters with spatial splits on, as the high-quality build
    /// (`--quality high`) uses them.
    pub fn high_quality(self) -> Self {
        BvhParams {
            spatial_splits: Self::HIGH_QUALITY_SPATIAL_SPLITS,
            ..self
        }
    }
}

impl Default for BvhParams {
    fn default() -> Self {
        BvhParams {
            leaf_size: 4,
            max_leaf_size: 8,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            leaf_block: 1,
            bins: 16,
            ploc_radius: 16,
            parallel_threshold: 4096,
            spatial_splits: 0.0,
        }
    }
}

/// A primitive during the build: its box in SIMD lanes, with the primitive
/// id's bits parked in `min.w`. Min, max and adds on the `w` lanes yield
/// junk that is never read, but no multiply may see the id (see
/// [`Ref::centroid4`]); the id is only ever read from a stored, copied
/// `Ref`, and copies keep bits intact.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ref {
    pub min: Vec4,
    pub max: Vec4,
}

impl Ref {
    /// The reference for primitive `id` with box `b`.
    #[inline(always)]
    pub fn new(id: u32, b: &Aabb) -> Self {
        Ref {
            min: b.min.extend(f32::from_bits(id)),
            max: b.max.extend(0.0),
        }
    }

    /// The primitive id.
    #[inline(always)]
    pub fn id(&self) -> u32 {
        self.min.w.to_bits()
    }

    /// The box.
    #[inline(always)]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(self.min.truncate(), self.max.truncate())
    }

    /// Centre of the box (`w` is 0), halved before adding so that huge
    /// boxes cannot overflow.
    #[inline(always)]
    pub fn centroid4(&self) -> Vec4 {
        // The id lane is cleared before the multiply: most ids are subnormal
        // as floats, and Intel cores multiply subnormals through a microcode
        // assist of a hundred-odd cycles (AMD's at full speed).
        let min = Vec4::select(BVec4A::new(true, true, true, false), self.min, Vec4::ZERO);
        min * 0.5 + self.max * 0.5
    }

    /// Centre of the box.
    #[inline(always)]
    pub fn centroid(&self) -> Vec3 {
        self.centroid4().truncate()
    }
}

/// A bounding volume hierarchy over any [`Primitives`].
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub(crate) nodes: Vec<BvhNode>,
    pub(crate) prims: Vec<u32>,
    pub(crate) unbounded: Vec<u32>,
    max_depth: usize,
    /// Whether a primitive sits in more than one leaf (spatial splits).
    repeats: bool,
}

impl Bvh {
    /// Builds with `builder` and `params`. Primitives with empty boxes are
    /// left out (they cannot be hit); those with NaN or infinite boxes are
    /// offered to every ray.
    pub fn build<P: Primitives + ?Sized>(
        prims: &P,
        builder: BvhBuilder,
        params: &BvhParams,
    ) -> Self {
        let (mut refs, unbounded) = prepare_map(prims, |id, b| Ref::new(id, &b));
        let mut bvh = Bvh {
            unbounded,
            ..Bvh::default()
        };
        if refs.is_empty() {
            return bvh;
        }
        let (nodes, order, depth) = match builder {
            BvhBuilder::Center => topdown::build(&topdown::Center, &mut refs, params),
            BvhBuilder::Median => topdown::build(&topdown::Median, &mut refs, params),
            BvhBuilder::BinnedSah if params.spatial_splits > 0.0 => {
                let n = refs.len();
                let built = spatial::build(prims, &refs, params);
                bvh.repeats = built.1.len() > n;
                built
            }
            BvhBuilder::BinnedSah => topdown::build(&topdown::Binned, &mut refs, params),
            BvhBuilder::SweepSah => sweep::build(&refs, params),
            BvhBuilder::Ploc => ploc::build(&refs, params),
        };
        bvh.nodes = nodes;
        bvh.prims = order;
        bvh.max_depth = depth;
        bvh
    }

    /// The nodes, root first, depth-first.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Primitive ids in leaf order.
    pub fn prim_indices(&self) -> &[u32] {
        &self.prims
    }

    /// Whether some primitive sits in more than one leaf (a build with
    /// [`BvhParams::spatial_splits`]), so that traversal may offer it twice.
    pub fn has_repeats(&self) -> bool {
        self.repeats
    }

    /// The nodes for drawing, indexed as [`Bvh::nodes`] (and as traversal
    /// reports them).
    pub fn layout(&self) -> Layout {
        let mut nodes: Vec<LayoutNode> = self
            .nodes
            .iter()
            .map(|n| LayoutNode {
                bounds: n.aabb(),
                depth: 0,
                children: Vec::new(),
                primitives: n.count,
                split: None,
            })
            .collect();
        // Depth-first: a parent precedes its children.
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf() {
                let depth = nodes[i].depth + 1;
                let kids = [i as u32 + 1, n.offset];
                for k in kids {
                    nodes[k as usize].depth = depth;
                }
                nodes[i].children = kids.to_vec();
            }
        }
        Layout::Tree {
            nodes,
            leaf_slots: Vec::new(),
            leaf_base: 0,
        }
    }

    /// Every leaf as `(first, count)`, sorted by `first`: the depth-first
    /// layout already lists them so (a left subtree holds the lower slots),
    /// which is checked, not assumed.
    pub(crate) fn leaves(&self) -> Vec<(u32, u32)> {
        let mut leaves: Vec<(u32, u32)> = self
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| (n.offset, n.count))
            .collect();
        if !leaves.is_sorted() {
            leaves.sort_unstable();
        }
        leaves
    }

    /// The primitives of leaf `n`, offered together.
    #[inline(always)]
    fn leaf_prims(&self, n: &BvhNode) -> &[u32] {
        let first = n.offset as usize;
        &self.prims[first..first + n.count as usize]
    }

    /// The SAH cost `(Σ_interior A(n)·c_t + Σ_leaf A(l)·c_i·|l|) / A(root)`
    /// with surface areas `A`; `None` for an empty tree or a root without
    /// finite positive area.
    pub fn sah_cost(&self, traversal_cost: f64, intersection_cost: f64) -> Option<f64> {
        let root = f64::from(self.nodes.first()?.aabb().surface_area());
        if !(root > 0.0 && root.is_finite()) {
            return None;
        }
        let sum: f64 = self
            .nodes
            .iter()
            .map(|n| {
                let a = f64::from(n.aabb().surface_area());
                if n.is_leaf() {
                    a * intersection_cost * f64::from(n.count)
                } else {
                    a * traversal_cost
                }
            })
            .sum();
        Some(sum / root)
    }
}

/// A ray prepared for node tests in SIMD lanes.
#[derive(Clone, Copy)]
pub(crate) struct RayBox {
    origin: Vec3A,
    inv_dir: Vec3A,
    tmin: f32,
}

impl RayBox {
    fn new(ray: &Ray) -> Self {
        RayBox::with_inv_dir(ray, ray.inv_dir())
    }

    /// `ray` with its `inv_dir`, already computed by the caller.
    #[inline(always)]
    pub(crate) fn with_inv_dir(ray: &Ray, inv_dir: Vec3) -> Self {
        RayBox {
            origin: ray.origin.into(),
            inv_dir: inv_dir.into(),
            tmin: ray.tmin,
        }
    }

    /// The entry distance into `node`'s box if the ray (clipped to
    /// `[tmin, tmax]`) touches it (see [`RayBox::hit_box`]).
    #[inline(always)]
    fn hit(&self, node: &BvhNode, tmax: f32) -> Option<f32> {
        self.hit_box(&node.aabb(), tmax)
    }

    /// The entry distance into `b` if the ray (clipped to `[tmin, tmax]`)
    /// touches it. The same arithmetic, lane for lane, as
    /// [`Aabb::intersect`], so it inherits that test's conservative bound.
    /// Callers pass `tmax` widened by that bound, so that a box entered at
    /// the current closest hit (up to the rounding of the entry distance) is
    /// never culled.
    #[inline(always)]
    pub(crate) fn hit_box(&self, b: &Aabb, tmax: f32) -> Option<f32> {
        let t0 = (Vec3A::from(b.min) - self.origin) * self.inv_dir;
        let t1 = (Vec3A::from(b.max) - self.origin) * self.inv_dir;
        let on_plane = t0.is_nan_mask() | t1.is_nan_mask();
        let near = Vec3A::select(on_plane, Vec3A::NEG_INFINITY, t0.min(t1));
        let far = Vec3A::select(on_plane, Vec3A::INFINITY, t0.max(t1));
        let enter = near.max_element().max(self.tmin);
        let exit = widen_exit(far.min_element()).min(tmax);
        (enter <= exit).then_some(enter)
    }
}

/// Records the children whose box test failed (`(node, hit)` pairs).
#[inline(always)]
fn skip_missed<C: Counters>(counters: &mut C, children: [(usize, bool); 2]) {
    for (node, hit) in children {
        if !hit {
            skip_node(counters, node as u32);
        }
    }
}

impl Accelerator for Bvh {
    fn unbounded(&self) -> &[PrimitiveId] {
        &self.unbounded
    }

    fn closest_bounded<C, F>(&self, mut ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        let Some(root) = self.nodes.first() else {
            return;
        };
        let rb = RayBox::new(&ray);
        if rb.hit(root, widen_up(ray.tmax)).is_none() {
            skip_node(counters, 0);
            return;
        }
        let mut stack = [(0u32, 0f32); STACK_SIZE];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            count_node(counters, node as u32);
            let n = &self.nodes[node];
            if n.is_leaf() {
                offer_closest(self.leaf_prims(n), &mut ray, counters, hit);
            } else {
                let (l, r) = (node + 1, n.offset as usize);
                let wide = widen_up(ray.tmax);
                let hl = rb.hit(&self.nodes[l], wide);
                let hr = rb.hit(&self.nodes[r], wide);
                if C::RECORDS {
                    skip_missed(counters, [(l, hl.is_some()), (r, hr.is_some())]);
                }
                match (hl, hr) {
                    (Some(tl), Some(tr)) => {
                        // Nearest child first; the other waits with its entry
                        // distance so it can be culled once a closer hit is known.
                        let (near, far, tfar) = if tl <= tr { (l, r, tr) } else { (r, l, tl) };
                        stack[sp] = (far as u32, tfar);
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (nd, tenter) = stack[sp];
                if tenter <= widen_up(ray.tmax) {
                    node = nd as usize;
                    break;
                }
                // Entered when pushed, but beyond the closest hit by now.
                skip_node(counters, nd);
            }
        }
    }

    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        let Some(root) = self.nodes.first() else {
            return false;
        };
        let rb = RayBox::new(ray);
        let wide = widen_up(ray.tmax);
        if rb.hit(root, wide).is_none() {
            skip_node(counters, 0);
            return false;
        }
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            count_node(counters, node as u32);
            let n = &self.nodes[node];
            if n.is_leaf() {
                if offer_any(self.leaf_prims(n), ray, counters, hit) {
                    return true;
                }
            } else {
                let (l, r) = (node + 1, n.offset as usize);
                let hl = rb.hit(&self.nodes[l], wide).is_some();
                let hr = rb.hit(&self.nodes[r], wide).is_some();
                if C::RECORDS {
                    skip_missed(counters, [(l, hl), (r, hr)]);
                }
                match (hl, hr) {
                    (true, true) => {
                        stack[sp] = r as u32;
                        sp += 1;
                        node = l;
                        continue;
                    }
                    (true, false) => {
                        node = l;
                        continue;
                    }
                    (false, true) => {
                        node = r;
                        continue;
                    }
                    (false, false) => {}
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack[sp] as usize;
        }
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            nodes: self.nodes.len(),
            leaves: self.nodes.iter().filter(|n| n.is_leaf()).count(),
            max_depth: self.max_depth,
            memory_bytes: std::mem::size_of::<Self>()
                + self.nodes.len() * std::mem::size_of::<BvhNode>()
                + (self.prims.len() + self.unbounded.len()) * 4,
            sah_cost: self.sah_cost(1.0, 1.0),
        }
    }
}

/// A tree built in parallel: sequentially built pieces joined by the
/// interior nodes above them. Flattening it copies each node once, where
/// appending each level's vectors into its parent's would copy the lower
/// nodes once per parallel level.
pub(crate) enum Subtree {
    /// Nodes in depth-first order, child indices relative to the first.
    Flat(Vec<BvhNode>),
    /// An interior node with this box over two subtrees.
    Split(Aabb, Box<(Subtree, Subtree)>),
}

impl Subtree {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        match self {
            Subtree::Flat(v) => v.len(),
            Subtree::Split(_, c) => 1 + c.0.len() + c.1.len(),
        }
    }

    /// The nodes in depth-first order, each copied once, the pieces in
    /// parallel (serial, this copy was a few percent of a million-triangle
    /// build).
    pub fn flatten(self) -> Vec<BvhNode> {
        let len = self.len();
        let mut out = Vec::with_capacity(len);
        self.write(&mut out.spare_capacity_mut()[..len], 0);
        // SAFETY: `write` filled every one of the `len` slots: each `Flat`
        // piece checks that its stretch is exactly its length, and the
        // stretches tile the slots.
        unsafe { out.set_len(len) };
        out
    }

    /// Writes the nodes depth-first into `out`, exactly `self.len()` slots
    /// whose first is node `base` of the whole tree.
    fn write(self, out: &mut [MaybeUninit<BvhNode>], base: usize) {
        match self {
            Subtree::Flat(v) => {
                assert_eq!(out.len(), v.len(), "a piece's stretch is its length");
                // Child indices were relative to the piece's first node.
                for (slot, mut n) in out.iter_mut().zip(v) {
                    if !n.is_leaf() {
                        n.offset += base as u32;
                    }
                    slot.write(n);
                }
            }
            Subtree::Split(b, children) => {
                let (l, r) = *children;
                let (me, rest) = out.split_first_mut().expect("a slot for the node");
                let (lo, ro) = rest.split_at_mut(l.len());
                let right = base + 1 + lo.len();
                me.write(BvhNode::interior(&b, right));
                rayon::join(|| l.write(lo, base + 1), || r.write(ro, right));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::counters::{NoCounters, RayCounts};
    use crate::list::List;
    use crate::test_meshes::{bumpy_grid, offered};
    use crate::triangle::mesh::TriangleMesh;

    fn closest<A: Accelerator>(a: &A, m: &TriangleMesh, r: &Ray) -> Option<(f32, u32)> {
        let mut best = None;
        a.closest(r, &mut NoCounters, |p, ray| {
            let h = m.intersect(p, ray)?;
            best = Some((h.t, p));
            Some(h.t)
        });
        best
    }

    const BUILDERS: [BvhBuilder; 5] = [
        BvhBuilder::Center,
        BvhBuilder::Median,
        BvhBuilder::BinnedSah,
        BvhBuilder::SweepSah,
        BvhBuilder::Ploc,
    ];

    #[test]
    fn every_builder_matches_list() {
        let m = bumpy_grid(24);
        let list = List::build(&m);
        for b in BUILDERS {
            let bvh = Bvh::build(&m, b, &BvhParams::default());
            let s = bvh.stats();
            assert!(s.leaves * 2 - 1 == s.nodes, "{b:?}");
            assert_eq!(bvh.prim_indices().len(), m.triangles.len());
            for k in 0..200 {
                let f = k as f32;
                let o = Vec3::new((f * 0.13).fract(), (f * 0.29).fract(), 1.0);
                let d = Vec3::new((f * 0.7).sin() * 0.3, (f * 0.3).cos() * 0.3, -1.0);
                let r = Ray::new(o, d, 0.0, f32::INFINITY);
                assert_eq!(
                    closest(&bvh, &m, &r).map(|h| h.0),
                    closest(&list, &m, &r).map(|h| h.0),
                    "{b:?} ray {k}"
                );
                let test = |p: u32, ray: &Ray| m.intersect(p, ray).is_some();
                let ob = bvh.occluded(&r, &mut NoCounters, test);
                let ol = list.occluded(&r, &mut NoCounters, test);
                assert_eq!(ob, ol);
            }
        }
    }

    #[test]
    fn sah_quality_and_culling() {
        let m = bumpy_grid(40);
        let p = BvhParams::default();
        let sweep = Bvh::build(&m, BvhBuilder::SweepSah, &p)
            .stats()
            .sah_cost
            .unwrap();
        let binned = Bvh::build(&m, BvhBuilder::BinnedSah, &p)
            .stats()
            .sah_cost
            .unwrap();
        let ploc = Bvh::build(&m, BvhBuilder::Ploc, &p)
            .stats()
            .sah_cost
            .unwrap();
        assert!(binned <= sweep * 1.05, "binned {binned} sweep {sweep}");
        assert!(ploc <= sweep * 1.3, "ploc {ploc} sweep {sweep}");
        let bvh = Bvh::build(&m, BvhBuilder::BinnedSah, &p);
        let mut c = RayCounts::default();
        let r = Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
        bvh.closest(&r, &mut c, |i, ray| m.intersect(i, ray).map(|h| h.t));
        assert!(c.tests < 40, "{c:?}");
    }

    #[test]
    fn parallel_build_is_deterministic() {
        let m = bumpy_grid(60);
        for b in BUILDERS {
            let seq = BvhParams {
                parallel_threshold: usize::MAX,
                ..BvhParams::default()
            };
            let par = BvhParams {
                parallel_threshold: 64,
                ..BvhParams::default()
            };
            let a = Bvh::build(&m, b, &seq);
            let c = Bvh::build(&m, b, &par);
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            let d = one.install(|| Bvh::build(&m, b, &par));
            assert_eq!(a.nodes(), c.nodes(), "{b:?}");
            assert_eq!(a.prim_indices(), c.prim_indices(), "{b:?}");
            assert_eq!(c.nodes(), d.nodes(), "{b:?}");
        }
    }

    #[test]
    fn empty_and_degenerate_inputs() {
        let none: Vec<Aabb> = Vec::new();
        let odd = vec![
            Aabb::EMPTY,
            Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE),
            Aabb::new(Vec3::splat(f32::NEG_INFINITY), Vec3::ONE),
            Aabb::new(Vec3::ONE, Vec3::ONE),
            Aabb::new(Vec3::ONE, Vec3::ONE),
            Aabb::new(Vec3::splat(-3e38), Vec3::splat(3e38)),
        ];
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 100];
        for b in BUILDERS {
            let e = Bvh::build(&none, b, &BvhParams::default());
            let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0);
            assert!(!e.occluded(&r, &mut NoCounters, |_, _| true));
            let o = Bvh::build(&odd, b, &BvhParams::default());
            let r = Ray::new(Vec3::ZERO, Vec3::ONE, 0.0, f32::INFINITY);
            let mut seen = offered(&o, &r);
            seen.sort();
            assert_eq!(seen, vec![1, 2, 3, 4, 5], "{b:?}");
            let s = Bvh::build(&same, b, &BvhParams::default());
            assert!(s.stats().max_depth <= FORCE_MEDIAN_DEPTH + 32);
            assert_eq!(offered(&s, &r).len(), 100);
        }
    }

    #[test]
    fn centroids_carry_no_id_bits() {
        // The id lane must stay out of the centroid's arithmetic (subnormal
        // ids are slow to multiply on some CPUs), and the centre must not
        // change for it.
        let b = Aabb::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::new(3.0, 2.0, 1.5));
        for id in [1, 12_345, 1 << 22, u32::MAX] {
            let c = Ref::new(id, &b).centroid4();
            assert_eq!(c.w.to_bits(), 0, "id {id}");
            assert_eq!(c.truncate(), Vec3::new(1.0, 2.0, 1.0), "id {id}");
        }
    }

    /// FNV-1a over every node's fields and the leaf order: any difference in
    /// the tree changes it.
    fn fingerprint(bvh: &Bvh) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let words = bvh.nodes().iter().flat_map(|n| {
            let f = [n.min.x, n.min.y, n.min.z, n.max.x, n.max.y, n.max.z];
            f.map(f32::to_bits).into_iter().chain([n.offset, n.count])
        });
        for w in words.chain(bvh.prim_indices().iter().copied()) {
            for byte in w.to_le_bytes() {
                h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
            }
        }
        h
    }

    /// `n` small boxes along a random walk (neighbours in the list are
    /// neighbours in space, as on a mesh) or scattered through a cube, from
    /// exact arithmetic only, so every platform builds the same boxes.
    fn boxes(n: usize, walk: bool, seed: u64) -> Vec<Aabb> {
        let mut next = crate::util::unit_sequence(seed);
        let mut p = Vec3::ZERO;
        (0..n)
            .map(|_| {
                let r = Vec3::new(next(), next(), next());
                p = if walk { p + (r - 0.5) * 0.01 } else { r };
                let size = Vec3::new(next(), next(), next()) * 0.004;
                Aabb::new(p - size, p + size)
            })
            .collect()
    }

    /// `n` boxes around the origin, a third of their coordinates exactly 0
    /// or -0: which zero a box keeps depends on the order boxes are merged.
    fn zero_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut next = crate::util::unit_sequence(seed);
        let mut coord = |sign: f32| match next() {
            u if u < 0.15 => 0.0,
            u if u < 0.3 => -0.0,
            _ => sign * 0.01 * next(),
        };
        (0..n)
            .map(|_| {
                let lo = Vec3::new(coord(-1.0), coord(-1.0), coord(-1.0));
                Aabb::new(lo, Vec3::new(coord(1.0), coord(1.0), coord(1.0)))
            })
            .collect()
    }

    #[test]
    fn binned_sah_trees_are_pinned() {
        // Speed work on the binned builder must keep its trees bit for bit
        // (same nodes, same leaf order). The inputs are large enough for the
        // parallel, sampled and small-node paths; a deliberate change of the
        // trees updates these values.
        let block4 = BvhParams {
            leaf_block: 4,
            ..BvhParams::default()
        };
        let cases = [
            (
                boxes(60_000, true, 3),
                BvhParams::default(),
                0xfc77_e68b_01de_fb16,
            ),
            (boxes(60_000, true, 3), block4, 0xdfc0_37e2_6f3b_1fdc),
            (boxes(60_000, false, 5), block4, 0x0b3a_8117_c82f_8d09),
            (zero_boxes(40_000, 7), block4, 0x3a0e_3a85_0ad9_a87f),
        ];
        let got = cases
            .each_ref()
            .map(|(b, params, _)| fingerprint(&Bvh::build(b, BvhBuilder::BinnedSah, params)));
        assert_eq!(got, cases.each_ref().map(|c| c.2), "{got:#018x?}");
    }
}
