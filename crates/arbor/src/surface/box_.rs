//! The axis-aligned box (`<surface type="Box">`).

use std::sync::Arc;

use glam::DVec3;

use crate::ray::Ray;
use crate::shader::Shader;

/// A box given by two corners (in its own space).
#[derive(Clone, Debug)]
pub struct BoxSurface {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
    /// Shader.
    pub shader: Arc<Shader>,
}

/// The 2010 framework's slab test (spec §5.2): the hit is at the entering
/// distance only (a ray starting inside does not hit), ties between axes go
/// to the first in x, y, z order. Returns `t` and the outward normal of the
/// entering face.
pub fn intersect(min: DVec3, max: DVec3, ray: &Ray) -> Option<(f64, DVec3)> {
    let (o, d, tmin, tmax) = (ray.origin, ray.direction, ray.tmin, ray.tmax);
    let mut t_near = f64::NEG_INFINITY;
    let mut t_far = f64::INFINITY;
    let mut normal = DVec3::ZERO;
    for k in 0..3 {
        let lo = (min[k] - o[k]) / d[k];
        let hi = (max[k] - o[k]) / d[k];
        let (enter, exit, sign) = if lo < hi {
            (lo, hi, -1.0)
        } else {
            (hi, lo, 1.0)
        };
        if enter > t_near {
            t_near = enter;
            normal = DVec3::ZERO;
            normal[k] = sign;
        }
        if exit < t_far {
            t_far = exit;
        }
    }
    if t_near > t_far || t_far < 0.0 || !(t_near > tmin && t_near < tmax) {
        return None;
    }
    Some((t_near, normal))
}

/// The 2015 framework's box: 12 triangles over corners rounded to `f32`,
/// as (corners, triangles) (spec §5.2).
pub fn triangles_2015(min: DVec3, max: DVec3) -> ([DVec3; 8], [[u32; 3]; 12]) {
    let f = |x: f64| x as f32 as f64;
    let (x0, y0, z0) = (f(min.x), f(min.y), f(min.z));
    let (x1, y1, z1) = (f(max.x), f(max.y), f(max.z));
    let v = [
        DVec3::new(x0, y0, z0),
        DVec3::new(x0, y1, z0),
        DVec3::new(x1, y1, z0),
        DVec3::new(x1, y0, z0),
        DVec3::new(x0, y0, z1),
        DVec3::new(x0, y1, z1),
        DVec3::new(x1, y1, z1),
        DVec3::new(x1, y0, z1),
    ];
    let t = [
        [0, 1, 2],
        [0, 2, 3],
        [0, 5, 1],
        [0, 4, 5],
        [0, 7, 4],
        [0, 3, 7],
        [4, 6, 5],
        [4, 7, 6],
        [2, 5, 6],
        [2, 1, 5],
        [2, 6, 7],
        [2, 7, 3],
    ];
    (v, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entering_face_and_inside_start() {
        let (min, max) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        let (t, n) = intersect(
            min,
            max,
            &Ray::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z, 0.0, 1e30),
        )
        .unwrap();
        assert_eq!((t, n), (4.0, DVec3::Z));
        let (t, n) = intersect(
            min,
            max,
            &Ray::new(DVec3::new(-5.0, 0.2, 0.0), DVec3::X, 0.0, 1e30),
        )
        .unwrap();
        assert_eq!((t, n), (4.0, DVec3::NEG_X));
        assert!(intersect(min, max, &Ray::new(DVec3::ZERO, DVec3::X, 1e-6, 1e30)).is_none());
    }

    #[test]
    fn box_triangles_face_outward() {
        let (v, tris) = triangles_2015(DVec3::splat(-1.0), DVec3::splat(1.0));
        for t in tris {
            let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
            let n = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            assert!(n.dot(centroid) > 0.0, "{t:?}");
        }
    }
}
