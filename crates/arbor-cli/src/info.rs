//! `arbor info`: what a scene holds: its settings, its hierarchy, and what
//! flattening makes of it (unique primitives, placements, primitives as
//! placed).

use std::fmt::Write as _;
use std::path::PathBuf;

use arbor::flatten::{Flattened, DEFAULT_MAX_PLACEMENTS};
use arbor::load::Format;
use arbor::scene::{Scene, Variant};
use arbor::surface::Surface;
use clap::Args;

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
}

/// Runs `arbor info`.
pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let (name, scene) = match &args.input {
        Some(path) if Format::from_path(path).is_ok_and(Format::is_model) => {
            return run_model(path, args.depth)
        }
        Some(path) => {
            let loaded =
                arbor::load::load_cornell_scene(path).map_err(|e| InputError(e.to_string()))?;
            for w in &loaded.warnings {
                eprintln!("{w}");
            }
            (path.display().to_string(), loaded.scene)
        }
        None => (
            "(built-in default scene)".to_string(),
            arbor::default_scene::classroom(),
        ),
    };
    print!("{}", describe(&name, &scene, args.depth)?);
    Ok(())
}

/// Model files (`.obj`, `.ply`, `.stl`, `.gltf`, `.glb`): what the file
/// holds (nodes, meshes, placements, triangles unique and as placed), then
/// the report of the framed scene `arbor render` would draw.
fn run_model(path: &std::path::Path, depth: usize) -> anyhow::Result<()> {
    let (scene, model) =
        arbor::load::load_model_scene(path).map_err(|e| InputError(e.to_string()))?;
    for w in &model.warnings {
        eprintln!("{w}");
    }
    let s = model.stats;
    println!("model       {}", path.display());
    println!("nodes       {}", s.nodes);
    println!(
        "meshes      {} ({} placed more than once)",
        s.meshes, s.shared_meshes
    );
    println!("placed      {} times", s.placements);
    println!(
        "triangles   {} unique, {} as placed",
        s.unique_triangles, s.instanced_triangles
    );
    print!("{}", describe(&path.display().to_string(), &scene, depth)?);
    Ok(())
}

/// The report for `scene`.
pub fn describe(name: &str, scene: &Scene, depth: usize) -> anyhow::Result<String> {
    let flat =
        Flattened::new(scene, DEFAULT_MAX_PLACEMENTS).map_err(|e| InputError(e.to_string()))?;
    let mut out = String::new();
    let variant = match scene.variant {
        Variant::Cornell2010 => "Cornell 2010",
        Variant::Cornell2015 => "Cornell 2015",
    };
    writeln!(out, "scene       {name} ({variant} conventions)")?;
    writeln!(
        out,
        "image       {}x{}, {} samples per pixel",
        scene.width,
        scene.height,
        scene.samples_per_side * scene.samples_per_side
    )?;
    writeln!(out, "lights      {}", scene.lights.len())?;
    writeln!(out, "surfaces    {} at the top level", scene.surfaces.len())?;
    let mut shared = std::collections::HashSet::new();
    count_shared(&scene.surfaces, &mut shared);
    writeln!(
        out,
        "shared      {} surfaces placed by reference",
        shared.len()
    )?;
    writeln!(out, "primitives  {} unique", flat.unique_primitives())?;
    writeln!(
        out,
        "placements  {} of shared geometry",
        flat.placements.len()
    )?;
    writeln!(
        out,
        "as placed   {} primitives",
        flat.instanced_primitives()
    )?;
    writeln!(out, "hierarchy")?;
    let mut shown = std::collections::HashMap::new();
    for s in &scene.surfaces {
        tree(&mut out, s, 1, depth, &mut shown)?;
    }
    Ok(out)
}

fn count_shared(surfaces: &[Surface], seen: &mut std::collections::HashSet<usize>) {
    for s in surfaces {
        match s {
            Surface::Group(g) => count_shared(&g.children, seen),
            Surface::Instance(inner) if seen.insert(std::sync::Arc::as_ptr(inner) as usize) => {
                count_shared(std::slice::from_ref(inner.as_ref()), seen);
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
            "{indent}mesh {} triangles, {} vertices{}",
            m.data.triangles.len(),
            m.data.positions.len(),
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
