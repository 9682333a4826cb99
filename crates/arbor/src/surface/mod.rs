//! The scene structure of the lecture: surfaces (sphere, box, cylinder,
//! triangle mesh), groups with transformations, nested to any depth.
//!
//! This is the scene graph as loaded. Rendering never walks it directly: it
//! is flattened into world-space primitives by [`crate::flatten`] and indexed
//! by an acceleration structure kept separate from it.

use std::sync::Arc;

use glam::{DMat4, DVec3};

use crate::shader::Shader;

pub mod box_;
pub mod cylinder;
pub mod group;
mod mesh_data;
pub mod sphere;
pub mod transformed;
pub mod triangle;

pub use box_::BoxSurface;
pub use cylinder::Cylinder;
pub use group::Group;
pub use mesh_data::MeshData;
pub use sphere::Sphere;
pub(crate) use transformed::corner_bounds;
pub use transformed::Transform;

/// A node of the scene graph.
#[derive(Clone, Debug)]
pub enum Surface {
    /// An analytic sphere.
    Sphere(Sphere),
    /// An axis-aligned box (in its own space).
    Box(BoxSurface),
    /// A capped cylinder along z (2015).
    Cylinder(Cylinder),
    /// A triangle mesh, shaded by one shader.
    Mesh(MeshSurface),
    /// Children under a common transformation.
    Group(Group),
    /// Instancing: a placement of a surface that may be placed many times.
    /// The enclosing groups' transforms place it; the surface itself is
    /// shared, never copied, so the scene graph is a DAG.
    Instance(Arc<Surface>),
}

/// A triangle mesh placed in the scene.
#[derive(Clone, Debug)]
pub struct MeshSurface {
    /// The geometry, shared when several surfaces use the same file.
    pub data: Arc<MeshData>,
    /// The shader of every triangle.
    pub shader: Arc<Shader>,
    /// Whether back faces are shaded like front faces (except by glass,
    /// whose refraction needs to know inside from outside). Imported models
    /// are two-sided: their open surfaces (a sheet, a leaf, a wall of one
    /// layer) are meant to be seen from both sides, and a one-sided shader
    /// turns the far side black. The course's scenes are one-sided, as its
    /// reference renderer is.
    pub two_sided: bool,
    /// Whether shadow rays start from the point lifted toward the surface
    /// the interpolated normals describe ([`crate::terminator`]), which
    /// softens the shadow terminator of coarse smooth meshes. Imported
    /// models do; the course's scenes do not (their references are exact).
    pub soft_terminator: bool,
}

impl Surface {
    /// Calls `visit` with every leaf and its world matrix, depth first in
    /// document order, expanding every instance (so a shared surface is
    /// visited once per placement). `parent` is the matrix of the enclosing
    /// groups.
    pub fn for_each_leaf(&self, parent: DMat4, visit: &mut dyn FnMut(&Surface, DMat4)) {
        match self {
            Surface::Group(g) => {
                let m = parent * g.transform;
                for child in &g.children {
                    child.for_each_leaf(m, visit);
                }
            }
            Surface::Instance(shared) => shared.for_each_leaf(parent, visit),
            leaf => visit(leaf, parent),
        }
    }
}

/// The result of an exact object-space intersection: the ray parameter and
/// what the final hit computation needs to recover the normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Ray parameter (shared between object and world space).
    pub t: f64,
    /// Shape-specific data: barycentrics for triangles, the entering face
    /// normal for boxes, unused otherwise.
    pub aux: DVec3,
}
