//! [`TriangleBvh`]: the default wide BVH specialised to a triangle mesh, for
//! callers that cast rays against plain triangles (`arbor trace`, benchmarks
//! against Embree) rather than through their own primitive test.
//!
//! The generic structures hand the caller one primitive index at a time, and
//! the caller looks its triangle up: two dependent loads per test and a
//! scalar test. Here each leaf's triangles are copied into the structure as
//! packets of four, coordinates in lanes (`Tri4`, 160 bytes: 40 per
//! triangle when full), and go through the watertight test's `f32` edge
//! stage four at a time in SIMD lanes (`triangle/lanes.rs`). The tree is
//! built knowing this: its SAH counts a leaf of `n` triangles as
//! `ceil(n / 4)` tests (`BvhParams::leaf_block`), so leaves fill packets. The answers are bit for bit
//! those of [`WideBvh`] with [`intersect_triangle_sheared`] as the caller's
//! test (same traversal, same triangles offered in the same order, the same
//! arithmetic per triangle), which the tests below check against brute force.

use glam::Vec3;
use rayon::prelude::*;

use super::packet_query::PacketQuery;
use crate::accel::{AccelStats, Accelerator};
use crate::bvh2::{Bvh, BvhBuilder, BvhParams};
use crate::counters::Counters;
use crate::mesh::MeshHit;
use crate::ray::Ray;
#[cfg(target_arch = "x86_64")]
use crate::triangle::lanes::pair;
use crate::triangle::lanes::{edge_stage, EdgeVerdict, Tri4, LANES};
use crate::triangle::mesh::TriangleMesh;
use crate::triangle::watertight::{
    intersect_triangle_owned, intersect_triangle_sheared, RayShear, TriangleHit,
};
use crate::util::prefetch_ptr;
use crate::wide::packet::{one_octant, PACKET, PACKET16};
use crate::wide::WideBvh;

/// Leaves packed by one parallel task: a leaf is one or two packets, too
/// little work to hand to a thread alone.
const PACK_GRAIN: usize = 256;

/// A wide BVH over a triangle mesh that owns its triangles, packed four to
/// a packet in leaf order.
#[derive(Clone, Debug, Default)]
pub struct TriangleBvh {
    /// The tree; its leaves' `first` index `packets`.
    bvh: WideBvh,
    /// Each leaf's triangles, `ceil(count / 4)` packets from its `first`.
    packets: Vec<Tri4>,
    /// Triangles without a finite box (offered to every ray), with their ids.
    unbounded: Vec<(u32, [Vec3; 3])>,
}

/// Packs the triangles of every leaf (`leaves[i]` holds slots
/// `first..first + count` of `slots` and gets packets
/// `packet_of[i]..packet_of[i + 1]`).
///
/// Leaves pack independently, so groups of them are packed in parallel,
/// each group straight into its own stretch of the result: serial, packing
/// was a fifth of a million-triangle build (every triangle's three vertices
/// are fetched from wherever the mesh keeps them).
fn pack_leaves(
    mesh: &TriangleMesh,
    slots: &[u32],
    leaves: &[(u32, u32)],
    packet_of: &[u32],
) -> Vec<Tri4> {
    let total = packet_of[leaves.len()] as usize;
    let mut packets: Vec<Tri4> = Vec::with_capacity(total);
    // Hand each group of leaves the uninitialised slots of its packets.
    let mut work = Vec::with_capacity(leaves.len().div_ceil(PACK_GRAIN));
    let mut rest = &mut packets.spare_capacity_mut()[..total];
    for (g, group) in leaves.chunks(PACK_GRAIN).enumerate() {
        let start = packet_of[g * PACK_GRAIN];
        let end = packet_of[g * PACK_GRAIN + group.len()];
        let (mine, after) = rest.split_at_mut((end - start) as usize);
        work.push((group, mine));
        rest = after;
    }
    work.into_par_iter().for_each(|(group, out)| {
        let mut out = out.iter_mut();
        for &(first, count) in group {
            for ids in slots[first as usize..(first + count) as usize].chunks(LANES) {
                // A fixed buffer: one allocation per packet was a quarter of
                // a million for a million triangles.
                let mut tris = [[Vec3::ZERO; 3]; LANES];
                for (t, &p) in tris.iter_mut().zip(ids) {
                    *t = mesh.triangle(p);
                }
                // `packet_of` gave this group exactly one slot per packet.
                out.next()
                    .expect("a slot per packet")
                    .write(Tri4::new(&tris[..ids.len()], ids));
            }
        }
        // Checked, not assumed: `set_len` below relies on it.
        assert!(out.next().is_none(), "every slot written");
    });
    // SAFETY: the groups' stretches tile `0..total` (consecutive ranges of
    // `packet_of`), each task wrote every slot of its stretch (asserted
    // above), and every task has finished.
    unsafe { packets.set_len(total) };
    packets
}

