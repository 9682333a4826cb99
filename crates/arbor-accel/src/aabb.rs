use glam::Vec3;

use crate::ray::Ray;
use crate::util::widen_up;

/// Unit roundoff of `f32`: the largest relative error of one rounding.
const F32_UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// The factor that widens a slab test's positive exit distance so that
/// rounding can never make the test reject a box the exact ray touches:
/// `1 + 8u = 1 + 2^-21` (`u = 2^-24`).
///
/// Each slab distance `(plane - origin) * inv_dir` carries three roundings
/// (the subtraction, the reciprocal, the product), so a computed entry can
/// exceed its exact value by the factor `(1 + u)^3` while a computed exit
/// falls short of its own by `(1 - u)^3`, and the widening's own product
/// rounds once more. Since `(1 - u)^4 (1 + 8u) - (1 + u)^3 = u - 29u^2 +
/// ... > 0`, a widened exit is never below an entry the exact ray reaches
/// no later. (Ize's `1 + 2 gamma(3)` ("Robust BVH Ray Traversal", JCGT
/// 2013; pbrt), which rounds to `1 + 6u` in `f32`, covers each distance's
/// three roundings only to first order and not the widening's own
/// product: `(1 - u)^4 (1 + 6u) < (1 + u)^3`.) The bound is relative, so it
/// holds while the distances are normal numbers; a box touched only at a
/// subnormal distance (within about `1e-38` of the origin, in units of the
/// direction) is outside it.
pub const SLAB_TFAR_SCALE: f32 = 1.0 + 8.0 * F32_UNIT_ROUNDOFF;

/// The factor that widens a negative exit distance toward `+inf` (shrinking
/// its magnitude): `1 - 8u`. For an exit `f < 0` and an entry no later, the
/// computed entry's magnitude is at least `|f| (1 - u)^3` and the widened
/// exit's at most `|f| (1 + u)^4 (1 - 8u)`, which is smaller (the factors
/// differ by `u + 29u^2` and less). Multiplying a negative exit by
/// [`SLAB_TFAR_SCALE`] would move it the wrong way: for rays with `tmin < 0`, boxes behind the origin touched
/// along an edge were rejected (nine in ten such tangent cases in a random
/// search).
pub const SLAB_TFAR_SCALE_NEGATIVE: f32 = 1.0 - 8.0 * F32_UNIT_ROUNDOFF;

/// A slab test's exit distance `far` widened toward `+inf` by the rounding
/// bound, whatever its sign ([`SLAB_TFAR_SCALE`],
/// [`SLAB_TFAR_SCALE_NEGATIVE`]). For `far >= 0` it is `far *
/// SLAB_TFAR_SCALE`, bit for bit (the other product is not larger), which
/// is what the structures' fast paths compute for rays with `tmin >= 0`: a
/// negative exit rejects the box for them either way.
#[inline(always)]
pub fn widen_exit(far: f32) -> f32 {
    (far * SLAB_TFAR_SCALE).max(far * SLAB_TFAR_SCALE_NEGATIVE)
}

