//! The 8-wide node of [`super::WideBvh`] and the slab test of its eight
//! child boxes at once, in two implementations with identical results:
//! AVX2 (one 256-bit register per row, chosen at run time when the CPU has
//! it) and portable (two 4-lane `glam::Vec4` halves: SSE on x86-64, NEON on
//! aarch64, scalar elsewhere).
//!
//! Both perform per lane exactly the operations of [`crate::aabb::Aabb::intersect`]
//! in the same order, and their `min`/`max` take their operands in the same
//! order (`glam::Vec4::min(a, b)` is `minps(a, b)` on x86-64, as
//! `_mm256_min_ps(a, b)` is), so NaN lanes resolve identically too: a
//! structure traced with either path visits the same nodes in the same order.

use glam::{Vec3, Vec3A, Vec4};

use super::stack::{LaneStack, OrderedStack};
use crate::aabb::{SLAB_TFAR_SCALE, SLAB_TFAR_SCALE_NEGATIVE};
use crate::ray::Ray;

/// Children per node.
pub(crate) const WIDTH: usize = 8;

/// Child slot holding nothing.
pub(crate) const EMPTY: u32 = u32::MAX;

/// Eight children: their boxes in lanes, then what each child is.
/// `bounds` holds six rows of eight lanes: the boxes' `min x, min y, min z,
/// max x, max y, max z` (rows [`MIN`]` + a` and [`MAX`]` + a` for axis `a`).
/// `child[i]` is a node index (leaf count 0), the first primitive slot of
/// a leaf, or [`EMPTY`].
///
/// `meta[i]` packs two things. Its low [`COUNT_BITS`] bits are slot `i`'s
/// leaf count ([`Node8::count`]). The twelve bits above hold the node's
/// child order ([`Node8::set_orders`]): for each of the four ray octants
/// whose x direction is positive, the slot at position `i` of that
/// octant's visiting order, three bits each. An octant with negative x
/// walks the opposite octant's order backwards (farther for one direction
/// is nearer for the opposite one), so eight orders fit in the 256 bytes
/// the node already had.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct Node8 {
    pub bounds: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
    pub meta: [u32; WIDTH],
}

/// Bits of [`Node8::meta`] holding a slot's leaf count.
pub(crate) const COUNT_BITS: u32 = 20;

/// The mask of the count bits of [`Node8::meta`].
pub(crate) const COUNT_MASK: u32 = (1 << COUNT_BITS) - 1;

/// The most primitives a leaf of the wide tree may hold: its count must fit
/// in [`COUNT_BITS`]. The builders' leaves are far smaller (at most
/// `BvhParams::max_leaf_size`, clamped to this by the wide builds).
pub(crate) const MAX_LEAF_COUNT: usize = COUNT_MASK as usize;

/// Which order of [`Node8::meta`] a ray walks: the bit offset of its
/// octant's three-bit slot numbers, and whether it reads them backwards
/// (octants with a negative x direction).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Order {
    pub shift: u32,
    /// 7 to read the positions backwards (position `p` is stored at
    /// `p ^ flip`), 0 otherwise.
    pub flip: u32,
}

impl Order {
    /// The order of a ray whose inverse direction has the sign bits
    /// `negative` (bit `a` set: axis `a` negative).
    #[inline(always)]
    pub(crate) fn for_signs(negative: u32) -> Order {
        // Negative x: the opposite octant's order, backwards.
        let reversed = negative & 1 != 0;
        let octant = if reversed { !negative & 7 } else { negative };
        Order {
            shift: COUNT_BITS + 3 * (octant >> 1),
            flip: if reversed { 7 } else { 0 },
        }
    }

    /// The order of a ray with inverse direction `inv`.
    #[inline(always)]
    pub(crate) fn of(inv: Vec3) -> Order {
        Order::for_signs(inv.is_negative_bitmask())
    }
}

/// Row of `Node8::bounds` holding the boxes' lower corners along x.
pub(crate) const MIN: usize = 0;
/// Row of `Node8::bounds` holding the boxes' upper corners along x.
pub(crate) const MAX: usize = 3;

