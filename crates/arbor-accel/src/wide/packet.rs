//! Ray packets: eight coherent rays (neighbouring camera rays) through the
//! wide BVH together, one ray per AVX2 lane; sixteen, one per AVX-512
//! lane, where the CPU has AVX-512 F (chosen at run time).
//!
//! A single ray tests a node's eight child boxes in the eight lanes of a
//! register; a packet tests one child box against its eight rays in the
//! lanes instead, so a node costs the packet eight box tests where eight
//! rays would pay eight, and the traversal's control (ordering the entered
//! children, the stack, the loop) is paid once for all eight. Camera rays
//! through neighbouring pixels enter mostly the same nodes, so the packet
//! shares those costs. Above all, a packet that misses the root's box (most
//! camera rays of a framed model do) is turned away by one test instead of
//! eight.
//!
//! Identical answers, ray by ray: each lane runs, operation for operation,
//! the single ray's fast-path slab test (`lanes.rs`: near and far planes
//! chosen by the direction's signs, the same subtractions, products,
//! `max`/`min` order and exit widening), so a ray enters exactly the boxes
//! it would enter alone for the same culling distance; and each leaf is
//! tested per ray by the caller's single-ray leaf test. Only the order of
//! the leaves differs (the packet goes nearest-first by a lower bound of
//! its rays' entry distances), which can change which of several triangles
//! hit at exactly the same distance is reported, as the order of offering
//! does between any two structures. Culling stays conservative: a popped
//! entry drops a ray only when even that lower bound lies beyond the ray's
//! closest hit (widened by the slab rounding bound, as for single rays).
//!
//! A packet must be coherent in the sense the fast path needs: finite
//! origins and directions, no zero direction component, `tmin >= 0`, and
//! every direction in the same octant (so that the near planes are the same
//! rows for all lanes). The traversal checks it first and declines other
//! groups, which callers then trace ray by ray.

// Packets are traced with AVX2 only; elsewhere callers trace ray by ray.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_imports))]

use std::mem::MaybeUninit;

use super::lanes::Node8;
use super::WideBvh;
use crate::bvh2::STACK_SIZE;
use crate::counters::Counters;
use crate::ray::Ray;
use crate::util::widen_up;

/// Rays in a packet on AVX2: one per lane.
pub const PACKET: usize = 8;

/// Rays in a packet on AVX-512: one per lane.
pub const PACKET16: usize = 16;

/// The packet width this CPU traces with: [`PACKET16`] with AVX-512 F,
/// else [`PACKET`] (when it has AVX2; callers check that first).
pub(crate) fn packet_width() -> usize {
    #[cfg(target_arch = "x86_64")]
    if super::lanes::has_avx512() {
        return PACKET16;
    }
    PACKET
}

/// Whether all directions of `rays` lie in one octant (the same sign bits):
/// the cheap half of what a packet needs (see
/// [`crate::mesh::triangle_bvh::TriangleBvh::packet`]), which secondary rays in random
/// directions fail at once.
pub fn one_octant(rays: &[Ray]) -> bool {
    let Some(first) = rays.first() else {
        return true;
    };
    let octant = first.dir.is_negative_bitmask();
    rays.iter().all(|r| r.dir.is_negative_bitmask() == octant)
}

/// Whether `rays` look like a stream of camera rays, worth offering to
/// [`crate::mesh::triangle_bvh::TriangleBvh::packet`] in eights: at least
/// half of the first 64 groups of eight share one origin and have all their
/// directions in one octant. Secondary rays (random directions) do not, nor
/// do shadow rays toward one light (one octant, but origins all over the
/// surface, for which packets measured up to a fifth slower), and keep the
/// plain per-ray loop.
pub(crate) fn looks_coherent(rays: &[Ray]) -> bool {
    let (mut groups, mut coherent) = (0, 0);
    for g in rays.chunks_exact(PACKET).take(64) {
        groups += 1;
        coherent += usize::from(one_octant(g) && g.iter().all(|r| r.origin == g[0].origin));
    }
    groups > 0 && 2 * coherent >= groups
}

