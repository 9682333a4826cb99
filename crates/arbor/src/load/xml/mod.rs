//! The Cornell course's XML scene format, both variants (2010 and 2015), as
//! specified in `docs/cornell-scene-format.md` of the shared material and
//! summarised with our extensions in `docs/scene-format.md`.
//!
//! Element names are case-insensitive; `type`, `name` and `ref` attributes
//! work on any element; names must be defined before they are used. Every
//! error names the file, line and column of the offending element and what
//! was expected there.

use crate::hash_map::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use roxmltree::{Document, Node};

use crate::camera::{Camera, CameraKind};
use crate::light::Light;
use crate::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_NESTING, MAX_SAMPLES};
use crate::load::{load_mesh, Format, LoadError, ObjRule};
use crate::scene::{LoadedScene, Scene, Variant};
use crate::shader::Shader;
use crate::surface::{MeshData, Surface};
use crate::texture::{CubeMap, TexelEncoding, Texture, Wrap};

mod shader;
mod surface;
mod values;

pub use values::{parse_int, parse_number, parse_size, parse_vector};

/// Reads and parses the scene file at `path`; meshes are resolved relative
/// to its folder.
pub fn load_scene(path: &Path) -> Result<LoadedScene> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| LoadError::file(path, format!("cannot read scene file: {e}")))?;
    parse_scene(&text, path)
}

/// Parses scene text; `path` names it in messages and anchors relative mesh
/// file names.
pub fn parse_scene(text: &str, path: &Path) -> Result<LoadedScene> {
    let doc = Document::parse(text).map_err(|e| {
        let pos = e.pos();
        LoadError::at_column(
            path,
            pos.row as usize,
            pos.col as usize,
            format!("malformed XML: {e}"),
        )
    })?;
    let root = doc.root_element();
    let variant = detect_variant(root);
    let mut loader = Loader {
        doc: &doc,
        path,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        variant,
        names: HashMap::default(),
        warnings: Vec::new(),
        meshes: HashMap::default(),
        depth: 0,
        pending: HashMap::default(),
        resolving: Vec::new(),
    };
    let scene = loader.scene(root)?;
    Ok(LoadedScene {
        scene,
        warnings: loader.warnings,
    })
}

/// Spec §1: a `type` attribute on `<camera>` marks the 2015 variant.
fn detect_variant(root: Node) -> Variant {
    let typed_camera = root
        .children()
        .filter(Node::is_element)
        .any(|c| c.tag_name().name().eq_ignore_ascii_case("camera") && c.has_attribute("type"));
    if typed_camera {
        Variant::Cornell2015
    } else {
        Variant::Cornell2010
    }
}

/// Something stored under a `name=` for later `ref=`.
#[derive(Clone)]
enum Named {
    Shader(Arc<Shader>),
    Surface(Arc<Surface>),
    Camera(Camera),
    Light(Light),
    Texture(Arc<Texture>),
    /// The text of a value element (vectors, numbers, file names), reparsed
    /// wherever it is referenced.
    Text(String),
    /// An object element whose kind is not reusable by reference.
    Other(&'static str),
}

impl Named {
    fn kind(&self) -> &'static str {
        match self {
            Named::Shader(_) => "shader",
            Named::Surface(_) => "surface",
            Named::Camera(_) => "camera",
            Named::Light(_) => "light",
            Named::Texture(_) => "texture",
            Named::Text(_) => "value",
            Named::Other(k) => k,
        }
    }
}

struct Loader<'a, 'input> {
    doc: &'a Document<'input>,
    path: &'a Path,
    dir: PathBuf,
    variant: Variant,
    names: HashMap<String, Named>,
    warnings: Vec<String>,
    meshes: HashMap<PathBuf, Arc<MeshData>>,
    depth: usize,
    /// `<defs>` entries not parsed yet, by name: definitions may refer to
    /// each other in any order, so each is parsed when first needed.
    pending: HashMap<String, Node<'a, 'input>>,
    /// The definitions being parsed, outermost first (to report cycles).
    resolving: Vec<String>,
}

type Result<T> = std::result::Result<T, LoadError>;

/// The element's name as written.
fn tag<'a>(node: Node<'a, '_>) -> &'a str {
    node.tag_name().name()
}

/// The element's name folded for case-insensitive matching.
fn key(node: Node) -> String {
    tag(node).to_ascii_lowercase()
}

