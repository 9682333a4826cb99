//! The 8-wide node of [`super::WideBvh`] and the slab test of its eight
//! child boxes at once, in two implementations with identical results:
//! AVX2 (one 256-bit register per row, chosen at run time when the CPU has
//! it) and portable (two 4-lane `glam::Vec4` halves: SSE on x86-64, NEON on
//! aarch64, scalar elsewhere).
//!
//! Both perform per lane exactly the operations of [`crate::Aabb::intersect`]
//! in the same order, and their `min`/`max` take their operands in the same
//! order (`glam::Vec4::min(a, b)` is `minps(a, b)` on x86-64, as
//! `_mm256_min_ps(a, b)` is), so NaN lanes resolve identically too: a
//! structure traced with either path visits the same nodes in the same order.

use glam::Vec4;

use crate::aabb::SLAB_TFAR_SCALE;
use crate::Ray;

/// Children per node.
pub(crate) const WIDTH: usize = 8;

/// Child slot holding nothing.
pub(crate) const EMPTY: u32 = u32::MAX;

/// Eight children: their boxes in lanes, then what each child is.
/// `child[i]` is a node index (`count[i] == 0`), the first primitive slot of
/// a leaf (`count[i] > 0` primitives), or [`EMPTY`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct Node8 {
    pub min: [[f32; WIDTH]; 3],
    pub max: [[f32; WIDTH]; 3],
    pub child: [u32; WIDTH],
    pub count: [u32; WIDTH],
}

const _: () = assert!(std::mem::size_of::<Node8>() == 256);

impl Node8 {
    /// A node with every slot empty.
    pub const EMPTY: Node8 = Node8 {
        min: [[0.0; WIDTH]; 3],
        max: [[0.0; WIDTH]; 3],
        child: [EMPTY; WIDTH],
        count: [0; WIDTH],
    };

    /// Bit `i` set when slot `i` holds a child: empty slots have no
    /// meaningful box (an inverted box would pass the slab test), so they
    /// are masked out.
    #[inline(always)]
    fn valid(&self) -> u32 {
        let mut bits = 0;
        for (i, &c) in self.child.iter().enumerate() {
            bits |= u32::from(c != EMPTY) << i;
        }
        bits
    }
}

/// A ray prepared for testing a node's eight boxes.
pub(crate) trait BoxLanes {
    /// Splats `ray` into lanes.
    fn new(ray: &Ray) -> Self;

    /// Entry distances of the eight children and which of them (bit `i` for
    /// slot `i`, empty slots never) the ray touches before `tmax` (already
    /// widened by the caller).
    ///
    /// `NAN_SAFE = false` is the fast path for rays whose origin and
    /// direction are finite and whose direction has no zero component:
    /// then `(bound - origin) * inv` is never NaN (no `0 * inf`, and `inv`
    /// is never 0), so the on-plane fix-up can be skipped with the same
    /// results.
    fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32);
}

/// Whether a ray needs the NaN fix-up of [`BoxLanes::hit`].
#[inline(always)]
pub(crate) fn needs_nan_care(ray: &Ray) -> bool {
    !(ray.origin.is_finite() && ray.dir.is_finite() && ray.inv_dir().is_finite())
}

/// Two 4-lane halves; works everywhere.
pub(crate) struct Portable {
    origin: [Vec4; 3],
    inv: [Vec4; 3],
    tmin: Vec4,
}

impl Portable {
    /// One half: children `4 * half .. 4 * half + 4`.
    #[inline(always)]
    fn half<const NAN_SAFE: bool>(&self, n: &Node8, half: usize, tmax: f32) -> (Vec4, u32) {
        let row = |r: &[f32; WIDTH]| Vec4::from_slice(&r[4 * half..4 * half + 4]);
        let mut near = self.tmin;
        let mut far = Vec4::INFINITY;
        for a in 0..3 {
            let t0 = (row(&n.min[a]) - self.origin[a]) * self.inv[a];
            let t1 = (row(&n.max[a]) - self.origin[a]) * self.inv[a];
            let (lo, hi) = if NAN_SAFE {
                let on_plane = t0.is_nan_mask() | t1.is_nan_mask();
                (
                    Vec4::select(on_plane, Vec4::NEG_INFINITY, t0.min(t1)),
                    Vec4::select(on_plane, Vec4::INFINITY, t0.max(t1)),
                )
            } else {
                (t0.min(t1), t0.max(t1))
            };
            near = near.max(lo);
            far = far.min(hi);
        }
        let exit = (far * SLAB_TFAR_SCALE).min(Vec4::splat(tmax));
        (near, near.cmple(exit).bitmask())
    }
}

