//! The watertight ray/triangle test for up to four triangles at once: its
//! `f32` edge stage (where most triangles are rejected) in SIMD lanes, the
//! rest per lane with the one-triangle code.
//!
//! Identical answers are the point, not an approximation of them. Each lane
//! performs, operation for operation, the `f32` arithmetic of
//! [`intersect_triangle_sheared`]: the same subtractions, shear products,
//! edge functions, the same left-to-right sums of absolute values for the
//! error bound. IEEE arithmetic is deterministic, so the lane values equal
//! the scalar ones. The only lane operations whose results could differ are
//! `min`/`max`, whose NaN handling differs between SSE and `f32::min`; a lane
//! is therefore decided here only when its three edge functions are not NaN,
//! which (each edge function combines two vertices' sheared coordinates,
//! which combine every relative vertex coordinate) makes every input of
//! those `min`/`max` non-NaN, where they are exact and agree. Such a lane is
//! either rejected (signs certain and mixed: the scalar test returns `None`
//! there too) or finished by [`hit_from_certain_edges`] with its lane values,
//! the scalar test's own continuation. Every other lane runs the whole scalar
//! test.

use glam::{Vec3, Vec4};

use crate::ray::Ray;
use crate::triangle::watertight::{
    certain_any_hit, certainly_hit, hit_ahead, hit_from_certain_edges, intersect_triangle_owned,
    intersect_triangle_sheared,
};
use crate::triangle::watertight::{RayShear, TriangleHit};

/// Triangles tested together.
pub(crate) const LANES: usize = 4;

/// Up to four triangles stored for the edge stage: coordinate `c` of vertex
/// `j` of the triangle in lane `k` is `v[j][c][k]`, so the stage loads each
/// row straight into a register instead of gathering it (160 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Tri4 {
    pub v: [[[f32; LANES]; 3]; 3],
    /// The triangles' ids; [`Tri4::NO_ID`] in unused lanes.
    pub ids: [u32; LANES],
}

impl Tri4 {
    /// Id of an unused lane.
    pub const NO_ID: u32 = u32::MAX;

    /// Packs 1 to 4 triangles with their ids; unused lanes repeat the last
    /// triangle (so their arithmetic is harmless) and are never reported.
    pub fn new(tris: &[[Vec3; 3]], ids: &[u32]) -> Self {
        debug_assert!(!tris.is_empty() && tris.len() <= LANES && ids.len() == tris.len());
        let mut packed = Tri4 {
            v: [[[0.0; LANES]; 3]; 3],
            ids: [Tri4::NO_ID; LANES],
        };
        for k in 0..LANES {
            let t = tris[k.min(tris.len() - 1)];
            for (row, vertex) in packed.v.iter_mut().zip(t) {
                for (lanes, coord) in row.iter_mut().zip(vertex.to_array()) {
                    lanes[k] = coord;
                }
            }
        }
        packed.ids[..ids.len()].copy_from_slice(ids);
        packed
    }

    /// The triangle in lane `k`.
    #[inline(always)]
    pub fn triangle(&self, k: usize) -> [Vec3; 3] {
        let vertex = |j: usize| Vec3::new(self.v[j][0][k], self.v[j][1][k], self.v[j][2][k]);
        [vertex(0), vertex(1), vertex(2)]
    }
}

/// The edge stage's verdict for up to `N` triangles ([`LANES`] in one
/// packet, twice that for the AVX2 stage of two packets).
pub(crate) struct EdgeVerdict<const N: usize = LANES> {
    u: [f32; N],
    v: [f32; N],
    w: [f32; N],
    /// The lanes' `s` (largest L1 norm of a relative vertex), bit for bit
    /// the scalar test's for every decided lane.
    scale: [f32; N],
    /// Lanes certainly missed (the scalar test would return `None`).
    miss: u32,
    /// Lanes whose edge functions certainly put the ray inside: finish with
    /// [`hit_from_certain_edges`].
    inside: u32,
    /// Lanes of `inside` whose plane certainly meets the ray's line behind
    /// its origin, for a ray with `tmin >= 0`: missed, as the full test
    /// finds first thing (see [`certainly_behind_lanes`]).
    behind: u32,
    /// Whether `behind` was worked out (by the AVX2 stage, for a ray with
    /// `tmin >= 0`): then the other `inside` lanes are known to be ahead
    /// and skip the full test's own check.
    behind_known: bool,
}