const _: () = assert!(std::mem::size_of::<Node8>() == 256);

impl Node8 {
    /// A node with every slot empty. Empty slots hold the inverted infinite
    /// box (`min = +inf`, `max = -inf`), which a ray with a finite origin
    /// and finite, nonzero inverse direction never enters: its entry
    /// distance is `+inf` and its exit `-inf`. Only the NaN-safe path, which
    /// turns undefined slab distances into `(-inf, inf)`, masks them out.
    pub const EMPTY: Node8 = Node8 {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY; WIDTH],
        meta: [0; WIDTH],
    };

    /// Slot `i`'s leaf count (0 for a node or an empty slot).
    #[inline(always)]
    pub(crate) fn count(&self, i: usize) -> u32 {
        self.meta[i] & COUNT_MASK
    }

    /// Sets slot `i`'s leaf count, which must not exceed [`MAX_LEAF_COUNT`].
    pub(crate) fn set_count(&mut self, i: usize, count: u32) {
        assert!(
            count as usize <= MAX_LEAF_COUNT,
            "leaf of {count} primitives"
        );
        self.meta[i] = (self.meta[i] & !COUNT_MASK) | count;
    }

    /// The slot at position `position` of `order`.
    #[inline(always)]
    pub(crate) fn slot_at(&self, order: Order, position: usize) -> usize {
        (self.meta[position ^ order.flip as usize] >> order.shift & 7) as usize
    }

    /// Writes the visiting orders of the four octants with positive x into
    /// `meta` (the counts stay): for the octant's direction `d` (each
    /// component +1 or -1), the slots by decreasing `d . centre` of their
    /// boxes, farthest first, so that pushing them in this order leaves the
    /// nearest on top of the stack. Empty slots come last. The order only
    /// steers which child is visited first; the answers do not depend on it.
    pub(crate) fn set_orders(&mut self) {
        let valid = self.valid();
        for octant in 0..4u32 {
            // Octant with x positive: bits 1 and 2 of the full octant index.
            let negative = octant << 1;
            let d = [0, 1, 2].map(|a| if negative >> a & 1 == 1 { -1.0 } else { 1.0 });
            let key: [f32; WIDTH] = std::array::from_fn(|slot| {
                if valid >> slot & 1 == 0 {
                    return f32::NEG_INFINITY;
                }
                (0..3)
                    .map(|a| d[a] * (self.bounds[MIN + a][slot] + self.bounds[MAX + a][slot]))
                    .sum()
            });
            let mut slots: [usize; WIDTH] = std::array::from_fn(|i| i);
            slots.sort_by(|&a, &b| key[b].total_cmp(&key[a]));
            let shift = COUNT_BITS + 3 * octant;
            for (position, &slot) in slots.iter().enumerate() {
                self.meta[position] =
                    (self.meta[position] & !(7 << shift)) | (slot as u32) << shift;
            }
        }
    }

    /// Bit `i` set when slot `i` holds a child.
    #[inline(always)]
    pub(crate) fn valid(&self) -> u32 {
        let mut bits = 0;
        for (i, &c) in self.child.iter().enumerate() {
            bits |= u32::from(c != EMPTY) << i;
        }
        bits
    }
}

/// A ray prepared for testing a node's eight boxes.
pub(crate) trait BoxLanes {
    /// Splats `ray` into lanes; `inv` is `ray.inv_dir()`.
    fn new(ray: &Ray, inv: Vec3) -> Self;

