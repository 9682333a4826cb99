//! The capped cylinder (2015 variant): axis parallel to z through `center`.

use std::sync::Arc;

use glam::DVec3;

use crate::ray::Ray;
use crate::shader::Shader;

/// A closed cylinder of the given radius, `height` long along z, centred at
/// `center` (in its own space).
#[derive(Clone, Debug)]
pub struct Cylinder {
    /// Centre of the axis.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Length along z.
    pub height: f64,
    /// Shader.
    pub shader: Arc<Shader>,
}

/// The nearest hit strictly inside the ray's `(tmin, tmax)` on the side or a cap, with
/// its object-space normal (not yet flipped toward the ray). A clean capped
/// cylinder test, as the spec (§5.6) allows instead of the framework's
/// approximation at silhouettes.
pub fn intersect(center: DVec3, radius: f64, height: f64, ray: &Ray) -> Option<(f64, DVec3)> {
    let (o, d, tmin, tmax) = (ray.origin, ray.direction, ray.tmin, ray.tmax);
    let (z0, z1) = (center.z - height / 2.0, center.z + height / 2.0);
    let mut best: Option<(f64, DVec3)> = None;
    let mut consider = |t: f64, n: DVec3| {
        if t > tmin && t < tmax && best.is_none_or(|(b, _)| t < b) {
            best = Some((t, n));
        }
    };
    // Side: (ox + t dx - cx)^2 + (oy + t dy - cy)^2 = r^2 with z inside the caps.
    let (px, py) = (o.x - center.x, o.y - center.y);
    let a = d.x * d.x + d.y * d.y;
    if a > 0.0 {
        let b = px * d.x + py * d.y;
        let c = px * px + py * py - radius * radius;
        let disc = b * b - a * c;
        if disc >= 0.0 {
            let s = disc.sqrt();
            for t in [(-b - s) / a, (-b + s) / a] {
                let z = o.z + t * d.z;
                if z >= z0 && z <= z1 {
                    consider(t, DVec3::new(px + t * d.x, py + t * d.y, 0.0));
                }
            }
        }
    }
    // Caps: the planes z = z0 and z = z1 inside the radius.
    if d.z != 0.0 {
        for (z, nz) in [(z0, -1.0), (z1, 1.0)] {
            let t = (z - o.z) / d.z;
            let (x, y) = (px + t * d.x, py + t * d.y);
            if x * x + y * y <= radius * radius {
                consider(t, DVec3::new(0.0, 0.0, nz));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_and_cap() {
        let c = DVec3::ZERO;
        let (t, n) = intersect(
            c,
            1.0,
            2.0,
            &Ray::new(DVec3::new(5.0, 0.0, 0.0), DVec3::NEG_X, 0.0, 1e30),
        )
        .unwrap();
        assert_eq!(t, 4.0);
        assert_eq!(n.normalize(), DVec3::X);
        let (t, n) = intersect(
            c,
            1.0,
            2.0,
            &Ray::new(DVec3::new(0.5, 0.0, 5.0), DVec3::NEG_Z, 0.0, 1e30),
        )
        .unwrap();
        assert_eq!((t, n), (4.0, DVec3::Z));
        // Passing above the top cap misses.
        assert!(intersect(
            c,
            1.0,
            2.0,
            &Ray::new(DVec3::new(5.0, 0.0, 1.5), DVec3::NEG_X, 0.0, 1e30)
        )
        .is_none());
    }
}
