//! `arbor info`: what a scene holds: its settings, its hierarchy, and what
//! flattening makes of it (unique primitives, placements, primitives as
//! placed).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;

use arbor::census::{Census, CensusError};
use arbor::light::Light;
use arbor::load::Model;
use arbor::scene::{Scene, Variant};
use arbor::shader::Shader;
use arbor::surface::Surface;
use clap::Args;
use glam::DVec3;
use serde_json::json;

use crate::input::{load_input, Input, ReadAs};
use crate::render::plural;
use crate::InputError;

/// Arguments of `arbor info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The scene file (Cornell XML) or a model (.obj, .ply, .stl, .gltf,
    /// .glb). Without one, the built-in default scene.
    pub input: Option<PathBuf>,
    /// Show at most this many levels of the hierarchy.
    #[arg(long, default_value_t = 6)]
    pub depth: usize,
    /// Also write the description as a JSON object to FILE (keys: `input`,
    /// `kind`, `bounds`, `triangles`, `vertices`, `materials`, `camera`,
    /// `lights`, `floor`, `image`, ...).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// Runs `arbor info`.
pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    if let Some(path) = &args.json {
        crate::output::check_writable(path, "--json")?;
    }
    let name = match &args.input {
        Some(path) => path.display().to_string(),
        None => "(built-in default scene)".to_string(),
    };
    let (scene, model) = match load_input(args.input.as_deref(), ReadAs::Description, false)? {
        Input::Model { scene, model } => (scene, Some(*model)),
        other => (other.into_scene()?, None),
    };
    // Everything is counted before anything is printed or written: a scene
    // that cannot be counted (too deep, counts beyond 128 bits) is an input
    // error with no output.
    let located = |e: CensusError| InputError(format!("{name}: {e}"));
    let census = Census::new(&scene.surfaces, scene.variant).map_err(located)?;
    // A model's summary counts its own surfaces (without the automatic
    // floor); a scene's is the census above.
    let model_census = match &model {
        Some(m) => Some(Census::new(&m.surfaces, scene.variant).map_err(located)?),
        None => None,
    };
    let summary = Summary::new(model_census.as_ref().unwrap_or(&census));
    let mut text = String::new();
    if let Some(model) = &model {
        text += &describe_model(&name, model, &summary)?;
    }
    text += &describe(&name, &scene, model.is_some(), args.depth, &census)?;
    print!("{text}");
    if let Some(path) = &args.json {
        let json = summary.to_json(&name, &scene, model.as_ref(), &census);
        let text = serde_json::to_string_pretty(&json)? + "\n";
        crate::output::write_text(path, &text)?;
    }
    Ok(())
}

/// What `info` reports beyond the hierarchy: bounds, counts, materials,
/// and which camera, lights and floor the picture gets.
struct Summary {
    /// World bounds of the triangles (the model's, floor excluded).
    bounds: Option<(DVec3, DVec3)>,
    /// Triangles and vertices stored once per mesh.
    triangles: u64,
    vertices: u64,
    /// Distinct shaders, with the meshes and triangles (as stored) using them.
    materials: Vec<(Arc<Shader>, u64, u64)>,
}