impl BoxLanes for Portable {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let inv = ray.inv_dir();
        Portable {
            origin: [
                Vec4::splat(ray.origin.x),
                Vec4::splat(ray.origin.y),
                Vec4::splat(ray.origin.z),
            ],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            tmin: Vec4::splat(ray.tmin),
        }
    }

    #[inline(always)]
    fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32) {
        let (near0, bits0) = self.half::<NAN_SAFE>(n, 0, tmax);
        let (near1, bits1) = self.half::<NAN_SAFE>(n, 1, tmax);
        let mut near = [0.0; WIDTH];
        near[..4].copy_from_slice(&near0.to_array());
        near[4..].copy_from_slice(&near1.to_array());
        (near, (bits0 | bits1 << 4) & n.valid())
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::{has_avx2, Avx2};

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{BoxLanes, Node8, EMPTY, WIDTH};
    use crate::aabb::SLAB_TFAR_SCALE;
    use crate::Ray;

    /// Whether this CPU runs the AVX2 path (checked once, then cached by
    /// the standard library).
    #[inline(always)]
    pub(crate) fn has_avx2() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    /// One 256-bit register per row. Only ever created inside functions
    /// compiled with `#[target_feature(enable = "avx2")]`, which callers
    /// reach only after [`has_avx2`] said yes.
    pub(crate) struct Avx2 {
        origin: [__m256; 3],
        inv: [__m256; 3],
        tmin: __m256,
    }

    impl BoxLanes for Avx2 {
        #[inline(always)]
        fn new(ray: &Ray) -> Self {
            let inv = ray.inv_dir();
            // SAFETY: AVX is available (see the type's documentation).
            unsafe {
                Avx2 {
                    origin: [
                        _mm256_set1_ps(ray.origin.x),
                        _mm256_set1_ps(ray.origin.y),
                        _mm256_set1_ps(ray.origin.z),
                    ],
                    inv: [
                        _mm256_set1_ps(inv.x),
                        _mm256_set1_ps(inv.y),
                        _mm256_set1_ps(inv.z),
                    ],
                    tmin: _mm256_set1_ps(ray.tmin),
                }
            }
        }

        #[inline(always)]
        fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32) {
            // SAFETY: AVX2 is available (see the type's documentation); the
            // loads read whole 32-byte rows of `n` (unaligned loads, so no
            // alignment requirement either).
            unsafe {
                let mut near = self.tmin;
                let mut far = _mm256_set1_ps(f32::INFINITY);
                for a in 0..3 {
                    let lo = _mm256_loadu_ps(n.min[a].as_ptr());
                    let hi = _mm256_loadu_ps(n.max[a].as_ptr());
                    let t0 = _mm256_mul_ps(_mm256_sub_ps(lo, self.origin[a]), self.inv[a]);
                    let t1 = _mm256_mul_ps(_mm256_sub_ps(hi, self.origin[a]), self.inv[a]);
                    let (tlo, thi) = if NAN_SAFE {
                        let on_plane = _mm256_or_ps(
                            _mm256_cmp_ps::<_CMP_UNORD_Q>(t0, t0),
                            _mm256_cmp_ps::<_CMP_UNORD_Q>(t1, t1),
                        );
                        (
                            _mm256_blendv_ps(
                                _mm256_min_ps(t0, t1),
                                _mm256_set1_ps(f32::NEG_INFINITY),
                                on_plane,
                            ),
                            _mm256_blendv_ps(
                                _mm256_max_ps(t0, t1),
                                _mm256_set1_ps(f32::INFINITY),
                                on_plane,
                            ),
                        )
                    } else {
                        (_mm256_min_ps(t0, t1), _mm256_max_ps(t0, t1))
                    };
                    near = _mm256_max_ps(near, tlo);
                    far = _mm256_min_ps(far, thi);
                }
                let exit = _mm256_min_ps(
                    _mm256_mul_ps(far, _mm256_set1_ps(SLAB_TFAR_SCALE)),
                    _mm256_set1_ps(tmax),
                );
                let inside = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, exit)) as u32;
                let empty = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
                    _mm256_loadu_si256(n.child.as_ptr().cast()),
                    _mm256_set1_epi32(EMPTY as i32),
                ))) as u32;
                let mut t = [0.0; WIDTH];
                _mm256_storeu_ps(t.as_mut_ptr(), near);
                (t, inside & !empty)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Both implementations give the same bits and entry distances on every
    /// kind of ray, hostile ones included (when this CPU has AVX2).
    #[test]
    fn implementations_agree() {
        let mut node = Node8::EMPTY;
        for i in 0..7 {
            let f = i as f32;
            for a in 0..3 {
                node.min[a][i] = -1.0 + 0.3 * f - a as f32 * 0.1;
                node.max[a][i] = node.min[a][i] + 0.5 + 0.1 * f;
            }
            node.child[i] = i as u32;
        }
        // A flat box, and slot 7 empty.
        node.max[1][6] = node.min[1][6];
        let values = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.25,
            1e-30,
            f32::INFINITY,
            f32::NAN,
            2.5,
        ];
        let mut agreed = 0;
        let mut entered = 0;
        for &ox in &values {
            for &dy in &values {
                for &dz in &values[..6] {
                    let ray = Ray::new(
                        Vec3::new(ox, 0.1, -3.0),
                        Vec3::new(0.3, dy, dz),
                        0.0,
                        if dz == 0.0 { 2.0 } else { f32::INFINITY },
                    );
                    let p = Portable::new(&ray);
                    let (pt, pb) = if needs_nan_care(&ray) {
                        p.hit::<true>(&node, ray.tmax)
                    } else {
                        p.hit::<false>(&node, ray.tmax)
                    };
                    assert_eq!(pb & 0x80, 0, "the empty slot is never entered");
                    entered += pb.count_ones();
                    #[cfg(target_arch = "x86_64")]
                    if has_avx2() {
                        let v = Avx2::new(&ray);
                        let (vt, vb) = if needs_nan_care(&ray) {
                            v.hit::<true>(&node, ray.tmax)
                        } else {
                            v.hit::<false>(&node, ray.tmax)
                        };
                        assert_eq!(pb, vb, "{ray:?}");
                        for i in 0..WIDTH {
                            if pb & (1 << i) != 0 {
                                assert_eq!(pt[i].to_bits(), vt[i].to_bits(), "{ray:?} slot {i}");
                            }
                        }
                        agreed += 1;
                    }
                }
            }
        }
        assert!(entered > 30, "only {entered} boxes entered");
        #[cfg(target_arch = "x86_64")]
        assert!(!has_avx2() || agreed > 0);
        let _ = agreed;
    }
}
