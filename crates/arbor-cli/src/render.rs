//! `arbor render`: a scene file (or the built-in default scene) to a picture.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use arbor::film::ImageFormat;
use arbor::flatten::{Flattened, DEFAULT_MAX_PLACEMENTS};
use arbor::render::Region;
use arbor::tracer::Tracer;
use arbor_accel::AccelKind;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use arbor::render::render_region_with;
use arbor::stats::{NoStats, RayKind, RenderStats};

use crate::InputError;

/// Arguments of `arbor render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (Cornell XML) or a model (.obj, .ply, .stl, .gltf, .glb,
    /// framed automatically). Without one, the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Output image: `.png` (8-bit) or `.exr` (linear float). Default: the
    /// scene's name with `.png`, in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Acceleration structure (`list` is brute force).
    #[arg(long, default_value_t = AccelKind::DEFAULT)]
    pub accel: AccelKind,
    /// Worker threads (default: all cores). The image is the same for any number.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print timings and structure statistics.
    #[arg(long)]
    pub stats: bool,
    /// Wrap every top-level object in a bounding volume tested before the
    /// object (the lecture's bounded surface); `--stats` shows what it saved.
    #[arg(long, value_name = "sphere|aabb|obb")]
    pub bvol: Option<arbor::tracer::BoundingVolumeKind>,
    /// When interrupted (Ctrl-C), write the tiles finished so far instead of
    /// no file at all.
    #[arg(long)]
    pub partial: bool,
    /// Most placements of shared (instanced) surfaces to accept.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_PLACEMENTS)]
    pub max_instances: u64,
    /// Also write the traversal cost of each pixel's camera rays (nodes
    /// visited plus primitive tests) as a false-colour PNG with a colour bar.
    #[arg(long, value_name = "FILE.png")]
    pub heatmap: Option<PathBuf>,
    /// Render only tile K of N (K from 0 to N-1; the image cut into N
    /// horizontal bands of whole rows) to a `.part` file for `arbor merge`.
    #[arg(long, value_name = "K/N", value_parser = crate::farm::part::parse_tile, conflicts_with = "region")]
    pub tile: Option<(u32, u32)>,
    /// Render only the pixels x0..x1 by y0..y1 (row 0 at the top) to a
    /// `.part` file for `arbor merge`.
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = crate::farm::part::parse_region)]
    pub region: Option<Region>,
    /// Models: the file's up axis (x, y, z, -x, -y, -z); by default z for
    /// STL, y for OBJ, PLY and glTF.
    #[arg(long, value_name = "AXIS", allow_hyphen_values = true)]
    pub up: Option<arbor::load::Up>,
    /// Models: `auto` frames the model with arbor's camera even when the
    /// file has its own.
    #[arg(long, value_name = "auto", value_parser = ["auto"])]
    pub camera: Option<String>,
}

/// Runs `arbor render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let pool = crate::thread_pool(args.threads)?;
    pool.install(|| render_in_pool(&args))
}

fn render_in_pool(args: &RenderArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let (scene, output) = match &args.scene {
        Some(path) => {
            let options = arbor::load::ModelOptions {
                up: args.up,
                auto_camera: args.camera.is_some(),
            };
            let loaded = arbor::load::load_scene_with(path, &options)
                .map_err(|e| InputError(e.to_string()))?;
            if !args.quiet {
                for w in &loaded.warnings {
                    eprintln!("{w}");
                }
            }
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "out".into());
            (loaded.scene, PathBuf::from(format!("{stem}.png")))
        }
        None => (
            arbor::default_scene::classroom(),
            PathBuf::from("arbor.png"),
        ),
    };
    // Partial renders: --tile, --region or a `.part` output (farm::part).
    let part_spec = crate::farm::part::spec(args.tile, args.region);
    let target = crate::farm::part::target(part_spec, args.output.as_deref(), &output, &scene)?;
    let (output, part) = (target.output, target.part);
    // Check the format before spending time on the render.
    if part.is_none() {
        ImageFormat::from_path(&output).map_err(|e| InputError(e.to_string()))?;
    }
    let region = part.map_or(
        Region {
            x0: 0,
            y0: 0,
            x1: scene.width,
            y1: scene.height,
        },
        |p| p.0,
    );
    if let Some(path) = &args.heatmap {
        check_heatmap_path(path)?;
    }
    let loaded = start.elapsed();

    let flat = match args.bvol {
        Some(_) => Flattened::bounded(&scene, args.max_instances),
        None => Flattened::new(&scene, args.max_instances),
    }
    .map_err(|e| InputError(e.to_string()))?;
    let (unique, instanced) = (flat.unique_primitives(), flat.instanced_primitives());
    let build_start = Instant::now();
    let tracer = match args.bvol {
        Some(volume) => Tracer::from_flattened_bounded(flat, args.accel, volume),
        None => Tracer::from_flattened(flat, args.accel),
    };
    let built = build_start.elapsed();

    let cancel = Arc::new(AtomicBool::new(false));
    install_interrupt_handler(cancel.clone());
    let total = region.area();
    let bar = progress_bar(total, args.quiet);
    let render_start = Instant::now();
    let film = render_counted(
        &scene,
        &tracer,
        region,
        &|n| bar.inc(n),
        &cancel,
        args.stats,
    );
    bar.finish_and_clear();
    let (film, ray_stats) = match film {
        Ok(f) => f,
        Err(cancelled) => {
            if args.partial && part.is_none() {
                cancelled.partial.write(&output, scene.variant)?;
                anyhow::bail!(
                    "interrupted: wrote the finished tiles to {} (--partial)",
                    output.display()
                );
            }
            anyhow::bail!("interrupted: no image written")
        }
    };
    let rendered = render_start.elapsed();
    match part {
        // A part records where it belongs and what it was rendered from.
        Some((region, tile)) => arbor::partial::Partial {
            header: arbor::partial::PartHeader {
                width: scene.width,
                height: scene.height,
                region,
                tile,
                variant: scene.variant,
                scene_hash: arbor::partial::scene_hash(&scene),
            },
            film,
        }
        .write(&output),
        None => film.write(&output, scene.variant),
    }
    .with_context(|| "writing the image")?;
    if !args.quiet {
        eprintln!(
            "wrote {} ({}x{}, {} samples per pixel) in {:.2} s",
            output.display(),
            scene.width,
            scene.height,
            scene.samples_per_side * scene.samples_per_side,
            start.elapsed().as_secs_f64()
        );
    }
    let heatmap = match &args.heatmap {
        Some(path) => Some(write_heatmap(&scene, &tracer, path)?),
        None => None,
    };
    if args.stats {
        let s = arbor_accel::Accelerator::stats(tracer.accel());
        eprintln!(
            "primitives: {unique} unique, {} placements of shared geometry, {instanced} as placed",
            tracer.placements()
        );
        eprintln!(
            "accel {}: top level {} nodes, {} leaves, depth {}; all levels {} bytes",
            tracer.kind(),
            s.nodes,
            s.leaves,
            s.max_depth,
            tracer.accel_memory_bytes()
        );
        if let Some(volume) = args.bvol {
            let v = tracer.volume_stats();
            let load =
                |a: &std::sync::atomic::AtomicU64| a.load(std::sync::atomic::Ordering::Relaxed);
            eprintln!(
                "bounding volumes ({volume:?}): {} tests, {} missed, {} surface tests saved",
                load(&v.tests),
                load(&v.misses),
                load(&v.saved)
            );
        }
        eprintln!(
            "time: load {:.3} s, build {:.3} s, render {:.3} s",
            loaded.as_secs_f64(),
            built.as_secs_f64(),
            rendered.as_secs_f64()
        );
    }
    if let Some(stats) = &ray_stats {
        print_ray_stats(stats, heatmap.as_ref());
    }
    Ok(())
}

