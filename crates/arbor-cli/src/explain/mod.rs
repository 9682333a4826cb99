//! `arbor explain`: one self-contained HTML page showing a scene's graph,
//! its acceleration structures and camera rays' traversals of them, from
//! the very structures that render the picture; or, with `--ray X,Y
//! --json FILE`, one ray's traversal as JSON. The data is the document of
//! docs/explain-data.md; the page around it is [`page::page_html`].

mod base64;
mod graph;
mod level_path;
mod levels;
mod page;
mod picks;
mod primitives;
mod structures;
mod traversal;
mod volumes;

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use arbor::nested::{Instancing, Plan};
use arbor::scene::Scene;
use arbor::tracer::{BoundingVolumeKind, Tracer};
use arbor_accel::AccelKind;
use clap::Args;
use serde_json::{json, Value};

use crate::input::{load_input, ReadAs};
use crate::InputError;
use structures::View;
use traversal::InnerLayouts;

/// The structures shown when `--accel` names none.
const DEFAULT_ACCELS: &str = "bvh-center,bvh-median,bvh-sah,bvh-wide,grid,kdtree";

/// The picture's longest side unless `--size` says otherwise.
const MAX_PICTURE_SIDE: u32 = 480;

/// Arguments of `arbor explain`.
#[derive(Args, Debug)]
pub struct ExplainArgs {
    /// The scene file (Cornell XML) or a model (.obj, .ply, .stl, .gltf,
    /// .glb), as for `arbor render`. Without one, the built-in classroom.
    pub input: Option<PathBuf>,
    /// The page to write. Default `explain.html`; with `--json` and no
    /// `-o`, no page is written.
    #[arg(short, long, value_name = "FILE.html")]
    pub output: Option<PathBuf>,
    /// The structures to show, comma-separated.
    #[arg(long, value_name = "NAME,...", value_delimiter = ',',
          value_parser = crate::accel_arg::parse, default_value = DEFAULT_ACCELS)]
    pub accel: Vec<AccelKind>,
    /// With --json: the pixel (column, row; 0,0 at the top left) whose first
    /// camera ray is traced.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, requires = "json",
          allow_hyphen_values = true)]
    pub ray: Option<(u32, u32)>,
    /// With --ray: write that ray's traversal of each structure to FILE as
    /// JSON (docs/explain-data.md).
    #[arg(long, value_name = "FILE", requires = "ray")]
    pub json: Option<PathBuf>,
    /// The picture's size (default: the scene's, its long side capped to 480).
    #[arg(long, value_name = "WxH", value_parser = crate::overrides::parse_size)]
    pub size: Option<(u32, u32)>,
    /// Render as `arbor render --bvol` does: every top-level object in a
    /// bounding volume.
    #[arg(long, value_name = "sphere|aabb|obb")]
    pub bvol: Option<BoundingVolumeKind>,
    /// Models: the file's up axis (x, y, z, -x, -y, -z), as for render.
    #[arg(long, value_name = "AXIS", allow_hyphen_values = true)]
    pub up: Option<arbor::load::Up>,
    /// Models: `auto` frames the model with arbor's camera even when the
    /// file has its own.
    #[arg(long, value_name = "auto", value_parser = ["auto"])]
    pub camera: Option<String>,
    /// Most placements of shared (instanced) surfaces to accept (flat
    /// instancing only).
    #[arg(long, value_name = "N", default_value_t = arbor::flatten::DEFAULT_MAX_PLACEMENTS)]
    pub max_instances: u64,
    /// How references are traced, as for `arbor render`: `flat` (one
    /// placement per copy), `nested` (each shared definition its own
    /// level, built once; the page shows the levels and each ray's way
    /// through them) or `auto` (flat unless copies multiply).
    #[arg(long, value_name = "flat|nested|auto", default_value_t = Instancing::Auto)]
    pub instancing: Instancing,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parses `--ray X,Y`.
fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let err = || format!("`{text}`: expected a pixel X,Y (two whole numbers from 0, e.g. 120,80)");
    let (x, y) = text.split_once(',').ok_or_else(err)?;
    let n = |s: &str| s.trim().parse::<u32>().map_err(|_| err());
    Ok((n(x)?, n(y)?))
}