    /// Entry distances of the eight children and which of them (bit `i` for
    /// slot `i`, empty slots never) the ray touches before `tmax` (already
    /// widened by the caller).
    ///
    /// `NAN_SAFE = false` is the fast path for rays whose origin and
    /// direction are finite, whose direction has no zero component and
    /// whose `tmin` is not negative (see [`needs_slow_path`]):
    /// then `(bound - origin) * inv` is never NaN (no `0 * inf`, and `inv`
    /// is never 0 or NaN), so the on-plane fix-up can be skipped, and the
    /// sign of `inv` tells in advance which plane of each slab is the near
    /// one (`(min - o) * inv <= (max - o) * inv` for `inv > 0`, as rounding
    /// is monotonic): the near distances come from the near rows alone, the
    /// far ones from the far rows, with the very values `min`/`max` of both
    /// would pick and without the six `min`/`max` (the trick Embree and pbrt
    /// use). Empty slots need no mask there (see [`Node8::EMPTY`]), and the
    /// exit is widened by the plain product with `SLAB_TFAR_SCALE`: with
    /// `tmin >= 0` an exit below zero rejects the box however it is
    /// widened.
    fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32);

    /// Pushes the children of `n` set in `entered` onto `stack` in `order`
    /// ([`OrderedStack::push_portable`], or its AVX2 form).
    #[inline(always)]
    fn push_ordered(
        stack: &mut OrderedStack,
        n: &Node8,
        near: &[f32; WIDTH],
        entered: u32,
        order: Order,
    ) {
        stack.push_portable(n, near, entered, order);
    }

    /// Pushes the children of `n` set in `entered` onto `stack` in slot
    /// order ([`LaneStack::push_portable`], or its AVX2 form).
    #[inline(always)]
    fn push_lanes(stack: &mut LaneStack, n: &Node8, entered: u32) {
        stack.push_portable(n, entered);
    }
}

/// Whether a ray with inverse direction `inv` needs the slow path of
/// [`BoxLanes::hit`]: an origin, direction or inverse direction that is not
/// finite (the NaN fix-up), or `tmin < 0` (or NaN), for which a box's exit
/// behind the origin can matter and must be widened by its sign (see
/// `crate::aabb::widen_exit`).
#[inline(always)]
pub(crate) fn needs_slow_path(ray: &Ray, inv: Vec3) -> bool {
    // The nine finiteness checks as three SIMD compares and one mask
    // instead of nine scalar tests and branches (run once per ray).
    let finite = Vec3A::from(ray.origin).is_finite_mask()
        & Vec3A::from(ray.dir).is_finite_mask()
        & Vec3A::from(inv).is_finite_mask();
    !finite.all() || ray.tmin.is_nan() || ray.tmin < 0.0
}

/// The rows of `Node8::bounds` holding each axis's near and far planes for
/// a ray with inverse direction `inv` (meaningful when `inv` is finite).
#[inline(always)]
fn near_far_rows(inv: Vec3) -> ([usize; 3], [usize; 3]) {
    rows_for_signs(inv.is_negative_bitmask() as usize)
}

/// [`near_far_rows`] for the inverse direction's sign bits `negative`
/// (bit `a` set: axis `a` is negative), shared with the packets' lanes.
#[inline(always)]
pub(crate) fn rows_for_signs(negative: usize) -> ([usize; 3], [usize; 3]) {
    // Sign bit `a` set: the max plane of axis `a` is the near one.
    let shift = |a: usize| (MAX - MIN) * (negative >> a & 1);
    let near = [0, 1, 2].map(|a| MIN + a + shift(a));
    let far = [0, 1, 2].map(|a| MAX + a - shift(a));
    (near, far)
}

/// Two 4-lane halves; works everywhere.
pub(crate) struct Portable {
    origin: [Vec4; 3],
    inv: [Vec4; 3],
    tmin: Vec4,
    near: [usize; 3],
    far: [usize; 3],
}

