//! Loading: every file arbor reads, from Cornell meshes to the models
//! people have, turned into mesh data or a renderable model.

mod error;
pub mod frame;
pub mod gltf;
pub mod mesh_data;
pub mod model;
pub mod msh;
pub mod obj_exact;
pub mod obj_import;
pub mod ply;
pub mod stl;
mod text;
pub mod triangulate;

pub use error::LoadError;
pub use mesh_data::{load_mesh_file, MeshData};
pub use model::{
    default_shader, is_model_path, load_mesh_data, load_model, load_model_scene, lower_extension,
    Model, ModelStats, MODEL_EXTENSIONS,
};
pub use msh::{load_msh, parse_msh};
pub use obj_exact::{load_obj, parse_obj, ObjMesh, ObjRule};

use model::{check_finite, sanitize_normals};
use text::{read_bytes, read_text, shorten};
