//! Triangle meshes as loaded from files, before they enter a scene.

use std::fmt;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

pub mod msh;
pub mod obj;

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

/// An error while reading a mesh file: the file, the 1-based line when one
/// applies, and what was expected. Displays as `FILE:LINE: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshError {
    /// The mesh file.
    pub path: PathBuf,
    /// 1-based line, when the error belongs to one.
    pub line: Option<usize>,
    /// What went wrong and what was expected.
    pub message: String,
}

impl MeshError {
    /// An error at `line` (1-based) of `path`.
    pub fn at(path: &Path, line: usize, message: impl Into<String>) -> Self {
        MeshError {
            path: path.to_path_buf(),
            line: Some(line),
            message: message.into(),
        }
    }

    /// An error about the file as a whole.
    pub fn file(path: &Path, message: impl Into<String>) -> Self {
        MeshError {
            path: path.to_path_buf(),
            line: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.path.display(), line, self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for MeshError {}
