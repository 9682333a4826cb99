//! The one place that names the library's mesh query type.
//!
//! The binding asks one owned type, `MeshAccel`, for every answer. Until
//! `arbor_accel::MeshAccel` lands, this module stands in for it with the
//! same names over [`TriangleBvh`] (the structure behind `bvh-wide`); the
//! other structures are refused until then. Switching to the library's type
//! is a change of this file alone.

use arbor_accel::{MeshHit, NoCounters, Ray, TriangleBvh, TriangleMesh, Vec3};
use rayon::prelude::*;

pub use arbor_accel::AccelKind;

/// Why a mesh could not be built: a face names a vertex that does not exist,
/// or the structure is not available.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshError(String);

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// A triangle mesh with an acceleration structure over it, owning both.
pub struct MeshAccel {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    bvh: TriangleBvh,
}

impl MeshAccel {
    /// Builds `kind` over the mesh; every index must name a vertex.
    pub fn build(
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        kind: AccelKind,
    ) -> Result<Self, MeshError> {
        if kind != AccelKind::BvhWide {
            return Err(MeshError(format!(
                "accel {:?} is not available from Python yet; use \"bvh-wide\"",
                kind.name()
            )));
        }
        let n = vertices.len();
        if let Some((i, t)) = triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&k| k as usize >= n))
        {
            return Err(MeshError(format!(
                "triangle {i} has vertex indices {t:?}, but there are only {n} vertices"
            )));
        }
        let mesh = TriangleMesh::new(vertices, triangles);
        let bvh = TriangleBvh::build(&mesh, &TriangleBvh::params());
        Ok(MeshAccel {
            vertices: mesh.vertices,
            triangles: mesh.triangles,
            bvh,
        })
    }

    /// The vertex positions.
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The triangles, as indices into [`Self::vertices`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The closest hit of every ray, in parallel on the current rayon pool.
    pub fn closest_batch(&self, rays: &[Ray]) -> Vec<Option<MeshHit>> {
        rays.par_iter()
            .map(|r| self.bvh.closest(r, &mut NoCounters))
            .collect()
    }

    /// Whether anything lies on each ray, in parallel on the current pool.
    pub fn occluded_batch(&self, rays: &[Ray]) -> Vec<bool> {
        rays.par_iter()
            .map(|r| self.bvh.occluded(r, &mut NoCounters))
            .collect()
    }
}