/// Calls `$stage::<KX, KY, KZ>(args)` with the ray shear's axis
/// permutation as constants (shared by the four- and eight-lane stages).
macro_rules! by_permutation {
    ($s:expr, $stage:ident($($arg:expr),*)) => {
        match ($s.kx, $s.ky) {
            (1, 2) => $stage::<1, 2, 0>($($arg),*),
            (2, 1) => $stage::<2, 1, 0>($($arg),*),
            (2, 0) => $stage::<2, 0, 1>($($arg),*),
            (0, 2) => $stage::<0, 2, 1>($($arg),*),
            (0, 1) => $stage::<0, 1, 2>($($arg),*),
            _ => $stage::<1, 0, 2>($($arg),*),
        }
    };
}

/// Lanes (bit `i` for lane `i`) whose three edge functions, given by their
/// sign bits, do not all share a sign.
#[inline(always)]
fn mixed_signs(nu: u32, nv: u32, nw: u32) -> u32 {
    (nu | nv | nw) & !(nu & nv & nw)
}

/// The `f32` edge stage of the watertight test for the first `count`
/// triangles of `tris`.
#[inline(always)]
pub(crate) fn edge_stage(ray: &Ray, s: &RayShear, tris: &Tri4, count: usize) -> EdgeVerdict {
    debug_assert!((1..=LANES).contains(&count));
    // The axis permutation as constants: indexing lanes by a runtime axis
    // would spill them to memory. Within one ray the arm never changes, so
    // the branch costs nothing.
    by_permutation!(s, stage(ray, s, tris, count))
}

/// [`edge_stage`] for the permutation `(KX, KY, KZ)` of the ray's shear.
#[inline(always)]
fn stage<const KX: usize, const KY: usize, const KZ: usize>(
    ray: &Ray,
    s: &RayShear,
    tris: &Tri4,
    count: usize,
) -> EdgeVerdict {
    debug_assert_eq!((s.kx, s.ky, s.kz), (KX, KY, KZ));
    let o = ray.origin.to_array();
    // Coordinate `c` of vertex `j` relative to the origin, in lanes.
    let rel = |j: usize, c: usize| Vec4::from_array(tris.v[j][c]) - Vec4::splat(o[c]);
    let (sx, sy) = (Vec4::splat(s.sx), Vec4::splat(s.sy));
    // The sheared coordinates of vertex `j`, and its relative coordinates in
    // the original axis order (for the error bound's sums).
    let vertex = |j: usize| {
        let p = [rel(j, 0), rel(j, 1), rel(j, 2)];
        let sheared = (p[KX] - sx * p[KZ], p[KY] - sy * p[KZ]);
        let l1 = p[0].abs() + p[1].abs() + p[2].abs();
        (sheared, l1)
    };
    let ((ax, ay), la) = vertex(0);
    let ((bx, by), lb) = vertex(1);
    let ((cx, cy), lc) = vertex(2);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    // The scalar test's error bound, in the same order of operations. (A
    // cheaper one, `m` replaced by `s`, sends most camera-ray lanes to the
    // scalar test: docs/perf-log/2026-11-23-fourth-round.md.)
    let scale = la.max(lb).max(lc);
    let m = ax
        .abs()
        .max(ay.abs())
        .max(bx.abs())
        .max(by.abs())
        .max(cx.abs())
        .max(cy.abs());
    let bound = m * scale * Vec4::splat(1.0 / 262_144.0);
    // Certain signs: every magnitude above the bound, and the bound a
    // normal number (a NaN compares false, so a NaN lane is undecided, as
    // in the scalar test). Then no edge function is zero, and the signs are
    // mixed unless all three sign bits agree.
    let decided = u.abs().cmpgt(bound)
        & v.abs().cmpgt(bound)
        & w.abs().cmpgt(bound)
        & bound.cmpge(Vec4::splat(f32::MIN_POSITIVE));
    let (nu, nv, nw) = (
        u.is_negative_bitmask(),
        v.is_negative_bitmask(),
        w.is_negative_bitmask(),
    );
    let mixed = mixed_signs(nu, nv, nw);
    let valid = (1u32 << count) - 1;
    let decided = decided.bitmask() & valid;
    EdgeVerdict {
        u: u.to_array(),
        v: v.to_array(),
        w: w.to_array(),
        scale: scale.to_array(),
        miss: decided & mixed,
        inside: decided & !mixed,
        behind: 0,
        behind_known: false,
    }
}

/// The edge stage of two packets at once in the eight lanes of AVX2
/// registers: per lane, operation for operation, what [`edge_stage`] does
/// in four (the same subtractions, products, sums in the same order; `abs`
/// as a mask, `max` and the compares as `maxps`/`cmpps`, whose AVX forms
/// are the SSE ones on twice the lanes), so each verdict is bit for bit the
/// one `edge_stage` gives for its packet. A leaf of five to eight triangles
/// then costs one pass instead of two.
#[cfg(target_arch = "x86_64")]
pub(crate) mod pair {
    use std::arch::x86_64::*;

