//! Model import: the files people have (OBJ with MTL materials, PLY, STL,
//! glTF 2.0) turned into a renderable [`Scene`] with an automatic camera,
//! a ground plane and default lights ([`super::frame`]).
//!
//! The readers here are general importers, unlike [`crate::load::obj_exact`],
//! whose two exact numbering rules serve the Cornell scenes and the ray/hit
//! interface and must not change. Every reader treats its input as
//! untrusted: errors name the file (and the line, for text formats), counts
//! promised by a header are checked against the file size before anything
//! is allocated for them, and nothing panics.

use std::path::Path;
use std::sync::Arc;

use glam::{DMat4, DVec3, Vec3};

use super::{gltf, obj_import as obj, ply, stl};
use crate::camera::Camera;
use crate::light::Light;
use crate::load::{Format, LoadError, MeshData};
use crate::scene::Scene;
use crate::shader::Shader;
use crate::surface::{Group, MeshSurface, Surface};

/// A model as imported: its surfaces, and what the file says about viewing
/// it, before [`super::frame::scene_for`] adds what the file leaves out.
#[derive(Clone, Debug, Default)]
pub struct Model {
    /// Top-level surfaces (meshes, or groups placing shared meshes).
    pub surfaces: Vec<Surface>,
    /// The file's own camera (glTF), if any.
    pub camera: Option<Camera>,
    /// Aspect ratio (width / height) the file's camera asks for, if any.
    pub aspect: Option<f64>,
    /// The file's own lights (glTF's `KHR_lights_punctual`), if any; they
    /// replace the automatic lights.
    pub lights: Vec<Light>,
    /// Non-fatal remarks for the user, each naming the file.
    pub warnings: Vec<String>,
    /// What the file holds, for `arbor info`.
    pub stats: ModelStats,
}

/// Counts describing a model's structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelStats {
    /// Scene-graph nodes (glTF nodes; 0 for single-mesh formats).
    pub nodes: u64,
    /// Distinct meshes (one per OBJ material group, 1 for PLY and STL).
    pub meshes: u64,
    /// Placements of meshes (equal to `meshes` without instancing).
    pub placements: u64,
    /// Meshes placed more than once (shared, stored once).
    pub shared_meshes: u64,
    /// Triangles stored once per mesh.
    pub unique_triangles: u64,
    /// Triangles as placed in the scene (each placement counted).
    pub instanced_triangles: u64,
}

/// Imports the model at `path`, choosing the reader by its [`Format`].
/// A model whose triangles all have zero area gets a warning saying so (it
/// would show as an empty floor).
pub fn load_model(path: &Path) -> Result<Model, LoadError> {
    let mut model = read_model(path)?;
    if !has_area(&model.surfaces) {
        model.warnings.push(format!(
            "{}: warning: every triangle has zero area (its corners on one line); the picture shows no model",
            path.display()
        ));
    }
    Ok(model)
}

/// Whether any triangle of `surfaces` has a non-zero area.
fn has_area(surfaces: &[Surface]) -> bool {
    let mut any = false;
    for s in surfaces {
        s.for_each_leaf(glam::DMat4::IDENTITY, &mut |leaf, _| {
            if let Surface::Mesh(m) = leaf {
                let p = &m.data.positions;
                any = any
                    || m.data.triangles.iter().any(|t| {
                        let [a, b, c] = t.map(|i| p[i as usize].as_dvec3());
                        (b - a).cross(c - a).length_squared() > 0.0
                    });
            }
        });
    }
    any
}

/// Imports the model at `path` with the reader its [`Format`] names.
fn read_model(path: &Path) -> Result<Model, LoadError> {
    match Format::from_path(path)? {
        Format::Obj => obj::load(path),
        Format::Ply => Ok(single_mesh(ply::load(path)?)),
        Format::Stl => Ok(single_mesh(z_up_to_y_up(stl::load(path)?))),
        Format::Gltf | Format::Glb => gltf::load(path),
        other => Err(other.refused(path, "is not a model", &Format::listed(Format::is_model))),
    }
}

