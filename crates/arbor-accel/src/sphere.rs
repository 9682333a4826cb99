//! Bounding spheres: the cheapest bounding volume to test and to transform
//! (a rotation leaves them unchanged), at the price of a loose fit around
//! elongated shapes.

use glam::{DVec3, Vec3};

use crate::aabb::Aabb;
use crate::ray::Ray;

/// Relative padding applied to radii so that `f32` rounding of the centre and
/// radius can never leave a fitted point outside.
const RADIUS_PAD: f64 = 1e-6;

/// A sphere enclosing some geometry. The empty sphere has a negative radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingSphere {
    /// Centre.
    pub center: Vec3,
    /// Radius; negative for the empty sphere.
    pub radius: f32,
}

impl BoundingSphere {
    /// The sphere that contains nothing.
    pub const EMPTY: BoundingSphere = BoundingSphere {
        center: Vec3::ZERO,
        radius: -1.0,
    };

    /// The sphere with this centre and radius.
    pub fn new(center: Vec3, radius: f32) -> Self {
        BoundingSphere { center, radius }
    }

    /// Whether the sphere contains no point.
    pub fn is_empty(&self) -> bool {
        // Written so that a NaN radius also counts as empty.
        self.radius.is_nan() || self.radius < 0.0
    }

    /// The circumsphere of a box (empty for an empty box).
    pub fn from_aabb(b: &Aabb) -> Self {
        if b.is_empty() {
            return Self::EMPTY;
        }
        let c = b.center().as_dvec3();
        let r = (b.max.as_dvec3() - c)
            .length()
            .max((c - b.min.as_dvec3()).length());
        Self::padded(c, r)
    }

    /// A sphere around `points` by Ritter's method (an approximately minimal
    /// sphere in two linear passes, typically within 5-20% of the optimal
    /// radius), followed by a pass that grows it to contain every point
    /// exactly. Non-finite points are ignored; no points give the empty sphere.
    pub fn from_points(points: &[Vec3]) -> Self {
        let pts: Vec<DVec3> = points
            .iter()
            .filter(|p| p.is_finite())
            .map(|p| p.as_dvec3())
            .collect();
        let Some(&first) = pts.first() else {
            return Self::EMPTY;
        };
        let farthest = |from: DVec3| {
            pts.iter()
                .copied()
                .max_by(|a, b| {
                    a.distance_squared(from)
                        .total_cmp(&b.distance_squared(from))
                })
                .unwrap_or(from)
        };
        // Two farthest-point hops approximate a diameter.
        let a = farthest(first);
        let b = farthest(a);
        let mut c = (a + b) * 0.5;
        let mut r = a.distance(b) * 0.5;
        for &p in &pts {
            let d = p.distance(c);
            if d > r {
                // Grow just enough to hold both the old sphere and `p`.
                let nr = (r + d) * 0.5;
                c += (p - c) * ((nr - r) / d);
                r = nr;
            }
        }
        // The incremental updates round; make containment exact.
        let r = pts.iter().fold(r, |m, p| m.max(p.distance(c)));
        Self::padded(c, r)
    }

    /// Rounds an `f64` sphere to `f32`, widening the radius to cover the
    /// rounding of the centre.
    fn padded(c: DVec3, r: f64) -> Self {
        let cf = c.as_vec3();
        let shift = (cf.as_dvec3() - c).length();
        let r = (r + shift) * (1.0 + RADIUS_PAD) + f64::from(f32::MIN_POSITIVE);
        BoundingSphere {
            center: cf,
            radius: r as f32 * (1.0 + f32::EPSILON),
        }
    }

    /// The smallest sphere containing both spheres.
    #[must_use]
    pub fn union(&self, other: &BoundingSphere) -> BoundingSphere {
        if self.is_empty() {
            return *other;
        }
        if other.is_empty() {
            return *self;
        }
        let (c0, r0) = (self.center.as_dvec3(), f64::from(self.radius));
        let (c1, r1) = (other.center.as_dvec3(), f64::from(other.radius));
        let d = c0.distance(c1);
        if d + r1 <= r0 {
            return *self;
        }
        if d + r0 <= r1 {
            return *other;
        }
        let r = (d + r0 + r1) * 0.5;
        // d > 0 here, otherwise one sphere would contain the other.
        let c = c0 + (c1 - c0) * ((r - r0) / d);
        Self::padded(c, r)
    }

