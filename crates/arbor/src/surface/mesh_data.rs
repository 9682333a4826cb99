//! Triangle meshes as the files give them, before they enter a scene: the
//! data every loader produces and [`super::MeshSurface`] holds (it sits at
//! the surface level so that surfaces need nothing from the loaders).

use glam::{Vec2, Vec3};

/// An indexed triangle mesh as read from a file: positions and optional
/// per-vertex normals and texture coordinates, all `f32` as the files store
/// them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex normals, one per position, when the file has them.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, one per position, when the file has them.
    pub uvs: Option<Vec<Vec2>>,
    /// Per-vertex colours, linear (decoded from OBJ's and PLY's sRGB;
    /// glTF's `COLOR_0` is linear already, and comes multiplied by the base
    /// colour factor), one per position, when the file has them (OBJ's `v
    /// x y z r g b`, PLY's `red`/`green`/`blue`, glTF's `COLOR_0`). They
    /// replace the material's diffuse colour, and multiply its texture.
    pub colors: Option<Vec<Vec3>>,
    /// Triangles as indices into `positions` (every index is in range).
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// The vertex positions that some triangle uses (an unused vertex does
    /// not count toward a mesh's bounds), in storage order.
    pub fn used_positions(&self) -> impl Iterator<Item = glam::DVec3> + '_ {
        let mut used = vec![false; self.positions.len()];
        for &i in self.triangles.iter().flatten() {
            if let Some(u) = used.get_mut(i as usize) {
                *u = true;
            }
        }
        self.positions
            .iter()
            .zip(used)
            .filter(|(_, u)| *u)
            .map(|(p, _)| p.as_dvec3())
    }
}
