//! glTF 2.0 import (in progress).

use std::path::Path;

use super::Model;
use crate::mesh::MeshError;

/// Imports the glTF file at `path`.
pub fn load(path: &Path) -> Result<Model, MeshError> {
    Err(MeshError::file(path, "glTF import is not available yet"))
}