impl TriangleBvh {
    /// The build parameters that suit four-at-a-time leaf tests: the binned
    /// SAH counting a leaf of `n` triangles as `ceil(n / 4)` tests, so that
    /// leaves fill their packets: fewer bytes per triangle for slightly more
    /// instructions (docs/perf-log/2026-11-23-second-round.md).
    pub fn params() -> BvhParams {
        BvhParams {
            leaf_block: LANES,
            ..BvhParams::default()
        }
    }

    /// Builds the wide BVH over `mesh` with `params` and packs each leaf's
    /// triangles. The mesh is not needed afterwards.
    pub fn build(mesh: &TriangleMesh, params: &BvhParams) -> Self {
        let bin = Bvh::build(mesh, BvhBuilder::BinnedSah, &WideBvh::params(params));
        let leaves = bin.leaves();
        let slots = bin.prim_indices();
        // Leaf `first` -> its first packet, in the order of `leaves`; the
        // last entry is the packet count.
        let mut packet_of = Vec::with_capacity(leaves.len() + 1);
        packet_of.push(0u32);
        for &(_, count) in &leaves {
            packet_of.push(packet_of[packet_of.len() - 1] + count.div_ceil(LANES as u32));
        }
        // The collapse needs only the binary tree and the packing only its
        // leaves, so they run side by side (the collapse is serial).
        let (bvh, packets) = rayon::join(
            || WideBvh::collapse(&bin),
            || pack_leaves(mesh, slots, &leaves, &packet_of),
        );
        let unbounded: Vec<(u32, [Vec3; 3])> = bvh
            .unbounded()
            .iter()
            .map(|&p| (p, mesh.triangle(p)))
            .collect();
        let bvh = bvh.into_leaf_storage(|first| {
            let i = leaves.partition_point(|&(f, _)| f < first);
            packet_of[i]
        });
        TriangleBvh {
            bvh,
            packets,
            unbounded,
        }
    }

    /// Whether a triangle sits in more than one leaf (a build with spatial
    /// splits), so that traversal may offer it twice.
    pub fn has_repeats(&self) -> bool {
        self.bvh.has_repeats()
    }

    /// The closest hit within `[ray.tmin, ray.tmax]`. Of hits at the same
    /// distance, the first offered wins (as with [`WideBvh`] and a caller
    /// that keeps the first of equal hits).
    #[inline]
    pub fn closest<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Option<MeshHit> {
        // The shear is computed at the first triangle test: most rays of a
        // camera framing a model miss it at the root and never need it.
        let mut shear: Option<RayShear> = None;
        let mut best: Option<MeshHit> = None;
        let mut keep = |prim: u32, hit: TriangleHit, ray: &mut Ray| {
            if best.is_none_or(|b| hit.t < b.hit.t) {
                best = Some(MeshHit { prim, hit });
            }
            ray.tmax = ray.tmax.min(hit.t);
        };
        let mut ray = *ray;
        for &(prim, [a, b, c]) in &self.unbounded {
            counters.test();
            let shear = shear.get_or_insert_with(|| RayShear::new(&ray));
            if let Some(hit) = intersect_triangle_sheared(&ray, shear, a, b, c) {
                keep(prim, hit, &mut ray);
            }
        }
        self.bvh.closest_leaves(
            ray,
            counters,
            #[inline(always)]
            |first, count, ray, counters| {
                let shear = &*shear.get_or_insert_with(|| RayShear::new(ray));
                self.test_leaf::<false, false, C>(
                    first,
                    count,
                    ray,
                    shear,
                    counters,
                    |prim, hit, ray| {
                        keep(prim, hit, ray);
                        false
                    },
                );
            },
            |first| prefetch_ptr(self.packets.as_ptr().wrapping_add(first)),
        );
        best
    }

