//! The closest point of the mesh to a point.
//!
//! Nearest-first search of a binary BVH: of a node's two children the
//! nearer box is searched first, and a box farther than the best distance
//! found so far is skipped. Distances are squared `f64` values from the
//! point's `f32` coordinates, so the answer is the brute-force minimum of
//! the same `f64` point-triangle distances (boxes are skipped only when
//! their distance exceeds the best by more than any rounding could
//! account for).

use super::{MeshAccel, PER_TASK};
use crate::bvh2::Bvh;
use crate::morton;
use crate::primitives::PrimitiveId;
use glam::DVec3;
use glam::Vec3;

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// The point on the mesh.
    pub point: Vec3,
    /// The triangle it lies on (of several at the same distance, the one
    /// with the smallest index).
    pub prim: PrimitiveId,
    /// Barycentric weight of the triangle's second vertex.
    pub u: f32,
    /// Barycentric weight of its third vertex: the point is
    /// `(1 - u - v) p0 + u p1 + v p2`.
    pub v: f32,
    /// Distance from the query point.
    pub distance: f32,
}

/// A box is skipped when its squared distance times this still exceeds the
/// best squared distance: the two are computed with a few `f64` roundings
/// each (relative error below 1e-15), so no box holding a triangle at the
/// best distance is ever skipped.
const SKIP_MARGIN: f64 = 1.0 - 1e-12;

/// Levels of the traversal stack (a binary BVH is at most 63 deep, see
/// `FORCE_MEDIAN_DEPTH`, and holds at most one entry per level).
const STACK: usize = 128;

impl MeshAccel {
    /// The point of the mesh closest to `p`, if one lies within
    /// `max_distance` (inclusive; `f32::INFINITY` for no limit). `None` for
    /// an empty mesh, a non-finite `p`, or a negative or NaN
    /// `max_distance`. Triangles with non-finite vertices are never
    /// closest.
    pub fn closest_point(&self, p: Vec3, max_distance: f32) -> Option<ClosestPoint> {
        self.closest_point_from(p, max_distance, None)
    }

    /// [`MeshAccel::closest_point`], starting from triangle `hint`'s
    /// distance as the best so far (the answer of a nearby point): boxes
    /// farther than that are skipped from the start. The answer is the
    /// same with or without a hint; only the work differs.
    pub(crate) fn closest_point_from(
        &self,
        p: Vec3,
        max_distance: f32,
        hint: Option<PrimitiveId>,
    ) -> Option<ClosestPoint> {
        if !p.is_finite() || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        let limit = f64::from(max_distance) * f64::from(max_distance);
        nearest(self.point_bvh(), p.as_dvec3(), limit, hint, |prim| {
            let [a, b, c] = self.triangle(prim);
            closest_on_triangle(p.as_dvec3(), a.as_dvec3(), b.as_dvec3(), c.as_dvec3())
        })
    }

    /// [`MeshAccel::closest_point`] for every point with its own
    /// `max_distances[i]`, in parallel (answered in Morton order of the
    /// points, so that neighbours share what is in cache, each search
    /// starting from the triangle found for the point before it; returned
    /// in the points' order).
    ///
    /// # Panics
    /// If the two slices differ in length.
    pub fn closest_point_batch(
        &self,
        points: &[Vec3],
        max_distances: &[f32],
    ) -> Vec<Option<ClosestPoint>> {
        assert_eq!(points.len(), max_distances.len(), "one limit per point");
        // Built before the parallel loop, so no worker waits on another's build.
        self.point_bvh();
        morton::answer_in_order_carrying(
            points,
            PER_TASK,
            || None,
            |hint, i| {
                let found = self.closest_point_from(points[i], max_distances[i], *hint);
                if let Some(c) = found {
                    *hint = Some(c.prim);
                }
                found
            },
        )
    }
}

/// The squared distance from `p` to the box `[lo, hi]` (0 inside).
#[inline]
fn box_distance2(p: DVec3, lo: Vec3, hi: Vec3) -> f64 {
    let gap = (lo.as_dvec3() - p).max(p - hi.as_dvec3()).max(DVec3::ZERO);
    gap.length_squared()
}

/// Nearest-first search of `bvh` for the primitive closest to `p`, whose
/// point, barycentrics and squared distance `closest(prim)` gives, among
/// those within squared distance `limit`.
fn nearest(
    bvh: &Bvh,
    p: DVec3,
    limit: f64,
    hint: Option<u32>,
    closest: impl Fn(u32) -> Option<(DVec3, f64, f64, f64)>,
) -> Option<ClosestPoint> {
    let nodes = bvh.nodes();
    let prims = bvh.prim_indices();
    let root = nodes.first()?;
    // (squared distance, prim, point, u, v) of the best so far. The hint's
    // distance is the one its leaf would give, so the search below finds
    // the same minimum (and the same smallest index among ties) as without
    // it: no box within the best distance is ever skipped.
    let mut best: Option<(f64, u32, DVec3, f64, f64)> = hint
        .and_then(|prim| closest(prim).map(|(q, u, v, e2)| (e2, prim, q, u, v)))
        .filter(|b| b.0 <= limit);
    let bound = |best: &Option<(f64, u32, DVec3, f64, f64)>| best.map_or(limit, |b| b.0);
    let mut stack = [(0u32, 0f64); STACK];
    stack[0] = (0, box_distance2(p, root.min, root.max));
    let mut len = 1;
    while len > 0 {
        len -= 1;
        let (index, d2) = stack[len];
        if d2 * SKIP_MARGIN > bound(&best) {
            continue;
        }
        let node = &nodes[index as usize];
        if node.is_leaf() {
            let first = node.offset as usize;
            for &prim in &prims[first..first + node.count as usize] {
                let Some((q, u, v, e2)) = closest(prim) else {
                    continue;
                };
                let better = match best {
                    None => e2 <= limit,
                    Some((b2, bp, ..)) => e2 < b2 || (e2 == b2 && prim < bp),
                };
                if better {
                    best = Some((e2, prim, q, u, v));
                }
            }
            continue;
        }
        let children = [index + 1, node.offset];
        let dist = children.map(|c| {
            let n = &nodes[c as usize];
            box_distance2(p, n.min, n.max)
        });
        // The nearer child is pushed last, so it is searched first.
        let order = if dist[0] <= dist[1] { [1, 0] } else { [0, 1] };
        for k in order {
            if dist[k] * SKIP_MARGIN <= bound(&best) && len < STACK {
                stack[len] = (children[k], dist[k]);
                len += 1;
            }
        }
    }
    best.map(|(d2, prim, q, u, v)| ClosestPoint {
        point: q.as_vec3(),
        prim,
        u: u as f32,
        v: v as f32,
        distance: d2.sqrt() as f32,
    })
}

