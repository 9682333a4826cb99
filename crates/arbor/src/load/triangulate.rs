//! Polygon triangulation by ear clipping.
//!
//! Model files store faces with any number of corners. A fan from the first
//! corner (what most loaders do) is only right for convex polygons: for a
//! concave one it puts triangles outside the polygon. Ear clipping on the
//! polygon projected to its dominant plane is right for any simple polygon.

use glam::{DVec2, DVec3, Vec3};

/// Triangulates the polygon whose corners are `corners` (indices into
/// `positions`, in order), appending triangles that keep the polygon's
/// winding to `out`. Degenerate polygons (collinear corners, repeated
/// points) still yield triangles covering the corners in order, so that no
/// face silently disappears; a polygon with fewer than 3 corners yields none.
pub fn triangulate(positions: &[Vec3], corners: &[u32], out: &mut Vec<[u32; 3]>) {
    let n = corners.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([corners[0], corners[1], corners[2]]);
        return;
    }
    let p = |i: u32| -> DVec3 {
        positions
            .get(i as usize)
            .map_or(DVec3::ZERO, |v| v.as_dvec3())
    };
    // Newell's normal: robust for non-planar and concave polygons.
    let mut normal = DVec3::ZERO;
    for k in 0..n {
        let (a, b) = (p(corners[k]), p(corners[(k + 1) % n]));
        normal += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    if !normal.is_finite() || normal.length_squared() <= 0.0 {
        fan(corners, out);
        return;
    }
    // Project onto the plane of the normal's largest component, keeping the
    // orientation so that the polygon is counter-clockwise in 2D.
    let axis = normal.abs().max_position();
    let flip = normal[axis] < 0.0;
    let project = |v: DVec3| -> DVec2 {
        let q = match axis {
            0 => DVec2::new(v.y, v.z),
            1 => DVec2::new(v.z, v.x),
            _ => DVec2::new(v.x, v.y),
        };
        if flip {
            DVec2::new(q.y, q.x)
        } else {
            q
        }
    };
    let pts: Vec<DVec2> = corners.iter().map(|&c| project(p(c))).collect();
    let mut ring: Vec<usize> = (0..n).collect();
    // Each pass clips at least one ear from a simple polygon; the guard stops
    // a self-intersecting one from looping forever.
    let mut guard = 0;
    while ring.len() > 3 && guard < 2 * n * n {
        guard += 1;
        let m = ring.len();
        let mut clipped = false;
        for k in 0..m {
            let (ia, ib, ic) = (ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]);
            if is_ear(&pts, &ring, ia, ib, ic) {
                out.push([corners[ia], corners[ib], corners[ic]]);
                ring.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            // Not simple (or numerically degenerate): finish with a fan of
            // what remains rather than dropping the face.
            let rest: Vec<u32> = ring.iter().map(|&i| corners[i]).collect();
            fan(&rest, out);
            return;
        }
    }
    if ring.len() == 3 {
        out.push([corners[ring[0]], corners[ring[1]], corners[ring[2]]]);
    }
}

/// The fan `(0, k, k+1)`.
fn fan(corners: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..corners.len().saturating_sub(1) {
        out.push([corners[0], corners[k], corners[k + 1]]);
    }
}

fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Whether the corner `b` (between `a` and `c`) is a convex corner whose
/// triangle holds no other remaining corner.
fn is_ear(pts: &[DVec2], ring: &[usize], a: usize, b: usize, c: usize) -> bool {
    let (pa, pb, pc) = (pts[a], pts[b], pts[c]);
    if cross(pa, pb, pc) <= 0.0 {
        return false;
    }
    ring.iter().all(|&j| {
        if j == a || j == b || j == c {
            return true;
        }
        let q = pts[j];
        // A corner at the same place as one of the ear's is the other end of
        // a bridge (a polygon with a hole is written as one outline with a
        // seam walked twice): it does not block the ear. Any other corner on
        // the ear's boundary does, or slivers would cross the seam.
        if q == pa || q == pb || q == pc {
            return true;
        }
        !(cross(pa, pb, q) >= 0.0 && cross(pb, pc, q) >= 0.0 && cross(pc, pa, q) >= 0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area2(pos: &[Vec3], t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| pos[i as usize].as_dvec3());
        (b - a).cross(c - a).z
    }

    #[test]
    fn concave_polygon_stays_inside() {
        // An arrow head: concave at corner 2, where a fan from corner 0
        // would cover area outside the polygon.
        let pos = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let mut out = Vec::new();
        triangulate(&pos, &[0, 1, 2, 3, 4], &mut out);
        assert_eq!(out.len(), 3);
        // Same winding as the polygon, and the areas add up to the polygon's.
        let total: f64 = out.iter().map(|&t| area2(&pos, t)).sum();
        assert!(out.iter().all(|&t| area2(&pos, t) > 0.0), "{out:?}");
        let shoelace: f64 = (0..5)
            .map(|k| {
                let (a, b) = (pos[k], pos[(k + 1) % 5]);
                (a.x * b.y - b.x * a.y) as f64
            })
            .sum();
        assert!((total - shoelace).abs() < 1e-9, "{total} vs {shoelace}");
    }

    #[test]
    fn clockwise_and_tilted_polygons_keep_winding() {
        // A clockwise L shape in the yz plane.
        let pos: Vec<Vec3> = [(0., 0.), (0., 2.), (1., 2.), (1., 1.), (2., 1.), (2., 0.)]
            .iter()
            .map(|&(y, z)| Vec3::new(0.0, y, z))
            .collect();
        let corners = [0, 1, 2, 3, 4, 5];
        let mut out = Vec::new();
        triangulate(&pos, &corners, &mut out);
        assert_eq!(out.len(), 4);
        for t in out {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            // The polygon's normal is -x (clockwise seen from +x).
            assert!((b - a).cross(c - a).x < 0.0);
        }
    }

    #[test]
    fn polygon_with_a_bridged_hole_keeps_the_hole() {
        // A 4x4 square with a 2x2 hole, as one outline: the outer corners
        // counter-clockwise, a seam to the hole, the hole clockwise, and the
        // seam back (vertices 0 and 4 are walked twice).
        let pos: Vec<Vec3> = [
            (0., 0.),
            (4., 0.),
            (4., 4.),
            (0., 4.),
            (1., 1.),
            (1., 3.),
            (3., 3.),
            (3., 1.),
        ]
        .iter()
        .map(|&(x, y)| Vec3::new(x, y, 0.0))
        .collect();
        let corners = [0, 1, 2, 3, 0, 4, 5, 6, 7, 4];
        let mut out = Vec::new();
        triangulate(&pos, &corners, &mut out);
        assert_eq!(out.len(), 8);
        let total: f64 = out.iter().map(|&t| area2(&pos, t)).sum();
        assert!(out.iter().all(|&t| area2(&pos, t) >= 0.0), "{out:?}");
        assert!((total / 2.0 - 12.0).abs() < 1e-9, "area {}", total / 2.0);
    }

    #[test]
    fn degenerate_polygon_is_not_dropped() {
        let pos = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0];
        let mut out = Vec::new();
        triangulate(&pos, &[0, 1, 2, 3], &mut out);
        assert_eq!(out.len(), 2);
        out.clear();
        triangulate(&pos, &[0, 1], &mut out);
        assert!(out.is_empty());
    }
}
