//! The triangle test of the course: Cramer's rule in `f64` (spec §5.3).

use glam::DVec3;

use crate::ray::Ray;

/// Intersects `ray` with triangle `[p0, p1, p2]`; returns `(t, β, γ)`
/// (weights `(1-β-γ, β, γ)`) when `t` lies in the ray's interval (`closed`
/// selects `[tmin, tmax]` instead of `(tmin, tmax)`). Two-sided.
#[inline]
pub fn intersect([p0, p1, p2]: [DVec3; 3], ray: &Ray, closed: bool) -> Option<(f64, f64, f64)> {
    let (o, w, tmin, tmax) = (ray.origin, ray.direction, ray.tmin, ray.tmax);
    let (a, b, c) = (p0.x - p1.x, p0.y - p1.y, p0.z - p1.z);
    let (d, e, f) = (p0.x - p2.x, p0.y - p2.y, p0.z - p2.z);
    let (g, h, i) = (w.x, w.y, w.z);
    let (j, k, l) = (p0.x - o.x, p0.y - o.y, p0.z - o.z);
    let ei_hf = e * i - h * f;
    let gf_di = g * f - d * i;
    let dh_eg = d * h - e * g;
    let det = a * ei_hf + b * gf_di + c * dh_eg;
    let ak_jb = a * k - j * b;
    let jc_al = j * c - a * l;
    let bl_kc = b * l - k * c;
    let t = -(f * ak_jb + e * jc_al + d * bl_kc) / det;
    let inside = if closed {
        t >= tmin && t <= tmax
    } else {
        t > tmin && t < tmax
    };
    if !inside {
        return None;
    }
    let beta = (j * ei_hf + k * gf_di + l * dh_eg) / det;
    if !(0.0..=1.0).contains(&beta) {
        return None;
    }
    let gamma = (i * ak_jb + h * jc_al + g * bl_kc) / det;
    if !(gamma >= 0.0 && beta + gamma <= 1.0) {
        return None;
    }
    Some((t, beta, gamma))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hit_and_barycentrics() {
        let (p0, p1, p2) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let o = DVec3::new(0.25, 0.5, 1.0);
        let (t, b, g) =
            intersect([p0, p1, p2], &Ray::new(o, DVec3::NEG_Z, 0.0, 10.0), false).unwrap();
        assert_eq!((t, b, g), (1.0, 0.25, 0.5));
        // From behind too (two-sided).
        let o = DVec3::new(0.25, 0.5, -1.0);
        assert!(intersect([p0, p1, p2], &Ray::new(o, DVec3::Z, 0.0, 10.0), false).is_some());
        // Outside.
        let o = DVec3::new(0.75, 0.5, 1.0);
        assert!(intersect([p0, p1, p2], &Ray::new(o, DVec3::NEG_Z, 0.0, 10.0), false).is_none());
        // Degenerate triangle: det = 0 gives NaN, never a hit.
        assert!(intersect(
            [p0, p1, p1 * 2.0],
            &Ray::new(o, DVec3::NEG_Z, 0.0, 10.0),
            false
        )
        .is_none());
    }

    #[test]
    fn interval_ends() {
        let (p0, p1, p2) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let o = DVec3::new(0.25, 0.25, 1.0);
        assert!(intersect([p0, p1, p2], &Ray::new(o, DVec3::NEG_Z, 0.0, 1.0), false).is_none());
        assert!(intersect([p0, p1, p2], &Ray::new(o, DVec3::NEG_Z, 0.0, 1.0), true).is_some());
    }
}
