//! Loading: every file arbor reads, chosen by one registry ([`Format`]) and
//! reached through one entry point per purpose:
//!
//! * [`load_ray_mesh`]: a triangle mesh for batch ray casting (`arbor
//!   trace`): `.msh`, or OBJ under the fan rule ([`ObjRule::Fan`]), numbered
//!   in file order as the ray/hit interface and Embree number them, PLY,
//!   STL, and glTF as one mesh with its node transforms applied ([`placed`]);
//! * [`load_mesh`]: one mesh of any mesh format (`.msh`, OBJ under a given
//!   rule, PLY, STL), for a scene's `Mesh` surface and `arbor bench`;
//! * [`load_model`] and [`load_model_scene`]: a model to render (OBJ through
//!   tobj with ear clipping, PLY, STL, glTF), framed with a camera, a floor
//!   and lights ([`frame`]);
//! * [`load_cornell_scene`]: a Cornell XML scene ([`xml`]), whose OBJ
//!   meshes follow the Cornell 2015 rule;
//! * [`load_scene`]: whatever `arbor render` draws, a Cornell scene or a
//!   framed model.
//!
//! Two OBJ readers live here on purpose: [`obj_exact`] implements the two
//! exact numbering rules that the Cornell scenes and the ray/hit interface
//! fix, [`obj_import`] is the general importer (materials, groups). Every
//! error is a [`LoadError`] naming the file (and the line, for text formats).

use std::path::Path;

mod error;
mod format;
pub mod frame;
pub mod gltf;
mod gltf_ext;
mod gltf_material;
mod loaded_mesh;
mod model;
pub mod msh;
mod mtl;
pub mod obj_exact;
pub mod obj_import;
pub mod placed;
pub mod ply;
pub mod stl;
mod text;
pub mod triangulate;
pub mod xml;

pub use crate::surface::MeshData;
pub use error::LoadError;
pub use format::Format;
pub use loaded_mesh::LoadedMesh;
pub use model::{
    default_shader, load_model, load_model_scene, load_model_scene_with, load_model_with, Model,
    ModelOptions, ModelStats, Up,
};
pub use msh::{load_msh, parse_msh};
pub use obj_exact::{load_obj, parse_obj, ObjRule};

use crate::scene::LoadedScene;
use model::{check_finite, ignored_features_warning, note_ignored, sanitize_normals};
use text::{decode_text, read_bytes, read_text, shorten};

/// Reads one triangle mesh from a mesh file (`.msh`, `.obj` read under
/// `rule`, `.ply`, `.stl`), as it is stored: no turning, no materials.
pub fn load_mesh(path: &Path, rule: ObjRule) -> Result<LoadedMesh, LoadError> {
    let mesh = match Format::from_path(path)? {
        Format::Msh => load_msh(path)?,
        Format::Obj => return load_obj(path, rule),
        Format::Ply => ply::load(path)?,
        Format::Stl => stl::load(path)?,
        other => {
            return Err(LoadError::file(
                path,
                format!(
                    "a .{} file is not a mesh; expected a {} file",
                    other.extension(),
                    Format::listed(Format::is_mesh)
                ),
            ))
        }
    };
    Ok(LoadedMesh {
        mesh,
        skipped_polygons: 0,
    })
}

/// Reads a mesh file for batch ray casting: `.msh` is the Cornell format,
/// `.obj` is read with [`ObjRule::Fan`] so that triangles are numbered as the
/// ray/hit file interface (and Embree's `embree_trace`) number them, `.ply`
/// and `.stl` as stored (faces in file order, PLY polygons as fans, no
/// turning of STL's z up). `.gltf` and `.glb` become one mesh of every
/// triangle primitive with its nodes' transforms applied, in the order of
/// [`placed`] (the default scene's nodes depth first, a node's mesh before
/// its children, primitives and triangles in file order, strips and fans
/// as the renderer assembles them; points and lines have no triangles).
pub fn load_ray_mesh(path: &Path) -> Result<MeshData, LoadError> {
    match Format::from_path(path)? {
        Format::Gltf | Format::Glb => placed::placed_mesh(&gltf::load(path)?.surfaces, path),
        f if f.is_mesh() => Ok(load_mesh(path, ObjRule::Fan)?.mesh),
        other => Err(other.refused(
            path,
            "is not a mesh for ray casting",
            &format!("a {} file", Format::listed(Format::is_ray_mesh)),
        )),
    }
}

