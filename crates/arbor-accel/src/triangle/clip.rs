//! Exact boxes of the parts of a triangle inside a box (clipping) or on
//! either side of a plane, for the spatial splits of the BVH builders and
//! the k-d tree.

use glam::{DVec3, Vec3};

use crate::aabb::Aabb;
use crate::rounding::{f32_at_or_above, f32_at_or_below};

/// The boxes of the parts of a triangle inside `b` below and above the
/// plane `axis = plane`, for spatial splits: each side's corners and the
/// points where edges cross the plane, intersected with the side's half of
/// `b`. Looser than the full clip (only one plane is cut), a small part of
/// its cost. Triangles with non-finite vertices get the halves of their
/// box's overlap with `b`.
pub fn split_triangle_bounds(
    tri: [Vec3; 3],
    b: &Aabb,
    axis: usize,
    plane: f32,
) -> [Option<Aabb>; 2] {
    let (mut below_half, mut above_half) = (*b, *b);
    below_half.max[axis] = plane;
    above_half.min[axis] = plane;
    let keep = |side: Aabb, half: &Aabb| {
        let s = side.intersection(half);
        (!s.is_empty()).then_some(s)
    };
    // The conservative answer: the triangle's whole box on both sides.
    let whole = || {
        let tb = Aabb::from_points(tri);
        [keep(tb, &below_half), keep(tb, &above_half)]
    };
    if !tri.iter().all(|p| p.is_finite()) || !plane.is_finite() {
        return whole();
    }
    let (mut below, mut above) = (Aabb::EMPTY, Aabb::EMPTY);
    // A crossing is computed in `f32` with an error of a few units of
    // roundoff of the largest coordinate (`s` within 3u, the point within
    // 5u of `scale`); 2^-20 of `scale` (16u) encloses it with room to spare.
    let scale = tri
        .iter()
        .fold(plane.abs(), |m, p| m.max(p.abs().max_element()));
    let margin = Vec3::splat(scale * 2.0f32.powi(-20));
    for i in 0..3 {
        let (p, q) = (tri[i], tri[(i + 1) % 3]);
        if p[axis] <= plane {
            below = below.grow(p);
        }
        if p[axis] >= plane {
            above = above.grow(p);
        }
        if (p[axis] < plane && q[axis] > plane) || (p[axis] > plane && q[axis] < plane) {
            let s = (plane - p[axis]) / (q[axis] - p[axis]);
            let x = p + (q - p) * s;
            if !x.is_finite() {
                // An edge longer than the largest float (`q - p`
                // overflowed): no bound on the crossing, so none is cut.
                return whole();
            }
            let (lo, hi) = (x - margin, x + margin);
            below = below.grow(lo).grow(hi);
            above = above.grow(lo).grow(hi);
        }
    }
    [keep(below, &below_half), keep(above, &above_half)]
}

/// The box around the part of a triangle inside `clip`, or `None` when the
/// triangle misses the box.
///
/// The triangle is clipped as a polygon against the six planes
/// (Sutherland–Hodgman) in `f64`, against a box widened by a tiny margin so
/// that rounding can only keep, never drop, a triangle that touches `clip`.
/// The result is padded by the same margin, rounded outward to `f32` and
/// intersected with `clip`, so it encloses the exact clipped polygon.
/// Triangles with non-finite vertices fall back to the conservative overlap
/// of their box with `clip`.
pub fn clip_triangle_bounds(tri: [Vec3; 3], clip: &Aabb) -> Option<Aabb> {
    let tb = Aabb::from_points(tri);
    let overlap = tb.intersection(clip);
    if overlap.is_empty() {
        return None;
    }
    if !tri.iter().all(|p| p.is_finite()) || !clip.min.is_finite() || !clip.max.is_finite() {
        return Some(overlap);
    }
    if clip.contains_box(&tb) {
        return Some(tb);
    }
    // The clipping error of f64 is ~2^-50 of the largest magnitude involved;
    // 2^-40 leaves a wide safety factor and is still far below f32 precision.
    let scale = tri
        .iter()
        .fold(clip.min.abs().max(clip.max.abs()), |m, p| m.max(p.abs()))
        .max_element() as f64;
    let margin = scale * f64::from(2.0f32.powi(-40));
    let lo = clip.min.as_dvec3() - DVec3::splat(margin);
    let hi = clip.max.as_dvec3() + DVec3::splat(margin);

    let mut poly = [DVec3::ZERO; 9];
    let mut n = 3;
    for (i, p) in tri.iter().enumerate() {
        poly[i] = p.as_dvec3();
    }
    let mut tmp = [DVec3::ZERO; 9];
    for axis in 0..3 {
        for (plane, keep_above) in [(lo[axis], true), (hi[axis], false)] {
            // Signed distance, positive on the kept side.
            let dist = |p: DVec3| {
                if keep_above {
                    p[axis] - plane
                } else {
                    plane - p[axis]
                }
            };
            let mut m = 0;
            for i in 0..n {
                let p = poly[i];
                let q = poly[(i + 1) % n];
                let (dp, dq) = (dist(p), dist(q));
                if dp >= 0.0 {
                    tmp[m] = p;
                    m += 1;
                }
                if (dp >= 0.0) != (dq >= 0.0) {
                    let s = dp / (dp - dq);
                    let mut x = p + (q - p) * s;
                    // Snap onto the plane: the crossing lies on it exactly.
                    x[axis] = plane;
                    tmp[m] = x;
                    m += 1;
                }
            }
            // A convex polygon clipped by a half-space gains at most one vertex.
            n = m.min(9);
            poly[..n].copy_from_slice(&tmp[..n]);
            if n == 0 {
                return None;
            }
        }
    }
    let mut bmin = DVec3::splat(f64::INFINITY);
    let mut bmax = DVec3::splat(f64::NEG_INFINITY);
    for p in &poly[..n] {
        bmin = bmin.min(*p);
        bmax = bmax.max(*p);
    }
    let bmin = round_down(bmin - DVec3::splat(margin));
    let bmax = round_up(bmax + DVec3::splat(margin));
    // Both the triangle's own box and `clip` enclose the exact clipped polygon.
    let b = Aabb::new(bmin, bmax).intersection(&overlap);
    (!b.is_empty()).then_some(b)
}

