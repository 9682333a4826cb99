//! Triangle meshes as loaded from files, before they enter a scene.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::{load_msh, load_obj, LoadError, ObjRule};

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
    /// Triangles as indices into `positions` (every index is in range).
    pub triangles: Vec<[u32; 3]>,
}

/// Reads a mesh file for batch ray casting, choosing the reader by extension
/// (case-insensitive): `.msh` is the Cornell format, `.obj` is read with
/// [`ObjRule::Fan`] so that triangles are numbered as the ray/hit file
/// interface (and Embree's `embree_trace`) number them.
pub fn load_mesh_file(path: &Path) -> Result<MeshData, LoadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("msh") => load_msh(path),
        Some("obj") => load_obj(path, ObjRule::Fan).map(|m| m.mesh),
        _ => Err(LoadError::file(
            path,
            "unknown mesh file type; expected a .msh or .obj file",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// `../shared/scenes/cornell-2010/TEST_B`, or `None` (after printing why)
    /// when the shared data is absent and `ARBOR_REQUIRE_TEST_DATA=1` is not set.
    fn test_b() -> Option<PathBuf> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/scenes/cornell-2010/TEST_B");
        if dir.is_dir() {
            return Some(dir);
        }
        assert!(
            std::env::var("ARBOR_REQUIRE_TEST_DATA").as_deref() != Ok("1"),
            "ARBOR_REQUIRE_TEST_DATA=1 but {} is missing",
            dir.display()
        );
        eprintln!("skipping: shared test data {} is absent", dir.display());
        None
    }

    #[test]
    fn shared_msh_files_load() {
        let Some(dir) = test_b() else { return };
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
        let buddha = load_mesh_file(&dir.join("buddha100k.msh")).unwrap();
        assert_eq!(buddha.positions.len(), 49950);
        assert_eq!(buddha.triangles.len(), 100000);
    }

    #[test]
    fn load_mesh_file_picks_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("q.OBJ");
        std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        // Fan rule: the quad becomes two triangles.
        assert_eq!(load_mesh_file(&obj).unwrap().triangles.len(), 2);
        let msh = dir.path().join("t.msh");
        std::fs::write(
            &msh,
            "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n2\n",
        )
        .unwrap();
        assert_eq!(load_mesh_file(&msh).unwrap().triangles, vec![[0, 1, 2]]);
        let other = dir.path().join("t.ply");
        std::fs::write(&other, "ply\n").unwrap();
        let e = load_mesh_file(&other).unwrap_err();
        assert!(e.message.contains(".msh or .obj"), "{e}");
    }
}
