//! glTF 2.0 import (`.gltf` with external or data-URI buffers, `.glb`)
//! through the `gltf` crate, keeping instancing.
//!
//! The node hierarchy becomes [`Group`]s carrying each node's matrix (TRS or
//! given). A mesh is built once as one shared `Arc<Surface>` and placed by
//! [`Surface::Instance`] wherever a node uses it, so a mesh used by many
//! nodes is stored once and [`crate::flatten::FlattenedScene`] keeps it shared.
//! Triangle primitives (lists, strips and fans) are read with their
//! normals, one texture coordinate set and `COLOR_0`; points and lines are
//! skipped with a warning. Materials become shaders as
//! `gltf_material.rs` maps them, with the base colour and emissive
//! textures (from a buffer view, a `data:` URI or a file beside the model;
//! otherwise a warning) looked up through `KHR_texture_transform`; the
//! extensions arbor reads come from the JSON (`gltf_ext.rs`).
//! `KHR_lights_punctual` lights are placed by their nodes. The first camera
//! met in the scene becomes ours; without one [`super::frame`] frames the
//! model.
//!
//! The crate validates indices between JSON objects; what it leaves to us
//! is checked before reading: node cycles, accessor ranges against their
//! buffers (the crate's readers would panic on a short buffer), vertex
//! indices against vertex counts, and the number of placements a deep
//! hierarchy multiplies out to.

use crate::hash_map::HashMap;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat4, DVec3, Vec2, Vec3};
use gltf::mesh::Mode;

use super::gltf_ext::{FileExt, TextureTransform};
use super::gltf_material::{ignored_features, shader_for};
use super::{Model, ModelStats};
use crate::camera::{Camera, CameraKind};
use crate::light::Light;
use crate::limits::DEFAULT_MAX_PLACEMENTS;
use crate::load::{LoadError, MeshData};
use crate::shader::Shader;
use crate::surface::{Group, MeshSurface, Surface};
use crate::texture::{TexelEncoding, Texture, Wrap};

/// Imports the glTF or GLB file at `path`, external buffers resolved
/// beside it.
pub fn load(path: &Path) -> Result<Model, LoadError> {
    let bytes = super::read_bytes(path)?;
    parse(&bytes, path, Some(path.parent().unwrap_or(Path::new("."))))
}

/// Imports glTF JSON or GLB bytes; `path` is only used in messages. Buffers
/// given by a relative or `file:` URI are read from the folder `base`;
/// without one only embedded buffers (GLB binary chunk, `data:` URIs) load.
pub fn parse(bytes: &[u8], path: &Path, base: Option<&Path>) -> Result<Model, LoadError> {
    if bytes.is_empty() {
        return Err(LoadError::file(path, "the file is empty"));
    }
    // A GLB header's total length below the header's own 12 bytes: the
    // crate subtracts 12 from it unchecked (an overflow panic in a debug
    // build).
    if bytes.starts_with(b"glTF") {
        if let Some(&[a, b, c, d]) = bytes.get(8..12) {
            if u32::from_le_bytes([a, b, c, d]) < 12 {
                return Err(LoadError::file(
                    path,
                    "the GLB header gives a length shorter than the header",
                ));
            }
        }
    }
    let prepared = if bytes.starts_with(b"glTF") {
        if bytes.get(4..8) == Some(&1u32.to_le_bytes()[..]) {
            return Err(LoadError::file(
                path,
                "a glTF 1.0 binary file; arbor reads glTF 2.0",
            ));
        }
        // The JSON chunk is checked; it is not rewritten.
        if let Some(json) = glb_json_chunk(bytes) {
            prepare_json(json, path)?;
        }
        None
    } else {
        prepare_json(bytes, path)?
    };
    let bytes = prepared.as_deref().unwrap_or(bytes);
    let json = if bytes.starts_with(b"glTF") {
        glb_json_chunk(bytes).unwrap_or_default()
    } else {
        bytes
    };
    let ext = FileExt::read(json);
    let invalid = |e: gltf::Error| LoadError::file(path, format!("not a valid glTF 2.0 file: {e}"));
    let mut gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(invalid)?;
    // The crate's validation indexes the accessors by each primitive's
    // POSITION before checking that index: check it first.
    let json = gltf.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for p in &mesh.primitives {
            let position = p.attributes.get(&gltf::json::validation::Checked::Valid(
                gltf::Semantic::Positions,
            ));
            if position.is_some_and(|a| a.value() >= json.accessors.len()) {
                return Err(LoadError::file(
                    path,
                    format!("mesh {m}: POSITION names an accessor that does not exist"),
                ));
            }
        }
    }
    gltf.document = gltf::Document::from_json(gltf.document.into_json()).map_err(invalid)?;
    check_buffer_uris(&gltf.document, path, base)?;
    let buffers = gltf::import_buffers(&gltf.document, base, gltf.blob.clone())
        .map_err(|e| LoadError::file(path, format!("cannot load a buffer: {e}")))?;
    Importer {
        path,
        base,
        doc: &gltf.document,
        buffers: buffers.iter().map(|b| b.0.as_slice()).collect(),
        textures: HashMap::default(),
        meshes: HashMap::default(),
        mesh_triangles: HashMap::default(),
        mesh_uses: HashMap::default(),
        warnings: (!ext.ignored.is_empty())
            .then(|| {
                format!(
                    "{}: warning: the file uses glTF extensions arbor ignores ({}); the picture may differ from the author's",
                    path.display(),
                    ext.ignored.join(", ")
                )
            })
            .into_iter()
            .collect(),
        ext,
        lights: Vec::new(),
        lights_left_out: 0,
        ignored_features: Vec::new(),
        stats: ModelStats {
            nodes: gltf.document.nodes().len() as u64,
            meshes: gltf.document.meshes().len() as u64,
            ..ModelStats::default()
        },
        camera: None,
        aspect: None,
    }
    .run()
}

