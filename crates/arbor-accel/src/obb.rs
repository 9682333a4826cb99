//! Oriented bounding boxes: a box along the principal axes of the geometry,
//! far tighter than an axis-aligned box around long, thin, tilted shapes.

use glam::{DMat3, DVec3, Vec3};

use crate::aabb::Aabb;
use crate::ray::Ray;

/// An oriented box: the points `p` with `|axes[i] · (p - center)| <= half[i]`
/// for each `i`. The axes are orthonormal up to rounding; the definition as an
/// intersection of three slabs keeps the tests exact for the stored axes
/// whatever that rounding is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obb {
    /// Centre.
    pub center: Vec3,
    /// Unit directions of the box's edges.
    pub axes: [Vec3; 3],
    /// Half extent along each axis.
    pub half: Vec3,
}

impl Obb {
    /// The box as an oriented box (identity axes).
    pub fn from_aabb(b: &Aabb) -> Self {
        Obb {
            center: b.center(),
            axes: [Vec3::X, Vec3::Y, Vec3::Z],
            half: b.extent() * 0.5 * (1.0 + 4.0 * f32::EPSILON),
        }
    }

    /// Fits a box to `points`: the axes are the eigenvectors of the points'
    /// covariance matrix (principal component analysis, via Jacobi rotations),
    /// the extents the range of the points' projections, padded so that every
    /// point is inside despite rounding. Non-finite points are ignored; `None`
    /// when no point remains.
    pub fn from_points(points: &[Vec3]) -> Option<Self> {
        let pts: Vec<DVec3> = points
            .iter()
            .filter(|p| p.is_finite())
            .map(|p| p.as_dvec3())
            .collect();
        if pts.is_empty() {
            return None;
        }
        let n = pts.len() as f64;
        let mean = pts.iter().copied().sum::<DVec3>() / n;
        let mut cov = [[0.0f64; 3]; 3];
        for p in &pts {
            let d = *p - mean;
            for (i, row) in cov.iter_mut().enumerate() {
                for (j, c) in row.iter_mut().enumerate() {
                    *c += d[i] * d[j];
                }
            }
        }
        let axes = jacobi_eigenvectors(cov).map(|a| a.as_vec3().normalize_or_zero());
        // Rounding the axes to f32 can break orthogonality slightly; project
        // with exactly the stored f32 axes so the slabs hold every point.
        let axes = if axes.iter().all(|a| a.length_squared() > 0.5) {
            axes
        } else {
            [Vec3::X, Vec3::Y, Vec3::Z]
        };
        let ad = axes.map(|a| a.as_dvec3());
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &pts {
            let q = DVec3::new(ad[0].dot(*p), ad[1].dot(*p), ad[2].dot(*p));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let mid = (lo + hi) * 0.5;
        let center = DMat3::from_cols(ad[0], ad[1], ad[2]).transpose().inverse() * mid;
        let center = center.as_vec3();
        // Half extents about the stored (rounded) centre.
        let cq = DVec3::new(
            ad[0].dot(center.as_dvec3()),
            ad[1].dot(center.as_dvec3()),
            ad[2].dot(center.as_dvec3()),
        );
        let half = (hi - cq).max(cq - lo);
        let scale = hi.abs().max(lo.abs()).max_element();
        let half = (half + DVec3::splat(scale * 1e-6 + f64::from(f32::MIN_POSITIVE))).as_vec3();
        Some(Obb { center, axes, half })
    }

    /// Whether `p` lies inside or on the box.
    pub fn contains(&self, p: Vec3) -> bool {
        let d = p.as_dvec3() - self.center.as_dvec3();
        (0..3).all(|i| self.axes[i].as_dvec3().dot(d).abs() <= f64::from(self.half[i]))
    }

    /// A world-space axis-aligned box enclosing this box.
    pub fn aabb(&self) -> Aabb {
        let e = self.axes[0].abs() * self.half.x
            + self.axes[1].abs() * self.half.y
            + self.axes[2].abs() * self.half.z;
        let e = e * (1.0 + 4.0 * f32::EPSILON);
        Aabb::new(self.center - e, self.center + e)
    }

    /// The parameter interval where `ray` is inside the box, clipped to
    /// `[ray.tmin, ray.tmax]`, or `None` when it misses.
    ///
    /// The ray is taken into the box's frame (origin and direction projected
    /// on the axes) and slab-tested there, all in `f64`; the interval is then
    /// widened by a relative `1e-6` before rounding to `f32`, so a box that
    /// the exact ray touches is never rejected. A ray parallel to a slab
    /// counts as inside it when its origin is.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        let o = ray.origin.as_dvec3() - self.center.as_dvec3();
        let d = ray.dir.as_dvec3();
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for i in 0..3 {
            let a = self.axes[i].as_dvec3();
            let (oi, di, h) = (a.dot(o), a.dot(d), f64::from(self.half[i]));
            if di == 0.0 {
                if oi.abs() > h {
                    return None;
                }
                continue;
            }
            let (n, f) = ((-h - oi) / di, (h - oi) / di);
            t0 = t0.max(n.min(f));
            t1 = t1.min(n.max(f));
        }
        let slack = (t0.abs().min(1e300) + t1.abs().min(1e300)) * 1e-6;
        let t0 = ((t0 - slack) as f32).max(ray.tmin);
        let t1 = ((t1 + slack) as f32).min(ray.tmax);
        (t0 <= t1).then_some((t0, t1))
    }
}

