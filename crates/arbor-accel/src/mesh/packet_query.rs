//! The queries a packet of rays answers lane by lane ([`PacketQuery`]):
//! closest hits, occlusion, crossing counts and every hit, each with the
//! single ray's leaf test of [`TriangleBvh`].

use super::triangle_bvh::TriangleBvh;
use super::MeshHit;
use crate::counters::Counters;
use crate::ray::Ray;
use crate::triangle::watertight::RayShear;

/// A query a packet answers, lane by lane, with the single ray's leaf test
/// (`TriangleBvh::test_leaf`): what a lane keeps, how a hit changes it, and
/// where the lane's ray may still go after a leaf.
pub(crate) trait PacketQuery {
    /// One ray's answer, its default the answer before the first leaf.
    type Answer: Default + Send;

    /// Whether the query leaves `bvh`'s rays to single rays.
    fn declined(bvh: &TriangleBvh) -> bool {
        let _ = bvh;
        false
    }

    /// The leaf `(first, count)` tested for the lane's `ray`, its hits
    /// taken into `answer` (which may shrink `ray`): `test_leaf` with the
    /// query's `ANY_HIT` and `OWNED`. `true` when it stopped early.
    fn test<C: Counters>(
        bvh: &TriangleBvh,
        leaf: (usize, usize),
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        answer: &mut Self::Answer,
    ) -> bool;

    /// The lane's culling distance after a leaf, whose test ended early
    /// when `stopped`: by default the ray's `tmax` (shrunk by the closest
    /// hit; the whole interval for the crossings, so that every leaf the
    /// ray enters is offered once, as on the single ray's walk).
    #[inline(always)]
    fn after_leaf(answer: &mut Self::Answer, stopped: bool, ray: &Ray) -> f32 {
        let _ = (answer, stopped);
        ray.tmax
    }
}

/// Each ray's closest hit, as [`TriangleBvh::closest`] finds it.
pub(crate) struct Closest;

/// Whether anything blocks each ray, as [`TriangleBvh::occluded`] answers
/// (a ray leaves the packet at its first blocker).
pub(crate) struct Occluded;

/// How many crossings of the surface each ray meets, each once (the
/// mesh's `count`: the owned triangle test on the ray's whole interval).
/// Declined where a triangle sits in several leaves
/// ([`TriangleBvh::has_repeats`]): counting there needs the crossings'
/// triangles told apart.
pub(crate) struct Crossings;

impl PacketQuery for Closest {
    type Answer = Option<MeshHit>;
    #[inline(always)]
    fn test<C: Counters>(
        bvh: &TriangleBvh,
        (first, count): (usize, usize),
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        best: &mut Option<MeshHit>,
    ) -> bool {
        bvh.test_leaf::<false, false, C>(first, count, ray, shear, counters, |prim, hit, ray| {
            if best.is_none_or(|b| hit.t < b.hit.t) {
                *best = Some(MeshHit { prim, hit });
            }
            ray.tmax = ray.tmax.min(hit.t);
            false
        })
    }
}

impl PacketQuery for Occluded {
    type Answer = bool;
    // The single ray's any-hit test: it stops at the first triangle
    // certainly hit.
    #[inline(always)]
    fn test<C: Counters>(
        bvh: &TriangleBvh,
        (first, count): (usize, usize),
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        _: &mut bool,
    ) -> bool {
        bvh.test_leaf::<true, false, C>(first, count, ray, shear, counters, |_, _, _| true)
    }

    #[inline(always)]
    fn after_leaf(blocked: &mut bool, stopped: bool, ray: &Ray) -> f32 {
        if stopped {
            *blocked = true;
            // Below every entry distance (a packet's rays have
            // `tmin >= 0`), so the ray enters nothing more; finite, so
            // that widening it stays a number.
            return -1.0;
        }
        ray.tmax
    }
}

impl PacketQuery for Crossings {
    type Answer = u32;
    fn declined(bvh: &TriangleBvh) -> bool {
        bvh.has_repeats()
    }

    // The owned test: each crossing reported by one triangle.
    #[inline(always)]
    fn test<C: Counters>(
        bvh: &TriangleBvh,
        (first, count): (usize, usize),
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        crossings: &mut u32,
    ) -> bool {
        bvh.test_leaf::<false, true, C>(first, count, ray, shear, counters, |_, _, _| {
            *crossings += 1;
            false
        })
    }
}

/// Every crossing of each ray, as the mesh's `all_hits` finds them (the
/// owned test on the whole interval), in the order met; the caller sorts
/// them. Declined where triangles repeat, as [`Crossings`].
pub(crate) struct EveryHit;

impl PacketQuery for EveryHit {
    type Answer = Vec<MeshHit>;

    fn declined(bvh: &TriangleBvh) -> bool {
        bvh.has_repeats()
    }

    #[inline(always)]
    fn test<C: Counters>(
        bvh: &TriangleBvh,
        (first, count): (usize, usize),
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        hits: &mut Vec<MeshHit>,
    ) -> bool {
        bvh.test_leaf::<false, true, C>(first, count, ray, shear, counters, |prim, hit, _| {
            hits.push(MeshHit { prim, hit });
            false
        })
    }
}