    /// The answers of query `Q` ([`Closest`](super::packet_query::Closest), [`Occluded`](super::packet_query::Occluded), [`Crossings`](super::packet_query::Crossings))
    /// for `N` rays traced together as a packet, `N` being [`PACKET`]
    /// (eight, on a CPU with AVX2) or [`PACKET16`] (sixteen, with AVX-512
    /// F), or `None` (nothing traced) when they are not coherent enough for
    /// one: they must be finite, with no zero direction component,
    /// `tmin >= 0` and all directions in one octant (neighbouring camera
    /// rays are), and the CPU must have the width's instructions. Callers
    /// answer the others one by one. Each lane runs the single ray's leaf
    /// test, so each answer is the ray's own (see `wide/packet.rs`; of
    /// several triangles hit at exactly the same distance, a closest-hit
    /// packet may report another one than the single ray would).
    #[inline(never)]
    pub(crate) fn packet<const N: usize, C: Counters, Q: PacketQuery>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
    ) -> Option<[Q::Answer; N]> {
        // Directions in different octants (secondary rays, mostly) cannot
        // form a packet: found out here for the price of `N` sign masks.
        if !self.unbounded.is_empty() || !one_octant(rays) {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if N == PACKET16 && crate::wide::lanes::has_avx512() {
                // SAFETY: the CPU has AVX-512 F.
                return unsafe { self.packet_avx512::<N, C, Q>(rays, counters) };
            }
            if N == PACKET && crate::wide::lanes::has_avx2() {
                // SAFETY: the CPU has AVX2.
                return unsafe { self.packet_avx2::<N, C, Q>(rays, counters) };
            }
        }
        let _ = counters;
        None
    }

    /// [`TriangleBvh::packet`] compiled for AVX2, the leaf test inlined.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt")]
    unsafe fn packet_avx2<const N: usize, C: Counters, Q: PacketQuery>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
    ) -> Option<[Q::Answer; N]> {
        self.packet_lanes::<N, C, Q>(rays, counters)
    }

    /// [`TriangleBvh::packet`] compiled for AVX-512 F.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,bmi1,bmi2,popcnt")]
    unsafe fn packet_avx512<const N: usize, C: Counters, Q: PacketQuery>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
    ) -> Option<[Q::Answer; N]> {
        self.packet_lanes::<N, C, Q>(rays, counters)
    }

    /// The packet traversal with query `Q`'s leaf test for each lane.
    ///
    /// # Safety
    /// As [`WideBvh::closest_packet_lanes`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn packet_lanes<const N: usize, C: Counters, Q: PacketQuery>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
    ) -> Option<[Q::Answer; N]> {
        if Q::declined(self) {
            return None;
        }
        let mut each = *rays;
        let mut shears: [Option<RayShear>; N] = [None; N];
        let mut answers: [Q::Answer; N] = std::array::from_fn(|_| Q::Answer::default());
        let traced = self.bvh.closest_packet_lanes(
            rays,
            counters,
            #[inline(always)]
            |first, count, lane, counters| {
                let ray = &mut each[lane];
                let shear = &*shears[lane].get_or_insert_with(|| RayShear::new(ray));
                let answer = &mut answers[lane];
                let stopped = Q::test(self, (first, count), ray, shear, counters, answer);
                Q::after_leaf(answer, stopped, ray)
            },
        );
        traced.then_some(answers)
    }

    /// Whether any triangle is hit within `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn occluded<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        // Computed at the first triangle test, as in `closest`.
        let mut shear: Option<RayShear> = None;
        for &(_, [a, b, c]) in &self.unbounded {
            counters.test();
            let shear = shear.get_or_insert_with(|| RayShear::new(ray));
            if intersect_triangle_sheared(ray, shear, a, b, c).is_some() {
                return true;
            }
        }
        self.bvh.occluded_leaves(
            ray,
            counters,
            #[inline(always)]
            |first, count, ray, counters| {
                let shear = &*shear.get_or_insert_with(|| RayShear::new(ray));
                let mut ray = *ray;
                self.test_leaf::<true, false, C>(
                    first,
                    count,
                    &mut ray,
                    shear,
                    counters,
                    |_, _, _| true,
                )
            },
            |first| prefetch_ptr(self.packets.as_ptr().wrapping_add(first)),
        )
    }

    /// Calls `f` for every crossing of the surface within the ray's whole
    /// interval (which is never shrunk), each reported by one triangle
    /// ([`crate::numerics::intersect_triangle_owned`]), in traversal order.
    pub(crate) fn for_each_crossing<C: Counters>(
        &self,
        ray: &Ray,
        counters: &mut C,
        mut f: impl FnMut(MeshHit),
    ) {
        let mut shear: Option<RayShear> = None;
        for &(prim, [a, b, c]) in &self.unbounded {
            counters.test();
            let shear = shear.get_or_insert_with(|| RayShear::new(ray));
            if let Some(hit) = intersect_triangle_owned(ray, shear, a, b, c) {
                f(MeshHit { prim, hit });
            }
        }
        // Nothing prunes the walk (the interval never shrinks), so the
        // children's order is worthless: the unordered any-hit walk, whose
        // leaf callback here never ends it.
        self.bvh.occluded_leaves(
            ray,
            counters,
            // Inlined into the AVX2 traversal, so the lane test is compiled
            // for AVX2 too (out of line, its intrinsics became calls).
            #[inline(always)]
            |first, count, ray, counters| {
                let shear = &*shear.get_or_insert_with(|| RayShear::new(ray));
                let mut ray = *ray;
                self.test_leaf::<false, true, C>(
                    first,
                    count,
                    &mut ray,
                    shear,
                    counters,
                    |prim, hit, _| {
                        f(MeshHit { prim, hit });
                        false
                    },
                )
            },
            |first| prefetch_ptr(self.packets.as_ptr().wrapping_add(first)),
        );
    }

    /// Runs the leaf `(first, count)`'s triangles through the watertight
    /// test, four at a time, in leaf order, and calls `on_hit(id, hit, ray)`
    /// for each one hit (it may shrink `ray.tmax` for the ones after it).
    /// Stops and returns `true` as soon as `on_hit` does, or, with
    /// `ANY_HIT`, at the first triangle certainly hit inside the interval
    /// (before `on_hit` and without the exact distance: see
    /// `EdgeVerdict::any_hit_certainty`).
    /// With `OWNED`, each crossing is reported by one triangle only (see
    /// [`crate::numerics::intersect_triangle_owned`]).
    #[inline(always)]
    pub(super) fn test_leaf<const ANY_HIT: bool, const OWNED: bool, C: Counters>(
        &self,
        first: usize,
        count: usize,
        ray: &mut Ray,
        shear: &RayShear,
        counters: &mut C,
        mut on_hit: impl FnMut(u32, TriangleHit, &mut Ray) -> bool,
    ) -> bool {
        let packets = count.div_ceil(LANES);
        let mut i = 0;
        while i < packets {
            let left = count - i * LANES;
            let a = self.tri4(first + i);
            // Up to eight triangles (two packets) in one AVX2 pass; a leaf's
            // last lone packet goes in twice with only its lanes valid. The
            // edge stage does not depend on `tmax`, so computing the second
            // packet's verdict before the first packet's hits changes
            // nothing.
            #[cfg(target_arch = "x86_64")]
            if crate::wide::lanes::has_avx2() {
                let b = if left > LANES {
                    self.tri4(first + i + 1)
                } else {
                    a
                };
                let valid = if left >= 2 * LANES {
                    0xff
                } else {
                    (1u32 << left) - 1
                };
                for _ in 0..valid.count_ones() {
                    counters.test();
                }
                // SAFETY: the CPU has AVX2.
                // The behind-the-origin check in lanes pays for closest hits;
                // for any-hit queries it cost more in the walk's registers
                // than it saved (docs/perf-log/2026-12-07-behind-in-lanes.md).
                let verdict =
                    unsafe { pair::edge_stage8(ray, shear, [a, b], valid, false, !ANY_HIT) };
                if let Some(verdict) = verdict {
                    let triangle = |k: usize| {
                        let p = if k < LANES { a } else { b };
                        (p.ids[k % LANES], p.triangle(k % LANES))
                    };
                    let todo = verdict.candidates_of(valid);
                    if finish::<ANY_HIT, OWNED, 8>(
                        &verdict,
                        todo,
                        triangle,
                        ray,
                        shear,
                        &mut on_hit,
                    ) {
                        return true;
                    }
                }
                i += 2;
                continue;
            }
            let lanes = left.min(LANES);
            for _ in 0..lanes {
                counters.test();
            }
            let verdict = edge_stage(ray, shear, a, lanes);
            let triangle = |k: usize| (a.ids[k], a.triangle(k));
            let todo = verdict.candidates(lanes);
            if finish::<ANY_HIT, OWNED, LANES>(&verdict, todo, triangle, ray, shear, &mut on_hit) {
                return true;
            }
            i += 1;
        }
        false
    }

    /// Triangle packet `i` (of a leaf).
    #[inline(always)]
    fn tri4(&self, i: usize) -> &Tri4 {
        debug_assert!(i < self.packets.len());
        // SAFETY: leaves name their packets: `build` gives each leaf
        // `ceil(count / 4)` packets from the first one its reference names
        // (`packet_of`), and the traversal asks only for those.
        unsafe { self.packets.get_unchecked(i) }
    }
}

