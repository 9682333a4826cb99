//! One mesh file as loaded, with what the reader dropped.

use crate::surface::MeshData;

/// One mesh file as loaded, and what the reader dropped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadedMesh {
    /// The triangles.
    pub mesh: MeshData,
    /// OBJ `f` lines with more than 3 corners that
    /// [`super::ObjRule::Cornell2015`] skipped, so that the caller can warn
    /// (always 0 for other rules and formats).
    pub skipped_polygons: usize,
}