/// The most `KHR_lights_punctual` lights a file's nodes may place.
const MAX_LIGHTS: usize = 64;

/// The extensions arbor reads when a file requires them (none of the
/// required-extension kind today: each one listed here changes geometry or
/// materials in a way the importer implements).
const SUPPORTED_REQUIRED: &[&str] = &[];

/// Checks what the JSON says before the crate parses it, for one clear line
/// where the crate would give a misleading one: glTF 1.0 (a different
/// schema), required extensions arbor lacks (named once each), and returns
/// the JSON with what the specification makes optional filled in (a scene
/// without `nodes`, a default `scene` naming no scene). `json` is the JSON
/// text, or a GLB's JSON chunk.
fn prepare_json(json: &[u8], path: &Path) -> Result<Option<Vec<u8>>, LoadError> {
    let Ok(mut root) = gltf::json::deserialize::from_slice::<gltf::json::Value>(json) else {
        // Not JSON at all: the crate's own message says where.
        return Ok(None);
    };
    // glTF 1.0 exporters also wrote the version as a number (`"version": 1`).
    let version = match root.pointer("/asset/version") {
        Some(gltf::json::Value::String(v)) => v.clone(),
        Some(gltf::json::Value::Number(n)) => n.to_string(),
        _ => String::new(),
    };
    if version.starts_with('1') {
        return Err(LoadError::file(
            path,
            format!("a glTF {version} file; arbor reads glTF 2.0"),
        ));
    }
    let mut missing: Vec<String> = Vec::new();
    if let Some(required) = root.get("extensionsRequired").and_then(|v| v.as_array()) {
        for name in required.iter().filter_map(|v| v.as_str()) {
            if !SUPPORTED_REQUIRED.contains(&name) && !missing.iter().any(|m| m == name) {
                missing.push(name.to_string());
            }
        }
    }
    if !missing.is_empty() {
        return Err(LoadError::file(
            path,
            format!(
                "the file requires the glTF extension{} {}, which arbor does not read",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", ")
            ),
        ));
    }
    let mut changed = false;
    let scenes = root
        .get("scenes")
        .and_then(|s| s.as_array())
        .map_or(0, |s| s.len());
    if let Some(obj) = root.as_object_mut() {
        // A default scene that names no scene: no default scene.
        if obj
            .get("scene")
            .and_then(|s| s.as_u64())
            .is_some_and(|s| s as usize >= scenes)
        {
            obj.remove("scene");
            changed = true;
        }
        // `nodes` of a scene is optional: an empty scene.
        if let Some(list) = obj.get_mut("scenes").and_then(|s| s.as_array_mut()) {
            for scene in list.iter_mut().filter_map(|s| s.as_object_mut()) {
                if !scene.contains_key("nodes") {
                    scene.insert("nodes".into(), gltf::json::Value::Array(Vec::new()));
                    changed = true;
                }
            }
        }
    }
    Ok(changed.then(|| gltf::json::serialize::to_vec(&root).unwrap_or_default()))
}

/// The JSON chunk of a GLB file (the first chunk, by the format), when the
/// header and the chunk's length are consistent.
fn glb_json_chunk(bytes: &[u8]) -> Option<&[u8]> {
    let len = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?) as usize;
    if bytes.get(16..20)? != b"JSON" {
        return None;
    }
    bytes.get(20..20usize.checked_add(len)?)
}