/// The candidates `todo` of one edge-stage `verdict` (lane `k`'s triangle
/// and id from `triangle(k)`), in lane order, through the full test; stops
/// and returns `true` as soon as `on_hit` does. A function rather than a
/// closure so that it can be forced inline into the traversal.
#[inline(always)]
fn finish<const ANY_HIT: bool, const OWNED: bool, const N: usize>(
    verdict: &EdgeVerdict<N>,
    mut todo: u32,
    triangle: impl Fn(usize) -> (u32, [Vec3; 3]),
    ray: &mut Ray,
    shear: &RayShear,
    on_hit: &mut impl FnMut(u32, TriangleHit, &mut Ray) -> bool,
) -> bool {
    while todo != 0 {
        let k = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        let (id, tri) = triangle(k);
        // An any-hit query stops at a blocker certain without the `f64`
        // distance (its caller would stop at any hit `on_hit` is given), and
        // passes over a triangle certainly behind the origin (the full test
        // would turn it away first thing).
        if ANY_HIT {
            match verdict.any_hit_certainty(k, ray, shear, tri) {
                Some(true) => return true,
                Some(false) => continue,
                None => {}
            }
        }
        if let Some(hit) = verdict.finish::<OWNED>(k, ray, shear, tri) {
            if on_hit(id, hit, ray) {
                return true;
            }
        }
    }
    false
}