impl Summary {
    /// Counts over the DAG (each shared definition visited once, with the
    /// number of times it is placed), never placement by placement.
    fn new(census: &Census) -> Summary {
        let surfaces = census.roots();
        let mut placed_vertices = 0u128;
        census.for_each_leaf_once(&mut |leaf, uses| {
            if let Surface::Mesh(m) = leaf {
                let n = uses.saturating_mul(m.data.positions.len() as u128);
                placed_vertices = placed_vertices.saturating_add(n);
            }
        });
        let mut summary = Summary {
            // Exact bounds (every placed vertex) while that is quick; past
            // that, each definition's box carried through its placements.
            bounds: if placed_vertices <= EXACT_BOUNDS_VERTICES {
                arbor::load::frame::bounds(surfaces)
            } else {
                census.mesh_bounds()
            },
            triangles: 0,
            vertices: 0,
            materials: Vec::new(),
        };
        let mut meshes = std::collections::HashSet::new();
        {
            census.for_each_leaf_once(&mut |leaf, uses| {
                let uses = u64::try_from(uses).unwrap_or(u64::MAX);
                let (shader, triangles, surfaces) = match leaf {
                    Surface::Mesh(m) => {
                        // A shared mesh counts once, as stored.
                        if !meshes.insert(Arc::as_ptr(&m.data) as usize) {
                            return;
                        }
                        summary.triangles += m.data.triangles.len() as u64;
                        summary.vertices += m.data.positions.len() as u64;
                        (&m.shader, m.data.triangles.len() as u64, 1)
                    }
                    Surface::Sphere(x) => (&x.shader, 0, uses),
                    Surface::Box(x) => (&x.shader, 0, uses),
                    Surface::Cylinder(x) => (&x.shader, 0, uses),
                    _ => return,
                };
                match summary
                    .materials
                    .iter_mut()
                    .find(|(s, _, _)| Arc::ptr_eq(s, shader))
                {
                    Some(entry) => {
                        entry.1 = entry.1.saturating_add(surfaces);
                        entry.2 += triangles;
                    }
                    None => summary
                        .materials
                        .push((shader.clone(), surfaces, triangles)),
                }
            });
        }
        summary
    }

    fn to_json(
        &self,
        name: &str,
        scene: &Scene,
        model: Option<&Model>,
        census: &Census,
    ) -> serde_json::Value {
        let v = |x: DVec3| json!([x.x, x.y, x.z]);
        let camera = &scene.camera;
        let floor = model
            .and_then(|_| scene.surfaces.last())
            .and_then(|s| match s {
                Surface::Box(b) => {
                    Some(json!({"automatic": true, "min": v(b.min), "max": v(b.max)}))
                }
                _ => None,
            });
        json!({
            "input": name,
            "kind": if model.is_some() { "model" } else { "scene" },
            "conventions": match (model, scene.variant) {
                (Some(_), _) => serde_json::Value::Null,
                (None, Variant::Cornell2010) => json!("Cornell 2010"),
                (None, Variant::Cornell2015) => json!("Cornell 2015"),
            },
            "bounds": self.bounds.map(|(lo, hi)| json!({"min": v(lo), "max": v(hi)})),
            "triangles": self.triangles,
            "vertices": self.vertices,
            // Decimal strings: as placed, these exceed 64 bits (and JSON
            // readers' doubles) in deeply instanced scenes.
            "unique_primitives": census.unique_primitives.to_string(),
            "placements": census.placements.to_string(),
            "primitives_as_placed": census.placed_primitives.to_string(),
            "materials": self.materials.iter().map(|(shader, meshes, triangles)| {
                let mut m = shader_json(shader);
                m["surfaces"] = json!(meshes);
                m["triangles"] = json!(triangles);
                m
            }).collect::<Vec<_>>(),
            "camera": {
                "source": camera_source(model),
                "kind": format!("{:?}", camera.kind),
                "position": v(camera.view_point),
                "direction": v(camera.view_dir),
                "up": v(camera.view_up),
                "view_width": camera.view_width,
                "view_height": camera.view_height,
            },
            "lights": {
                "source": lights_source(model),
                "list": scene.lights.iter().map(|l| match l {
                    Light::Point { position, intensity } =>
                        json!({"type": "point", "position": v(*position), "intensity": v(*intensity)}),
                    Light::Directional { direction, intensity } =>
                        json!({"type": "directional", "direction": v(*direction), "intensity": v(*intensity)}),
                    Light::Spot { position, direction, intensity, cos_inner, cos_outer } =>
                        json!({"type": "spot", "position": v(*position), "direction": v(*direction), "intensity": v(*intensity),
                               "inner_cone_degrees": cos_inner.acos().to_degrees(), "outer_cone_degrees": cos_outer.acos().to_degrees()}),
                }).collect::<Vec<_>>(),
            },
            "floor": floor,
            "image": {
                "width": scene.width,
                "height": scene.height,
                "samples_per_pixel": scene.samples_per_side * scene.samples_per_side,
            },
        })
    }
}