/// A pending subtree: node or leaf (`child`, `count` as in a node's
/// slots), the rays that entered it (bit `i` for lane `i`, up to sixteen),
/// and a lower bound of their entry distances.
#[derive(Clone, Copy)]
struct Pending {
    child: u32,
    count: u32,
    rays: u32,
    dist: f32,
}

/// Entries: each visited node pushes at most seven siblings, one node per
/// level (as for single rays).
const PACKET_STACK: usize = 7 * STACK_SIZE;

/// A packet's rays in SIMD lanes and the slab test of one box against all
/// of them: what [`WideBvh::closest_packet_in`] needs of a vector width.
/// Every method requires the CPU feature of its implementation.
pub(crate) trait PacketLanes<const N: usize>: Sized {
    /// One value per lane.
    type Vector: Copy;
    /// Which lanes a comparison holds in.
    type Mask: Copy;

    /// The lanes of `rays`, or `None` unless every ray is on the
    /// single-ray fast path (finite origin, direction and inverse
    /// direction, `tmin >= 0`: `lanes::needs_slow_path` says no) and all
    /// directions share one octant. The inverse directions are `1 / d`
    /// per lane, bit for bit `Ray::inv_dir` wherever that is finite.
    unsafe fn new(rays: &[Ray; N]) -> Option<Self>;

    /// The culling distances as a vector.
    unsafe fn load(cull: &[f32; N]) -> Self::Vector;

    /// Entry distances and the lanes whose ray enters box `slot` of
    /// `bounds` (rows as in `Node8::bounds`) before `cull`: for each lane,
    /// operation for operation the single-ray fast path
    /// (`lanes::Avx2::hit`).
    unsafe fn slab(
        &self,
        bounds: &[[f32; 8]; 6],
        slot: usize,
        cull: Self::Vector,
    ) -> (Self::Vector, Self::Mask);

    /// Bit `i` set where lane `i` of `mask` is.
    unsafe fn bits(mask: Self::Mask) -> u32;

    /// The smallest lane of `x` among those set in `mask`, which must not
    /// be empty (the AVX2 lanes give +inf then, the AVX-512 ones need not).
    unsafe fn hmin_where(x: Self::Vector, mask: Self::Mask) -> f32;

    /// The lanes whose culling distance `cull` is not below `dist`.
    unsafe fn reach(dist: f32, cull: Self::Vector) -> u32;
}