fn elements<'a, 'input>(node: Node<'a, 'input>) -> impl Iterator<Item = Node<'a, 'input>> {
    node.children().filter(Node::is_element)
}

impl<'a, 'input> Loader<'a, 'input> {
    fn error(&self, node: Node, message: impl Into<String>) -> LoadError {
        let pos = self.doc.text_pos_at(node.range().start);
        LoadError::at_column(self.path, pos.row as usize, pos.col as usize, message)
    }

    fn warn(&mut self, node: Node, message: impl fmt::Display) {
        let pos = self.doc.text_pos_at(node.range().start);
        self.warnings.push(format!(
            "{}:{}:{}: warning: {message}",
            self.path.display(),
            pos.row,
            pos.col
        ));
    }

    fn is2015(&self) -> bool {
        self.variant == Variant::Cornell2015
    }

    fn unknown_element(&self, child: Node, parent: &str, expected: &[&str]) -> LoadError {
        self.error(
            child,
            format!(
                "unknown element <{}> in {parent}; expected {}",
                tag(child),
                expected.join(", ")
            ),
        )
    }

    /// Warns about attributes other than `type`, `name` and `ref`.
    fn check_attributes(&mut self, node: Node) {
        let unknown: Vec<String> = node
            .attributes()
            .filter(|a| !matches!(a.name(), "type" | "name" | "ref"))
            .map(|a| a.name().to_string())
            .collect();
        for name in unknown {
            self.warn(
                node,
                format!("ignoring unknown attribute '{name}' on <{}>", tag(node)),
            );
        }
    }

    /// The object stored under the element's `ref`, if it has one.
    fn referenced(&self, node: Node) -> Result<Option<Named>> {
        let Some(name) = node.attribute("ref") else {
            return Ok(None);
        };
        match self.names.get(name) {
            Some(n) => Ok(Some(n.clone())),
            None => Err(self.error(
                node,
                format!(
                    "<{} ref=\"{name}\">: no element named '{name}' is defined before this point",
                    tag(node)
                ),
            )),
        }
    }

    /// What `node`'s `ref` names, when it has one: an error when the name
    /// is unknown or names another kind than `expected` (a
    /// [`Named::kind`], one per variant), so that the caller's pattern of
    /// that variant matches.
    fn referenced_kind(&self, node: Node, expected: &str) -> Result<Option<Named>> {
        match self.referenced(node)? {
            Some(named) if named.kind() != expected => Err(self.wrong_kind(node, &named, expected)),
            found => Ok(found),
        }
    }

    fn remember(&mut self, node: Node, value: Named) {
        if let Some(name) = node.attribute("name") {
            self.names.insert(name.to_string(), value);
        }
    }

    fn wrong_kind(&self, node: Node, found: &Named, expected: &str) -> LoadError {
        self.error(
            node,
            format!(
                "<{} ref=\"{}\"> names a {}, but a {expected} is expected here",
                tag(node),
                node.attribute("ref").unwrap_or_default(),
                found.kind()
            ),
        )
    }

    /// The text of a value element (following `ref` to a stored value).
    fn text(&mut self, node: Node) -> Result<String> {
        self.check_attributes(node);
        if let Some(Named::Text(t)) = self.referenced_kind(node, "value")? {
            return Ok(t);
        }
        let mut text = String::new();
        for child in node.children() {
            if child.is_element() {
                return Err(self.error(
                    child,
                    format!(
                        "unexpected element <{}> inside the value element <{}>",
                        tag(child),
                        tag(node)
                    ),
                ));
            }
            if child.is_comment() {
                return Err(self.error(
                    node,
                    format!(
                        "a comment inside the value element <{}> is not allowed",
                        tag(node)
                    ),
                ));
            }
            if let Some(t) = child.text() {
                text.push_str(t);
            }
        }
        if text.trim().is_empty() {
            return Err(self.error(node, format!("<{}> is empty; expected a value", tag(node))));
        }
        self.remember(node, Named::Text(text.clone()));
        Ok(text)
    }

    fn value<T>(
        &mut self,
        node: Node,
        parse: impl FnOnce(&str) -> std::result::Result<T, String>,
    ) -> Result<T> {
        let text = self.text(node)?;
        parse(&text).map_err(|m| self.error(node, format!("<{}>: {m}", tag(node))))
    }

    fn number(&mut self, node: Node) -> Result<f64> {
        self.value(node, parse_number)
    }

    fn vector(&mut self, node: Node) -> Result<DVec3> {
        self.value(node, parse_vector)
    }