impl Portable {
    /// One half: children `4 * half .. 4 * half + 4`.
    #[inline(always)]
    fn half<const NAN_SAFE: bool>(&self, n: &Node8, half: usize, tmax: f32) -> (Vec4, u32) {
        let row = |r: usize| Vec4::from_slice(&n.bounds[r][4 * half..4 * half + 4]);
        let mut near = self.tmin;
        let mut far = Vec4::INFINITY;
        for a in 0..3 {
            let (lo, hi) = if NAN_SAFE {
                let t0 = (row(MIN + a) - self.origin[a]) * self.inv[a];
                let t1 = (row(MAX + a) - self.origin[a]) * self.inv[a];
                let on_plane = t0.is_nan_mask() | t1.is_nan_mask();
                (
                    Vec4::select(on_plane, Vec4::NEG_INFINITY, t0.min(t1)),
                    Vec4::select(on_plane, Vec4::INFINITY, t0.max(t1)),
                )
            } else {
                (
                    (row(self.near[a]) - self.origin[a]) * self.inv[a],
                    (row(self.far[a]) - self.origin[a]) * self.inv[a],
                )
            };
            near = near.max(lo);
            far = far.min(hi);
        }
        // The fast path serves rays with `tmin >= 0` only, for which the
        // plain product is the widened exit wherever it matters (see
        // `widen_exit`); otherwise a negative exit is widened toward +inf.
        let far = if NAN_SAFE {
            (far * SLAB_TFAR_SCALE).max(far * SLAB_TFAR_SCALE_NEGATIVE)
        } else {
            far * SLAB_TFAR_SCALE
        };
        let exit = far.min(Vec4::splat(tmax));
        (near, near.cmple(exit).bitmask())
    }
}

impl BoxLanes for Portable {
    #[inline(always)]
    fn new(ray: &Ray, inv: Vec3) -> Self {
        let (near, far) = near_far_rows(inv);
        Portable {
            origin: [
                Vec4::splat(ray.origin.x),
                Vec4::splat(ray.origin.y),
                Vec4::splat(ray.origin.z),
            ],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            tmin: Vec4::splat(ray.tmin),
            near,
            far,
        }
    }

