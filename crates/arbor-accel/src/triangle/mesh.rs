//! [`TriangleMesh`]: an indexed triangle mesh that the acceleration
//! structures index as [`Primitives`], with the watertight test per triangle.

use glam::Vec3;

use super::clip::clip_triangle_bounds;
use super::watertight::{intersect_triangle, intersect_triangle_sheared, RayShear, TriangleHit};
use crate::aabb::Aabb;
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;

/// An indexed triangle mesh. Triangle `i` has the vertices
/// `vertices[triangles[i][0..3]]`; every index must be in range.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Vertex indices, three per triangle.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// A mesh from positions and index triples.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        TriangleMesh {
            vertices,
            triangles,
        }
    }

    /// The three vertices of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: PrimitiveId) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[i as usize];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// The watertight test of `ray` against triangle `i`.
    #[inline]
    pub fn intersect(&self, i: PrimitiveId, ray: &Ray) -> Option<TriangleHit> {
        let [a, b, c] = self.triangle(i);
        intersect_triangle(ray, a, b, c)
    }

    /// [`TriangleMesh::intersect`] with the ray's shear computed once by the
    /// caller (`RayShear::new(ray)`), for loops over many triangles.
    #[inline]
    pub fn intersect_sheared(
        &self,
        i: PrimitiveId,
        ray: &Ray,
        shear: &RayShear,
    ) -> Option<TriangleHit> {
        let [a, b, c] = self.triangle(i);
        intersect_triangle_sheared(ray, shear, a, b, c)
    }
}

impl Primitives for TriangleMesh {
    fn len(&self) -> usize {
        self.triangles.len()
    }

    fn bounds(&self, index: PrimitiveId) -> Aabb {
        Aabb::from_points(self.triangle(index))
    }

    fn clipped_bounds(&self, index: PrimitiveId, clip: &Aabb) -> Option<Aabb> {
        clip_triangle_bounds(self.triangle(index), clip)
    }

    fn corners(&self, index: PrimitiveId) -> Option<[Vec3; 3]> {
        Some(self.triangle(index))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P0: Vec3 = Vec3::new(0.0, 0.0, 0.0);
    const P1: Vec3 = Vec3::new(1.0, 0.0, 0.0);
    const P2: Vec3 = Vec3::new(0.0, 1.0, 0.0);

    fn ray(o: Vec3, d: Vec3) -> Ray {
        Ray::new(o, d, 0.0, f32::INFINITY)
    }

    #[test]
    fn mesh_primitives() {
        let m = TriangleMesh::new(vec![P0, P1, P2], vec![[0, 1, 2]]);
        assert_eq!(Primitives::len(&m), 1);
        assert_eq!(m.bounds(0), Aabb::new(P0, Vec3::new(1.0, 1.0, 0.0)));
        assert!(m
            .intersect(0, &ray(Vec3::new(0.1, 0.1, 1.0), -Vec3::Z))
            .is_some());
    }
}