    fn positive(&mut self, node: Node) -> Result<f64> {
        let v = self.number(node)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.error(node, format!("<{}> must be positive, found {v}", tag(node))))
        }
    }

    fn scene(&mut self, root: Node<'a, 'input>) -> Result<Scene> {
        self.check_attributes(root);
        let mut camera = None;
        let mut size = None;
        let mut samples = 1;
        let mut lights = Vec::new();
        let mut surfaces = Vec::new();
        let mut background = DVec3::ZERO;
        let mut exposure = 1.0;
        let mut cubemap = None;
        let mut expected = vec![
            "camera", "image", "samples", "light", "surface", "shader", "defs",
        ];
        if self.is2015() {
            expected.extend(["backColor", "exposure", "cubemap"]);
        }
        for child in elements(root) {
            match key(child).as_str() {
                "camera" => camera = Some(self.camera(child)?),
                "image" => size = Some(self.image_size(child)?),
                "samples" => {
                    let n = self.value(child, parse_int)?;
                    if !(0..=MAX_SAMPLES).contains(&n) {
                        return Err(self.error(
                            child,
                            format!("<samples> must be between 0 and {MAX_SAMPLES}, found {n}"),
                        ));
                    }
                    samples = Scene::samples_per_side_for(n as u32);
                }
                "light" => lights.push(self.light(child)?),
                "defs" => self.defs(child)?,
                "surface" => surfaces.push(self.surface(child)?),
                "shader" => {
                    self.shader(child)?;
                }
                "backcolor" if self.is2015() => background = self.vector(child)?,
                "exposure" if self.is2015() => {
                    // Spec §2.6: a value <= 0 is ignored.
                    let e = self.number(child)?;
                    if e > 0.0 {
                        exposure = e;
                    }
                }
                "cubemap" if self.is2015() => cubemap = Some(self.cubemap(child)?),
                "backcolor" | "exposure" | "cubemap" => {
                    return Err(self.error(
                        child,
                        format!(
                            "<{}> belongs to the 2015 variant of the format, but this scene is a 2010 scene (its <camera> has no type attribute)",
                            tag(child)
                        ),
                    ))
                }
                _ => return Err(self.unknown_element(child, &format!("<{}>", tag(root)), &expected)),
            }
        }
        let camera =
            camera.ok_or_else(|| self.error(root, "the scene has no <camera>; expected one"))?;
        let (width, height) = size.ok_or_else(|| {
            self.error(
                root,
                "the scene has no <image> size; expected <image>WIDTH HEIGHT</image>",
            )
        })?;
        Ok(Scene {
            variant: self.variant,
            camera,
            width,
            height,
            samples_per_side: samples,
            lights,
            surfaces,
            background,
            exposure,
            cubemap,
        })
    }

    fn image_size(&mut self, node: Node) -> Result<(u32, u32)> {
        let (w, h) = self.value(node, parse_size)?;
        if w < 1 || h < 1 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE || w * h > MAX_IMAGE_PIXELS {
            return Err(self.error(
                node,
                format!(
                    "<image> size {w} x {h} is out of range; expected sides from 1 to {MAX_IMAGE_SIDE} and at most {MAX_IMAGE_PIXELS} pixels"
                ),
            ));
        }
        Ok((w as u32, h as u32))
    }

    fn camera(&mut self, node: Node) -> Result<Camera> {
        self.check_attributes(node);
        if let Some(Named::Camera(c)) = self.referenced_kind(node, "camera")? {
            return Ok(c);
        }
        let mut cam = Camera::default_2010();
        if self.is2015() {
            cam.proj_normal = DVec3::ZERO;
            cam.kind = match node.attribute("type") {
                Some("PerspectiveCamera") => CameraKind::Perspective2015,
                Some("ParallelCamera") | Some("OrthographicCamera") => CameraKind::Parallel2015,
                Some(other) => {
                    return Err(self.error(
                        node,
                        format!("unknown camera type '{other}'; expected PerspectiveCamera, ParallelCamera or OrthographicCamera"),
                    ))
                }
                None => unreachable!("2015 scenes are recognised by the camera type"),
            };
        }
        let expected = [
            "viewPoint",
            "viewDir",
            "viewUp",
            "projNormal",
            "projDistance",
            "viewWidth",
            "viewHeight",
        ];
        for child in elements(node) {
            match key(child).as_str() {
                "viewpoint" => cam.view_point = self.vector(child)?,
                "viewdir" => cam.view_dir = self.nonzero_vector(child)?,
                "viewup" => cam.view_up = self.nonzero_vector(child)?,
                "projnormal" => cam.proj_normal = self.vector(child)?,
                "projdistance" if cam.kind == CameraKind::Parallel2015 => {
                    return Err(
                        self.error(child, "<projDistance> does not apply to a parallel camera")
                    )
                }
                "projdistance" => cam.proj_distance = self.positive(child)?,
                "viewwidth" => cam.view_width = self.positive(child)?,
                "viewheight" => cam.view_height = self.positive(child)?,
                _ => return Err(self.unknown_element(child, "<camera>", &expected)),
            }
        }
        if cam.kind == CameraKind::Perspective2010 && cam.proj_normal == DVec3::ZERO {
            return Err(self.error(node, "<projNormal> must not be the zero vector"));
        }
        if cam.view_up.cross(cam.view_dir) == DVec3::ZERO {
            return Err(self.error(node, "<viewUp> is parallel to <viewDir>; expected an up direction that differs from the view direction"));
        }
        self.remember(node, Named::Camera(cam.clone()));
        Ok(cam)
    }

    fn nonzero_vector(&mut self, node: Node) -> Result<DVec3> {
        let v = self.vector(node)?;
        if v == DVec3::ZERO {
            return Err(self.error(node, format!("<{}> must not be the zero vector", tag(node))));
        }
        Ok(v)
    }

    fn light(&mut self, node: Node) -> Result<Light> {
        self.check_attributes(node);
        if let Some(Named::Light(l)) = self.referenced_kind(node, "light")? {
            return Ok(l);
        }
        let directional = match (self.variant, node.attribute("type")) {
            (_, None) => false,
            (Variant::Cornell2015, Some("PointLight")) => false,
            (Variant::Cornell2015, Some("DirectionalLight")) => true,
            (Variant::Cornell2015, Some(other)) => {
                return Err(self.error(
                    node,
                    format!(
                        "unknown light type '{other}'; expected PointLight or DirectionalLight"
                    ),
                ))
            }
            (Variant::Cornell2010, Some(other)) => {
                return Err(self.error(
                    node,
                    format!(
                        "unknown light type '{other}'; 2010 scenes use untyped <light> elements"
                    ),
                ))
            }
        };
        let mut position = DVec3::ZERO;
        let mut direction = None;
        let mut intensity = DVec3::ONE;
        let expected: &[&str] = if directional {
            &["direction", "intensity"]
        } else {
            &["position", "intensity"]
        };
        for child in elements(node) {
            match key(child).as_str() {
                "position" if !directional => position = self.vector(child)?,
                "direction" if directional => direction = Some(self.nonzero_vector(child)?),
                "intensity" => intensity = self.vector(child)?,
                _ => return Err(self.unknown_element(child, "<light>", expected)),
            }
        }
        let light = if directional {
            let direction = direction.ok_or_else(|| {
                self.error(
                    node,
                    "a DirectionalLight needs a <direction> (toward the light)",
                )
            })?;
            Light::Directional {
                direction: direction.normalize(),
                intensity,
            }
        } else {
            Light::Point {
                position,
                intensity,
            }
        };
        self.remember(node, Named::Light(light.clone()));
        Ok(light)
    }

    fn texture(&mut self, node: Node) -> Result<Arc<Texture>> {
        self.check_attributes(node);
        if let Some(Named::Texture(t)) = self.referenced_kind(node, "texture")? {
            return Ok(t);
        }
        let wrap = match node.attribute("type") {
            Some("ClampTexture") => Wrap::Clamp,
            Some("RepeatTexture") => Wrap::Repeat,
            other => {
                return Err(self.error(
                    node,
                    format!(
                        "unknown texture type '{}'; expected ClampTexture or RepeatTexture",
                        other.unwrap_or("")
                    ),
                ))
            }
        };
        let mut file = None;
        for child in elements(node) {
            match key(child).as_str() {
                "image" => file = Some((child, self.text(child)?.trim().to_string())),
                _ => return Err(self.unknown_element(child, "<texture>", &["image"])),
            }
        }
        let (at, file) =
            file.ok_or_else(|| self.error(node, "a texture needs an <image> file name"))?;
        let path = self.dir.join(&file);
        let texture = Arc::new(Texture::load(&path, wrap, TexelEncoding::Raw).map_err(|e| {
            self.error(
                at,
                format!("cannot read texture image '{}': {e}", path.display()),
            )
        })?);
        self.remember(node, Named::Texture(texture.clone()));
        Ok(texture)
    }

    fn cubemap(&mut self, node: Node) -> Result<Arc<CubeMap>> {
        self.check_attributes(node);
        let mut file = None;
        let mut scale = 1.0;
        for child in elements(node) {
            match key(child).as_str() {
                "filename" => file = Some((child, self.text(child)?.trim().to_string())),
                "scalefactor" => scale = self.number(child)?,
                _ => {
                    return Err(self.unknown_element(
                        child,
                        "<cubemap>",
                        &["filename", "scaleFactor"],
                    ))
                }
            }
        }
        let (at, file) = file.ok_or_else(|| self.error(node, "a <cubemap> needs a <filename>"))?;
        // The framework resolves it against the working directory; we also
        // look beside the scene, where users keep it.
        let candidates = [PathBuf::from(&file), self.dir.join(&file)];
        let path = candidates
            .iter()
            .find(|p| p.is_file())
            .ok_or_else(|| self.error(at, format!("cube map file '{file}' not found (looked in the working directory and beside the scene)")))?;
        let map = crate::texture::read_pfm_cubemap(path, scale)
            .map_err(|m| self.error(at, format!("{}: {m}", path.display())))?;
        let map = Arc::new(map);
        self.remember(node, Named::Other("cubemap"));
        Ok(map)
    }

    /// `<defs>`: named surfaces that are not rendered by themselves, only
    /// placed by `<surface ref="NAME"/>`. They may refer to each other in any
    /// order; a cycle is an error naming its members.
    fn defs(&mut self, node: Node<'a, 'input>) -> Result<()> {
        self.check_attributes(node);
        let mut order = Vec::new();
        for child in elements(node) {
            if key(child) != "surface" {
                return Err(self.unknown_element(child, "<defs>", &["surface"]));
            }
            if child.has_attribute("ref") {
                return Err(self.error(
                    child,
                    "a definition in <defs> cannot itself be a ref; give it a type",
                ));
            }
            let Some(name) = child.attribute("name") else {
                return Err(self.error(
                    child,
                    "every surface in <defs> needs a name=\"...\" to be placed by",
                ));
            };
            if self.pending.insert(name.to_string(), child).is_some() {
                return Err(self.error(child, format!("'{name}' is defined twice in <defs>")));
            }
            order.push(name.to_string());
        }
        for name in order {
            if let Some(def) = self.pending.get(&name).copied() {
                self.resolve(&name, def)?;
            }
        }
        Ok(())
    }

    /// Parses the pending definition `name` now (it is needed by a `ref`).
    fn resolve(&mut self, name: &str, def: Node<'a, 'input>) -> Result<()> {
        if let Some(start) = self.resolving.iter().position(|n| n == name) {
            let mut cycle = self.resolving[start..].to_vec();
            cycle.push(name.to_string());
            return Err(self.error(
                def,
                format!("definitions form a cycle: {}", cycle.join(" -> ")),
            ));
        }
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.error(
                def,
                format!("definitions refer to each other more than {MAX_NESTING} deep"),
            ));
        }
        self.resolving.push(name.to_string());
        self.surface(def)?;
        self.resolving.pop();
        self.pending.remove(name);
        self.depth -= 1;
        Ok(())
    }

    fn mesh(&mut self, at: Node, file: &str) -> Result<Arc<MeshData>> {
        let path = self.dir.join(file);
        if let Some(m) = self.meshes.get(&path) {
            return Ok(m.clone());
        }
        if !path.is_file() {
            return Err(self.error(at, format!("mesh file '{}' not found", path.display())));
        }
        let format = Format::from_path(&path).map_err(|e| self.error(at, e.to_string()))?;
        if !format.is_mesh() {
            return Err(self.error(
                at,
                format!(
                    "mesh file '{file}' is a .{} file; expected a {} mesh",
                    format.extension(),
                    Format::listed(Format::is_mesh)
                ),
            ));
        }
        let loaded = load_mesh(&path, ObjRule::Cornell2015)?;
        if loaded.skipped_polygons > 0 {
            self.warn(
                at,
                format!(
                    "{}: skipped {} faces with more than 3 corners (the 2015 reader accepts triangles only)",
                    path.display(),
                    loaded.skipped_polygons
                ),
            );
        }
        let data = loaded.mesh;
        let data = Arc::new(data);
        self.meshes.insert(path, data.clone());
        Ok(data)
    }
}