/// Runs `arbor explain`.
pub fn run(args: ExplainArgs) -> anyhow::Result<()> {
    crate::thread_pool(args.threads)?.install(|| explain(&args))
}

/// The picture's size: `--size`, or the scene's with its long side capped.
fn picture_size(scene: &Scene, size: Option<(u32, u32)>) -> (u32, u32) {
    if let Some(s) = size {
        return s;
    }
    let (w, h) = (scene.width, scene.height);
    let long = w.max(h);
    if long <= MAX_PICTURE_SIDE {
        return (w, h);
    }
    let scale = |s: u32| {
        ((u64::from(s) * u64::from(MAX_PICTURE_SIDE)).div_ceil(u64::from(long)) as u32).max(1)
    };
    (scale(w), scale(h))
}

fn explain(args: &ExplainArgs) -> anyhow::Result<()> {
    let page = match (&args.output, &args.json) {
        (Some(p), _) => Some(p.clone()),
        (None, Some(_)) => None,
        (None, None) => Some(PathBuf::from("explain.html")),
    };
    if let Some(p) = &page {
        crate::output::check_writable(p, "-o")?;
    }
    if let Some(j) = &args.json {
        crate::output::check_writable(j, "--json")?;
    }
    let options = crate::render::scene_options(
        (args.up, args.camera.is_some()),
        args.max_instances,
        args.bvol,
        args.instancing,
    );
    let read_as = ReadAs::Render(&options);
    let mut scene = load_input(args.input.as_deref(), read_as, args.quiet)?.into_scene()?;
    let (w, h) = picture_size(&scene, args.size);
    if (w, h) != (scene.width, scene.height) {
        crate::overrides::resize(&mut scene, w, h);
    }
    if let Some((x, y)) = args.ray {
        if x >= w || y >= h {
            return Err(InputError(format!(
                "--ray {x},{y}: the pixel is outside the {w}x{h} picture (columns 0 to {}, rows 0 to {})",
                w - 1,
                h - 1
            ))
            .into());
        }
    }
    let out = match arbor::render::plan(&scene, &options) {
        Plan::Flat => flat_outputs(args, &scene, &options, page.is_some())?,
        Plan::Nested { flatten_budget } => {
            levels::outputs(args, &scene, &options, flatten_budget, page.is_some())?
        }
    };
    let mut staged = Vec::new();
    if let (Some(path), Some(one)) = (&args.json, &out.ray) {
        let text = serde_json::to_string_pretty(one)? + "\n";
        staged.push(crate::output::stage(path, |f| {
            std::io::Write::write_all(f, text.as_bytes())
        })?);
    }
    if let (Some(path), Some(data)) = (&page, &out.page) {
        let html = page::page_html(&serde_json::to_string(data)?);
        staged.push(crate::output::stage(path, |f| {
            std::io::Write::write_all(f, html.as_bytes())
        })?);
    }
    crate::output::commit_all(staged)?;
    if !args.quiet {
        for p in page.iter().chain(args.json.iter()) {
            eprintln!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// What one run writes: the `--ray` traversal and the page's document.
struct Outputs {
    ray: Option<Value>,
    page: Option<Value>,
}

/// The outputs of a flat plan: every `--accel` structure over the
/// flattened scene.
fn flat_outputs(
    args: &ExplainArgs,
    scene: &Scene,
    options: &arbor::render::RenderOptions,
    want_page: bool,
) -> anyhow::Result<Outputs> {
    let flat = crate::render::flatten(scene, options)?;
    let mut accels: Vec<AccelKind> = Vec::new();
    for &k in &args.accel {
        if !accels.contains(&k) {
            accels.push(k);
        }
    }
    let mut views: Vec<View> = accels
        .iter()
        .map(|&k| {
            let options = arbor::render::RenderOptions {
                accel: k,
                ..*options
            };
            View::new(k, arbor::render::build_tracer(flat.clone(), &options))
        })
        .collect();
    // The page's node numbers depend on the picks; `--ray` uses the same.
    let pick_pixels = picks::pick_pixels(scene);
    picks::name_visited_nodes(scene, &mut views, &pick_pixels.1);
    let mut inner = InnerLayouts::default();
    let ray = args
        .ray
        .map(|pixel| traversal::pixel_traversal(scene, &views, &mut inner, pixel, true));
    let page = want_page
        .then(|| document(args, scene, &flat, &views, &mut inner, pick_pixels))
        .transpose()?;
    Ok(Outputs { ray, page })
}

/// The whole page document of docs/explain-data.md.
fn document(
    args: &ExplainArgs,
    scene: &Scene,
    flat: &arbor::flatten::FlattenedScene,
    views: &[View],
    inner: &mut InnerLayouts,
    pick_pixels: (u32, Vec<(u32, u32)>),
) -> anyhow::Result<Value> {
    let (w, h) = (scene.width, scene.height);
    let pixels = u64::from(w) * u64::from(h);
    let bar = crate::render::progress_bar(pixels * (1 + views.len() as u64), args.quiet);
    let progress = |n: u64| bar.inc(n);
    let mut notes = Vec::new();

    let picture = render_png(scene, &views[0].tracer, &progress)?;
    let heatmaps: Vec<Value> = views
        .iter()
        .map(|v| structures::heatmap_json(scene, v, &progress))
        .collect();
    let picks = picks::picks(scene, views, inner, pick_pixels, &mut notes);
    bar.finish_and_clear();

    let structures: Vec<Value> = views
        .iter()
        .zip(heatmaps)
        .map(|(v, heat)| structures::structure_json(v, heat, &mut notes))
        .collect();
    let graph = graph::scene_graph(scene, flat, &mut notes);
    let prims = primitives::primitives_json(flat, &mut notes);
    // Every view's tracer fits the same volumes over the same objects.
    let bounding_volumes = views.first().map_or_else(Vec::new, |v| {
        volumes::bounding_volumes_json(&v.tracer, flat.world.len())
    });
    Ok(json!({
        "format": "arbor-explain",
        "version": 1,
        "instancing": "flat",
        "input": input_label(args),
        "notes": notes,
        "image": { "width": w, "height": h, "png_base64": picture },
        "camera": camera_json(scene),
        "scene_graph": graph,
        "primitives": prims,
        "bounding_volumes": bounding_volumes,
        "structures": structures,
        "picks": { "stride": picks.stride, "rays": picks.rays },
    }))
}

/// The input as the page names it.
fn input_label(args: &ExplainArgs) -> String {
    args.input
        .as_ref()
        .map_or("built-in classroom".to_string(), |p| {
            p.display().to_string()
        })
}

/// The picture as `arbor render` renders it through `tracer`, as base64 PNG.
fn render_png(
    scene: &Scene,
    tracer: &Tracer,
    progress: &(dyn Fn(u64) + Sync),
) -> anyhow::Result<String> {
    let cancel = AtomicBool::new(false);
    let film = arbor::render::render(scene, tracer, progress, &cancel)
        .map_err(|_| anyhow::anyhow!("rendering the picture was interrupted"))?;
    let mut png = Vec::new();
    arbor::film::encode_png(
        &mut png,
        film.width(),
        film.height(),
        &film.to_rgb8(scene.variant),
    )?;
    Ok(base64::encode(&png))
}

/// The camera: eye, a point it looks at, up and the vertical field of view
/// (`null` for a parallel projection).
fn camera_json(scene: &Scene) -> Value {
    let c = &scene.camera;
    let dir = c.view_dir.normalize_or_zero();
    let target = c.view_point + dir * c.proj_distance.max(1e-9);
    let perspective = !matches!(c.kind, arbor::camera::CameraKind::Parallel2015);
    let vfov =
        perspective.then(|| 2.0 * (0.5 * c.view_height / c.proj_distance).atan().to_degrees());
    json!({
        "eye": c.view_point.to_array(),
        "target": target.to_array(),
        "up": c.view_up.to_array(),
        "vfov_degrees": vfov,
        "view_width": c.view_width,
        "view_height": c.view_height,
    })
}