fn camera_source(model: Option<&Model>) -> &'static str {
    match model {
        Some(m) if m.camera.is_none() => "automatic",
        _ => "file",
    }
}

fn lights_source(model: Option<&Model>) -> &'static str {
    match model {
        Some(m) if m.lights.is_empty() => "automatic",
        _ => "file",
    }
}

/// A shader's kind and parameters as JSON.
fn shader_json(shader: &Shader) -> serde_json::Value {
    let v = |x: &DVec3| json!([x.x, x.y, x.z]);
    let texture = |t: &Option<Arc<arbor::texture::Texture>>| {
        t.as_ref()
            .map(|t| json!({"width": t.width, "height": t.height}))
    };
    match shader {
        Shader::Lambertian {
            diffuse,
            texture: t,
        } => {
            json!({"shader": "Lambertian", "diffuse": v(diffuse), "texture": texture(t)})
        }
        Shader::Phong {
            diffuse,
            specular,
            exponent,
            texture: t,
        } => json!({
            "shader": "Phong", "diffuse": v(diffuse), "specular": v(specular),
            "exponent": exponent, "texture": texture(t)
        }),
        Shader::CookTorrance {
            diffuse,
            specular,
            roughness,
            refractive_index,
            texture: t,
        } => json!({
            "shader": "CookTorrance", "diffuse": v(diffuse), "specular": v(specular),
            "roughness": roughness, "refractive_index": refractive_index, "texture": texture(t)
        }),
        Shader::Glazed {
            refractive_index,
            substrate,
            ..
        } => json!({
            "shader": "Glazed", "refractive_index": refractive_index,
            "substrate": shader_json(substrate), "texture": null
        }),
        Shader::Reflective {
            reflectance,
            substrate,
        } => json!({
            "shader": "Reflective", "reflectance": v(reflectance),
            "substrate": shader_json(substrate), "texture": null
        }),
        Shader::Glass { refractive_index } => {
            json!({"shader": "Glass", "refractive_index": refractive_index, "texture": null})
        }
        Shader::RgbNormals => json!({"shader": "RgbNormals", "texture": null}),
        Shader::Emissive {
            emission,
            texture: t,
            surface,
        } => json!({
            "shader": "Emissive", "emission": v(emission), "texture": texture(t),
            "surface": shader_json(surface)
        }),
    }
}

/// A shader in one line: kind, colours, texture.
fn shader_line(shader: &Shader) -> String {
    let c = |x: &DVec3| format!("{:.3} {:.3} {:.3}", x.x, x.y, x.z);
    let texture = |t: &Option<Arc<arbor::texture::Texture>>| match t {
        Some(t) => format!(", texture {}x{}", t.width, t.height),
        None => String::new(),
    };
    match shader {
        Shader::Lambertian {
            diffuse,
            texture: t,
        } => {
            format!("Lambertian diffuse {}{}", c(diffuse), texture(t))
        }
        Shader::Phong {
            diffuse,
            specular,
            exponent,
            texture: t,
        } => format!(
            "Phong diffuse {}, specular {}, exponent {exponent}{}",
            c(diffuse),
            c(specular),
            texture(t)
        ),
        Shader::CookTorrance {
            diffuse,
            specular,
            roughness,
            texture: t,
            ..
        } => format!(
            "CookTorrance diffuse {}, specular {}, roughness {roughness}{}",
            c(diffuse),
            c(specular),
            texture(t)
        ),
        Shader::Glazed {
            refractive_index,
            substrate,
            ..
        } => {
            format!(
                "Glazed (index {refractive_index}) over {}",
                shader_line(substrate)
            )
        }
        Shader::Reflective {
            reflectance,
            substrate,
        } => format!(
            "Reflective (reflectance {}) over {}",
            c(reflectance),
            shader_line(substrate)
        ),
        Shader::Glass { refractive_index } => format!("Glass, index {refractive_index}"),
        Shader::RgbNormals => "RgbNormals".into(),
        Shader::Emissive {
            emission,
            texture: t,
            surface,
        } => format!(
            "Emissive {}{} over {}",
            c(emission),
            texture(t),
            shader_line(surface)
        ),
    }
}