/// Checks what the crate's buffer import would trip on: a relative URI
/// that does not percent-decode to UTF-8 (it panics), and an external
/// buffer that is not a regular file (`/dev/zero` would be read forever).
fn check_buffer_uris(
    doc: &gltf::Document,
    path: &Path,
    base: Option<&Path>,
) -> Result<(), LoadError> {
    for buffer in doc.buffers() {
        let gltf::buffer::Source::Uri(uri) = buffer.source() else {
            continue;
        };
        let fail = |why: &str| LoadError::file(path, format!("buffer {}: {why}", buffer.index()));
        // data: URIs, schemes the crate refuses, and relative URIs without a
        // base folder (the crate refuses external buffers then) are left to
        // the crate.
        let Some(file) = uri_file(uri, base).map_err(fail)? else {
            continue;
        };
        if base.is_some() && !is_regular_file(&file) {
            return Err(fail(&format!(
                "'{}' is not a readable file",
                file.display()
            )));
        }
    }
    Ok(())
}

/// The file a `file:` or relative URI names (relative ones beside `base`),
/// or `None` for other schemes (`data:`) and for a relative URI without a
/// base folder; an error when a relative URI does not percent-decode to
/// UTF-8.
fn uri_file(uri: &str, base: Option<&Path>) -> Result<Option<PathBuf>, &'static str> {
    if let Some(rest) = uri.strip_prefix("file://").or(uri.strip_prefix("file:")) {
        return Ok(Some(PathBuf::from(rest)));
    }
    if uri.contains(':') {
        return Ok(None);
    }
    let decoded = percent_decode(uri).ok_or("the URI is not percent-encoded UTF-8")?;
    Ok(base.map(|b| b.join(decoded)))
}

/// Whether `path` is a regular file (not a folder, and not a device such as
/// `/dev/zero`, which would be read forever).
fn is_regular_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.is_file())
}

