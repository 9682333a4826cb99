//! A model's meshes as placed: one triangle mesh with every node's
//! transform applied, for ray casting a scene graph (glTF) as one mesh.
//!
//! The order is the model's tree order, depth first: the top-level surfaces
//! in turn, in each group its children in turn (a glTF node's own mesh
//! before its child nodes), in each mesh its primitives and then their
//! triangles in file order. A mesh placed by several nodes appears once per
//! placement, with its own copy of the vertices.

use std::path::Path;

use glam::DMat4;

use super::{check_finite, LoadError, MeshData};
use crate::surface::Surface;

/// The triangles of `surfaces`, as placed, in the order the module
/// describes; `path` names the file in errors (a mesh too large for 32-bit
/// vertex indices once every placement is copied, or a transform that
/// carries a vertex beyond the range of `f32`).
pub fn placed_mesh(surfaces: &[Surface], path: &Path) -> Result<MeshData, LoadError> {
    // Counted before anything is copied: placements multiply.
    let (mut vertices, mut triangles) = (0u64, 0u64);
    for s in surfaces {
        s.for_each_leaf(DMat4::IDENTITY, &mut |leaf, _| {
            if let Surface::Mesh(m) = leaf {
                vertices += m.data.positions.len() as u64;
                triangles += m.data.triangles.len() as u64;
            }
        });
    }
    if vertices > u64::from(u32::MAX) {
        return Err(LoadError::file(
            path,
            format!(
                "the meshes as placed have {vertices} vertices; a mesh for ray casting holds at most {}",
                u32::MAX
            ),
        ));
    }
    let mut out = MeshData {
        positions: Vec::with_capacity(vertices as usize),
        triangles: Vec::with_capacity(triangles as usize),
        ..MeshData::default()
    };
    for s in surfaces {
        s.for_each_leaf(DMat4::IDENTITY, &mut |leaf, placement| {
            let Surface::Mesh(m) = leaf else { return };
            let base = out.positions.len() as u32;
            out.positions.extend(
                m.data
                    .positions
                    .iter()
                    .map(|p| placement.transform_point3(p.as_dvec3()).as_vec3()),
            );
            out.triangles
                .extend(m.data.triangles.iter().map(|t| t.map(|i| i + base)));
        });
    }
    check_finite(path, &out.positions)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::{DVec3, Vec3};

    use super::*;
    use crate::surface::{Group, MeshSurface};

    fn triangle(x: f32) -> Surface {
        Surface::Mesh(MeshSurface {
            data: Arc::new(MeshData {
                positions: vec![Vec3::new(x, 0.0, 0.0), Vec3::X, Vec3::Y],
                triangles: vec![[0, 1, 2]],
                ..MeshData::default()
            }),
            shader: super::super::default_shader(),
            two_sided: true,
            soft_terminator: false,
        })
    }

    #[test]
    fn placements_are_copied_in_tree_order() {
        let shared = Arc::new(triangle(0.0));
        let moved = DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0));
        let surfaces = vec![
            Surface::Group(Group {
                transform: moved,
                children: vec![Surface::Instance(shared.clone()), triangle(-1.0)],
            }),
            Surface::Instance(shared),
        ];
        let mesh = placed_mesh(&surfaces, Path::new("m.gltf")).unwrap();
        assert_eq!(mesh.triangles, [[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
        assert_eq!(mesh.positions[0], Vec3::new(0.0, 0.0, 5.0));
        assert_eq!(mesh.positions[3], Vec3::new(-1.0, 0.0, 5.0));
        assert_eq!(mesh.positions[6], Vec3::ZERO);
    }

    #[test]
    fn a_placement_beyond_f32_is_refused() {
        let surfaces = vec![Surface::Group(Group {
            transform: DMat4::from_scale(DVec3::splat(1e300)),
            children: vec![triangle(0.0)],
        })];
        let e = placed_mesh(&surfaces, Path::new("m.gltf")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("m.gltf: vertex 2 has a coordinate"),
            "{e}"
        );
    }
}