/// The point of triangle `abc` closest to `p`, with its barycentric
/// weights `u` (of `b`) and `v` (of `c`) and its squared distance; `None`
/// when that is not finite (a non-finite vertex).
///
/// The triangle's Voronoi regions are told apart by the signs of dot
/// products (vertex regions, then edge regions, then the face), each
/// closest point written as `a + v1 (b - a) + v2 (c - a)` or along one edge.
/// A degenerate triangle (zero area) is the union of its edges.
pub(crate) fn closest_on_triangle(
    p: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
) -> Option<(DVec3, f64, f64, f64)> {
    let (u, v) = if (b - a).cross(c - a) == DVec3::ZERO {
        degenerate_weights(p, a, b, c)
    } else {
        face_weights(p, a, b, c)
    };
    let q = a + (b - a) * u + (c - a) * v;
    let d2 = (p - q).length_squared();
    d2.is_finite().then_some((q, u, v, d2))
}

/// Weights `(u, v)` of the closest point of a non-degenerate triangle.
fn face_weights(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, f64) {
    let (ab, ac) = (b - a, c - a);
    let ap = p - a;
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (0.0, 0.0); // vertex a
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (1.0, 0.0); // vertex b
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (d1 / (d1 - d3), 0.0); // edge ab
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (0.0, 1.0); // vertex c
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (0.0, d2 / (d2 - d6)); // edge ac
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (1.0 - w, w); // edge bc
    }
    let denom = va + vb + vc;
    (vb / denom, vc / denom)
}

/// Weights `(u, v)` of the closest point of a zero-area triangle: the
/// nearest of its three edges' closest points.
fn degenerate_weights(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (f64, f64) {
    // Parameter of the closest point on segment from `s` to `e`.
    let along = |s: DVec3, e: DVec3| {
        let d = e - s;
        let len2 = d.length_squared();
        if len2 > 0.0 {
            ((p - s).dot(d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let (tab, tbc, tca) = (along(a, b), along(b, c), along(c, a));
    let candidates = [(tab, 0.0), (1.0 - tbc, tbc), (0.0, 1.0 - tca)];
    let dist2 = |(u, v): (f64, f64)| (p - (a + (b - a) * u + (c - a) * v)).length_squared();
    candidates
        .into_iter()
        .min_by(|x, y| dist2(*x).total_cmp(&dist2(*y)))
        .unwrap_or((0.0, 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::test_meshes;

    fn soup_mesh(n: u32) -> MeshAccel {
        let soup = test_meshes::soup(n);
        MeshAccel::build(soup.vertices, soup.triangles, AccelKind::DEFAULT).unwrap()
    }

    /// Whatever triangle the search starts from, it ends where the search
    /// without a start does: at the smallest-index triangle at the minimum
    /// distance, or nothing within the limit.
    #[test]
    fn any_hint_gives_the_answer_of_no_hint() {
        let mesh = soup_mesh(300);
        let mut unit = crate::util::unit_sequence(60);
        for k in 0..40 {
            let p = Vec3::new(unit(), unit(), unit()) * 14.0 - Vec3::splat(2.0);
            for limit in [f32::INFINITY, 0.5, 0.0] {
                let plain = mesh.closest_point(p, limit);
                for hint in [0, 7 * k as u32 % 300, 299] {
                    assert_eq!(
                        mesh.closest_point_from(p, limit, Some(hint)),
                        plain,
                        "{p} {limit} {hint}"
                    );
                }
            }
        }
    }

    /// Of two copies of one triangle, the search started from the copy with
    /// the larger index still answers the smaller.
    #[test]
    fn a_hint_on_a_tie_yields_to_the_smaller_index() {
        let vertices = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(5.0, 5.0, 5.0),
            Vec3::new(6.0, 5.0, 5.0),
            Vec3::new(5.0, 6.0, 5.0),
        ];
        let triangles = vec![[3, 4, 5], [0, 1, 2], [0, 1, 2]];
        let mesh = MeshAccel::build(vertices, triangles, AccelKind::DEFAULT).unwrap();
        let p = Vec3::new(0.25, 0.25, 1.0);
        let found = mesh.closest_point_from(p, f32::INFINITY, Some(2)).unwrap();
        assert_eq!((found.prim, found.distance), (1, 1.0));
    }
}
