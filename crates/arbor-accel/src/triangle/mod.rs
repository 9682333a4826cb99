//! Triangles: the watertight ray/triangle test (`watertight.rs`), its
//! four- and eight-lane edge stage (`lanes.rs`), the indexed mesh that the
//! structures index (`mesh.rs`) and the exact clipping for spatial splits
//! (`clip.rs`).

pub(crate) mod clip;
pub(crate) mod lanes;
pub(crate) mod mesh;
pub(crate) mod watertight;