/// An axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`,
/// so that its union with any box is that box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    /// The box that contains nothing.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box with these corners.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The smallest box containing all `points` (empty for no points).
    pub fn from_points<I: IntoIterator<Item = Vec3>>(points: I) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    /// Whether the box contains no point.
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// This box grown to contain `p`.
    #[must_use]
    pub fn grow(&self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box containing both.
    #[must_use]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The overlap of both boxes (possibly empty).
    #[must_use]
    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    /// Whether `p` lies inside or on the boundary.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Whether `other` lies entirely inside this box.
    pub fn contains_box(&self, other: &Aabb) -> bool {
        other.is_empty() || (self.contains(other.min) && self.contains(other.max))
    }

    /// Extent along each axis (zero for an empty box).
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// The centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The axis (0 = x, 1 = y, 2 = z) along which the box is longest.
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Surface area (zero for an empty box).
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }

    /// Conservative slab test: the parameter interval `[t_enter, t_exit]`
    /// where `ray` is inside the box, clipped to `[ray.tmin, ray.tmax]`, or
    /// `None` when the ray misses. `inv_dir` is `1 / ray.dir` per component
    /// as computed by [`Ray::inv_dir`].
    ///
    /// Error bound: the exit distance is widened by [`widen_exit`], so a box
    /// that the exact ray touches is never rejected because of rounding.
    /// A zero direction component gives an infinite `inv_dir`, and
    /// `0 * inf = NaN` when the origin lies exactly on that slab's plane: the
    /// ray then runs inside the face's plane forever, so that slab is treated
    /// as `(-inf, inf)`.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, inv_dir: Vec3) -> Option<(f32, f32)> {
        let t0 = (self.min - ray.origin) * inv_dir;
        let t1 = (self.max - ray.origin) * inv_dir;
        let on_plane = t0.is_nan_mask() | t1.is_nan_mask();
        let near = Vec3::select(on_plane, Vec3::NEG_INFINITY, t0.min(t1));
        let far = Vec3::select(on_plane, Vec3::INFINITY, t0.max(t1));
        let t_enter = near.max_element().max(ray.tmin);
        let t_exit = widen_exit(far.min_element()).min(ray.tmax);
        (t_enter <= t_exit).then_some((t_enter, t_exit))
    }

    /// [`Aabb::intersect`] with `ray.tmax` widened up by one rounding, as
    /// traversal culls: a box entered exactly at the current closest hit (a
    /// shared vertex, a tie) may be entered a rounding later and must still
    /// pass.
    #[inline(always)]
    pub(crate) fn intersect_widened(&self, ray: &Ray, inv_dir: Vec3) -> Option<(f32, f32)> {
        let widened = Ray {
            tmax: widen_up(ray.tmax),
            ..*ray
        };
        self.intersect(&widened, inv_dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    /// `v` as an exact integer multiple of 2^-56, or `None` when it is not
    /// one (below about 1e-10); products of two stay below 2^127 for
    /// magnitudes below 2^7, as generated below.
    fn fixed(v: f32) -> Option<i128> {
        let bits = v.to_bits();
        let exp = ((bits >> 23) & 0xff) as i32;
        let mantissa = i128::from(bits & 0x7f_ffff | 0x80_0000);
        let shift = exp - 150 + 56;
        if v == 0.0 {
            return Some(0);
        }
        let magnitude = mantissa.checked_shl(u32::try_from(shift).ok()?)?;
        Some(if v < 0.0 { -magnitude } else { magnitude })
    }

    /// Rays whose exact line touches a box along an edge (it enters the x
    /// slab no later than it leaves the y slab, decided in exact integer
    /// arithmetic) are never turned away, in front of the origin or behind
    /// it (`tmin < 0`). Before the exit widening respected the sign, nine in
    /// ten of the cases behind the origin were rejected.
    #[test]
    fn boxes_touched_along_an_edge_are_entered() {
        let mut unit = crate::util::unit_sequence(13);
        let mut next = move || f64::from(unit());
        let (mut ahead, mut behind) = (0, 0);
        for i in 0..200_000 {
            let (ox, oy) = ((next() * 20.0 - 10.0) as f32, (next() * 20.0 - 10.0) as f32);
            let (dx, dy) = ((next() * 3.0 + 0.01) as f32, (next() * 3.0 + 0.01) as f32);
            let t = (next() * 20.0 + 0.1) * if i % 2 == 0 { 1.0 } else { -1.0 };
            // The x slab's near plane, and the y slab's far plane at about
            // the same distance, nudged up to the first float the exact line
            // leaves no earlier than it enters x.
            let x0 = (f64::from(ox) + t * f64::from(dx)) as f32;
            let tx = (f64::from(x0) - f64::from(ox)) / f64::from(dx);
            let mut y1 = (f64::from(oy) + tx * f64::from(dy)) as f32;
            let touches = |y: f32| -> Option<bool> {
                let [x0, ox, dx, y, oy, dy] = [x0, ox, dx, y, oy, dy].map(fixed);
                Some((x0? - ox?) * dy? <= (y? - oy?) * dx?)
            };
            let mut exact = touches(y1);
            while exact == Some(false) {
                y1 = y1.next_up();
                exact = touches(y1);
            }
            if exact.is_none() {
                continue; // a coordinate too small for the exact check
            }
            let b = Aabb::new(Vec3::new(x0, y1 - 1.0, -1e4), Vec3::new(x0 + 1.0, y1, 1e4));
            let ray = Ray::new(Vec3::new(ox, oy, 0.0), Vec3::new(dx, dy, 0.5), -1e3, 1e3);
            assert!(
                b.intersect(&ray, ray.inv_dir()).is_some(),
                "{ray:?} {b:?} (case {i})"
            );
            if t > 0.0 {
                ahead += 1;
            } else {
                behind += 1;
            }
        }
        assert!(ahead > 50_000 && behind > 50_000);
    }

    /// The widened exit lies at or beyond the exit, for both signs, and is
    /// the plain product for positive exits (the fast paths' arithmetic).
    #[test]
    fn exits_widen_toward_plus_infinity() {
        for far in [1.0f32, 3.7e-20, 8.5e30, -1.0, -2.5e-10, -7.1e25] {
            assert!(widen_exit(far) > far, "{far}");
        }
        for far in [0.0f32, -0.0, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(widen_exit(far).to_bits(), far.to_bits());
        }
        for far in [1.0f32, 0.3, 123.456, 1e-30] {
            assert_eq!(widen_exit(far).to_bits(), (far * SLAB_TFAR_SCALE).to_bits());
        }
    }

    fn hits(b: &Aabb, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
        let r = Ray::new(o, d, 0.0, f32::INFINITY);
        b.intersect(&r, r.inv_dir())
    }

    #[test]
    fn slab_hit_and_miss() {
        let b = unit();
        let (t0, t1) = hits(&b, Vec3::new(-1.0, 0.5, 0.5), Vec3::X).unwrap();
        assert_eq!(t0, 1.0);
        assert!((2.0..2.0001).contains(&t1));
        assert!(hits(&b, Vec3::new(-1.0, 1.5, 0.5), Vec3::X).is_none());
        assert!(hits(&b, Vec3::new(-1.0, 0.5, 0.5), -Vec3::X).is_none());
    }

    #[test]
    fn ray_in_face_plane_with_zero_component_counts_as_inside() {
        // Origin exactly on the y = 0 plane, direction has no y component.
        let b = unit();
        assert!(hits(&b, Vec3::new(-1.0, 0.0, 0.5), Vec3::X).is_some());
        assert!(hits(&b, Vec3::new(-1.0, 1.0, 0.5), Vec3::X).is_some());
        assert!(hits(&b, Vec3::new(-1.0, 1.0000001, 0.5), Vec3::X).is_none());
    }

    #[test]
    fn origin_inside_starts_at_tmin() {
        let (t0, _) = hits(&unit(), Vec3::splat(0.5), Vec3::new(0.3, -0.2, 0.1)).unwrap();
        assert_eq!(t0, 0.0);
    }

    #[test]
    fn grazing_edge_is_kept() {
        // A ray along the box's edge x = 1, y = 1.
        assert!(hits(&unit(), Vec3::new(1.0, 1.0, -5.0), Vec3::Z).is_some());
    }

    #[test]
    fn union_and_empty() {
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.union(&unit()), unit());
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
        assert_eq!(unit().surface_area(), 6.0);
        assert!(unit()
            .intersection(&Aabb::new(Vec3::splat(2.0), Vec3::splat(3.0)))
            .is_empty());
    }
}
