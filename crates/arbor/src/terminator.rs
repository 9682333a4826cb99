//! Softening the shadow terminator of smooth-shaded meshes.
//!
//! A coarse mesh with interpolated normals is shaded as if it were curved,
//! but its shadow rays leave the flat triangle: near the terminator the
//! shading normal still sees a light that the triangle's own neighbours
//! hide, and the shading breaks into a staircase along the triangle edges.
//! Hanika's remedy ("Hacking the Shadow Terminator", Ray Tracing Gems II,
//! 2021) starts shadow rays from a point lifted toward the curved surface
//! the normals describe: the hit point is projected onto the tangent plane
//! of each corner (its position and normal) that lies above it, and the
//! projections are blended with the barycentric weights. Points already
//! above every corner's plane are not moved, so flat regions and convex
//! silhouettes keep their exact shadows.

use glam::DVec3;

/// The vector from the hit point `p` (on the triangle `corners`, with
/// barycentric weights `weights`) to where its shadow rays should start,
/// given the corners' shading normals `normals` (turned to the side being
/// shaded; any length but zero).
pub fn shadow_offset(
    p: DVec3,
    corners: [DVec3; 3],
    normals: [DVec3; 3],
    weights: [f64; 3],
) -> DVec3 {
    let mut offset = DVec3::ZERO;
    for i in 0..3 {
        let n = normals[i].normalize_or_zero();
        // Below the corner's tangent plane by `-depth`: lift by that much.
        let depth = (p - corners[i]).dot(n).min(0.0);
        offset -= weights[i] * depth * n;
    }
    if offset.is_finite() {
        offset
    } else {
        DVec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CORNERS: [DVec3; 3] = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
    ];

    #[test]
    fn flat_normals_leave_the_point_alone() {
        let n = [DVec3::Z; 3];
        let p = DVec3::new(0.25, 0.25, 0.0);
        assert_eq!(shadow_offset(p, CORNERS, n, [0.5, 0.25, 0.25]), DVec3::ZERO);
    }

    #[test]
    fn normals_of_a_bulge_lift_the_point_toward_them() {
        // Normals leaning outward, as on a sphere's coarse facet: the
        // middle of the facet lies below every corner's tangent plane.
        let c = (CORNERS[0] + CORNERS[1] + CORNERS[2]) / 3.0;
        let normals = CORNERS.map(|k| (k - c + DVec3::Z * 2.0).normalize());
        let w = [1.0 / 3.0; 3];
        let off = shadow_offset(c, CORNERS, normals, w);
        assert!(off.z > 0.0, "{off}");
        // At a corner the point is on that corner's plane and the others
        // get no weight: no offset.
        let at_corner = shadow_offset(CORNERS[1], CORNERS, normals, [0.0, 1.0, 0.0]);
        assert!(at_corner.length() < 1e-15, "{at_corner}");
    }

    #[test]
    fn normals_of_a_hollow_do_not_move_the_point() {
        // Normals leaning inward (a concave patch): the point is above
        // every tangent plane.
        let c = (CORNERS[0] + CORNERS[1] + CORNERS[2]) / 3.0;
        let normals = CORNERS.map(|k| (c - k + DVec3::Z * 2.0).normalize());
        assert_eq!(
            shadow_offset(c, CORNERS, normals, [1.0 / 3.0; 3]),
            DVec3::ZERO
        );
    }
}