    #[cfg(test)]
    use super::LANES;
    use super::{mixed_signs, EdgeVerdict, Tri4};
    use crate::ray::Ray;
    use crate::triangle::watertight::{RayShear, TINY};

    /// The verdict for the triangles of `tris[0]` (lanes 0 to 3) and
    /// `tris[1]` (lanes 4 to 7) named by the bits of `valid`, or `None`
    /// when none of them is a candidate and not `all`: the common case,
    /// which then stores nothing. A leaf of up to four triangles passes its
    /// packet twice with only the low lanes valid. With `behind` (a
    /// constant at each call) and `tmin >= 0`, lanes certainly behind the
    /// origin are found here too and are no candidates.
    ///
    /// Not a `#[target_feature]` function (those cannot be forced inline,
    /// and a call passing the verdict back through memory cost more than
    /// the pass saves): it is inlined into the leaf test, which the AVX2
    /// traversal (`WideBvh::closest_avx2`) inlines in turn.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline(always)]
    pub(crate) unsafe fn edge_stage8(
        ray: &Ray,
        s: &RayShear,
        tris: [&Tri4; 2],
        valid: u32,
        all: bool,
        behind: bool,
    ) -> Option<EdgeVerdict<8>> {
        debug_assert!(valid != 0 && valid <= 0xff);
        by_permutation!(s, stage(ray, s, tris, valid, all, behind))
    }