/// The largest `f32` vector not above `v`, per component.
fn round_down(v: DVec3) -> Vec3 {
    Vec3::new(
        f32_at_or_below(v.x),
        f32_at_or_below(v.y),
        f32_at_or_below(v.z),
    )
}

/// The smallest `f32` vector not below `v`, per component.
fn round_up(v: DVec3) -> Vec3 {
    Vec3::new(
        f32_at_or_above(v.x),
        f32_at_or_above(v.y),
        f32_at_or_above(v.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const P0: Vec3 = Vec3::new(0.0, 0.0, 0.0);

    /// Both sides' boxes of a cut enclose every point of the triangle on
    /// their side (points on a lattice of barycentrics and the exact edge
    /// crossings, in `f64`), for ordinary, tiny, huge and overflowing
    /// triangles.
    #[test]
    fn split_bounds_enclose_both_parts() {
        let mut next = crate::util::unit_sequence(3);
        let mut cases: Vec<([Vec3; 3], usize, f32)> = Vec::new();
        for k in 0..300 {
            let size = [1.0f32, 1e-30, 1e30, 1e38][k % 4];
            let mut v = || Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0 * size;
            let tri = [v(), v(), v()];
            let axis = k % 3;
            let (lo, hi) = (
                tri.iter().map(|p| p[axis]).fold(f32::INFINITY, f32::min),
                tri.iter()
                    .map(|p| p[axis])
                    .fold(f32::NEG_INFINITY, f32::max),
            );
            cases.push((tri, axis, lo + (hi - lo) * next()));
        }
        // An edge whose difference overflows, cut just above a corner.
        let p = Vec3::new(-3e38, 0.0, 0.0);
        cases.push(([p, Vec3::new(3e38, 1e30, 0.0), Vec3::Z], 1, 1e-20));
        for (tri, axis, plane) in cases {
            let b = Aabb::from_points(tri);
            let [below, above] = split_triangle_bounds(tri, &b, axis, plane);
            let inside = |side: Option<Aabb>, x: DVec3| {
                side.is_some_and(|s| {
                    (0..3).all(|k| f64::from(s.min[k]) <= x[k] && x[k] <= f64::from(s.max[k]))
                })
            };
            let [a, c, d] = tri.map(|p| p.as_dvec3());
            let mut points = Vec::new();
            for i in 0..=8 {
                for j in 0..=8 - i {
                    let (u, v) = (i as f64 / 8.0, j as f64 / 8.0);
                    points.push(a + (c - a) * u + (d - a) * v);
                }
            }
            let plane64 = f64::from(plane);
            for (p, q) in [(a, c), (c, d), (d, a)] {
                if (p[axis] - plane64) * (q[axis] - plane64) < 0.0 {
                    let s = (plane64 - p[axis]) / (q[axis] - p[axis]);
                    let mut x = p + (q - p) * s;
                    x[axis] = plane64;
                    points.push(x);
                }
            }
            for x in points {
                if x[axis] <= plane64 {
                    assert!(inside(below, x), "{tri:?} {axis} {plane}: {x:?} below");
                }
                if x[axis] >= plane64 {
                    assert!(inside(above, x), "{tri:?} {axis} {plane}: {x:?} above");
                }
            }
        }
    }

    #[test]
    fn clipping_is_exact_and_conservative() {
        let tri = [P0, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        // The box [1,2]^2 x [-1,1] only holds the corner region x + y <= 2.
        let clip = Aabb::new(Vec3::new(1.0, 1.0, -1.0), Vec3::new(2.0, 2.0, 1.0));
        let b = clip_triangle_bounds(tri, &clip).unwrap();
        assert_eq!(b.min, Vec3::new(1.0, 1.0, 0.0));
        // Padding may add an ulp, never more.
        assert!(b.max.cmple(Vec3::new(1.0000002, 1.0000002, 0.0)).all());
        // Entirely beyond the hypotenuse: nothing remains.
        let clip = Aabb::new(Vec3::new(1.2, 1.2, -1.0), Vec3::new(2.0, 2.0, 1.0));
        assert!(clip_triangle_bounds(tri, &clip).is_none());
        let clip = Aabb::new(Vec3::new(0.5, -1.0, -1.0), Vec3::new(1.0, 3.0, 1.0));
        let b = clip_triangle_bounds(tri, &clip).unwrap();
        assert_eq!(b.min, Vec3::new(0.5, 0.0, 0.0));
        assert!(b.max.y >= 1.5 && b.max.y < 1.5001);
    }
}