    /// Whether `p` lies inside or on the sphere.
    pub fn contains(&self, p: Vec3) -> bool {
        !self.is_empty()
            && p.as_dvec3().distance_squared(self.center.as_dvec3())
                <= f64::from(self.radius).powi(2)
    }

    /// The parameter interval where `ray` is inside the sphere, clipped to
    /// `[ray.tmin, ray.tmax]`, or `None` when it misses.
    ///
    /// Computed in `f64` with the numerically stable form of the quadratic
    /// (the discriminant from the ray's closest approach, not `b^2 - 4ac`), and
    /// widened by a relative `1e-6` before rounding to `f32`, so a sphere the
    /// exact ray touches is never rejected.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        if self.is_empty() {
            return None;
        }
        let d = ray.dir.as_dvec3();
        let a = d.length_squared();
        if a == 0.0 || !a.is_finite() {
            return None;
        }
        let oc = ray.origin.as_dvec3() - self.center.as_dvec3();
        let tc = -oc.dot(d) / a;
        // Closest approach of the line to the centre.
        let l = oc + d * tc;
        let r = f64::from(self.radius) * (1.0 + RADIUS_PAD);
        let disc = r * r - l.length_squared();
        if disc < 0.0 {
            return None;
        }
        let half = (disc / a).sqrt();
        let slack = (tc.abs() + half) * 1e-6;
        let t0 = ((tc - half - slack) as f32).max(ray.tmin);
        let t1 = ((tc + half + slack) as f32).min(ray.tmax);
        (t0 <= t1).then_some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ritter_contains_points() {
        let pts: Vec<Vec3> = (0..200)
            .map(|i| {
                let f = i as f32;
                Vec3::new(
                    (f * 0.37).sin() * 3.0,
                    (f * 0.91).cos(),
                    (f * 1.3).sin() * 0.5,
                ) + 7.0
            })
            .collect();
        let s = BoundingSphere::from_points(&pts);
        assert!(pts.iter().all(|p| s.contains(*p)));
        // Ritter is within ~20% of optimal; the optimum is >= half the span.
        assert!(s.radius < 3.0 * 1.3);
        assert!(BoundingSphere::from_points(&[]).is_empty());
    }

    #[test]
    fn box_circumsphere_and_union() {
        let b = Aabb::new(Vec3::ZERO, Vec3::splat(2.0));
        let s = BoundingSphere::from_aabb(&b);
        assert!(b.corners().iter().all(|p| s.contains(*p)));
        let t = BoundingSphere::new(Vec3::new(10.0, 0.0, 0.0), 1.0);
        let u = s.union(&t);
        assert!(u.contains(Vec3::new(11.0, 0.0, 0.0)));
        assert!(b.corners().iter().all(|p| u.contains(*p)));
        assert_eq!(s.union(&BoundingSphere::EMPTY), s);
    }

    #[test]
    fn ray_test() {
        let s = BoundingSphere::new(Vec3::ZERO, 1.0);
        let r = Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY);
        let (t0, t1) = s.intersect(&r).unwrap();
        assert!((t0 - 4.0).abs() < 1e-4 && (t1 - 6.0).abs() < 1e-4);
        // Tangent ray is kept, a slightly offset one is not.
        let r = Ray::new(Vec3::new(-5.0, 1.0, 0.0), Vec3::X, 0.0, f32::INFINITY);
        assert!(s.intersect(&r).is_some());
        let r = Ray::new(Vec3::new(-5.0, 1.01, 0.0), Vec3::X, 0.0, f32::INFINITY);
        assert!(s.intersect(&r).is_none());
        // Inside: starts at tmin.
        let r = Ray::new(Vec3::ZERO, Vec3::Y, 0.0, 0.5);
        assert_eq!(s.intersect(&r), Some((0.0, 0.5)));
        let r = Ray::new(Vec3::ZERO, Vec3::ZERO, 0.0, 0.5);
        assert!(s.intersect(&r).is_none());
    }
}