impl WideBvh {
    /// Closest-hit traversal of a packet of `N` rays ([`PACKET`] or
    /// [`PACKET16`]): calls `leaf(first, count, lane, counters)` for every
    /// leaf that ray `lane` enters (and maybe some it would have culled:
    /// `leaf` must reject hits beyond its ray's `tmax`, as the single-ray
    /// leaf tests do), and takes the returned value as that ray's new
    /// `tmax`. Returns `false`, having traced nothing, when the rays are not
    /// coherent enough for a packet (see the module documentation).
    ///
    /// # Safety
    /// The caller must be compiled for, and the CPU support, AVX2 for
    /// eight rays and AVX-512 F for sixteen.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn closest_packet_lanes<const N: usize, C, L>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
        leaf: L,
    ) -> bool
    where
        C: Counters,
        L: FnMut(usize, usize, usize, &mut C) -> f32,
    {
        // `N` is a constant: one arm is left after monomorphisation.
        if let Ok(rays) = <&[Ray; PACKET16]>::try_from(rays.as_slice()) {
            self.closest_packet_in::<PACKET16, avx512::Lanes, C, L>(rays, counters, leaf)
        } else if let Ok(rays) = <&[Ray; PACKET]>::try_from(rays.as_slice()) {
            self.closest_packet_in::<PACKET, avx2::Lanes, C, L>(rays, counters, leaf)
        } else {
            false
        }
    }

    /// The packet traversal with the lanes `P` of width `N`.
    ///
    /// Kept whole although over 100 lines (the only such function): it is
    /// one loop whose state (the lanes' rays and culling distances, the
    /// active mask, the stack) every step reads and writes; split into
    /// steps, that state would be passed by reference through the packet
    /// path's hottest loop.
    ///
    /// # Safety
    /// The CPU must support what `P` needs.
    #[inline(always)]
    unsafe fn closest_packet_in<const N: usize, P, C, L>(
        &self,
        rays: &[Ray; N],
        counters: &mut C,
        mut leaf: L,
    ) -> bool
    where
        P: PacketLanes<N>,
        C: Counters,
        L: FnMut(usize, usize, usize, &mut C) -> f32,
    {
        let Some(lanes) = P::new(rays) else {
            return false;
        };
        if self.nodes.is_empty() {
            return true;
        }
        let mut cull = rays.each_ref().map(|r| widen_up(r.tmax));

        // The root's box first: a packet that misses it (the rays around a
        // framed model) costs one test.
        let b = self.bounds;
        let root = [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z].map(|p| [p; 8]);
        let (_, inside) = lanes.slab(&root, 0, P::load(&cull));
        let entered = P::bits(inside);
        if entered == 0 {
            return true;
        }

        // Left uninitialised: zeroing it cost more than tracing (as for
        // single rays, see `wide.rs`).
        let mut stack = [const { MaybeUninit::<Pending>::uninit() }; PACKET_STACK];
        let mut depth = 0;
        let mut at = Pending {
            child: 0,
            count: 0,
            rays: entered,
            dist: 0.0,
        };
        loop {
            counters.node();
            if at.count > 0 {
                let mut todo = at.rays;
                while todo != 0 {
                    let lane = todo.trailing_zeros() as usize;
                    todo &= todo - 1;
                    let tmax = leaf(at.child as usize, at.count as usize, lane, counters);
                    cull[lane] = widen_up(tmax);
                }
            } else {
                let n: &Node8 = &self.nodes[at.child as usize];
                let cull_lanes = P::load(&cull);
                // The children entered, nearest first (insertion into a
                // list of at most eight).
                let mut hits = [const { MaybeUninit::<Pending>::uninit() }; 8];
                let mut found = 0;
                let mut slots = n.valid();
                while slots != 0 {
                    let slot = slots.trailing_zeros() as usize;
                    slots &= slots - 1;
                    let (near, inside) = lanes.slab(&n.bounds, slot, cull_lanes);
                    let mask = P::bits(inside) & at.rays;
                    if mask == 0 {
                        continue;
                    }
                    // A lower bound of the entering rays' entry distances
                    // (lanes entering outside `at.rays` only lower it).
                    let dist = P::hmin_where(near, inside);
                    let mut j = found;
                    // SAFETY: the first `found` entries are written.
                    while j > 0 && unsafe { hits[j - 1].assume_init() }.dist > dist {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = MaybeUninit::new(Pending {
                        child: n.child[slot],
                        count: n.count(slot),
                        rays: mask,
                        dist,
                    });
                    found += 1;
                }
                if found > 0 {
                    // Farthest pushed first, the nearest visited now.
                    for &h in hits[1..found].iter().rev() {
                        stack[depth] = h;
                        depth += 1;
                    }
                    // SAFETY: `found > 0` entries are written.
                    at = unsafe { hits[0].assume_init() };
                    continue;
                }
            }
            // The nearest pending subtree that some ray can still reach.
            loop {
                if depth == 0 {
                    return true;
                }
                depth -= 1;
                // SAFETY: every slot below `depth` was written by a push.
                let next = unsafe { stack[depth].assume_init() };
                let reach = P::reach(next.dist, P::load(&cull));
                let rays = next.rays & reach;
                if rays != 0 {
                    at = Pending { rays, ..next };
                    break;
                }
            }
        }
    }
}