// --- `--stats` (rays by kind) and `--heatmap` -------------------------------

/// Renders `region`, counting every ray by kind when `count` is set. The two
/// cases are two monomorphisations of the integrator, chosen once here, so
/// an uncounted render pays nothing for the option.
fn render_counted(
    scene: &arbor::scene::Scene,
    tracer: &Tracer,
    region: arbor::render::Region,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
    count: bool,
) -> Result<(arbor::film::Film, Option<RenderStats>), arbor::render::Cancelled> {
    if count {
        render_region_with::<RenderStats>(scene, tracer, region, progress, cancel)
            .map(|(film, stats)| (film, Some(stats)))
    } else {
        render_region_with::<NoStats>(scene, tracer, region, progress, cancel)
            .map(|(film, _)| (film, None))
    }
}

/// `--heatmap` writes an 8-bit PNG; anything else is refused before rendering.
fn check_heatmap_path(path: &Path) -> Result<(), InputError> {
    let is_png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        Ok(())
    } else {
        Err(InputError(format!(
            "{}: --heatmap writes a .png file",
            path.display()
        )))
    }
}

/// Writes the primary-ray cost heatmap; returns the map and how long it took.
fn write_heatmap(
    scene: &arbor::scene::Scene,
    tracer: &Tracer,
    path: &Path,
) -> anyhow::Result<(arbor::heatmap::CostMap, std::time::Duration)> {
    let start = Instant::now();
    let map = arbor::heatmap::write_heatmap(scene, tracer, path)
        .with_context(|| "writing the heatmap")?;
    Ok((map, start.elapsed()))
}

/// The `--stats` lines about rays: count, nodes and tests per ray by kind.
fn print_ray_stats(
    stats: &RenderStats,
    heatmap: Option<&(arbor::heatmap::CostMap, std::time::Duration)>,
) {
    for kind in RayKind::ALL {
        let k = stats.kind(kind);
        eprintln!(
            "rays {:<10} {:>12}  {:>7.2} nodes/ray  {:>7.2} tests/ray",
            kind.name(),
            k.rays,
            k.nodes_per_ray(),
            k.tests_per_ray()
        );
    }
    let t = stats.total();
    eprintln!(
        "rays {:<10} {:>12}  {:>7.2} nodes/ray  {:>7.2} tests/ray",
        "all",
        t.rays,
        t.nodes_per_ray(),
        t.tests_per_ray()
    );
    if let Some((map, took)) = heatmap {
        eprintln!(
            "heatmap: camera-ray cost mean {:.1}, max {:.0} (nodes + tests), {:.3} s",
            map.mean(),
            map.max(),
            took.as_secs_f64()
        );
    }
}

/// What `arbor render` draws: a Cornell XML scene or a framed model, chosen
/// by the loader's format registry.
pub(crate) fn load_scene_or_model(path: &Path) -> anyhow::Result<arbor::xml::LoadedScene> {
    arbor::load::load_scene(path).map_err(|e| InputError(e.to_string()).into())
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    // indicatif hides a stderr bar by itself when stderr is not a terminal.
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} ETA {eta}")
            .expect("valid template"),
    );
    bar
}

/// The first Ctrl-C asks the render to stop (no file is written); a second
/// one exits at once.
fn install_interrupt_handler(cancel: Arc<AtomicBool>) {
    let _ = ctrlc::set_handler(move || {
        if cancel.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
}

/// Whether `path` has an image extension we write (for argument checks).
#[allow(dead_code)]
pub fn is_image_path(path: &Path) -> bool {
    ImageFormat::from_path(path).is_ok()
}
