//! The sphere.

use std::sync::Arc;

use glam::DVec3;

use crate::ray::Ray;
use crate::shader::Shader;
use crate::variant::Variant;

/// A sphere given by centre and radius (in its own space).
#[derive(Clone, Debug)]
pub struct Sphere {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Shader.
    pub shader: Arc<Shader>,
}

/// The nearer root of the ray/sphere quadratic lying strictly inside the
/// ray's `(tmin, tmax)`, else the farther one (a ray starting on or inside the
/// sphere must find its far side: spec §9.6), in the algebra of the
/// `variant`'s framework (the two round differently).
pub fn intersect(center: DVec3, radius: f64, ray: &Ray, variant: Variant) -> Option<f64> {
    let (o, d) = (ray.origin, ray.direction);
    let (t1, t2) = if variant == Variant::Cornell2015 {
        let q = o - center;
        let dd = d.dot(d);
        let qd = q.dot(d);
        let qq = q.dot(q);
        let disc = qd * qd - dd * (qq - radius * radius);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        ((-qd - s) / dd, (-qd + s) / dd)
    } else {
        let oc = o - center;
        let a = d.dot(d);
        let b = 2.0 * d.dot(oc);
        let c = oc.dot(oc) - radius * radius;
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        ((-b - s) / (2.0 * a), (-b + s) / (2.0 * a))
    };
    [t1, t2].into_iter().find(|&t| t > ray.tmin && t < ray.tmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_then_far_root() {
        let o = DVec3::new(0.0, 0.0, 5.0);
        let d = DVec3::NEG_Z;
        for year in [Variant::Cornell2010, Variant::Cornell2015] {
            assert_eq!(
                intersect(DVec3::ZERO, 1.0, &Ray::new(o, d, 0.0, 1e30), year),
                Some(4.0)
            );
            // From inside, the far side.
            let t = intersect(
                DVec3::ZERO,
                1.0,
                &Ray::new(DVec3::ZERO, d, 1e-6, 1e30),
                year,
            );
            assert_eq!(t, Some(1.0));
            assert_eq!(
                intersect(DVec3::ZERO, 1.0, &Ray::new(o, d, 0.0, 3.0), year),
                None
            );
            assert_eq!(
                intersect(DVec3::ZERO, 1.0, &Ray::new(o, DVec3::X, 0.0, 1e30), year),
                None
            );
        }
    }
}