/// Decodes `%XX` escapes (others kept as they are); `None` when the result
/// is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .filter(|h| h.iter().all(u8::is_ascii_hexdigit))
            .and_then(|h| u8::from_str_radix(std::str::from_utf8(h).ok()?, 16).ok());
        match hex {
            Some(v) if b[i] == b'%' => {
                out.push(v);
                i += 3;
            }
            _ => {
                out.push(b[i]);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// What an accessor is read as.
#[derive(Clone, Copy)]
enum Usage {
    /// A triangle index list.
    Indices,
    /// Positions or normals: VEC3 of floats.
    Vectors,
    /// Texture coordinates: VEC2 of floats or normalized integers.
    TexCoords,
    /// Vertex colours: VEC3 or VEC4 of floats or normalized integers.
    Colors,
}

struct Importer<'a> {
    path: &'a Path,
    /// The folder external files are read from, if any.
    base: Option<&'a Path>,
    doc: &'a gltf::Document,
    buffers: Vec<&'a [u8]>,
    /// Each image read once, by index (`None`: it could not be read).
    textures: HashMap<usize, Option<Arc<Texture>>>,
    /// Each mesh built once, shared by every node that uses it.
    meshes: HashMap<usize, Arc<Surface>>,
    mesh_triangles: HashMap<usize, u64>,
    /// How many nodes place each mesh.
    mesh_uses: HashMap<usize, u64>,
    warnings: Vec<String>,
    /// What the extensions arbor reads say.
    ext: FileExt,
    /// The file's lights (`KHR_lights_punctual`) as placed by the nodes.
    lights: Vec<Light>,
    /// Lights beyond [`MAX_LIGHTS`], not placed.
    lights_left_out: usize,
    /// Material features arbor does not render, named once each for one
    /// warning.
    ignored_features: Vec<&'static str>,
    stats: ModelStats,
    camera: Option<Camera>,
    aspect: Option<f64>,
}

impl Importer<'_> {
    fn err(&self, m: impl Into<String>) -> LoadError {
        LoadError::file(self.path, m)
    }

    fn run(mut self) -> Result<Model, LoadError> {
        let roots: Vec<usize> = match self
            .doc
            .default_scene()
            .or_else(|| self.doc.scenes().next())
        {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            // No scene: every node that is nobody's child is a root.
            None => {
                let mut is_child = vec![false; self.doc.nodes().len()];
                for n in self.doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                (0..is_child.len()).filter(|&i| !is_child[i]).collect()
            }
        };
        self.check_cycles(&roots)?;
        // Placements multiply down a DAG: count them before building.
        let mut memo = HashMap::default();
        let placements = roots.iter().fold(0u64, |a, &r| {
            a.saturating_add(self.count_placements(r, &mut memo))
        });
        if placements > DEFAULT_MAX_PLACEMENTS {
            return Err(self.err(format!(
                "the node hierarchy places meshes {placements} times; the limit is {DEFAULT_MAX_PLACEMENTS}"
            )));
        }
        let mut surfaces = Vec::new();
        for &r in &roots {
            if let Some(s) = self.node(r, DMat4::IDENTITY)? {
                surfaces.push(s);
            }
        }
        if self.stats.instanced_triangles == 0 {
            // The warnings say why (points, lines, textures...): keep them
            // in the one line the user sees.
            let prefix = format!("{}: warning: ", self.path.display());
            let why: Vec<&str> = self
                .warnings
                .iter()
                .map(|w| w.strip_prefix(&prefix).unwrap_or(w))
                .collect();
            let mut message = "the file has no triangles to render".to_string();
            if !why.is_empty() {
                message = format!("{message} ({})", why.join("; "));
            }
            return Err(self.err(message));
        }
        if self.lights_left_out > 0 {
            self.warnings.push(format!(
                "{}: warning: the file places {} lights; only the first {MAX_LIGHTS} are used",
                self.path.display(),
                MAX_LIGHTS + self.lights_left_out
            ));
        }
        self.warnings.extend(super::ignored_features_warning(
            self.path,
            &self.ignored_features,
        ));
        Ok(Model {
            surfaces,
            camera: self.camera,
            aspect: self.aspect,
            lights: self.lights,
            warnings: self.warnings,
            stats: self.stats,
        })
    }

    /// Fails on a node reachable from itself (the format forbids it; a
    /// cycle would make the hierarchy infinite).
    fn check_cycles(&self, roots: &[usize]) -> Result<(), LoadError> {
        // 0 unvisited, 1 on the current path, 2 done.
        let mut state = vec![0u8; self.doc.nodes().len()];
        let nodes: Vec<gltf::Node> = self.doc.nodes().collect();
        for &root in roots {
            let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
            if state[root] != 0 {
                continue;
            }
            state[root] = 1;
            while let Some(&mut (n, ref mut next)) = stack.last_mut() {
                let child = nodes[n].children().nth(*next).map(|c| c.index());
                *next += 1;
                match child {
                    Some(c) if state[c] == 1 => {
                        return Err(self.err(format!(
                            "the node hierarchy has a cycle: node {c} is its own ancestor (through node {n})"
                        )))
                    }
                    Some(c) if state[c] == 0 => {
                        state[c] = 1;
                        stack.push((c, 0));
                    }
                    Some(_) => {}
                    None => {
                        state[n] = 2;
                        stack.pop();
                    }
                }
            }
        }
        Ok(())
    }

    fn count_placements(&self, n: usize, memo: &mut HashMap<usize, u64>) -> u64 {
        if let Some(&c) = memo.get(&n) {
            return c;
        }
        let Some(node) = self.doc.nodes().nth(n) else {
            return 0;
        };
        let mut c = node.mesh().is_some() as u64;
        for child in node.children() {
            c = c.saturating_add(self.count_placements(child.index(), memo));
        }
        memo.insert(n, c);
        c
    }

    /// The group for node `n` (`None` when nothing under it has geometry);
    /// `world` is the parents' matrix (for the camera).
    fn node(&mut self, n: usize, world: DMat4) -> Result<Option<Surface>, LoadError> {
        let Some(node) = self.doc.nodes().nth(n) else {
            return Ok(None);
        };
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        if !local.is_finite() {
            return Err(self.err(format!("node {n} has a transform that is not finite")));
        }
        let world = world * local;
        if self.camera.is_none() {
            if let Some(cam) = node.camera() {
                self.set_camera(&cam, world);
            }
        }
        if let Some(&Some(light)) = self.ext.node_lights.get(n) {
            match self.ext.lights.get(light) {
                // Every light costs a shadow ray per shaded point.
                Some(Some(p)) if self.lights.len() < MAX_LIGHTS => {
                    self.lights.extend(p.placed(world))
                }
                Some(Some(_)) => self.lights_left_out += 1,
                _ => self.warnings.push(format!(
                    "{}: warning: node {n} places light {light}, which is not a point, spot or directional light arbor reads; it is left out",
                    self.path.display()
                )),
            }
        }
        let mut children = Vec::new();
        if let Some(mesh) = node.mesh() {
            if let Some(shared) = self.mesh(&mesh)? {
                self.stats.placements += 1;
                let uses = self.mesh_uses.entry(mesh.index()).or_insert(0);
                *uses += 1;
                if *uses == 2 {
                    self.stats.shared_meshes += 1;
                }
                self.stats.instanced_triangles += self.mesh_triangles[&mesh.index()];
                children.push(Surface::Instance(shared));
            }
        }
        for child in node.children() {
            if let Some(s) = self.node(child.index(), world)? {
                children.push(s);
            }
        }
        Ok((!children.is_empty()).then_some(Surface::Group(Group {
            transform: local,
            children,
        })))
    }

    fn set_camera(&mut self, cam: &gltf::Camera, world: DMat4) {
        let eye = world.transform_point3(DVec3::ZERO);
        let dir = world.transform_vector3(DVec3::NEG_Z);
        let up = world.transform_vector3(DVec3::Y);
        if !(eye.is_finite() && dir.length() > 0.0 && up.length() > 0.0) {
            return;
        }
        let (kind, width, height) = match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let aspect = p.aspect_ratio().map_or(super::frame::ASPECT, f64::from);
                let h = 2.0 * (p.yfov() as f64 / 2.0).tan();
                self.aspect = Some(aspect);
                (CameraKind::Perspective2015, h * aspect, h)
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (x, y) = (o.xmag() as f64, o.ymag() as f64);
                self.aspect = Some(x / y);
                (CameraKind::Parallel2015, 2.0 * x, 2.0 * y)
            }
        };
        if !(width.is_finite() && height.is_finite() && width > 0.0 && height > 0.0) {
            self.aspect = None;
            return;
        }
        self.camera = Some(Camera {
            kind,
            view_point: eye,
            view_dir: dir,
            view_up: up,
            proj_normal: DVec3::ZERO,
            proj_distance: 1.0,
            view_width: width,
            view_height: height,
        });
    }

    /// The shared surface for a mesh (built on first use).
    fn mesh(&mut self, mesh: &gltf::Mesh) -> Result<Option<Arc<Surface>>, LoadError> {
        if let Some(s) = self.meshes.get(&mesh.index()) {
            return Ok(Some(s.clone()));
        }
        let mut parts = Vec::new();
        let mut triangles = 0u64;
        for prim in mesh.primitives() {
            if !matches!(
                prim.mode(),
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.warnings.push(format!(
                    "{}: warning: mesh {} has a {:?} primitive; points and lines are skipped, only surfaces are rendered",
                    self.path.display(),
                    mesh.index(),
                    prim.mode()
                ));
                continue;
            }
            let data = self.primitive(mesh.index(), &prim)?;
            if data.triangles.is_empty() {
                continue;
            }
            triangles += data.triangles.len() as u64;
            parts.push(Surface::Mesh(MeshSurface {
                data: Arc::new(data),
                shader: {
                    let material = prim.material();
                    let texture = self.base_color_texture(&material);
                    let ext = self.ext.material(material.index());
                    super::note_ignored(
                        &mut self.ignored_features,
                        ignored_features(&material, &ext),
                    );
                    let surface = shader_for(&material, &ext, texture);
                    self.emissive(&material, surface)
                },
                two_sided: true,
                soft_terminator: true,
            }));
        }
        if parts.is_empty() {
            return Ok(None);
        }
        let surface = Arc::new(if parts.len() == 1 {
            parts.pop().expect("one part")
        } else {
            Surface::Group(Group {
                transform: DMat4::IDENTITY,
                children: parts,
            })
        });
        self.stats.unique_triangles += triangles;
        self.mesh_triangles.insert(mesh.index(), triangles);
        self.meshes.insert(mesh.index(), surface.clone());
        Ok(Some(surface))
    }

    /// Whether `accessor` holds what its use needs (the crate's readers
    /// assume the type and panic on another), with a stride no shorter than
    /// an element, and its data lies inside its buffer (the crate's readers
    /// slice without checking).
    fn check_accessor(
        &self,
        mesh: usize,
        accessor: &gltf::Accessor,
        usage: Usage,
    ) -> Result<(), LoadError> {
        use gltf::accessor::{DataType, Dimensions};
        let fail =
            |why: &str| self.err(format!("mesh {mesh}: accessor {} {why}", accessor.index()));
        if accessor.sparse().is_some() {
            return Err(fail("is sparse, which is not supported"));
        }
        let (ty, dims) = (accessor.data_type(), accessor.dimensions());
        match usage {
            Usage::Indices => {
                if dims != Dimensions::Scalar
                    || !matches!(ty, DataType::U8 | DataType::U16 | DataType::U32)
                {
                    return Err(fail("holds indices that are not unsigned integer scalars"));
                }
            }
            Usage::Vectors => {
                if dims != Dimensions::Vec3 || ty != DataType::F32 {
                    return Err(fail("is not VEC3 of floats"));
                }
            }
            Usage::Colors => {
                let normalized =
                    accessor.normalized() && matches!(ty, DataType::U8 | DataType::U16);
                if !matches!(dims, Dimensions::Vec3 | Dimensions::Vec4)
                    || !(ty == DataType::F32 || normalized)
                {
                    return Err(fail(
                        "holds colours that are not VEC3 or VEC4 of floats or normalized bytes or shorts",
                    ));
                }
            }
            Usage::TexCoords => {
                let normalized =
                    accessor.normalized() && matches!(ty, DataType::U8 | DataType::U16);
                if dims != Dimensions::Vec2 || !(ty == DataType::F32 || normalized) {
                    return Err(fail(
                        "holds texture coordinates that are not VEC2 of floats or normalized bytes or shorts",
                    ));
                }
            }
        }
        let Some(view) = accessor.view() else {
            return Err(fail("has no buffer view"));
        };
        let buffer = self
            .buffers
            .get(view.buffer().index())
            .ok_or_else(|| fail("refers to a missing buffer"))?;
        let view_end = view.offset().checked_add(view.length());
        if view_end.is_none_or(|e| e > buffer.len()) {
            return Err(fail("has a buffer view beyond the end of its buffer"));
        }
        let size = accessor.size();
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(fail("has a buffer view stride shorter than its elements"));
        }
        let count = accessor.count();
        let needed = match count {
            0 => Some(0),
            c => (c - 1)
                .checked_mul(stride)
                .and_then(|s| s.checked_add(size))
                .and_then(|s| s.checked_add(accessor.offset())),
        };
        if needed.is_none_or(|n| n > view.length()) {
            return Err(fail("reads beyond the end of its buffer view"));
        }
        Ok(())
    }

    /// The base colour texture of material `m`, each image read once and
    /// looked up through its `KHR_texture_transform`; `None` (with a warning
    /// naming the material and the image) when there is none or it cannot
    /// be read: the base colour is used instead, the model still loads.
    fn base_color_texture(&mut self, m: &gltf::Material) -> Option<Arc<Texture>> {
        let info = m.pbr_metallic_roughness().base_color_texture()?;
        let transform = self.ext.material(m.index()).base_color_transform;
        self.texture(
            m,
            &info,
            transform,
            "base colour",
            "the base colour is used",
        )
    }

    /// `surface` with the emission of material `m` added when it has one:
    /// `emissiveFactor` times `emissiveTexture`, scaled by
    /// `KHR_materials_emissive_strength`.
    fn emissive(&mut self, m: &gltf::Material, surface: Arc<Shader>) -> Arc<Shader> {
        let strength = self.ext.material(m.index()).emissive_strength;
        let emission = DVec3::from_array(m.emissive_factor().map(f64::from)) * strength;
        if !(emission.is_finite() && emission.max_element() > 0.0) {
            return surface;
        }
        let texture = self.emissive_texture(m);
        Arc::new(Shader::Emissive {
            emission,
            texture,
            surface,
        })
    }

    /// The emissive texture of material `m`, as [`Self::base_color_texture`]
    /// reads the base colour's (sRGB as well, by the specification).
    fn emissive_texture(&mut self, m: &gltf::Material) -> Option<Arc<Texture>> {
        let info = m.emissive_texture()?;
        let transform = self.ext.material(m.index()).emissive_transform;
        self.texture(
            m,
            &info,
            transform,
            "emissive",
            "its emissive factor alone is used",
        )
    }

    /// The texture coordinate set the primitives of material `m` are read
    /// with: the base colour texture's (after `KHR_texture_transform`'s
    /// `texCoord`), else the emissive texture's, else 0. A mesh keeps one
    /// set, so a texture of the material on another set is not used.
    fn uv_set(&self, m: &gltf::Material) -> u32 {
        let ext = self.ext.material(m.index());
        let base = m.pbr_metallic_roughness().base_color_texture();
        let set = |info: &gltf::texture::Info, t: Option<TextureTransform>| {
            t.and_then(|t| t.tex_coord).unwrap_or(info.tex_coord())
        };
        match (base, m.emissive_texture()) {
            (Some(b), _) => set(&b, ext.base_color_transform),
            (None, Some(e)) => set(&e, ext.emissive_transform),
            (None, None) => 0,
        }
    }

    /// The texture `info` names for the `what` of material `m`, looked up
    /// through `transform`; `fallback` says in a warning what is used when
    /// it cannot be read.
    fn texture(
        &mut self,
        m: &gltf::Material,
        info: &gltf::texture::Info,
        transform: Option<TextureTransform>,
        what: &str,
        fallback: &str,
    ) -> Option<Arc<Texture>> {
        let material = m.index().map_or("default".to_string(), |i| i.to_string());
        let set = transform
            .and_then(|t| t.tex_coord)
            .unwrap_or(info.tex_coord());
        if set != self.uv_set(m) {
            self.warnings.push(format!(
                "{}: warning: material {material}: its {what} texture uses TEXCOORD_{set}, its base colour TEXCOORD_{}; only one set is read per mesh; {fallback}",
                self.path.display(),
                self.uv_set(m)
            ));
            return None;
        }
        let image = info.texture().source();
        let texture = match self.textures.get(&image.index()) {
            Some(t) => t.clone(),
            None => {
                let texture = match self
                    .image_bytes(&image)
                    .and_then(|bytes| Texture::decode(&bytes, Wrap::Repeat, TexelEncoding::Srgb))
                {
                    Ok(t) => Some(Arc::new(t)),
                    Err(e) => {
                        self.warnings.push(format!(
                            "{}: warning: material {material}: image {}: {e}; {fallback}",
                            self.path.display(),
                            image.index()
                        ));
                        None
                    }
                };
                self.textures.insert(image.index(), texture.clone());
                texture
            }
        }?;
        Some(match transform {
            Some(t) => Arc::new(texture.transformed(t.transform)),
            None => texture,
        })
    }

    /// The encoded bytes of `image`: a slice of a buffer (checked against
    /// its end), a `data:` URI, or a file beside the model (only when the
    /// model was read from a folder, and only a regular file). Read from the
    /// JSON: the crate's `Image::source` unwraps a missing URI and a missing
    /// MIME type of a buffer view, which its validation lets through.
    fn image_bytes(&self, image: &gltf::Image) -> Result<Cow<'_, [u8]>, String> {
        let json = &self.doc.as_json().images[image.index()];
        let view = match &json.buffer_view {
            Some(index) => Some(
                self.doc
                    .views()
                    .nth(index.value())
                    .ok_or("its buffer view does not exist")?,
            ),
            None => None,
        };
        match (view, &json.uri) {
            (Some(view), _) => {
                let buffer = self
                    .buffers
                    .get(view.buffer().index())
                    .ok_or("its buffer view refers to a missing buffer")?;
                view.offset()
                    .checked_add(view.length())
                    .and_then(|end| buffer.get(view.offset()..end))
                    .map(Cow::Borrowed)
                    .ok_or_else(|| "its buffer view runs beyond the end of its buffer".into())
            }
            (None, Some(uri)) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, data) = rest
                        .split_once(";base64,")
                        .ok_or("a data: URI that is not base64")?;
                    return base64::decode(data)
                        .map(Cow::Owned)
                        .map_err(|e| format!("bad base64 in its data: URI ({e})"));
                }
                let file = match (uri_file(uri, self.base)?, self.base) {
                    (Some(file), Some(_)) => file,
                    _ => return Err("its URI names no file that can be read here".into()),
                };
                if !is_regular_file(&file) {
                    return Err(format!("'{}' is not a readable file", file.display()));
                }
                std::fs::read(&file)
                    .map(Cow::Owned)
                    .map_err(|e| format!("cannot read '{}': {e}", file.display()))
            }
            (None, None) => Err("it has neither a URI nor a buffer view".into()),
        }
    }

    fn primitive(&self, mesh: usize, prim: &gltf::Primitive) -> Result<MeshData, LoadError> {
        let uv_set = self.uv_set(&prim.material());
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(self.err(format!("mesh {mesh}: a primitive has no POSITION")));
        };
        self.check_accessor(mesh, &pos_acc, Usage::Vectors)?;
        // The crate's readers underflow on an empty accessor: read none.
        // Normals that do not match the positions one to one are dropped.
        let normal_acc = prim
            .get(&gltf::Semantic::Normals)
            .filter(|a| a.count() == pos_acc.count());
        if let Some(a) = &normal_acc {
            self.check_accessor(mesh, a, Usage::Vectors)?;
        }
        // Texture coordinates (the set the material's textures use),
        // likewise.
        let uv_acc = prim
            .get(&gltf::Semantic::TexCoords(uv_set))
            .filter(|a| a.count() == pos_acc.count());
        if let Some(a) = &uv_acc {
            self.check_accessor(mesh, a, Usage::TexCoords)?;
        }
        // Vertex colours (linear by the specification), likewise.
        let color_acc = prim
            .get(&gltf::Semantic::Colors(0))
            .filter(|a| a.count() == pos_acc.count());
        if let Some(a) = &color_acc {
            self.check_accessor(mesh, a, Usage::Colors)?;
        }
        if let Some(a) = prim.indices() {
            self.check_accessor(mesh, &a, Usage::Indices)?;
        }
        if pos_acc.count() == 0 || prim.indices().is_some_and(|a| a.count() == 0) {
            return Ok(MeshData::default());
        }
        let buffers = &self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).copied());
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| self.err(format!("mesh {mesh}: cannot read POSITION")))?
            .map(Vec3::from)
            .collect();
        let normals: Option<Vec<Vec3>> = normal_acc
            .is_some()
            .then(|| reader.read_normals().map(|it| it.map(Vec3::from).collect()))
            .flatten()
            .filter(|n: &Vec<Vec3>| n.len() == positions.len());
        // glTF's v runs down the image, ours (the course's) up.
        let uvs: Option<Vec<Vec2>> = uv_acc
            .is_some()
            .then(|| {
                reader
                    .read_tex_coords(uv_set)
                    .map(|it| it.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).collect())
            })
            .flatten()
            .filter(|t: &Vec<Vec2>| t.len() == positions.len());
        // COLOR_0 multiplies the base colour factor (the texture, when there
        // is one, is multiplied in at the hit).
        let factor =
            Vec3::from_slice(&prim.material().pbr_metallic_roughness().base_color_factor()[..3])
                .clamp(Vec3::ZERO, Vec3::ONE);
        let colors: Option<Vec<Vec3>> = color_acc
            .is_some()
            .then(|| {
                reader.read_colors(0).map(|it| {
                    it.into_rgb_f32()
                        .map(|c| Vec3::from(c).clamp(Vec3::ZERO, Vec3::ONE) * factor)
                        .collect()
                })
            })
            .flatten()
            .filter(|c: &Vec<Vec3>| c.len() == positions.len());
        let indices: Vec<u32> = match reader.read_indices() {
            Some(it) => it.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(self.err(format!(
                "mesh {mesh}: vertex index {bad} is out of range ({} vertices)",
                positions.len()
            )));
        }
        let mut data = MeshData {
            triangles: assemble(prim.mode(), &indices),
            positions,
            normals,
            uvs,
            colors,
        };
        super::check_finite(self.path, &data.positions)?;
        super::sanitize_normals(&mut data);
        Ok(data)
    }
}

