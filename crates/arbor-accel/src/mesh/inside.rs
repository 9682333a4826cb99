//! Inside or outside a closed mesh, and the signed distance.
//!
//! A point is inside when a ray from it crosses the surface an odd number
//! of times. With each crossing counted once ([`MeshAccel::count`]'s
//! ownership rule), one ray in one fixed direction answers exactly for a
//! closed mesh: no jittered rays, no votes. For a mesh with holes the
//! parity depends on the direction (a ray escaping through a hole misses a
//! crossing): the answer is then that of the fixed direction
//! [`INSIDE_DIRECTION`], and [`MeshAccel::open_edges`] says whether a mesh
//! is closed. Points on the surface may be answered either way.

use std::collections::HashMap;

use super::{MeshAccel, PER_TASK};
use crate::{morton, Ray, Vec3};

/// The direction of the inside test's ray: fixed, so answers are
/// deterministic; away from the axes and diagonals, so that rays from
/// points on a regular grid seldom run along a mesh's edges or faces.
pub const INSIDE_DIRECTION: Vec3 = Vec3::new(0.532_714_8, 0.374_023_44, 0.759_277_34);

impl MeshAccel {
    /// Whether `p` lies inside the mesh: an odd number of crossings along
    /// the ray from `p` in [`INSIDE_DIRECTION`]. Exact for a closed mesh;
    /// see the module documentation for meshes with holes. A non-finite
    /// point is outside.
    pub fn contains(&self, p: Vec3) -> bool {
        if !p.is_finite() {
            return false;
        }
        self.count(&Ray::new(p, INSIDE_DIRECTION, 0.0, f32::INFINITY)) % 2 == 1
    }

    /// [`MeshAccel::contains`] for every point, in parallel (in Morton order
    /// of the points, as [`MeshAccel::closest_point_batch`]).
    pub fn contains_batch(&self, points: &[Vec3]) -> Vec<bool> {
        morton::answer_in_order(points, PER_TASK, |i| self.contains(points[i]))
    }

    /// The distance from `p` to the mesh, negative inside: the sign is
    /// [`MeshAccel::contains`]'s answer, so the two always agree (for an
    /// open mesh, both follow the fixed direction's parity). `+inf` for an
    /// empty mesh, NaN for a non-finite point.
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        if !p.is_finite() {
            return f32::NAN;
        }
        let Some(near) = self.closest_point(p, f32::INFINITY) else {
            return f32::INFINITY;
        };
        if self.contains(p) {
            -near.distance
        } else {
            near.distance
        }
    }

    /// [`MeshAccel::signed_distance`] for every point, in parallel (in Morton
    /// order of the points, as [`MeshAccel::closest_point_batch`]).
    pub fn signed_distance_batch(&self, points: &[Vec3]) -> Vec<f32> {
        self.point_bvh();
        morton::answer_in_order(points, PER_TASK, |i| self.signed_distance(points[i]))
    }

    /// How many edges are not shared by exactly two triangles running along
    /// them in opposite directions: 0 for a closed, consistently oriented
    /// mesh, where [`MeshAccel::contains`] is exact. Vertices are matched by
    /// position, so an unwelded mesh (STL keeps three vertices per
    /// triangle) counts as closed when its surface is. Edges of zero length
    /// are ignored.
    pub fn open_edges(&self) -> usize {
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut id_of = |v: Vec3| {
            // +0 and -0 are the same point.
            let key = (v + Vec3::ZERO).to_array().map(f32::to_bits);
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        };
        let welded: Vec<u32> = self.vertices().iter().map(|&v| id_of(v)).collect();
        // Per undirected edge: how many triangles use it, and the balance of
        // their directions (+1 one way, -1 the other).
        let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::new();
        for t in self.triangles() {
            let v = t.map(|i| welded[i as usize]);
            for (a, b) in [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])] {
                if a == b {
                    continue;
                }
                let (key, dir) = if a < b { ((a, b), 1) } else { ((b, a), -1) };
                let e = edges.entry(key).or_insert((0, 0));
                e.0 += 1;
                e.1 += dir;
            }
        }
        edges
            .values()
            .filter(|&&(uses, balance)| uses != 2 || balance != 0)
            .count()
    }
}
