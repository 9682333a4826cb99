//! Wavefront OBJ import with MTL materials, through `tobj`.
//!
//! A first pass of our own checks every line that `tobj` would reject or
//! silently misread and reports it with its line number (`tobj` reports
//! errors without one); it also hands `tobj` a normalised copy of the text:
//! numbers are re-printed, so forms that C's `atof` accepts and Rust's
//! parser does not (`3.1+e2`, read as 3.1) still load, with a warning; and
//! text that is not UTF-8 is made so (it can only matter in comments and
//! names). `tobj` then does the OBJ semantics (objects, groups, `usemtl`,
//! the material library); polygons come back untriangulated and are
//! triangulated by ear clipping ([`super::triangulate`]), correct for
//! concave faces where `tobj`'s fan is not.
//!
//! # Materials (MTL → shaders)
//!
//! | MTL | shader |
//! | --- | --- |
//! | `illum` 4, 6 or 7, or `d` < 1 together with `Ni` > 1 | Glass, refractive index `Ni` (1.5 when `Ni` is absent or ≤ 1) |
//! | `illum` 3 or 5 | Glazed (a mirror-like coat, index `Ni` or 1.5) over the shader below |
//! | `Ks` not black and `Ns` ≥ 1 | Phong: diffuse `Kd`, specular `Ks`, exponent `Ns` |
//! | otherwise | Lambertian, diffuse `Kd` |
//!
//! `Kd` defaults to 0.8 grey when a material has none. `Ns` below 1 would be
//! a highlight as wide as the hemisphere (a uniform wash of `Ks`), so such
//! materials stay Lambertian. Faces with no material, or one the library
//! does not define, get [`super::default_shader`]; a missing or unreadable
//! library is a warning, not an error.

use crate::hash_map::HashMap;
use std::cell::RefCell;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DVec3, Vec2, Vec3};

use super::mtl;
use super::triangulate::triangulate;
use super::{default_shader, shorten, Model, ModelStats};
use crate::load::{LoadError, MeshData};
use crate::shader::{Fresnel, Shader};
use crate::surface::{MeshSurface, Surface};
use crate::texture::{srgb_to_linear, TexelEncoding, Texture, Wrap};

/// Imports the OBJ file at `path` with its material library.
pub fn load(path: &Path) -> Result<Model, LoadError> {
    let bytes = super::read_bytes(path)?;
    let text = super::decode_text(&bytes, path)?;
    let mut warnings = Vec::new();
    let clean = prepass(&text, path, &mut warnings)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let (models, materials) = parse(&clean, path, &dir, &mut warnings)?;
    let mut meshes = Meshes {
        ignored: Vec::new(),
        shaders: HashMap::default(),
        textures: Textures::new(&dir),
        default: default_shader(),
        surfaces: Vec::new(),
        stats: ModelStats::default(),
        undefined_material: false,
    };
    for m in &models {
        let Some(data) = mesh_data(&m.mesh) else {
            continue;
        };
        meshes.add(data, m.mesh.material_id, &materials, path, &mut warnings)?;
    }
    let Meshes {
        ignored,
        surfaces,
        stats,
        undefined_material,
        ..
    } = meshes;
    warnings.extend(super::ignored_features_warning(path, &ignored));
    if undefined_material {
        warnings.push(format!(
            "{}: warning: faces use a material the library does not define; they get the default material",
            path.display()
        ));
    }
    if surfaces.is_empty() {
        return Err(LoadError::file(
            path,
            "the file has no faces to render (an empty file or a point cloud?)",
        ));
    }
    Ok(Model {
        surfaces,
        warnings,
        stats,
        ..Model::default()
    })
}

/// `tobj`'s reading of the checked text `clean` of the OBJ file `path`:
/// its models and the materials of its libraries (read from `dir`; a
/// missing or unreadable library is a warning and no materials).
fn parse(
    clean: &str,
    path: &Path,
    dir: &Path,
    warnings: &mut Vec<String>,
) -> Result<(Vec<tobj::Model>, Vec<tobj::Material>), LoadError> {
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Libraries are read by us (any encoding, warnings naming them); tobj
    // only merges what they hold.
    let library_warnings = RefCell::new(Vec::new());
    let (models, materials) =
        tobj::load_obj_buf(&mut Cursor::new(clean.as_bytes()), &options, |p| {
            let p = dir.join(p);
            let mut warnings = library_warnings.borrow_mut();
            let materials = if p.is_file() {
                mtl::load_library(&p, &mut warnings)
            } else {
                warnings.push(format!(
                    "{}: warning: the material library named by {} is not there; using the default material",
                    p.display(),
                    path.display()
                ));
                Vec::new()
            };
            let names = mtl::index(&materials);
            Ok((materials, names))
        })
        .map_err(|e| LoadError::file(path, format!("malformed OBJ file: {e}")))?;
    warnings.extend(library_warnings.into_inner());
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            warnings.push(format!(
                "{}: warning: cannot load the material library ({e}); using the default material",
                path.display()
            ));
            Vec::new()
        }
    };
    Ok((models, materials))
}