/// The rays' origin coordinates, direction coordinates and `tmin`, one
/// row each, a ray per column: what the lanes load. A plain loop (closures
/// and array maps were compiled out of line, without the lanes' CPU
/// features).
#[inline(always)]
fn rows<const N: usize>(rays: &[Ray; N]) -> [[f32; N]; 7] {
    let mut rows = [[0.0f32; N]; 7];
    for (i, r) in rays.iter().enumerate() {
        rows[0][i] = r.origin.x;
        rows[1][i] = r.origin.y;
        rows[2][i] = r.origin.z;
        rows[3][i] = r.dir.x;
        rows[4][i] = r.dir.y;
        rows[5][i] = r.dir.z;
        rows[6][i] = r.tmin;
    }
    rows
}

/// The packet's lanes and their slab test, in AVX2: eight rays.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{PacketLanes, PACKET};
    use crate::aabb::SLAB_TFAR_SCALE;
    use crate::ray::Ray;
    use crate::wide::lanes::rows_for_signs;

    /// The rays' origins, inverse directions and `tmin`, one ray per lane,
    /// and the rows of a node's bounds holding each axis's near and far
    /// planes (the same for every ray of a packet). Only ever created
    /// inside functions compiled for AVX2.
    pub(super) struct Lanes {
        origin: [__m256; 3],
        inv: [__m256; 3],
        tmin: __m256,
        near: [usize; 3],
        far: [usize; 3],
    }

    impl PacketLanes<PACKET> for Lanes {
        type Vector = __m256;
        type Mask = __m256;

        #[inline(always)]
        unsafe fn new(rays: &[Ray; PACKET]) -> Option<Self> {
            let rows = super::rows(rays);
            let origin = [
                _mm256_loadu_ps(rows[0].as_ptr()),
                _mm256_loadu_ps(rows[1].as_ptr()),
                _mm256_loadu_ps(rows[2].as_ptr()),
            ];
            let one = _mm256_set1_ps(1.0);
            let inv = [
                _mm256_div_ps(one, _mm256_loadu_ps(rows[3].as_ptr())),
                _mm256_div_ps(one, _mm256_loadu_ps(rows[4].as_ptr())),
                _mm256_div_ps(one, _mm256_loadu_ps(rows[5].as_ptr())),
            ];
            // Finite lanes: `x * 0` is 0 for them and NaN for infinities
            // and NaN. The direction is finite where its inverse is
            // nonzero, and nonzero where its inverse is finite.
            let zero = _mm256_setzero_ps();
            let finite = |x: __m256| _mm256_cmp_ps::<_CMP_EQ_OQ>(_mm256_mul_ps(x, zero), zero);
            let nonzero = |x: __m256| _mm256_cmp_ps::<_CMP_NEQ_OQ>(x, zero);
            let mut ok = _mm256_and_ps(finite(origin[0]), finite(origin[1]));
            ok = _mm256_and_ps(ok, finite(origin[2]));
            for v in inv {
                ok = _mm256_and_ps(ok, _mm256_and_ps(finite(v), nonzero(v)));
            }
            // `tmin >= 0` (false for NaN), as the fast path requires.
            let tmin = _mm256_loadu_ps(rows[6].as_ptr());
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(tmin, zero));
            let signs = [
                _mm256_movemask_ps(inv[0]),
                _mm256_movemask_ps(inv[1]),
                _mm256_movemask_ps(inv[2]),
            ];
            if _mm256_movemask_ps(ok) != 0xff || signs.iter().any(|&m| m != 0 && m != 0xff) {
                return None;
            }
            // One sign per axis for the whole packet: lane 0's bits.
            let negative = (signs[0] & 1 | (signs[1] & 1) << 1 | (signs[2] & 1) << 2) as usize;
            let (near, far) = rows_for_signs(negative);
            Some(Lanes {
                origin,
                inv,
                tmin,
                near,
                far,
            })
        }

        #[inline(always)]
        unsafe fn load(cull: &[f32; PACKET]) -> __m256 {
            _mm256_loadu_ps(cull.as_ptr())
        }

        #[inline(always)]
        unsafe fn slab(
            &self,
            bounds: &[[f32; 8]; 6],
            slot: usize,
            cull: __m256,
        ) -> (__m256, __m256) {
            let mut near = self.tmin;
            let mut far = _mm256_set1_ps(f32::INFINITY);
            for a in 0..3 {
                // Broadcast straight from the node's rows.
                let lo = _mm256_broadcast_ss(&bounds[self.near[a]][slot]);
                let hi = _mm256_broadcast_ss(&bounds[self.far[a]][slot]);
                let lo = _mm256_mul_ps(_mm256_sub_ps(lo, self.origin[a]), self.inv[a]);
                let hi = _mm256_mul_ps(_mm256_sub_ps(hi, self.origin[a]), self.inv[a]);
                near = _mm256_max_ps(near, lo);
                far = _mm256_min_ps(far, hi);
            }
            let exit = _mm256_min_ps(_mm256_mul_ps(far, _mm256_set1_ps(SLAB_TFAR_SCALE)), cull);
            (near, _mm256_cmp_ps::<_CMP_LE_OQ>(near, exit))
        }

        #[inline(always)]
        unsafe fn bits(mask: __m256) -> u32 {
            _mm256_movemask_ps(mask) as u32
        }

        #[inline(always)]
        unsafe fn hmin_where(x: __m256, mask: __m256) -> f32 {
            let v = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), x, mask);
            let v = _mm256_min_ps(v, _mm256_permute2f128_ps::<1>(v, v));
            let v = _mm256_min_ps(v, _mm256_shuffle_ps::<0b01_00_11_10>(v, v));
            let v = _mm256_min_ps(v, _mm256_shuffle_ps::<0b10_11_00_01>(v, v));
            _mm256_cvtss_f32(v)
        }

        #[inline(always)]
        unsafe fn reach(dist: f32, cull: __m256) -> u32 {
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_set1_ps(dist), cull)) as u32
        }
    }
}