impl TriangleBvh {
    /// Size and shape; the memory includes the triangle copies.
    pub fn stats(&self) -> AccelStats {
        let mut stats = self.bvh.stats();
        stats.memory_bytes += std::mem::size_of_val(self.packets.as_slice())
            + std::mem::size_of_val(self.unbounded.as_slice());
        stats
    }

    /// Number of triangles indexed (in packets or unbounded).
    #[cfg(test)]
    fn len(&self) -> usize {
        let packed = self.packets.iter().flat_map(|p| p.ids);
        packed.filter(|&id| id != Tri4::NO_ID).count() + self.unbounded.len()
    }

    /// Whether no triangle is indexed.
    #[cfg(test)]
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Accel, AccelKind};
    use crate::mesh::packet_query::{Closest, Crossings, EveryHit, Occluded};
    use crate::test_meshes::{bumpy_grid, bumpy_grid_parts};
    use crate::wide::lanes::without_avx2;

    /// A deterministic bumpy mesh with shared edges, plus a few hostile
    /// triangles (degenerate, huge, NaN), and rays from all around.
    fn scene() -> (TriangleMesh, Vec<Ray>) {
        let (mut vertices, mut triangles) = bumpy_grid_parts(24);
        let base = vertices.len() as u32;
        vertices.extend([
            Vec3::new(0.5, 0.5, 0.05),
            Vec3::new(0.6, 0.5, 0.05),
            Vec3::new(0.7, 0.5, 0.05), // collinear: never hit
            Vec3::new(-1e30, -1e30, 0.2),
            Vec3::new(1e30, 0.0, 0.2),
            Vec3::new(0.0, 1e30, 0.2),
            Vec3::new(f32::NAN, 0.0, 0.0),
        ]);
        triangles.push([base, base + 1, base + 2]);
        triangles.push([base + 3, base + 4, base + 5]);
        triangles.push([base + 6, base, base + 1]);
        let mut rays = Vec::new();
        let mut k = 0u32;
        for i in 0..40 {
            for j in 0..40 {
                k += 1;
                let target = Vec3::new(i as f32 / 39.0, j as f32 / 39.0, 0.0);
                let from = Vec3::new(
                    0.5 + ((k * 37) % 11) as f32 - 5.0,
                    0.5 + ((k * 53) % 13) as f32 - 6.0,
                    if k.is_multiple_of(3) { -2.0 } else { 3.0 },
                );
                rays.push(Ray::new(from, target - from, 0.0, f32::INFINITY));
                // Axis-parallel rays (zero direction components) too.
                rays.push(Ray::new(
                    Vec3::new(target.x, target.y, 1.0),
                    Vec3::new(0.0, 0.0, -1.0),
                    0.0,
                    if k.is_multiple_of(5) {
                        0.5
                    } else {
                        f32::INFINITY
                    },
                ));
            }
        }
        (mesh_of(vertices, triangles), rays)
    }

    fn mesh_of(v: Vec<Vec3>, t: Vec<[u32; 3]>) -> TriangleMesh {
        TriangleMesh::new(v, t)
    }

    /// What brute force answers: every triangle in index order, the first of
    /// equal hits kept.
    fn brute(mesh: &TriangleMesh, ray: &Ray) -> (Option<(u32, f32)>, bool) {
        let list = Accel::build(AccelKind::List, mesh);
        let shear = RayShear::new(ray);
        let mut best: Option<(u32, f32)> = None;
        list.closest(ray, &mut crate::counters::NoCounters, |p, r| {
            let [a, b, c] = mesh.triangle(p);
            let h = intersect_triangle_sheared(r, &shear, a, b, c)?;
            if best.is_none_or(|(_, t)| h.t < t) {
                best = Some((p, h.t));
            }
            Some(h.t)
        });
        let any = list.occluded(ray, &mut crate::counters::NoCounters, |p, r| {
            let [a, b, c] = mesh.triangle(p);
            intersect_triangle_sheared(r, &shear, a, b, c).is_some()
        });
        (best, any)
    }

    #[test]
    fn answers_like_brute_force_and_like_the_generic_wide_bvh() {
        let (mesh, rays) = scene();
        for params in [BvhParams::default(), TriangleBvh::params()] {
            check_against_brute_force_and_generic(&mesh, &rays, &params);
        }
    }

    fn check_against_brute_force_and_generic(
        mesh: &TriangleMesh,
        rays: &[Ray],
        params: &BvhParams,
    ) {
        let fast = TriangleBvh::build(mesh, params);
        let wide = WideBvh::build(mesh, params);
        assert_eq!(
            fast.len(),
            mesh.triangles.len(),
            "NaN ones among the unbounded"
        );
        let mut hits = 0;
        for ray in rays {
            let got = fast.closest(ray, &mut crate::counters::NoCounters);
            // The portable traversal and leaf test (on a machine without
            // AVX2, the only ones) answer alike, hit for hit.
            let portable = without_avx2(|| {
                let closest = fast.closest(ray, &mut crate::counters::NoCounters);
                (
                    closest,
                    fast.occluded(ray, &mut crate::counters::NoCounters),
                )
            });
            assert_eq!(portable, (got, got.is_some()), "{ray:?}");
            let (want, any) = brute(mesh, ray);
            assert_eq!(got.map(|h| h.hit.t.to_bits()), want.map(|w| w.1.to_bits()));
            // The same triangle as the generic structure with the same test
            // (brute force may pick the other triangle of a shared edge).
            let shear = RayShear::new(ray);
            let mut generic: Option<MeshHit> = None;
            wide.closest(ray, &mut crate::counters::NoCounters, |p, r| {
                let [a, b, c] = mesh.triangle(p);
                let hit = intersect_triangle_sheared(r, &shear, a, b, c)?;
                if generic.is_none_or(|g| hit.t < g.hit.t) {
                    generic = Some(MeshHit { prim: p, hit });
                }
                Some(hit.t)
            });
            assert_eq!(got, generic, "{ray:?}");
            assert_eq!(
                fast.occluded(ray, &mut crate::counters::NoCounters),
                any,
                "{ray:?}"
            );
            hits += usize::from(got.is_some());
        }
        assert!(hits > rays.len() / 2, "only {hits} of {} hit", rays.len());
    }

    /// Packets of neighbouring camera rays answer ray by ray what single
    /// rays answer: the same distance bit for bit, and the same triangle
    /// unless another lies at exactly that distance (a shared edge or
    /// vertex). The camera sees the bumpy grid, its edges and the space
    /// beside it, with clipped intervals on some rows; packets of eight
    /// are really traced as packets on an AVX2 machine and packets of
    /// sixteen on an AVX-512 one (the test says it skipped them elsewhere),
    /// and declined without those and when their directions are not in one
    /// octant.
    #[test]
    fn packets_answer_like_single_rays() {
        let mesh = bumpy_grid(32);
        let bvh = TriangleBvh::build(&mesh, &TriangleBvh::params());
        let eye = Vec3::new(0.37, 0.61, 2.5);
        let (width, height) = (96, 72);
        let mut rays = Vec::new();
        for y in 0..height {
            for x in 0..width {
                let target = Vec3::new(
                    -0.3 + 1.6 * x as f32 / width as f32,
                    -0.3 + 1.6 * y as f32 / height as f32,
                    0.0,
                );
                let (tmin, tmax) = match y % 7 {
                    0 => (0.0, 0.9),
                    1 => (0.95, f32::INFINITY),
                    _ => (0.0, f32::INFINITY),
                };
                rays.push(Ray::new(eye, target - eye, tmin, tmax));
            }
        }
        // And packets whose rays part ways: one octant, targets scattered
        // over a quarter of the grid, from eyes at different heights, and
        // rays leaving a point on the grid again (`tmin` > 0).
        let mut next = crate::util::unit_sequence(11);
        for i in 0..3000 {
            let eye = Vec3::new(0.2 * next(), 0.2 * next(), 0.3 + 3.0 * next());
            // Groups of sixteen, so that packets of either width take rays
            // of one group.
            for _ in 0..PACKET16 {
                // A third of the packets from different origins
                // around the eye (so that the packet's origin intervals are
                // not points), a third from just above the grid.
                let ray = match i % 3 {
                    0 => {
                        let target = Vec3::new(0.25 + next(), 0.25 + next(), -0.2 * next());
                        Ray::new(eye, target - eye, 0.0, f32::INFINITY)
                    }
                    1 => {
                        let from = eye + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 0.4;
                        let target = Vec3::new(0.25 + next(), 0.25 + next(), -0.2 * next());
                        Ray::new(from, target - from, 0.0, f32::INFINITY)
                    }
                    _ => {
                        let (x, y) = (next(), next());
                        let z = 0.1 * ((7.0 * x).sin() * (5.0 * y).cos()) + 1e-3;
                        let dir = Vec3::new(next() + 0.01, next() + 0.01, 0.3 * next() + 0.01);
                        Ray::new(Vec3::new(x, y, z), dir, 1e-4, f32::INFINITY)
                    }
                };
                rays.push(ray);
            }
        }
        check_packets::<PACKET>(&mesh, &bvh, &rays, crate::wide::lanes::has_avx2());
        #[cfg(target_arch = "x86_64")]
        let wide = crate::wide::lanes::has_avx512();
        #[cfg(not(target_arch = "x86_64"))]
        let wide = false;
        if !wide {
            eprintln!("skipped: packets of sixteen (this CPU has no AVX-512 F)");
        }
        check_packets::<PACKET16>(&mesh, &bvh, &rays, wide);
        // The width the CPU offers; sixteen declined without AVX-512 (and
        // eight still traced).
        #[cfg(target_arch = "x86_64")]
        {
            use crate::wide::lanes::without_avx512;
            let sixteen: &[Ray; PACKET16] = rays[..PACKET16].try_into().unwrap();
            let eight: &[Ray; PACKET] = rays[..PACKET].try_into().unwrap();
            let hidden = without_avx512(|| {
                let width = crate::wide::packet::packet_width();
                let traced = bvh
                    .packet::<_, _, Closest>(eight, &mut crate::counters::NoCounters)
                    .is_some();
                (
                    width,
                    bvh.packet::<_, _, Closest>(sixteen, &mut crate::counters::NoCounters),
                    traced,
                )
            });
            assert_eq!(hidden, (PACKET, None, crate::wide::lanes::has_avx2()));
            let width = if wide { PACKET16 } else { PACKET };
            assert_eq!(crate::wide::packet::packet_width(), width);
        }
    }

    /// Where spatial splits put a triangle into several leaves, packets
    /// still answer closest hits and occlusion but leave counts and every
    /// hit to single rays, which tell the crossings' triangles apart.
    #[test]
    fn packets_leave_crossings_to_single_rays_where_triangles_repeat() {
        let mesh = crate::test_meshes::slivers();
        let bvh = TriangleBvh::build(&mesh, &TriangleBvh::params().high_quality());
        assert!(bvh.has_repeats(), "no triangle was cut");
        let eye = Vec3::new(5.0, 5.0, 8.0);
        let rays: [Ray; PACKET] = std::array::from_fn(|i| {
            Ray::new(
                eye,
                Vec3::new(0.1 + 0.01 * i as f32, 0.2, -1.0),
                0.0,
                f32::INFINITY,
            )
        });
        assert_eq!(
            bvh.packet::<_, _, Crossings>(&rays, &mut crate::counters::NoCounters),
            None
        );
        assert_eq!(
            bvh.packet::<_, _, EveryHit>(&rays, &mut crate::counters::NoCounters),
            None
        );
        let traced = bvh
            .packet::<_, _, Occluded>(&rays, &mut crate::counters::NoCounters)
            .is_some();
        assert_eq!(traced, crate::wide::lanes::has_avx2());
    }

    /// Packets of `N` rays from `rays` answer like single rays (see
    /// [`packets_answer_like_single_rays`]); `available`: the CPU traces
    /// packets of `N` (else every one must be declined).
    fn check_packets<const N: usize>(
        mesh: &TriangleMesh,
        bvh: &TriangleBvh,
        rays: &[Ray],
        available: bool,
    ) {
        let (mut packets, mut hits, mut other_triangle, mut several) = (0, 0, 0, 0);
        for chunk in rays.chunks_exact(N) {
            let packet: &[Ray; N] = chunk.try_into().unwrap();
            let coherent = one_octant(packet);
            let Some(got) = bvh.packet::<_, _, Closest>(packet, &mut crate::counters::NoCounters)
            else {
                assert!(!available || !coherent, "a coherent packet was declined");
                continue;
            };
            assert!(available && coherent);
            packets += 1;
            // Occlusion and counts take the same packets, each answer the
            // single ray's.
            let blocked = bvh
                .packet::<_, _, Occluded>(packet, &mut crate::counters::NoCounters)
                .unwrap();
            let counts = bvh
                .packet::<_, _, Crossings>(packet, &mut crate::counters::NoCounters)
                .unwrap();
            let every = bvh
                .packet::<_, _, EveryHit>(packet, &mut crate::counters::NoCounters)
                .unwrap();
            let answers = packet.iter().zip(&blocked).zip(&counts).zip(every);
            for (((ray, &blocked), &count), every) in answers {
                assert_eq!(
                    blocked,
                    bvh.occluded(ray, &mut crate::counters::NoCounters),
                    "{ray:?}"
                );
                let mut crossings = Vec::new();
                bvh.for_each_crossing(ray, &mut crate::counters::NoCounters, |hit| {
                    crossings.push(hit)
                });
                assert_eq!(count as usize, crossings.len(), "{ray:?}");
                // The same crossings, met in another order.
                let key = |h: &MeshHit| (h.prim, h.hit.t.to_bits());
                let mut got = every;
                got.sort_by_key(key);
                crossings.sort_by_key(key);
                assert_eq!(got, crossings, "{ray:?}");
                several += usize::from(count > 1);
            }
            for (ray, got) in packet.iter().zip(got) {
                let want = bvh.closest(ray, &mut crate::counters::NoCounters);
                assert_eq!(
                    got.map(|h| h.hit.t.to_bits()),
                    want.map(|h| h.hit.t.to_bits()),
                    "{ray:?}"
                );
                if let (Some(g), Some(w)) = (got, want) {
                    hits += 1;
                    if g.prim != w.prim {
                        // A tie: the packet's triangle lies at the same
                        // distance.
                        let [a, b, c] = mesh.triangle(g.prim);
                        let t = intersect_triangle_sheared(ray, &RayShear::new(ray), a, b, c)
                            .map(|h| h.t.to_bits());
                        assert_eq!(t, Some(w.hit.t.to_bits()), "{ray:?}");
                        other_triangle += 1;
                    }
                }
            }
        }
        if available {
            assert!(
                packets > rays.len() / N * 3 / 4,
                "only {packets} packets of {N}"
            );
            assert!(hits > rays.len() / 4, "only {hits} hits");
            assert!(several > 0, "no ray crosses the surface twice");
            assert!(
                other_triangle < hits / 100,
                "{other_triangle} ties of {hits}"
            );
        }
        // Declined: without AVX2, across octants, and with a ray that also
        // looks behind its origin (`tmin < 0`: the fast path's exit
        // widening holds only for `tmin >= 0`).
        let packet: &[Ray; N] = rays[..N].try_into().unwrap();
        let declined =
            without_avx2(|| bvh.packet::<_, _, Closest>(packet, &mut crate::counters::NoCounters));
        assert_eq!(declined, None);
        let mut mixed = *packet;
        mixed[3].dir.x = -mixed[3].dir.x;
        assert_eq!(
            bvh.packet::<_, _, Closest>(&mixed, &mut crate::counters::NoCounters),
            None
        );
        let mut behind = *packet;
        behind[N - 3].tmin = -1.0;
        assert_eq!(
            bvh.packet::<_, _, Closest>(&behind, &mut crate::counters::NoCounters),
            None
        );
        assert_eq!(
            bvh.packet::<_, _, Closest>(packet, &mut crate::counters::NoCounters)
                .is_some(),
            available
        );
    }

    #[test]
    fn empty_mesh_hits_nothing() {
        let fast = TriangleBvh::build(&TriangleMesh::default(), &BvhParams::default());
        let ray = Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
        assert!(fast.is_empty());
        assert_eq!(fast.closest(&ray, &mut crate::counters::NoCounters), None);
        assert!(!fast.occluded(&ray, &mut crate::counters::NoCounters));
    }
}