/// Which axis of a model file points up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Up {
    /// +x up.
    X,
    /// +y up (OBJ, PLY and glTF by default).
    Y,
    /// +z up (STL by default: CAD and 3D printing).
    Z,
    /// -x up.
    NegX,
    /// -y up.
    NegY,
    /// -z up.
    NegZ,
}

impl Up {
    /// The rotation that turns this axis to +y (arbor's up), keeping the
    /// handedness and the winding.
    fn to_y_up(self) -> DMat4 {
        let rows = |x: [f64; 3], y: [f64; 3], z: [f64; 3]| {
            DMat4::from_mat3(glam::DMat3::from_cols_array(&[
                x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2],
            ]))
        };
        match self {
            Up::Y => DMat4::IDENTITY,
            // (x, y, z) -> (x, z, -y), as STL files have always been turned.
            Up::Z => rows([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]),
            Up::NegZ => rows([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
            Up::X => rows([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            Up::NegX => rows([0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            Up::NegY => rows([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]),
        }
    }
}

impl std::str::FromStr for Up {
    type Err = String;

    fn from_str(s: &str) -> Result<Up, String> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "x" | "+x" => Up::X,
            "y" | "+y" => Up::Y,
            "z" | "+z" => Up::Z,
            "-x" => Up::NegX,
            "-y" => Up::NegY,
            "-z" => Up::NegZ,
            _ => {
                return Err(format!(
                    "unknown axis '{s}'; expected x, y, z, -x, -y or -z"
                ))
            }
        })
    }
}

/// How a model is placed and viewed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelOptions {
    /// The file's up axis; `None` is the format's rule (z for STL, y for the
    /// others).
    pub up: Option<Up>,
    /// Frame the model with arbor's own camera even when the file has one.
    pub auto_camera: bool,
}

/// Imports the model at `path` as [`load_model`] does, then turns it so
/// that `options.up` points up and drops the file's camera when
/// `options.auto_camera` asks for arbor's framing.
pub fn load_model_with(path: &Path, options: &ModelOptions) -> Result<Model, LoadError> {
    let mut model = load_model(path)?;
    if let Some(up) = options.up {
        // The readers have turned the model by its format's rule already.
        let default = if Format::from_path(path)? == Format::Stl {
            Up::Z
        } else {
            Up::Y
        };
        let turn = up.to_y_up() * default.to_y_up().inverse();
        if turn != DMat4::IDENTITY {
            model.surfaces = vec![Surface::Group(Group {
                transform: turn,
                children: std::mem::take(&mut model.surfaces),
            })];
            for light in &mut model.lights {
                turn_light(light, turn);
            }
            if let Some(c) = &mut model.camera {
                c.view_point = turn.transform_point3(c.view_point);
                c.view_dir = turn.transform_vector3(c.view_dir);
                c.view_up = turn.transform_vector3(c.view_up);
            }
        }
    }
    if options.auto_camera {
        model.camera = None;
        model.aspect = None;
    }
    Ok(model)
}

/// `light` turned by the rotation `turn`.
fn turn_light(light: &mut Light, turn: DMat4) {
    match light {
        Light::Point { position, .. } => *position = turn.transform_point3(*position),
        Light::Directional { direction, .. } => *direction = turn.transform_vector3(*direction),
        Light::Spot {
            position,
            direction,
            ..
        } => {
            *position = turn.transform_point3(*position);
            *direction = turn.transform_vector3(*direction);
        }
    }
}

/// Imports the model at `path` and builds the scene that frames it
/// ([`super::frame::scene_for`]). The warnings are the import's.
pub fn load_model_scene(path: &Path) -> Result<(Scene, Model), LoadError> {
    load_model_scene_with(path, &ModelOptions::default())
}

/// [`load_model_scene`] with the model placed and viewed by `options`.
pub fn load_model_scene_with(
    path: &Path,
    options: &ModelOptions,
) -> Result<(Scene, Model), LoadError> {
    let model = load_model_with(path, options)?;
    let scene = super::frame::scene_for(&model)
        .ok_or_else(|| LoadError::file(path, "the model has no triangles with finite size"))?;
    Ok((scene, model))
}

/// The material every surface gets when the file gives none: a light grey
/// with a soft highlight, so that shape reads well under the default lights.
pub fn default_shader() -> Arc<Shader> {
    Arc::new(Shader::Phong {
        diffuse: DVec3::splat(0.7),
        specular: DVec3::splat(0.2),
        exponent: 40.0,
        texture: None,
    })
}

/// A model of one mesh with the default material.
fn single_mesh(mesh: MeshData) -> Model {
    let n = mesh.triangles.len() as u64;
    Model {
        surfaces: vec![Surface::Mesh(MeshSurface {
            data: Arc::new(mesh),
            shader: default_shader(),
            two_sided: true,
            soft_terminator: true,
        })],
        stats: ModelStats {
            nodes: 0,
            meshes: 1,
            placements: 1,
            shared_meshes: 0,
            unique_triangles: n,
            instanced_triangles: n,
        },
        ..Model::default()
    }
}

/// STL files come from CAD and 3D printing, where z is up; our framing
/// (and OBJ, PLY and glTF) has y up. Turns (x, y, z) into (x, z, -y), a
/// rotation, so the winding and the handedness are kept.
fn z_up_to_y_up(mut mesh: MeshData) -> MeshData {
    for p in &mut mesh.positions {
        *p = Vec3::new(p.x, p.z, -p.y);
    }
    if let Some(ns) = &mut mesh.normals {
        for n in ns {
            *n = Vec3::new(n.x, n.z, -n.y);
        }
    }
    mesh
}

/// Adds to `found` the material `features` not named there yet, for
/// [`ignored_features_warning`].
pub(super) fn note_ignored(found: &mut Vec<&'static str>, features: Vec<&'static str>) {
    for feature in features {
        if !found.contains(&feature) {
            found.push(feature);
        }
    }
}

/// The one warning naming the material features of the model at `path`
/// that its shaders leave out, or `None` when there are none.
pub(super) fn ignored_features_warning(path: &Path, features: &[&str]) -> Option<String> {
    (!features.is_empty()).then(|| {
        format!(
            "{}: warning: material features arbor does not render are ignored: {}",
            path.display(),
            features.join(", ")
        )
    })
}

/// Drops per-vertex normals that are unusable (a zero or non-finite vector
/// anywhere would give a NaN shading normal) and returns whether it did.
pub(super) fn sanitize_normals(mesh: &mut MeshData) -> bool {
    if let Some(ns) = &mesh.normals {
        let bad = ns.len() != mesh.positions.len()
            || ns
                .iter()
                .any(|n| !n.is_finite() || n.length_squared() < 1e-20);
        if bad {
            mesh.normals = None;
            return true;
        }
    }
    false
}

/// Whether every position is finite (infinite or NaN coordinates would
/// poison the bounds and the acceleration structure).
pub(super) fn check_finite(path: &Path, positions: &[Vec3]) -> Result<(), LoadError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(i) => Err(LoadError::file(
            path,
            format!(
                "vertex {} has a coordinate that is not a finite number",
                i + 1
            ),
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_up_axis_turns_to_y_by_a_rotation() {
        let axes = [
            ("x", DVec3::X),
            ("y", DVec3::Y),
            ("z", DVec3::Z),
            ("-x", -DVec3::X),
            ("-y", -DVec3::Y),
            ("-Z", -DVec3::Z),
        ];
        for (name, axis) in axes {
            let m = name.parse::<Up>().unwrap().to_y_up();
            assert_eq!(m.transform_vector3(axis), DVec3::Y, "{name}");
            assert_eq!(m.determinant(), 1.0, "{name}");
        }
        assert!("w".parse::<Up>().unwrap_err().contains("expected x, y, z"));
    }
}