/// One `tobj` mesh as our mesh data, its polygons triangulated; `None`
/// when no triangle is left.
fn mesh_data(mesh: &tobj::Mesh) -> Option<MeshData> {
    let positions: Vec<Vec3> = mesh
        .positions
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let mut data = MeshData {
        normals: (mesh.normals.len() == mesh.positions.len()).then(|| {
            mesh.normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect()
        }),
        colors: (mesh.vertex_color.len() == mesh.positions.len() && !positions.is_empty()).then(
            || {
                mesh.vertex_color
                    .chunks_exact(3)
                    .map(|c| {
                        let linear = |v: f32| srgb_to_linear(v as f64) as f32;
                        Vec3::new(linear(c[0]), linear(c[1]), linear(c[2]))
                    })
                    .collect()
            },
        ),
        uvs: (mesh.texcoords.len() / 2 == positions.len() && !positions.is_empty()).then(|| {
            mesh.texcoords
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], c[1]))
                .collect()
        }),
        triangles: Vec::new(),
        positions,
    };
    if mesh.face_arities.is_empty() {
        data.triangles = mesh
            .indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
    } else {
        let mut start = 0usize;
        for &arity in &mesh.face_arities {
            let end = start + arity as usize;
            let Some(face) = mesh.indices.get(start..end) else {
                break;
            };
            triangulate(&data.positions, face, &mut data.triangles);
            start = end;
        }
    }
    (!data.triangles.is_empty()).then_some(data)
}

/// The surfaces of an OBJ file as they are made, with the shaders made
/// for its materials so far.
struct Meshes<'a> {
    /// Material features the shaders leave out, named once for the model.
    ignored: Vec<&'static str>,
    shaders: HashMap<usize, Arc<Shader>>,
    textures: Textures<'a>,
    default: Arc<Shader>,
    surfaces: Vec<Surface>,
    stats: ModelStats,
    /// Whether some face names a material no library defines.
    undefined_material: bool,
}

impl Meshes<'_> {
    /// Checks and adds one mesh with the shader of its material.
    fn add(
        &mut self,
        mut data: MeshData,
        material_id: Option<usize>,
        materials: &[tobj::Material],
        path: &Path,
        warnings: &mut Vec<String>,
    ) -> Result<(), LoadError> {
        super::check_finite(path, &data.positions)?;
        super::sanitize_normals(&mut data);
        let shader = match material_id {
            Some(id) if id < materials.len() => {
                let (textures, ignored) = (&mut self.textures, &mut self.ignored);
                self.shaders
                    .entry(id)
                    .or_insert_with(|| {
                        let m = &materials[id];
                        let texture = m
                            .diffuse_texture
                            .as_deref()
                            .and_then(|name| textures.get(name, &m.name, path, warnings));
                        super::note_ignored(ignored, ignored_features(m));
                        shader_for(m, texture)
                    })
                    .clone()
            }
            Some(_) => {
                self.undefined_material = true;
                self.default.clone()
            }
            None => self.default.clone(),
        };
        let n = data.triangles.len() as u64;
        self.stats.meshes += 1;
        self.stats.placements += 1;
        self.stats.unique_triangles += n;
        self.stats.instanced_triangles += n;
        self.surfaces.push(Surface::Mesh(MeshSurface {
            data: Arc::new(data),
            shader,
            two_sided: true,
            soft_terminator: true,
        }));
        Ok(())
    }
}

/// The texture images of one OBJ file's materials (`map_Kd`), each read
/// once however many materials name it.
struct Textures<'a> {
    dir: &'a Path,
    loaded: HashMap<PathBuf, Arc<Texture>>,
}

impl<'a> Textures<'a> {
    fn new(dir: &'a Path) -> Self {
        Textures {
            dir,
            loaded: HashMap::default(),
        }
    }