    /// [`edge_stage8`] as two four-lane verdicts, for comparing with
    /// [`super::edge_stage`] (`count` triangles of `tris[1]` in use).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(test)]
    pub(crate) unsafe fn edge_stage_pair(
        ray: &Ray,
        s: &RayShear,
        tris: [&Tri4; 2],
        count: usize,
    ) -> [EdgeVerdict; 2] {
        debug_assert!((1..=LANES).contains(&count));
        let valid = 0xf | ((1u32 << count) - 1) << LANES;
        let v = edge_stage8(ray, s, tris, valid, true, true).expect("all verdicts");
        let half = |h: usize| {
            let part = |x: &[f32; 8]| [x[4 * h], x[4 * h + 1], x[4 * h + 2], x[4 * h + 3]];
            let bits = |m: u32| (m >> (LANES * h)) & 0xf;
            EdgeVerdict {
                u: part(&v.u),
                v: part(&v.v),
                w: part(&v.w),
                scale: part(&v.scale),
                miss: bits(v.miss),
                inside: bits(v.inside),
                behind: bits(v.behind),
                behind_known: v.behind_known,
            }
        };
        [half(0), half(1)]
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[inline(always)]
    unsafe fn stage<const KX: usize, const KY: usize, const KZ: usize>(
        ray: &Ray,
        s: &RayShear,
        [t0, t1]: [&Tri4; 2],
        valid: u32,
        all: bool,
        behind: bool,
    ) -> Option<EdgeVerdict<8>> {
        // No closures here: a closure is compiled without AVX2 and would
        // call each intrinsic instead of inlining it; these helpers are
        // forced inline into the AVX2 traversal.
        let o = ray.origin.to_array();
        let (sx, sy) = (_mm256_set1_ps(s.sx), _mm256_set1_ps(s.sy));
        let ((ax, ay), la, az) = vertex::<KX, KY, KZ>([t0, t1], 0, o, sx, sy);
        let ((bx, by), lb, bz) = vertex::<KX, KY, KZ>([t0, t1], 1, o, sx, sy);
        let ((cx, cy), lc, cz) = vertex::<KX, KY, KZ>([t0, t1], 2, o, sx, sy);
        let u = cross(cx, by, cy, bx);
        let v = cross(ax, cy, ay, cx);
        let w = cross(bx, ay, by, ax);
        let scale = _mm256_max_ps(_mm256_max_ps(la, lb), lc);
        let mut m = abs(ax);
        for c in [ay, bx, by, cx, cy] {
            m = _mm256_max_ps(m, abs(c));
        }
        let bound = _mm256_mul_ps(_mm256_mul_ps(m, scale), _mm256_set1_ps(1.0 / 262_144.0));
        let normal = _mm256_cmp_ps::<_CMP_GE_OQ>(bound, _mm256_set1_ps(f32::MIN_POSITIVE));
        let decided = _mm256_and_ps(
            _mm256_and_ps(above(u, bound), above(v, bound)),
            _mm256_and_ps(above(w, bound), normal),
        );
        let decided = _mm256_movemask_ps(decided) as u32 & valid;
        let (nu, nv, nw) = (
            _mm256_movemask_ps(u) as u32,
            _mm256_movemask_ps(v) as u32,
            _mm256_movemask_ps(w) as u32,
        );
        let mixed = mixed_signs(nu, nv, nw);
        let miss = decided & mixed;
        if !all && valid & !miss == 0 {
            return None;
        }
        let inside = decided & !mixed;
        // Rays leaving a surface meet their own triangle's plane just behind
        // the origin, and the structures offer it to nearly every such ray:
        // found out here for all lanes at once, so that such a leaf ends
        // without a lane finished one at a time.
        let behind_known = behind && ray.tmin >= 0.0;
        let behind = if behind_known && inside != 0 {
            let diff = [az, bz, cz];
            inside & certainly_behind_lanes(s, diff, [u, v, w], scale)
        } else {
            0
        };
        if !all && valid & !miss & !behind == 0 {
            return None;
        }
        let row = |x: __m256| {
            let mut r = [0.0f32; 8];
            _mm256_storeu_ps(r.as_mut_ptr(), x);
            r
        };
        Some(EdgeVerdict {
            u: row(u),
            v: row(v),
            w: row(w),
            scale: row(scale),
            miss,
            inside,
            behind,
            behind_known,
        })
    }

    /// [`crate::triangle::watertight::certainly_behind`] for eight lanes,
    /// operation for operation (so each lane's answer is the scalar one):
    /// the lanes whose plane certainly meets the ray's line behind the
    /// origin, given each vertex's coordinate along the dominant axis
    /// relative to the origin (`diff`), the edge functions and the scale.
    /// Meaningful for lanes with certain, equal edge signs only.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline(always)]
    unsafe fn certainly_behind_lanes(
        s: &RayShear,
        diff: [__m256; 3],
        [u, v, w]: [__m256; 3],
        scale: __m256,
    ) -> u32 {
        // No closures (see `stage`): each would be compiled without AVX2.
        let sz = _mm256_set1_ps(s.sz);
        let z = [
            _mm256_mul_ps(diff[0], sz),
            _mm256_mul_ps(diff[1], sz),
            _mm256_mul_ps(diff[2], sz),
        ];
        let terms = [
            _mm256_mul_ps(u, z[0]),
            _mm256_mul_ps(v, z[1]),
            _mm256_mul_ps(w, z[2]),
        ];
        let t_num = _mm256_add_ps(_mm256_add_ps(terms[0], terms[1]), terms[2]);
        // `T` signed as `D`, which has the sign of `u`: negated where `u`
        // is negative (a sign flip, as the scalar negation).
        let sign = _mm256_set1_ps(-0.0);
        let toward = _mm256_xor_ps(t_num, _mm256_and_ps(u, sign));
        let (a, zs) = (sum_abs(terms), sum_abs(z));
        let b = _mm256_mul_ps(
            _mm256_mul_ps(
                scale,
                _mm256_mul_ps(scale, _mm256_set1_ps(1.0 + 1.0 / 1_048_576.0)),
            ),
            _mm256_set1_ps(1.0 / 262_144.0),
        );
        let e = _mm256_mul_ps(
            _mm256_add_ps(
                _mm256_mul_ps(a, _mm256_set1_ps(1.0 / 2_097_152.0)),
                _mm256_mul_ps(b, zs),
            ),
            _mm256_set1_ps(1.0 + 1.0 / 1024.0),
        );
        let beyond = _mm256_cmp_ps::<_CMP_LT_OQ>(toward, _mm256_xor_ps(e, sign));
        // `Numerator::far_from_underflow`, lane by lane.
        let tiny = _mm256_set1_ps(TINY);
        let mut normal =
            _mm256_cmp_ps::<_CMP_GE_OQ>(scale, _mm256_set1_ps(1.0 / 1_099_511_627_776.0));
        for i in 0..3 {
            let exact = _mm256_cmp_ps::<_CMP_EQ_OQ>(diff[i], _mm256_setzero_ps());
            let large = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(abs(z[i]), tiny),
                _mm256_cmp_ps::<_CMP_GE_OQ>(abs(terms[i]), tiny),
            );
            normal = _mm256_and_ps(normal, _mm256_or_ps(exact, large));
        }
        _mm256_movemask_ps(_mm256_and_ps(beyond, normal)) as u32
    }

    /// Vertex `j` of both packets: its sheared coordinates, the L1 norm of
    /// its position relative to the origin, and its relative coordinate
    /// along the dominant axis.
    #[inline(always)]
    unsafe fn vertex<const KX: usize, const KY: usize, const KZ: usize>(
        [t0, t1]: [&Tri4; 2],
        j: usize,
        o: [f32; 3],
        sx: __m256,
        sy: __m256,
    ) -> ((__m256, __m256), __m256, __m256) {
        let rel = |c: usize| {
            _mm256_sub_ps(
                _mm256_loadu2_m128(t1.v[j][c].as_ptr(), t0.v[j][c].as_ptr()),
                _mm256_set1_ps(o[c]),
            )
        };
        let p = [rel(0), rel(1), rel(2)];
        let sheared = (
            _mm256_sub_ps(p[KX], _mm256_mul_ps(sx, p[KZ])),
            _mm256_sub_ps(p[KY], _mm256_mul_ps(sy, p[KZ])),
        );
        let l1 = _mm256_add_ps(_mm256_add_ps(abs(p[0]), abs(p[1])), abs(p[2]));
        (sheared, l1, p[KZ])
    }

