use glam::Vec3;

use crate::Ray;

/// Unit roundoff of `f32`: the largest relative error of one rounding.
const F32_UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// `gamma(n) = n u / (1 - n u)`: the bound on relative error after `n`
/// roundings (Higham; pbrt's `gamma`).
const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * F32_UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// The factor that widens a slab test's exit distance so that rounding can
/// never make the test reject a box the exact ray touches. Each slab distance
/// `(bound - origin) * inv_dir` carries at most 3 roundings (the subtraction,
/// the reciprocal and the product), so `tfar * (1 + 2 gamma(3))` covers the
/// worst case of the entry distance rounded up while the exit rounds down
/// (Ize, "Robust BVH Ray Traversal", JCGT 2013).
pub const SLAB_TFAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

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
    /// Error bound: the exit distance is widened by [`SLAB_TFAR_SCALE`], so a
    /// box that the exact ray touches is never rejected because of rounding.
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
        let t_exit = (far.min_element() * SLAB_TFAR_SCALE).min(ray.tmax);
        (t_enter <= t_exit).then_some((t_enter, t_exit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
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