    /// The texture `name` (from material `material` of the OBJ file `obj`),
    /// or `None` with a warning when no readable image goes by that name:
    /// a missing texture leaves the material's colour, it does not stop the
    /// render. Names are tried as written, then with `\` read as a folder
    /// separator (files written on Windows, `.\wood.jpg`), then as their
    /// last word (options such as `-s 1 1 1` before the name).
    fn get(
        &mut self,
        name: &str,
        material: &str,
        obj: &Path,
        warnings: &mut Vec<String>,
    ) -> Option<Arc<Texture>> {
        let slashed = name.replace('\\', "/");
        let last = slashed.split_whitespace().last().unwrap_or_default();
        let Some(path) = [name, slashed.as_str(), last]
            .iter()
            .map(|n| self.dir.join(n))
            .find(|p| p.is_file())
        else {
            warnings.push(format!(
                "{}: warning: material '{material}': texture '{name}' not found; its colour is used",
                obj.display()
            ));
            return None;
        };
        if let Some(t) = self.loaded.get(&path) {
            return Some(t.clone());
        }
        match Texture::load(&path, Wrap::Repeat, TexelEncoding::Srgb) {
            Ok(t) => {
                let t = Arc::new(t);
                self.loaded.insert(path, t.clone());
                Some(t)
            }
            Err(e) => {
                warnings.push(format!(
                    "{}: warning: material '{material}': cannot read texture '{}': {e}; its colour is used",
                    obj.display(),
                    path.display()
                ));
                None
            }
        }
    }
}

/// The shader for an MTL material (the table in the module documentation),
/// with its diffuse texture (`map_Kd`) when one was read: the texture
/// replaces the diffuse colour, as textures do in the Cornell scenes, and
/// wraps around (texture coordinates of models often leave `[0, 1]`).
pub fn shader_for(m: &tobj::Material, texture: Option<Arc<Texture>>) -> Arc<Shader> {
    let rgb = |c: Option<[f32; 3]>, default: f64| {
        c.map_or(DVec3::splat(default), |[r, g, b]| {
            DVec3::new(r as f64, g as f64, b as f64).clamp(DVec3::ZERO, DVec3::ONE)
        })
    };
    let kd = rgb(m.diffuse, 0.8);
    let ks = rgb(m.specular, 0.0);
    let ns = m.shininess.map_or(0.0, |n| n as f64);
    let ni = m
        .optical_density
        .map(|n| n as f64)
        .filter(|n| n.is_finite() && *n > 1.0);
    let illum = m.illumination_model;
    let dissolve = m.dissolve.map_or(1.0, |d| d as f64);
    if matches!(illum, Some(4 | 6 | 7)) || (dissolve < 1.0 && ni.is_some()) {
        return Arc::new(Shader::Glass {
            refractive_index: ni.unwrap_or(1.5),
        });
    }
    let base = if ks.max_element() > 0.0 && ns >= 1.0 {
        Shader::Phong {
            diffuse: kd,
            specular: ks,
            exponent: ns,
            texture: texture.clone(),
        }
    } else {
        Shader::Lambertian {
            diffuse: kd,
            texture,
        }
    };
    if matches!(illum, Some(3 | 5)) {
        return Arc::new(Shader::Glazed {
            refractive_index: ni.unwrap_or(1.5),
            substrate: Arc::new(base),
            fresnel: Fresnel::Exact,
        });
    }
    Arc::new(base)
}

/// What of MTL material `m` the shader from [`shader_for`] does not
/// render, named for a warning: maps other than `map_Kd`, emission,
/// transparency short of glass, and `illum` modes outside 1 to 7.
pub(super) fn ignored_features(m: &tobj::Material) -> Vec<&'static str> {
    let mut out = Vec::new();
    let maps = [
        (&m.normal_texture, "bump maps (map_Bump)"),
        (&m.specular_texture, "specular maps (map_Ks)"),
        (&m.shininess_texture, "shininess maps (map_Ns)"),
        (&m.dissolve_texture, "transparency maps (map_d)"),
        (&m.ambient_texture, "ambient maps (map_Ka)"),
    ];
    out.extend(
        maps.iter()
            .filter(|(t, _)| t.is_some())
            .map(|(_, name)| *name),
    );
    if m.emissive.is_some_and(|e| e.iter().any(|&c| c > 0.0)) {
        out.push("emission (Ke)");
    }
    let glass = matches!(m.illumination_model, Some(4 | 6 | 7))
        || (m.dissolve.is_some_and(|d| d < 1.0) && m.optical_density.is_some_and(|n| n > 1.0));
    if !glass && m.dissolve.is_some_and(|d| d < 1.0) {
        out.push("transparency (d below 1)");
    }
    match m.illumination_model {
        Some(0) => out.push("illum 0 (colour without lighting)"),
        Some(8 | 9) => out.push("illum 8 and 9 (reflection without ray tracing)"),
        Some(10) => out.push("illum 10 (shadow matte)"),
        _ => {}
    }
    let unknown = |k: &str| {
        [
            "map_", "bump", "disp", "decal", "refl", "norm", "Pr", "Pm", "Ps", "Pc",
        ]
        .iter()
        .any(|p| k.starts_with(p))
    };
    if m.unknown_param.keys().any(|k| unknown(k)) {
        out.push("other maps and PBR parameters (disp, decal, refl, norm, Pr, Pm...)");
    }
    out
}