/// The packet's lanes and their slab test, in AVX-512: sixteen rays, the
/// same arithmetic per lane as [`avx2::Lanes`] (so as the single ray's),
/// comparisons into mask registers. Written out again rather than shared
/// through a vector abstraction: each line is one intrinsic of its width.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::*;

    use super::{PacketLanes, PACKET16};
    use crate::aabb::SLAB_TFAR_SCALE;
    use crate::ray::Ray;
    use crate::wide::lanes::rows_for_signs;

    /// As [`super::avx2::Lanes`], sixteen lanes wide. Only ever created
    /// inside functions compiled for AVX-512 F.
    pub(super) struct Lanes {
        origin: [__m512; 3],
        inv: [__m512; 3],
        tmin: __m512,
        near: [usize; 3],
        far: [usize; 3],
    }

    impl PacketLanes<PACKET16> for Lanes {
        type Vector = __m512;
        type Mask = __mmask16;

        #[inline(always)]
        unsafe fn new(rays: &[Ray; PACKET16]) -> Option<Self> {
            let rows = super::rows(rays);
            let origin = [
                _mm512_loadu_ps(rows[0].as_ptr()),
                _mm512_loadu_ps(rows[1].as_ptr()),
                _mm512_loadu_ps(rows[2].as_ptr()),
            ];
            let one = _mm512_set1_ps(1.0);
            let inv = [
                _mm512_div_ps(one, _mm512_loadu_ps(rows[3].as_ptr())),
                _mm512_div_ps(one, _mm512_loadu_ps(rows[4].as_ptr())),
                _mm512_div_ps(one, _mm512_loadu_ps(rows[5].as_ptr())),
            ];
            // The same checks as the AVX2 lanes', as masks.
            let zero = _mm512_setzero_ps();
            let finite = |x: __m512| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(_mm512_mul_ps(x, zero), zero);
            let nonzero = |x: __m512| _mm512_cmp_ps_mask::<_CMP_NEQ_OQ>(x, zero);
            let mut ok = finite(origin[0]) & finite(origin[1]) & finite(origin[2]);
            for v in inv {
                ok &= finite(v) & nonzero(v);
            }
            let tmin = _mm512_loadu_ps(rows[6].as_ptr());
            ok &= _mm512_cmp_ps_mask::<_CMP_GE_OQ>(tmin, zero);
            // The inverse directions are finite and nonzero where `ok`, so
            // `< 0` is their sign bit.
            let signs = [
                _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv[0], zero),
                _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv[1], zero),
                _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv[2], zero),
            ];
            if ok != 0xffff || signs.iter().any(|&m| m != 0 && m != 0xffff) {
                return None;
            }
            let negative = (signs[0] & 1 | (signs[1] & 1) << 1 | (signs[2] & 1) << 2) as usize;
            let (near, far) = rows_for_signs(negative);
            Some(Lanes {
                origin,
                inv,
                tmin,
                near,
                far,
            })
        }

        #[inline(always)]
        unsafe fn load(cull: &[f32; PACKET16]) -> __m512 {
            _mm512_loadu_ps(cull.as_ptr())
        }

        #[inline(always)]
        unsafe fn slab(
            &self,
            bounds: &[[f32; 8]; 6],
            slot: usize,
            cull: __m512,
        ) -> (__m512, __mmask16) {
            let mut near = self.tmin;
            let mut far = _mm512_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let lo = _mm512_set1_ps(bounds[self.near[a]][slot]);
                let hi = _mm512_set1_ps(bounds[self.far[a]][slot]);
                let lo = _mm512_mul_ps(_mm512_sub_ps(lo, self.origin[a]), self.inv[a]);
                let hi = _mm512_mul_ps(_mm512_sub_ps(hi, self.origin[a]), self.inv[a]);
                near = _mm512_max_ps(near, lo);
                far = _mm512_min_ps(far, hi);
            }
            let exit = _mm512_min_ps(_mm512_mul_ps(far, _mm512_set1_ps(SLAB_TFAR_SCALE)), cull);
            (near, _mm512_cmp_ps_mask::<_CMP_LE_OQ>(near, exit))
        }

        #[inline(always)]
        unsafe fn bits(mask: __mmask16) -> u32 {
            u32::from(mask)
        }

        #[inline(always)]
        unsafe fn hmin_where(x: __m512, mask: __mmask16) -> f32 {
            _mm512_mask_reduce_min_ps(mask, x)
        }

        #[inline(always)]
        unsafe fn reach(dist: f32, cull: __m512) -> u32 {
            u32::from(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(_mm512_set1_ps(dist), cull))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Camera rays through neighbouring pixels look coherent; rays in
    /// scattered directions do not; too few rays for a packet neither.
    #[test]
    fn camera_rays_look_coherent_and_scattered_rays_do_not() {
        let eye = Vec3::new(0.3, 0.2, 5.0);
        let camera: Vec<Ray> = (0..64 * 48)
            .map(|i| {
                let target = Vec3::new(
                    (i % 64) as f32 / 32.0 - 1.0,
                    (i / 64) as f32 / 24.0 - 1.0,
                    0.0,
                );
                Ray::new(eye, target - eye, 0.0, f32::INFINITY)
            })
            .collect();
        assert!(looks_coherent(&camera));
        let mut next = crate::util::unit_sequence(5);
        let scattered: Vec<Ray> = (0..4096)
            .map(|_| {
                let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                Ray::new(Vec3::ZERO, d, 0.0, f32::INFINITY)
            })
            .collect();
        assert!(!looks_coherent(&scattered));
        assert!(!looks_coherent(&camera[..PACKET - 1]));
        // Shadow rays from the camera rays' hits toward one light share an
        // octant but not an origin: single rays serve them better
        // (docs/perf-log/2026-12-06-zen5-walk.md).
        let light = Vec3::new(0.5, 4.0, 3.0);
        let shadow: Vec<Ray> = camera
            .iter()
            .map(|r| {
                let hit = r.origin + r.dir;
                Ray::new(hit, light - hit, 1e-4, 1.0)
            })
            .collect();
        assert!(!looks_coherent(&shadow));
    }
}