/// The triangles of a primitive's index list in its mode (glTF 2.0,
/// "Meshes"): lists in threes; strips with every other triangle's winding
/// turned, so all face one way; fans around the first vertex. In strips and
/// fans a triangle that repeats a vertex (a restart) is dropped.
fn assemble(mode: Mode, ix: &[u32]) -> Vec<[u32; 3]> {
    let distinct = |t: &[u32; 3]| t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
    match mode {
        Mode::TriangleStrip => (0..ix.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [ix[i], ix[i + 1], ix[i + 2]]
                } else {
                    [ix[i], ix[i + 2], ix[i + 1]]
                }
            })
            .filter(distinct)
            .collect(),
        Mode::TriangleFan => (1..ix.len().saturating_sub(1))
            .map(|i| [ix[i], ix[i + 1], ix[0]])
            .filter(distinct)
            .collect(),
        _ => ix.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_triangles_facing_one_way() {
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 2, 3, 4]),
            [[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
        assert_eq!(
            assemble(Mode::TriangleFan, &[0, 1, 2, 3]),
            [[1, 2, 0], [2, 3, 0]]
        );
        // A restart (repeated vertex) yields no triangle.
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 1, 2]),
            Vec::<[u32; 3]>::new()
        );
        assert_eq!(assemble(Mode::Triangles, &[0, 1, 2, 3]), [[0, 1, 2]]);
    }

    #[test]
    fn json_checks_before_the_crate() {
        let p = Path::new("m.gltf");
        let e = prepare_json(br#"{"asset":{"version":"1.0"}}"#, p).unwrap_err();
        assert_eq!(
            e.to_string(),
            "m.gltf: a glTF 1.0 file; arbor reads glTF 2.0"
        );
        let e = prepare_json(br#"{"asset":{"version":1}}"#, p).unwrap_err();
        assert_eq!(e.to_string(), "m.gltf: a glTF 1 file; arbor reads glTF 2.0");
        let e = prepare_json(
            br#"{"asset":{"version":"2.0"},"extensionsRequired":["KHR_draco_mesh_compression","KHR_draco_mesh_compression"]}"#,
            p,
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "m.gltf: the file requires the glTF extension KHR_draco_mesh_compression, which arbor does not read"
        );
        // Optional parts filled in: a scene's nodes, no default scene.
        let fixed = prepare_json(br#"{"asset":{"version":"2.0"},"scene":0}"#, p)
            .unwrap()
            .unwrap();
        let v: gltf::json::Value = gltf::json::deserialize::from_slice(&fixed).unwrap();
        assert!(v.get("scene").is_none());
        let fixed = prepare_json(br#"{"asset":{"version":"2.0"},"scenes":[{}]}"#, p)
            .unwrap()
            .unwrap();
        let v: gltf::json::Value = gltf::json::deserialize::from_slice(&fixed).unwrap();
        assert_eq!(
            v.pointer("/scenes/0/nodes"),
            Some(&gltf::json::Value::Array(vec![]))
        );
        assert!(prepare_json(br#"{"asset":{"version":"2.0"}}"#, p)
            .unwrap()
            .is_none());
    }
}
