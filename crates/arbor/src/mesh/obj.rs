//! Wavefront OBJ meshes.