    /// `|x0| + |x1| + |x2|`, summed left to right.
    #[inline(always)]
    unsafe fn sum_abs(x: [__m256; 3]) -> __m256 {
        _mm256_add_ps(_mm256_add_ps(abs(x[0]), abs(x[1])), abs(x[2]))
    }

    /// `p q - r t`.
    #[inline(always)]
    unsafe fn cross(p: __m256, q: __m256, r: __m256, t: __m256) -> __m256 {
        _mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, t))
    }

    /// `|x|`, as `glam::Vec4::abs` computes it: the sign bit cleared.
    #[inline(always)]
    unsafe fn abs(x: __m256) -> __m256 {
        _mm256_and_ps(x, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX)))
    }

    /// `|x| > bound` per lane (false for NaN).
    #[inline(always)]
    unsafe fn above(x: __m256, bound: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_GT_OQ>(abs(x), bound)
    }
}

impl<const N: usize> EdgeVerdict<N> {
    /// The lanes of the first `count` the edge stage did not reject, as a
    /// bit set.
    #[inline(always)]
    pub(crate) fn candidates(&self, count: usize) -> u32 {
        self.candidates_of((1u32 << count) - 1)
    }

    /// The lanes of `valid` the edge stage did not reject.
    #[inline(always)]
    pub(crate) fn candidates_of(&self, valid: u32) -> u32 {
        valid & !self.miss & !self.behind
    }

    /// For an any-hit query, what lane `k` (a candidate) is without the
    /// full test's `f64` distance (see [`certain_any_hit`]): certainly hit
    /// inside the ray's interval (`Some(true)`), certainly missed behind the
    /// origin (`Some(false)`, as [`EdgeVerdict::finish`] would find), or
    /// left to [`EdgeVerdict::finish`] (`None`).
    #[inline(always)]
    pub(crate) fn any_hit_certainty(
        &self,
        k: usize,
        ray: &Ray,
        s: &RayShear,
        tri: [Vec3; 3],
    ) -> Option<bool> {
        if self.inside & (1 << k) == 0 {
            return None;
        }
        let edges = [self.u[k], self.v[k], self.w[k]];
        if self.behind_known {
            // Not behind (those lanes are no candidates): only the hit is
            // left to decide.
            return certainly_hit(ray, s, tri, edges, self.scale[k]).then_some(true);
        }
        certain_any_hit(ray, s, tri, edges, self.scale[k])
    }

    /// The full test of lane `k` (a candidate), the triangle `tri`: exactly what
    /// [`intersect_triangle_sheared`] answers for it, or with `OWNED`
    /// [`intersect_triangle_owned`] (the two differ only where an edge
    /// function is exactly zero, which a lane with certain signs never has).
    #[inline(always)]
    pub(crate) fn finish<const OWNED: bool>(
        &self,
        k: usize,
        ray: &Ray,
        s: &RayShear,
        [p0, p1, p2]: [Vec3; 3],
    ) -> Option<TriangleHit> {
        if self.inside & (1 << k) != 0 {
            let edges = [self.u[k], self.v[k], self.w[k]];
            if self.behind_known {
                // Checked in lanes: not behind the origin.
                return hit_ahead(ray, s, p0, p1, p2, edges);
            }
            hit_from_certain_edges(ray, s, p0, p1, p2, edges, self.scale[k])
        } else if OWNED {
            intersect_triangle_owned(ray, s, p0, p1, p2)
        } else {
            intersect_triangle_sheared(ray, s, p0, p1, p2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (SplitMix64).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        /// Mostly ordinary coordinates, sometimes the values that break
        /// arithmetic: zeros, huge, tiny, infinities, NaN, shared values.
        fn coord(&mut self) -> f32 {
            match self.next() % 16 {
                0 => 0.0,
                1 => 1e30,
                2 => -1e-30,
                3 => f32::INFINITY,
                4 => f32::NAN,
                5 => 1.0,
                _ => (self.next() % 2001) as f32 / 1000.0 - 1.0,
            }
        }
        fn vec(&mut self) -> Vec3 {
            Vec3::new(self.coord(), self.coord(), self.coord())
        }
    }

    fn f32x3_bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    fn same(a: Option<TriangleHit>, b: Option<TriangleHit>) -> bool {
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                a.t.to_bits() == b.t.to_bits()
                    && a.u.to_bits() == b.u.to_bits()
                    && a.v.to_bits() == b.v.to_bits()
            }
            _ => false,
        }
    }