/// Model files (`.obj`, `.ply`, `.stl`, `.gltf`, `.glb`): what the file
/// holds (nodes, meshes, placements, triangles, bounds, materials), and the
/// camera, lights and floor that `arbor render` adds.
fn describe_model(name: &str, model: &Model, summary: &Summary) -> anyhow::Result<String> {
    let mut out = String::new();
    let s = model.stats;
    writeln!(out, "model       {name}")?;
    if let Some((lo, hi)) = summary.bounds {
        let size = hi - lo;
        writeln!(
            out,
            "bounds      {} .. {} (size {:.4} x {:.4} x {:.4})",
            short(lo),
            short(hi),
            size.x,
            size.y,
            size.z
        )?;
    }
    writeln!(out, "up axis     +y")?;
    writeln!(out, "nodes       {}", s.nodes)?;
    writeln!(
        out,
        "meshes      {} ({} placed more than once)",
        s.meshes, s.shared_meshes
    )?;
    writeln!(out, "placed      {}", times(s.placements))?;
    writeln!(
        out,
        "triangles   {} unique, {} as placed",
        s.unique_triangles, s.instanced_triangles
    )?;
    writeln!(out, "vertices    {} unique", summary.vertices)?;
    writeln!(out, "materials   {}", summary.materials.len())?;
    for (k, (shader, surfaces, triangles)) in summary.materials.iter().enumerate() {
        writeln!(
            out,
            "  #{} {}; {}, {}",
            k + 1,
            shader_line(shader),
            plural(*surfaces, "mesh", "meshes"),
            plural(*triangles, "triangle", "triangles")
        )?;
    }
    Ok(out)
}

/// Above this many vertices as placed, `info` bounds a scene by carrying
/// boxes through its placements instead of transforming every vertex.
const EXACT_BOUNDS_VERTICES: u128 = 1 << 26;

/// The report for `scene` (counted by `census`); for a model's scene
/// (`model`), the camera, lights and floor are said to be automatic where
/// they are.
pub fn describe(
    name: &str,
    scene: &Scene,
    model: bool,
    depth: usize,
    census: &Census,
) -> anyhow::Result<String> {
    let mut out = String::new();
    if !model {
        let variant = match scene.variant {
            Variant::Cornell2010 => "Cornell 2010",
            Variant::Cornell2015 => "Cornell 2015",
        };
        writeln!(out, "scene       {name} ({variant} conventions)")?;
    }
    let spp = scene.samples_per_side * scene.samples_per_side;
    writeln!(
        out,
        "image       {}x{}, {}",
        scene.width,
        scene.height,
        plural(spp, "sample per pixel", "samples per pixel")
    )?;
    let c = &scene.camera;
    writeln!(
        out,
        "camera      {}at {} looking along {}, view {} x {}",
        if model {
            "automatic (framing the model), "
        } else {
            ""
        },
        short(c.view_point),
        short(c.view_dir),
        number(c.view_width),
        number(c.view_height)
    )?;
    writeln!(
        out,
        "lights      {}{}",
        plural(scene.lights.len() as u64, "light", "lights"),
        if model { " (automatic)" } else { "" }
    )?;
    let mut surfaces = &scene.surfaces[..];
    if model {
        // The floor `arbor render` adds under a model: not the model's.
        if let Some((Surface::Box(b), rest)) = scene.surfaces.split_last() {
            writeln!(
                out,
                "floor       automatic: a box {} .. {} under the model",
                short(b.min),
                short(b.max)
            )?;
            surfaces = rest;
        }
    }
    writeln!(out, "surfaces    {} at the top level", surfaces.len())?;
    let mut placed = std::collections::HashMap::new();
    count_shared(&scene.surfaces, &mut placed);
    let shared = placed.values().filter(|&&n| n > 1).count() as u64;
    writeln!(
        out,
        "shared      {} placed more than once",
        plural(shared, "surface", "surfaces")
    )?;
    writeln!(out, "primitives  {} unique", census.unique_primitives)?;
    writeln!(out, "placements  {} of shared geometry", census.placements)?;
    writeln!(
        out,
        "as placed   {}",
        plural(census.placed_primitives, "primitive", "primitives")
    )?;
    writeln!(out, "hierarchy")?;
    let mut shown = std::collections::HashMap::new();
    for s in surfaces {
        tree(&mut out, s, 1, depth, &mut shown)?;
    }
    Ok(out)
}