/// Eigenvectors of a symmetric 3x3 matrix by cyclic Jacobi rotations; the
/// columns of the accumulated rotation. Converges quadratically; 32 sweeps
/// is far more than a 3x3 ever needs.
fn jacobi_eigenvectors(mut a: [[f64; 3]; 3]) -> [DVec3; 3] {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        if off < 1e-30 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A <- J^T A J, V <- V J for the rotation J in the (p, q) plane.
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    [0, 1, 2].map(|j| DVec3::new(v[0][j], v[1][j], v[2][j]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted_rod() -> Vec<Vec3> {
        let dir = Vec3::new(1.0, 1.0, 0.3).normalize();
        (0..100)
            .map(|i| {
                let f = i as f32;
                dir * (f * 0.1) + Vec3::new((f * 1.7).sin(), (f * 2.3).cos(), 0.0) * 0.05
            })
            .collect()
    }

    #[test]
    fn pca_fit_contains_points_and_is_tight() {
        let pts = tilted_rod();
        let b = Obb::from_points(&pts).unwrap();
        assert!(pts.iter().all(|p| b.contains(*p)));
        let vol = 8.0 * b.half.x * b.half.y * b.half.z;
        let a = Aabb::from_points(pts.iter().copied()).extent();
        assert!(vol < 0.1 * a.x * a.y * a.z, "obb volume {vol}");
        assert!(b
            .aabb()
            .contains_box(&Aabb::from_points(pts.iter().copied())));
        assert!(Obb::from_points(&[]).is_none());
        // A single point and a flat set still work.
        assert!(Obb::from_points(&[Vec3::ONE]).unwrap().contains(Vec3::ONE));
    }

    #[test]
    fn ray_test() {
        let pts = tilted_rod();
        let b = Obb::from_points(&pts).unwrap();
        for p in &pts {
            let o = Vec3::new(-3.0, 5.0, 2.0);
            let r = Ray::new(o, *p - o, 0.0, f32::INFINITY);
            let (t0, t1) = b.intersect(&r).unwrap();
            assert!(t0 <= 1.0 && t1 >= 1.0);
        }
        let r = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::X, 0.0, f32::INFINITY);
        assert!(b.intersect(&r).is_none());
        let unit = Obb::from_aabb(&Aabb::new(Vec3::ZERO, Vec3::ONE));
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, f32::INFINITY);
        let (t0, t1) = unit.intersect(&r).unwrap();
        assert!((t0 - 1.0).abs() < 1e-5 && (t1 - 2.0).abs() < 1e-5);
        let r = Ray::new(Vec3::new(-1.0, 1.5, 0.5), Vec3::X, 0.0, f32::INFINITY);
        assert!(unit.intersect(&r).is_none());
    }
}