    /// The edge-function bound of the behind-the-origin filter
    /// (`certainly_behind` in `triangle/watertight.rs`) is never below the test's own,
    /// on the directions that stress it most (two or three equal
    /// magnitudes, so that the shear factors round to about 1) and on
    /// hostile vertices: `s (s C) 2^-18 >= m s 2^-18` wherever neither side
    /// is NaN.
    #[test]
    fn lane_bound_covers_the_scalar_bound() {
        let mut rng = Rng(11);
        let mut checked = 0;
        for i in 0..300_000 {
            let mut d = rng.vec();
            if i % 2 == 0 {
                // Equal magnitudes on two or three axes.
                let m = (1 + rng.next() % 1000) as f32 / 7.0;
                let sign = |r: &mut Rng| {
                    if r.next().is_multiple_of(2) {
                        1.0
                    } else {
                        -1.0
                    }
                };
                d = Vec3::new(m * sign(&mut rng), m * sign(&mut rng), d.z);
                if i % 4 == 0 {
                    d.z = m * sign(&mut rng);
                }
            }
            let ray = Ray::new(rng.vec(), d, 0.0, f32::INFINITY);
            let sh = RayShear::new(&ray);
            let rel = [rng.vec(), rng.vec(), rng.vec()].map(|p| p - ray.origin);
            let sheared = rel.map(|p| [p[sh.kx] - sh.sx * p[sh.kz], p[sh.ky] - sh.sy * p[sh.kz]]);
            let s = rel
                .iter()
                .map(|p| p.abs().element_sum())
                .fold(f32::NEG_INFINITY, f32::max);
            let m = sheared
                .iter()
                .flatten()
                .map(|c| c.abs())
                .fold(f32::NEG_INFINITY, f32::max);
            let scalar = m * s * (1.0 / 262_144.0);
            let lanes = s * (s * (1.0 + 1.0 / 1_048_576.0)) * (1.0 / 262_144.0);
            if sheared.iter().flatten().any(|c| c.is_nan()) || scalar.is_nan() {
                continue;
            }
            assert!(lanes >= scalar, "{ray:?} {rel:?}: {lanes} < {scalar}");
            checked += 1;
        }
        assert!(checked > 100_000, "only {checked} cases checked");
    }