/// `1 time`, `3 times`.
fn times(n: u64) -> String {
    plural(n, "time", "times")
}

/// A vector with at most four decimals: `(1.25, 0, -3.5)`.
fn short(v: DVec3) -> String {
    format!("({}, {}, {})", number(v.x), number(v.y), number(v.z))
}

/// A number with at most four decimals, no trailing zeros.
fn number(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// How many times each shared surface is placed (by reference), counted
/// through the hierarchy once per reference.
fn count_shared(surfaces: &[Surface], placed: &mut std::collections::HashMap<usize, u64>) {
    for s in surfaces {
        match s {
            Surface::Group(g) => count_shared(&g.children, placed),
            Surface::Instance(inner) => {
                let n = placed.entry(Arc::as_ptr(inner) as usize).or_insert(0);
                *n += 1;
                if *n == 1 {
                    count_shared(std::slice::from_ref(inner.as_ref()), placed);
                }
            }
            _ => {}
        }
    }
}

/// Writes the hierarchy under `s`; a shared surface is written out at its
/// first placement and named by number at the others.
fn tree(
    out: &mut String,
    s: &Surface,
    level: usize,
    max: usize,
    shown: &mut std::collections::HashMap<usize, usize>,
) -> std::fmt::Result {
    let indent = "  ".repeat(level);
    if level > max {
        return Ok(());
    }
    match s {
        Surface::Sphere(x) => writeln!(out, "{indent}sphere r={} at {}", x.radius, x.center),
        Surface::Box(b) => writeln!(out, "{indent}box {} .. {}", b.min, b.max),
        Surface::Cylinder(c) => writeln!(out, "{indent}cylinder r={} h={}", c.radius, c.height),
        Surface::Mesh(m) => writeln!(
            out,
            "{indent}mesh {}, {}{}",
            plural(m.data.triangles.len() as u64, "triangle", "triangles"),
            plural(m.data.positions.len() as u64, "vertex", "vertices"),
            if m.data.normals.is_some() {
                ", smooth"
            } else {
                ""
            }
        ),
        Surface::Group(g) => {
            writeln!(out, "{indent}group of {}", g.children.len())?;
            if level == max && !g.children.is_empty() {
                return writeln!(out, "{indent}  ...");
            }
            for c in &g.children {
                tree(out, c, level + 1, max, shown)?;
            }
            Ok(())
        }
        Surface::Instance(inner) => {
            let key = std::sync::Arc::as_ptr(inner) as usize;
            if let Some(id) = shown.get(&key) {
                return writeln!(out, "{indent}instance of #{id} (shown above)");
            }
            let id = shown.len() + 1;
            shown.insert(key, id);
            writeln!(out, "{indent}instance of #{id}:")?;
            tree(out, inner, level + 1, max, shown)
        }
    }
}