    #[inline(always)]
    fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32) {
        let (near0, bits0) = self.half::<NAN_SAFE>(n, 0, tmax);
        let (near1, bits1) = self.half::<NAN_SAFE>(n, 1, tmax);
        let mut near = [0.0; WIDTH];
        near[..4].copy_from_slice(&near0.to_array());
        near[4..].copy_from_slice(&near1.to_array());
        let bits = bits0 | bits1 << 4;
        (near, if NAN_SAFE { bits & n.valid() } else { bits })
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx2::{has_avx2, has_avx512, Avx2};

#[cfg(test)]
thread_local! {
    /// Set while [`without_avx2`] runs its closure.
    static AVX2_HIDDEN: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Set while [`without_avx512`] runs its closure.
    static AVX512_HIDDEN: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with [`has_avx512`] answering no on this thread, so that the
/// AVX2 paths run on an AVX-512 machine too (unit tests only).
#[cfg(test)]
pub(crate) fn without_avx512<R>(f: impl FnOnce() -> R) -> R {
    AVX512_HIDDEN.set(true);
    let result = f();
    AVX512_HIDDEN.set(false);
    result
}

/// Runs `f` with [`has_avx2`] answering no on this thread: every traversal
/// and leaf test in it takes its portable path (unit tests only; the
/// property tests, on an AVX2 machine, only see the AVX2 paths).
#[cfg(test)]
pub(crate) fn without_avx2<R>(f: impl FnOnce() -> R) -> R {
    AVX2_HIDDEN.set(true);
    let result = f();
    AVX2_HIDDEN.set(false);
    result
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;
    use std::sync::atomic::{AtomicU8, Ordering};

    use glam::Vec3;

    use super::{near_far_rows, BoxLanes, Node8, Order, EMPTY, MAX, MIN, WIDTH};
    use crate::aabb::{SLAB_TFAR_SCALE, SLAB_TFAR_SCALE_NEGATIVE};
    use crate::ray::Ray;
    use crate::wide::stack::{LaneStack, OrderedStack};

    /// Whether this CPU runs the AVX2 path: AVX2 with BMI1, BMI2 and
    /// POPCNT (checked once, then cached by the standard library). In this crate's unit tests,
    /// `without_avx2` can say no on the current thread, so that
    /// the portable paths run on an AVX2 machine too.
    #[inline(always)]
    pub(crate) fn has_avx2() -> bool {
        #[cfg(test)]
        if super::AVX2_HIDDEN.get() {
            return false;
        }
        // Asked once per leaf too: one cached byte instead of four feature
        // lookups (those cost 85 instructions a shadow ray on buddha100k).
        match AVX2.load(Ordering::Relaxed) {
            YES => true,
            NO => false,
            _ => detect_avx2(),
        }
    }

    /// [`has_avx2`]'s cached answer: [`UNKNOWN`], [`NO`] or [`YES`].
    static AVX2: AtomicU8 = AtomicU8::new(UNKNOWN);
    const UNKNOWN: u8 = 0;
    const NO: u8 = 1;
    const YES: u8 = 2;

    /// Asks the CPU, and caches the answer in [`AVX2`].
    #[cold]
    fn detect_avx2() -> bool {
        // The bit-manipulation extensions come with AVX2 on every CPU that
        // has it (Intel Haswell, AMD Excavator and later); the AVX2 entry
        // points are compiled with them, so they are checked too.
        let yes = std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("popcnt");
        AVX2.store(if yes { YES } else { NO }, Ordering::Relaxed);
        yes
    }

    /// Whether this CPU runs the AVX-512 paths (AVX-512 F, with AVX2 for
    /// the code around them). `without_avx512` and
    /// `without_avx2` can say no on the current thread in unit
    /// tests.
    #[inline(always)]
    pub(crate) fn has_avx512() -> bool {
        #[cfg(test)]
        if super::AVX512_HIDDEN.get() {
            return false;
        }
        has_avx2() && std::arch::is_x86_feature_detected!("avx512f")
    }

    /// One 256-bit register per row. Only ever created inside functions
    /// compiled with `#[target_feature(enable = "avx2")]`, which callers
    /// reach only after [`has_avx2`] said yes.
    pub(crate) struct Avx2 {
        origin: [__m256; 3],
        inv: [__m256; 3],
        /// `-inv`, for the fast path's memory-operand form.
        neg_inv: [__m256; 3],
        tmin: __m256,
        near: [usize; 3],
        far: [usize; 3],
    }

    impl BoxLanes for Avx2 {
        #[inline(always)]
        fn new(ray: &Ray, inv: Vec3) -> Self {
            let (near, far) = near_far_rows(inv);
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
                    neg_inv: [
                        _mm256_set1_ps(-inv.x),
                        _mm256_set1_ps(-inv.y),
                        _mm256_set1_ps(-inv.z),
                    ],
                    tmin: _mm256_set1_ps(ray.tmin),
                    near,
                    far,
                }
            }
        }

        #[inline(always)]
        fn hit<const NAN_SAFE: bool>(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32) {
            // SAFETY: AVX2 is available (see the type's documentation); the
            // loads read whole 32-byte rows of `n` (unaligned loads, so no
            // alignment requirement either).
            unsafe {
                let row = |r: usize| _mm256_loadu_ps(n.bounds[r].as_ptr());
                let mut near = self.tmin;
                let mut far = _mm256_set1_ps(f32::INFINITY);
                for a in 0..3 {
                    let (tlo, thi) = if NAN_SAFE {
                        let t0 =
                            _mm256_mul_ps(_mm256_sub_ps(row(MIN + a), self.origin[a]), self.inv[a]);
                        let t1 =
                            _mm256_mul_ps(_mm256_sub_ps(row(MAX + a), self.origin[a]), self.inv[a]);
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
                        // `(origin - plane) * -inv` is bit for bit
                        // `(plane - origin) * inv` (negation is exact and
                        // rounding symmetric), and lets each row be a memory
                        // operand of the subtraction instead of a load.
                        // The rows exist: `near_far_rows` names rows 0..6.
                        let plane = |r: usize| n.bounds.as_ptr().add(r).cast::<f32>();
                        (
                            _mm256_mul_ps(
                                _mm256_sub_ps(self.origin[a], _mm256_loadu_ps(plane(self.near[a]))),
                                self.neg_inv[a],
                            ),
                            _mm256_mul_ps(
                                _mm256_sub_ps(self.origin[a], _mm256_loadu_ps(plane(self.far[a]))),
                                self.neg_inv[a],
                            ),
                        )
                    };
                    near = _mm256_max_ps(near, tlo);
                    far = _mm256_min_ps(far, thi);
                }
                // As in `Portable::half`: the plain product on the fast path
                // (`tmin >= 0`), a sign-aware widening otherwise.
                let scaled = _mm256_mul_ps(far, _mm256_set1_ps(SLAB_TFAR_SCALE));
                let widened = if NAN_SAFE {
                    _mm256_max_ps(
                        scaled,
                        _mm256_mul_ps(far, _mm256_set1_ps(SLAB_TFAR_SCALE_NEGATIVE)),
                    )
                } else {
                    scaled
                };
                let exit = _mm256_min_ps(widened, _mm256_set1_ps(tmax));
                let mut inside = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, exit)) as u32;
                if NAN_SAFE {
                    let empty = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
                        _mm256_loadu_si256(n.child.as_ptr().cast()),
                        _mm256_set1_epi32(EMPTY as i32),
                    ))) as u32;
                    inside &= !empty;
                }
                let mut t = [0.0; WIDTH];
                _mm256_storeu_ps(t.as_mut_ptr(), near);
                (t, inside)
            }
        }

        #[inline(always)]
        fn push_ordered(
            stack: &mut OrderedStack,
            n: &Node8,
            near: &[f32; WIDTH],
            entered: u32,
            order: Order,
        ) {
            // SAFETY: AVX2 is available (see the type's documentation).
            unsafe { stack.push_avx2(n, near, entered, order) }
        }

        #[inline(always)]
        fn push_lanes(stack: &mut LaneStack, n: &Node8, entered: u32) {
            // SAFETY: AVX2 is available (see the type's documentation).
            unsafe { stack.push_avx2(n, entered) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both implementations give the same bits and entry distances on every
    /// kind of ray, hostile ones included (when this CPU has AVX2).
    #[test]
    fn implementations_agree() {
        let mut node = Node8::EMPTY;
        for i in 0..7 {
            let f = i as f32;
            for a in 0..3 {
                node.bounds[MIN + a][i] = -1.0 + 0.3 * f - a as f32 * 0.1;
                node.bounds[MAX + a][i] = node.bounds[MIN + a][i] + 0.5 + 0.1 * f;
            }
            node.child[i] = i as u32;
        }
        // A flat box, and slot 7 empty.
        node.bounds[MAX + 1][6] = node.bounds[MIN + 1][6];
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
                    let inv = ray.inv_dir();
                    let slow = needs_slow_path(&ray, inv);
                    let p = Portable::new(&ray, inv);
                    let (pt, pb) = if slow {
                        p.hit::<true>(&node, ray.tmax)
                    } else {
                        p.hit::<false>(&node, ray.tmax)
                    };
                    assert_eq!(pb & 0x80, 0, "the empty slot is never entered");
                    entered += pb.count_ones();
                    // Each slot answers as the scalar slab test of its box.
                    for (i, &entry) in pt.iter().enumerate().take(7) {
                        let corner = |r: usize| {
                            Vec3::new(
                                node.bounds[r][i],
                                node.bounds[r + 1][i],
                                node.bounds[r + 2][i],
                            )
                        };
                        let aabb = crate::aabb::Aabb::new(corner(MIN), corner(MAX));
                        let want = aabb.intersect(&ray, inv);
                        assert_eq!(pb >> i & 1 == 1, want.is_some(), "{ray:?} slot {i}");
                        if let Some((enter, _)) = want {
                            assert_eq!(entry.to_bits(), enter.to_bits(), "{ray:?} slot {i}");
                        }
                    }
                    #[cfg(target_arch = "x86_64")]
                    if has_avx2() {
                        let v = Avx2::new(&ray, inv);
                        let (vt, vb) = if slow {
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