    /// A blocker certain without the `f64` distance is one the full test
    /// reports inside the ray's interval: on ordinary and hostile
    /// coordinates, with the interval's ends placed at, just beside and far
    /// from the full test's distance (where the shortcut must hold back).
    #[test]
    fn certain_blockers_are_hits_of_the_full_test() {
        let mut rng = Rng(11);
        let (mut certain, mut near_ends_held_back) = (0, 0);
        for _ in 0..150_000 {
            let origin = rng.vec();
            let dir = rng.vec();
            let probe = Ray::new(origin, dir, 0.0, f32::INFINITY);
            let tris: Vec<[Vec3; 3]> = (0..LANES)
                .map(|_| {
                    if !rng.next().is_multiple_of(4) {
                        // Around a point ahead on the ray, sizes from tiny
                        // to large against the distance.
                        let base = origin + dir * ((rng.next() % 1000) as f32 / 100.0);
                        let size = [1e-4, 1e-2, 1.0, 10.0][(rng.next() % 4) as usize];
                        [0, 1, 2].map(|_| {
                            base + Vec3::new(
                                (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                                (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                                (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                            ) * size
                        })
                    } else {
                        [rng.vec(), rng.vec(), rng.vec()]
                    }
                })
                .collect();
            let ids: Vec<u32> = (0..LANES as u32).collect();
            let packet = Tri4::new(&tris, &ids);
            for (k, &[a, b, c]) in tris.iter().enumerate() {
                let full = intersect_triangle_sheared(&probe, &RayShear::new(&probe), a, b, c);
                // Intervals: open, and with an end at, just beside and
                // around the full test's distance.
                let mut intervals = vec![(0.0, f32::INFINITY), (0.5, 3.0)];
                if let Some(h) = full {
                    for f in [
                        1.0,
                        1.0 + 1e-7,
                        1.0 - 1e-7,
                        1.0 + 1e-5,
                        1.0 - 1e-5,
                        2.0,
                        0.5,
                    ] {
                        intervals.push((0.0, h.t * f));
                        intervals.push((h.t * f, f32::INFINITY));
                    }
                }
                for (tmin, tmax) in intervals {
                    let ray = Ray::new(origin, dir, tmin, tmax);
                    let s = RayShear::new(&ray);
                    let verdict = edge_stage(&ray, &s, &packet, LANES);
                    if verdict.candidates(LANES) & (1 << k) == 0 {
                        continue;
                    }
                    let blocks =
                        verdict.any_hit_certainty(k, &ray, &s, packet.triangle(k)) == Some(true);
                    let hit = intersect_triangle_sheared(&ray, &s, a, b, c);
                    if blocks {
                        let h = hit.unwrap_or_else(|| panic!("{ray:?} {:?}: no hit", [a, b, c]));
                        assert!(h.t >= tmin && h.t <= tmax, "{ray:?}: {h:?}");
                        certain += 1;
                    } else if let Some(h) = hit {
                        if h.t == tmax || h.t == tmin {
                            near_ends_held_back += 1;
                        }
                    }
                }
            }
        }
        assert!(certain > 40_000, "only {certain} certain blockers");
        assert!(near_ends_held_back > 1_000, "{near_ends_held_back}");
    }

    /// The two-packet AVX2 stage gives, bit for bit, the verdicts of the
    /// four-lane stage on each packet, hostile coordinates included.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn pair_stage_matches_two_single_stages() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = Rng(5);
        let mut candidates = 0;
        for i in 0..100_000 {
            let ray = Ray::new(rng.vec(), rng.vec(), 0.0, f32::INFINITY);
            let s = RayShear::new(&ray);
            let count = 1 + i % LANES;
            let packet = |n: usize, rng: &mut Rng| {
                let tris: Vec<[Vec3; 3]> = (0..n)
                    .map(|_| {
                        if rng.next().is_multiple_of(2) {
                            let base = ray.origin + ray.dir * 0.5;
                            [0, 1, 2].map(|_| {
                                base + Vec3::new(
                                    (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                                    (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                                    (rng.next() % 2001) as f32 / 1000.0 - 1.0,
                                )
                            })
                        } else {
                            [rng.vec(), rng.vec(), rng.vec()]
                        }
                    })
                    .collect();
                let ids: Vec<u32> = (0..n as u32).collect();
                Tri4::new(&tris, &ids)
            };
            let (first, second) = (packet(LANES, &mut rng), packet(count, &mut rng));
            // SAFETY: checked above that the CPU has AVX2.
            let [p0, p1] = unsafe { pair::edge_stage_pair(&ray, &s, [&first, &second], count) };
            let bits = |x: &[f32; LANES]| x.map(f32::to_bits);
            for (got, want) in [
                (p0, edge_stage(&ray, &s, &first, LANES)),
                (p1, edge_stage(&ray, &s, &second, count)),
            ] {
                assert_eq!((got.miss, got.inside), (want.miss, want.inside), "{ray:?}");
                let decided = want.miss | want.inside;
                for k in 0..LANES {
                    if decided & (1 << k) != 0 {
                        let lane = |v: &EdgeVerdict| {
                            [
                                bits(&v.u)[k],
                                bits(&v.v)[k],
                                bits(&v.w)[k],
                                bits(&v.scale)[k],
                            ]
                        };
                        assert_eq!(lane(&got), lane(&want), "{ray:?} lane {k}");
                    }
                }
                candidates += want.candidates(LANES).count_ones();
            }
        }
        assert!(candidates > 10_000, "only {candidates} candidates");
    }

    /// The AVX2 stage's behind-the-origin lanes are, lane for lane, the
    /// scalar check's answers (`certainly_behind`), on triangles just
    /// behind, on and just ahead of the origin (where shadow and bounce rays
    /// start) and on hostile ones; a ray with `tmin < 0` gets none.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn behind_lanes_match_the_scalar_check() {
        use crate::triangle::watertight::certainly_behind;
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = Rng(17);
        let (mut behind, mut ahead) = (0, 0);
        for i in 0..60_000 {
            let tmin = if i % 10 == 0 { -1.0 } else { 0.0 };
            let ray = Ray::new(rng.vec(), rng.vec(), tmin, f32::INFINITY);
            let s = RayShear::new(&ray);
            let mut packet = || {
                let tris: Vec<[Vec3; 3]> = (0..LANES)
                    .map(|_| {
                        let at =
                            [-0.5, -1e-4, -1e-7, 0.0, 1e-7, 1e-4, 0.5][(rng.next() % 7) as usize];
                        if rng.next().is_multiple_of(8) {
                            return [rng.vec(), rng.vec(), rng.vec()];
                        }
                        let base = ray.origin + ray.dir * at;
                        [0, 1, 2].map(|_| {
                            let mut off = || ((rng.next() % 2001) as f32 / 1000.0 - 1.0) * 1e-2;
                            base + Vec3::new(off(), off(), off())
                        })
                    })
                    .collect();
                Tri4::new(&tris, &[0, 1, 2, 3])
            };
            let (first, second) = (packet(), packet());
            // SAFETY: checked above that the CPU has AVX2.
            let verdicts = unsafe { pair::edge_stage_pair(&ray, &s, [&first, &second], LANES) };
            for (v, p) in verdicts.iter().zip([&first, &second]) {
                assert_eq!(v.behind_known, tmin >= 0.0);
                assert_eq!(v.behind & !v.inside, 0);
                for k in 0..LANES {
                    let is_behind = v.behind & (1 << k) != 0;
                    if v.inside & (1 << k) == 0 || !v.behind_known {
                        assert!(!is_behind);
                        continue;
                    }
                    let edges = [v.u[k], v.v[k], v.w[k]];
                    let want = certainly_behind(&ray, &s, p.triangle(k), edges, v.scale[k]);
                    assert_eq!(is_behind, want, "{ray:?} lane {k}");
                    if want {
                        behind += 1;
                    } else {
                        ahead += 1;
                    }
                }
            }
        }
        assert!(
            behind > 5_000 && ahead > 5_000,
            "{behind} behind, {ahead} ahead"
        );
    }

    /// The lanes leave an underflowing bound's signs to the full test, as
    /// the scalar test does: the triangle the ray passes just outside of
    /// is missed and its neighbour hit, in the four-lane stage and in the
    /// pair stage.
    #[test]
    fn lanes_leave_an_underflowing_bound_to_the_full_test() {
        let (ray, outside, neighbour) = crate::triangle::watertight::underflow_case();
        let s = RayShear::new(&ray);
        let packet = Tri4::new(&[outside, neighbour], &[0, 1]);
        let answers = |v: &EdgeVerdict| {
            [0, 1].map(|k| {
                (v.candidates(2) & (1 << k) != 0)
                    .then(|| v.finish::<false>(k, &ray, &s, packet.triangle(k)))
                    .flatten()
            })
        };
        let [missed, hit] = answers(&edge_stage(&ray, &s, &packet, 2));
        assert_eq!(missed, None);
        let [p0, p1, p2] = neighbour;
        assert!(same(hit, intersect_triangle_sheared(&ray, &s, p0, p1, p2)));
        assert!(hit.is_some());
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: checked above that the CPU has AVX2.
            let [first, second] = unsafe { pair::edge_stage_pair(&ray, &s, [&packet, &packet], 2) };
            for verdict in [first, second] {
                let [missed, again] = answers(&verdict);
                assert_eq!(missed, None);
                assert!(same(again, hit));
            }
        }
    }

    /// Every lane answers bit for bit what the one-triangle test answers,
    /// including on hostile coordinates; and the edge stage does reject.
    #[test]
    fn lanes_answer_like_the_scalar_test() {
        let mut rng = Rng(7);
        let mut rejected = 0;
        let mut hits = 0;
        for i in 0..200_000 {
            let ray = Ray::new(rng.vec(), rng.vec(), 0.0, f32::INFINITY);
            let s = RayShear::new(&ray);
            let count = 1 + i % LANES;
            let tris: Vec<[Vec3; 3]> = (0..count)
                .map(|_| {
                    // Half the triangles near the ray, so that many are hit.
                    if rng.next().is_multiple_of(2) {
                        let base = ray.origin + ray.dir * 0.5;
                        let jitter = |r: &mut Rng| {
                            Vec3::new(
                                (r.next() % 2001) as f32 / 1000.0 - 1.0,
                                (r.next() % 2001) as f32 / 1000.0 - 1.0,
                                (r.next() % 2001) as f32 / 1000.0 - 1.0,
                            )
                        };
                        [
                            base + jitter(&mut rng),
                            base + jitter(&mut rng),
                            base + jitter(&mut rng),
                        ]
                    } else {
                        [rng.vec(), rng.vec(), rng.vec()]
                    }
                })
                .collect();
            let ids: Vec<u32> = (0..count as u32).collect();
            let packed = Tri4::new(&tris, &ids);
            let verdict = edge_stage(&ray, &s, &packed, count);
            for (k, tri) in tris.iter().enumerate() {
                assert_eq!(packed.triangle(k).map(f32x3_bits), tri.map(f32x3_bits));
                let scalar = intersect_triangle_sheared(&ray, &s, tri[0], tri[1], tri[2]);
                let lane = if verdict.candidates(count) & (1 << k) != 0 {
                    verdict.finish::<false>(k, &ray, &s, packed.triangle(k))
                } else {
                    rejected += 1;
                    None
                };
                assert!(
                    same(scalar, lane),
                    "lane {k} of {tris:?} for {ray:?}: {lane:?} vs scalar {scalar:?}"
                );
                hits += usize::from(scalar.is_some());
            }
        }
        assert!(rejected > 50_000, "the edge stage rejected only {rejected}");
        assert!(hits > 10_000, "only {hits} hits: the test sees too few");
    }
}