/// Reads a Cornell XML scene (meshes resolved relative to its folder).
pub fn load_cornell_scene(path: &Path) -> Result<LoadedScene, LoadError> {
    match Format::from_path(path)? {
        Format::Xml => xml::load_scene(path),
        other => Err(other.refused(path, "is not a scene", "a Cornell .xml scene")),
    }
}

/// Reads what `arbor render` draws: a Cornell XML scene, or a model
/// (`.obj`, `.ply`, `.stl`, `.gltf`, `.glb`) framed by [`load_model_scene`],
/// whose warnings become the scene's.
pub fn load_scene(path: &Path) -> Result<LoadedScene, LoadError> {
    load_scene_with(path, &ModelOptions::default())
}

/// [`load_scene`], a model placed and viewed by `options` (which a Cornell
/// scene ignores: it says where everything is).
pub fn load_scene_with(path: &Path, options: &ModelOptions) -> Result<LoadedScene, LoadError> {
    match Format::from_path(path)? {
        f if f.is_model() => {
            let (scene, model) = load_model_scene_with(path, options)?;
            Ok(LoadedScene {
                scene,
                warnings: model.warnings,
            })
        }
        Format::Xml => xml::load_scene(path),
        other => Err(other.refused(
            path,
            "is a mesh, not a scene",
            &format!(
                "a Cornell .xml scene or a {} model",
                Format::listed(Format::is_model)
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_msh_files_load() {
        let Some(dir) = arbor_test_data::shared("scenes/cornell-2010/TEST_B") else {
            return;
        };
        let bunny = load_msh(&dir.join("bunny500.msh")).unwrap();
        assert_eq!(bunny.positions.len(), 293);
        assert_eq!(bunny.triangles.len(), 500);
        assert!(bunny.normals.is_none());
        let norms = load_msh(&dir.join("bunny500_norms.msh")).unwrap();
        assert_eq!(norms.triangles.len(), 500);
        let normals = norms.normals.expect("bunny500_norms has normals");
        assert_eq!(normals.len(), norms.positions.len());
        // The format document promises unit normals in the shipped files.
        assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
        let buddha = load_ray_mesh(&dir.join("buddha100k.msh")).unwrap();
        assert_eq!(buddha.positions.len(), 49950);
        assert_eq!(buddha.triangles.len(), 100000);
    }

    #[test]
    fn load_mesh_file_picks_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("q.OBJ");
        std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        // Fan rule: the quad becomes two triangles.
        assert_eq!(load_ray_mesh(&obj).unwrap().triangles.len(), 2);
        let msh = dir.path().join("t.msh");
        std::fs::write(
            &msh,
            "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n2\n",
        )
        .unwrap();
        assert_eq!(load_ray_mesh(&msh).unwrap().triangles, vec![[0, 1, 2]]);
        // PLY and STL are read too (faces in file order).
        let ply = dir.path().join("t.ply");
        std::fs::write(
            &ply,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        )
        .unwrap();
        assert_eq!(load_ray_mesh(&ply).unwrap().triangles, vec![[0, 1, 2]]);
        let other = dir.path().join("t.xml");
        std::fs::write(&other, "<scene/>").unwrap();
        let e = load_ray_mesh(&other).unwrap_err();
        assert!(
            e.message.contains(".obj, .ply, .stl, .gltf, .glb or .msh"),
            "{e}"
        );
    }
}