/// Reads a number the way C's `atof` does: the longest prefix that is a
/// number. Returns the value and whether characters were left over.
fn lenient_number(token: &str) -> Option<(f32, bool)> {
    if let Ok(v) = token.parse::<f32>() {
        return Some((v, false));
    }
    // Rust accepts "inf" and "nan" spellings: those are not coordinates.
    (1..token.len())
        .rev()
        .filter(|&end| token.is_char_boundary(end))
        .find_map(|end| token[..end].parse::<f32>().ok())
        .filter(|v| v.is_finite())
        .map(|v| (v, true))
}

/// Checks the lines `tobj` would reject or misread and returns the text to
/// give it: vertex lines re-printed with clean numbers, bad `f` lines
/// reported with their line number.
fn prepass(text: &str, path: &Path, warnings: &mut Vec<String>) -> Result<String, LoadError> {
    let mut pass = Prepass::new(text, path);
    for (i, raw) in text.split('\n').enumerate() {
        pass.line(i + 1, raw)?;
    }
    pass.finish(warnings)
}

/// The state of [`prepass`]: the text for `tobj` so far and what was
/// counted on the way.
struct Prepass<'a> {
    path: &'a Path,
    out: String,
    /// Whether every `v` line carries a colour.
    colours: bool,
    /// Vertices, texture coordinates and normals defined so far (what a
    /// face corner may index).
    nv: i64,
    nt: i64,
    nn: i64,
    faces: usize,
    odd_numbers: usize,
    short_faces: usize,
    not_faces: usize,
    /// The line of the first number with trailing characters (0: none).
    first_odd: usize,
}

impl<'a> Prepass<'a> {
    fn new(text: &str, path: &'a Path) -> Self {
        Prepass {
            path,
            out: String::with_capacity(text.len() + 64),
            colours: every_vertex_has_a_colour(text),
            nv: 0,
            nt: 0,
            nn: 0,
            faces: 0,
            odd_numbers: 0,
            short_faces: 0,
            not_faces: 0,
            first_odd: 0,
        }
    }

    /// Checks line `line_no` and appends what `tobj` gets of it.
    fn line(&mut self, line_no: usize, raw: &str) -> Result<(), LoadError> {
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        let body = line.split_once('#').map_or(line, |(b, _)| b);
        let mut tokens = body.split_whitespace();
        let keyword = tokens.next().unwrap_or("");
        let needed = match keyword {
            "v" | "vn" => Some(3),
            "vt" => Some(1),
            _ => None,
        };
        if let Some(needed) = needed {
            return self.vertex_line(line_no, keyword, needed, tokens);
        }
        if keyword == "usemtl" && body.split_whitespace().nth(1).is_none() {
            // `usemtl` naming nothing (after a nameless `newmtl`): the faces
            // have no material. tobj refuses the empty name; a name no
            // library can define (a control character) gives the same.
            self.out.push_str("usemtl \u{1}\n");
            return Ok(());
        }
        if keyword == "l" || keyword == "p" {
            // Polylines and points have no area: not faces, not drawn.
            self.not_faces += 1;
            self.out.push('\n');
            return Ok(());
        }
        if keyword == "f" {
            let corners: Vec<&str> = tokens.collect();
            if corners.len() < 3 {
                self.short_faces += 1;
                self.out.push('\n');
                return Ok(());
            }
            for c in &corners {
                self.check_corner(line_no, c)?;
            }
            self.faces += 1;
        }
        self.out.push_str(line);
        self.out.push('\n');
        Ok(())
    }

