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
//!
//! For a closed mesh most points need no ray: the side grid
//! (`side_grid.rs`) knows the answer for every point not near the surface,
//! and gives the ray's answer there.

use rayon::prelude::*;

use super::edges::EdgeUses;
use super::side_grid::Side;
use super::{MeshAccel, PER_TASK};
use crate::morton;
use crate::primitives::PrimitiveId;
use crate::ray::Ray;
use glam::Vec3;

/// The direction of the inside test's ray: fixed, so answers are
/// deterministic; away from the axes and diagonals, so that rays from
/// points on a regular grid seldom run along a mesh's edges or faces.
pub const INSIDE_DIRECTION: Vec3 = Vec3::new(0.532_714_8, 0.374_023_44, 0.759_277_34);

impl MeshAccel {
    /// Whether `p` lies inside the mesh: an odd number of crossings along
    /// the ray from `p` in [`INSIDE_DIRECTION`]. Exact for a closed mesh;
    /// see the module documentation for meshes with holes. A non-finite
    /// point is outside. The first call builds the side grid, which then
    /// answers most points without a ray (the same answers).
    pub fn contains(&self, p: Vec3) -> bool {
        if !p.is_finite() {
            return false;
        }
        match self.side_grid().map(|grid| grid.side(p)) {
            Some(Side::Inside) => true,
            Some(Side::Outside) => false,
            Some(Side::Near) | None => self.ray_parity(p),
        }
    }

    /// The parity of the crossings along the ray from `p` in
    /// [`INSIDE_DIRECTION`]: odd is inside.
    pub(super) fn ray_parity(&self, p: Vec3) -> bool {
        self.count(&Ray::new(p, INSIDE_DIRECTION, 0.0, f32::INFINITY)) % 2 == 1
    }

    /// [`MeshAccel::contains`] for every point, in parallel (in Morton order
    /// of the points, as [`MeshAccel::closest_point_batch`]).
    pub fn contains_batch(&self, points: &[Vec3]) -> Vec<bool> {
        let Some(grid) = self.side_grid() else {
            return morton::answer_in_order(points, PER_TASK, |i| self.contains(points[i]));
        };
        // The lookups in the points' order (sorting them would cost more
        // than the lookups), then the few near the surface by ray, in
        // Morton order.
        let sides: Vec<Side> = points
            .par_iter()
            .with_min_len(4 * PER_TASK)
            .map(|&p| {
                if p.is_finite() {
                    grid.side(p)
                } else {
                    Side::Outside
                }
            })
            .collect();
        let near: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| sides[i as usize] == Side::Near)
            .collect();
        let near_points: Vec<Vec3> = near.iter().map(|&i| points[i as usize]).collect();
        let near_answers =
            morton::answer_in_order(&near_points, PER_TASK, |k| self.ray_parity(near_points[k]));
        let mut inside: Vec<bool> = sides.iter().map(|&s| s == Side::Inside).collect();
        for (&i, answer) in near.iter().zip(near_answers) {
            inside[i as usize] = answer;
        }
        inside
    }

    /// The distance from `p` to the mesh, negative inside: the sign is
    /// [`MeshAccel::contains`]'s answer, so the two always agree (for an
    /// open mesh, both follow the fixed direction's parity). `+inf` for an
    /// empty mesh, NaN for a non-finite point.
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        self.signed_distance_from(p, &mut None)
    }

    /// [`MeshAccel::signed_distance`], its closest-point search starting
    /// from triangle `hint` (see [`MeshAccel::closest_point_from`]), which
    /// becomes the triangle found.
    fn signed_distance_from(&self, p: Vec3, hint: &mut Option<PrimitiveId>) -> f32 {
        if !p.is_finite() {
            return f32::NAN;
        }
        let Some(near) = self.closest_point_from(p, f32::INFINITY, *hint) else {
            return f32::INFINITY;
        };
        *hint = Some(near.prim);
        if self.contains(p) {
            -near.distance
        } else {
            near.distance
        }
    }

    /// [`MeshAccel::signed_distance`] for every point, in parallel (in Morton
    /// order of the points, as [`MeshAccel::closest_point_batch`]).
    pub fn signed_distance_batch(&self, points: &[Vec3]) -> Vec<f32> {
        // Both built before the parallel loop: a worker building one inside
        // the loop would run the build's own parallel steps while the
        // other worker waits on it, or steal a query that waits on it.
        self.point_bvh();
        self.side_grid();
        morton::answer_in_order_carrying(
            points,
            PER_TASK,
            || None,
            |hint, i| self.signed_distance_from(points[i], hint),
        )
    }

    /// How many edges are not shared by exactly two triangles running along
    /// them in opposite directions: 0 for a closed, consistently oriented
    /// mesh, where [`MeshAccel::contains`] is exact. Vertices are matched by
    /// position, so an unwelded mesh (STL keeps three vertices per
    /// triangle) counts as closed when its surface is. Edges of zero length
    /// are ignored.
    pub fn open_edges(&self) -> usize {
        *self
            .open_edges
            .get_or_init(|| EdgeUses::of(self.vertices(), self.triangles()).open())
    }
}