    /// A `v`, `vt` or `vn` line (`needed` numbers at least): re-printed
    /// with its numbers read as `atof` reads them.
    fn vertex_line<'t>(
        &mut self,
        line_no: usize,
        keyword: &str,
        needed: usize,
        tokens: impl Iterator<Item = &'t str>,
    ) -> Result<(), LoadError> {
        let mut values = Vec::with_capacity(3);
        let take = match keyword {
            "vt" => 2,
            "v" if self.colours => 6,
            _ => 3,
        };
        for tok in tokens.take(take) {
            let Some((v, odd)) = lenient_number(tok) else {
                return Err(LoadError::at(
                    self.path,
                    line_no,
                    format!("'{keyword}' expects numbers, found '{}'", shorten(tok)),
                ));
            };
            if odd {
                self.odd_numbers += 1;
                if self.first_odd == 0 {
                    self.first_odd = line_no;
                }
            }
            values.push(v);
        }
        if values.len() < needed {
            return Err(LoadError::at(
                self.path,
                line_no,
                format!("'{keyword}' expects {needed} numbers or more"),
            ));
        }
        self.out.push_str(keyword);
        for v in &values {
            self.out.push(' ');
            self.out.push_str(&v.to_string());
        }
        self.out.push('\n');
        match keyword {
            "v" => self.nv += 1,
            "vt" => self.nt += 1,
            _ => self.nn += 1,
        }
        Ok(())
    }

    /// Checks face corner `c` (`v`, `v/t`, `v//n` or `v/t/n`): well formed,
    /// every index naming something defined above it.
    fn check_corner(&self, line_no: usize, c: &str) -> Result<(), LoadError> {
        let malformed = || {
            LoadError::at(
                self.path,
                line_no,
                format!("malformed face corner '{}'", shorten(c)),
            )
        };
        let parts: Vec<&str> = c.split('/').collect();
        if parts.len() > 3 || parts[0].is_empty() {
            return Err(malformed());
        }
        for (k, (part, count, noun)) in parts
            .iter()
            .zip([
                (self.nv, "vertex"),
                (self.nt, "texture coordinate"),
                (self.nn, "normal"),
            ])
            .map(|(p, (n, noun))| (p, n, noun))
            .enumerate()
        {
            if k > 0 && part.is_empty() {
                continue;
            }
            let Ok(idx) = part.parse::<i64>() else {
                return Err(malformed());
            };
            // 1-based; negative counts back from the last one defined.
            let ok = if idx > 0 {
                idx <= count
            } else {
                idx < 0 && -idx <= count
            };
            if !ok {
                return Err(LoadError::at(
                    self.path,
                    line_no,
                    format!(
                        "{noun} index {idx} is out of range ({count} {noun}s defined so far; indices start at 1)"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The warnings for what was read leniently or skipped, then the text;
    /// an error when no face was left.
    fn finish(self, warnings: &mut Vec<String>) -> Result<String, LoadError> {
        let path = self.path;
        if self.odd_numbers > 0 {
            warnings.push(format!(
                "{}:{}: warning: {} numbers with trailing characters were read up to the first one that is not part of a number",
                path.display(),
                self.first_odd,
                self.odd_numbers
            ));
        }
        if self.not_faces > 0 {
            warnings.push(format!(
                "{}: warning: skipped {} 'l' and 'p' lines (polylines and points have no area to render)",
                path.display(),
                self.not_faces
            ));
        }
        if self.short_faces > 0 {
            warnings.push(format!(
                "{}: warning: skipped {} faces with fewer than 3 corners",
                path.display(),
                self.short_faces
            ));
        }
        if self.faces == 0 {
            return Err(LoadError::file(
                path,
                if self.nv == 0 {
                    "the file has no vertices and no faces (is it empty?)"
                } else {
                    "the file has vertices but no faces (a point cloud?); nothing to render"
                },
            ));
        }
        Ok(self.out)
    }
}

/// Whether every `v` line carries a colour (`v x y z r g b`): vertex
/// colours are kept only then, as tobj would pair a partial list with the
/// wrong vertices.
fn every_vertex_has_a_colour(text: &str) -> bool {
    let mut vs = text.lines().filter(|l| l.trim_start().starts_with("v "));
    let counts = |l: &str| l.split('#').next().unwrap_or("").split_whitespace().count();
    let first = vs.next();
    first.is_some_and(|f| counts(f) >= 7) && vs.all(|l| counts(l) >= 7)
}
