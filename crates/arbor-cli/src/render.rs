//! `arbor render`: a scene file (or the built-in default scene) to a picture.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use arbor::film::ImageFormat;
use arbor::flatten::{FlattenError, FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use arbor::nested::{Instancing, Plan};
use arbor::render::{Region, RenderOptions};
use arbor::scene::Scene;
use arbor::tracer::Tracer;
use arbor_accel::AccelKind;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use arbor::render::render_region_observed;
use arbor::stats::{NoStats, RayKind, RenderStats};

use crate::input::{load_input, ReadAs};
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
    #[arg(long, value_name = "NAME", default_value_t = AccelKind::DEFAULT, value_parser = crate::accel_arg::parse)]
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
    /// Most placements of shared (instanced) surfaces to accept (flat
    /// instancing only).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_PLACEMENTS)]
    pub max_instances: u64,
    /// How references are traced: `flat` (one placement per copy), `nested`
    /// (each shared definition its own level, built once) or `auto` (flat
    /// unless copies multiply; docs/acceleration.md). The same picture.
    #[arg(long, value_name = "flat|nested|auto", default_value_t = Instancing::Auto)]
    pub instancing: Instancing,
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
    /// Render only the pixels x0..x1 by y0..y1 (row 0 at the top, ends
    /// excluded) as a picture of that size (or a `.part` file, as --region).
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = crate::farm::part::parse_region, conflicts_with_all = ["tile", "region"])]
    pub crop: Option<Region>,
    /// While rendering, write the picture so far to the output every
    /// SECONDS (atomically: a viewer can keep it open); removed again if the
    /// render is interrupted without --partial.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub preview_every: Option<f64>,
    /// Scene overrides.
    #[command(flatten)]
    pub overrides: crate::overrides::Overrides,
}

/// Runs `arbor render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    crate::preview_signal::install();
    crate::thread_pool(args.threads)?.install(|| render(&args))
}

/// The steps of a render, each named; every check comes before the work.
fn render(args: &RenderArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let job = prepare(args)?;
    let loaded = start.elapsed();
    let built = build(&render_options(args), &job.scene, args.scene.as_deref())?;
    let (film, ray_stats, rendered) = trace_image(args, &job, &built.tracer)?;
    let heatmap = write_outputs(args, &job, &built.tracer, film)?;
    if !args.quiet {
        let (w, h) = (job.region.x1 - job.region.x0, job.region.y1 - job.region.y0);
        let spp = job.scene.samples_per_side * job.scene.samples_per_side;
        eprintln!(
            "wrote {} ({w}x{h}, {}) in {:.2} s",
            job.output.display(),
            plural(spp, "sample per pixel", "samples per pixel"),
            start.elapsed().as_secs_f64()
        );
    }
    if args.stats {
        print_build_stats(args, &built);
        eprintln!(
            "time: load {:.3} s, build {:.3} s, render {:.3} s",
            loaded.as_secs_f64(),
            built.took.as_secs_f64(),
            rendered.as_secs_f64()
        );
    }
    if let Some(stats) = &ray_stats {
        print_ray_stats(stats, heatmap.as_ref());
    }
    Ok(())
}

/// A render ready to run: the scene as overridden, and where it goes.
struct Job {
    scene: Scene,
    output: PathBuf,
    /// The pixels computed (the whole image unless a tile, region or crop).
    region: Region,
    /// For a `.part` output: the tile it is, if one.
    part: Option<Option<(u32, u32)>>,
}

/// Checks every output (before loading anything), loads the scene and
/// applies the overrides, and decides which pixels to compute.
fn prepare(args: &RenderArgs) -> anyhow::Result<Job> {
    let default_picture = match &args.scene {
        Some(path) => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "out".into());
            PathBuf::from(format!("{stem}.png"))
        }
        None => PathBuf::from("arbor.png"),
    };
    // Partial renders: --tile, --region or a `.part` output (farm::part);
    // --crop is a region written as a picture.
    let crop = args.crop.is_some();
    let spec = crate::farm::part::spec(args.tile, args.region.or(args.crop));
    let output =
        crate::farm::part::output_path(spec, args.output.as_deref(), &default_picture, crop);
    crate::output::check_writable(&output, "-o")?;
    let is_part = crate::farm::part::check_kind(spec, &output, crop)?;
    if is_part && args.preview_every.is_some() {
        return Err(InputError(format!(
            "{}: --preview-every writes pictures, not .part files",
            output.display()
        ))
        .into());
    }
    if !is_part {
        ImageFormat::from_path(&output).map_err(|e| InputError(e.to_string()))?;
    }
    if let Some(path) = &args.heatmap {
        check_heatmap_path(path)?;
        crate::output::check_writable(path, "--heatmap")?;
    }

    // The library's steps (load, then --spp and --size), then the
    // command's own overrides.
    let options = render_options(args);
    let read_as = ReadAs::Render(&options);
    let mut scene = load_input(args.scene.as_deref(), read_as, args.quiet)?.into_scene()?;
    args.overrides.apply_quick_and_defines(&mut scene)?;
    let (region, tile) = match spec {
        // `resolve` names --region; a crop is the same rectangle, named as given.
        Some(spec) => crate::farm::part::resolve(spec, &scene).map_err(|e| match crop {
            true => InputError(e.0.replacen("--region", "--crop", 1)),
            false => e,
        })?,
        None => (crate::farm::part::whole(&scene), None),
    };
    Ok(Job {
        scene,
        output,
        region,
        part: is_part.then_some(tile),
    })
}

/// What `arbor render`'s flags ask of the library's render steps.
fn render_options(args: &RenderArgs) -> RenderOptions {
    RenderOptions {
        width: args.overrides.size.map(|(w, _)| w),
        height: args.overrides.size.map(|(_, h)| h),
        samples: args.overrides.spp,
        accel: args.accel,
        ..scene_options(
            (args.up, args.camera.is_some()),
            args.max_instances,
            args.bvol,
            args.instancing,
        )
    }
}

/// The render options of the flags `render` and `explain` share (how a
/// model is placed and viewed, `--max-instances`, `--bvol`,
/// `--instancing`), the rest the library's defaults.
pub(crate) fn scene_options(
    (up, auto_camera): (Option<arbor::load::Up>, bool),
    max_placements: u64,
    bounding_volume: Option<arbor::tracer::BoundingVolumeKind>,
    instancing: Instancing,
) -> RenderOptions {
    RenderOptions {
        model: arbor::load::ModelOptions { up, auto_camera },
        max_placements,
        bounding_volume,
        instancing,
        ..Default::default()
    }
}

/// The tracer and what building it took.
struct Built {
    tracer: Tracer,
    unique: u128,
    instanced: u128,
    took: std::time::Duration,
}

/// The scene flattened by the library's step, or the one-line error
/// (naming the flag that raises a limit).
pub(crate) fn flatten(scene: &Scene, options: &RenderOptions) -> anyhow::Result<FlattenedScene> {
    arbor::render::flatten(scene, options).map_err(|e| {
        let hint = match e {
            FlattenError::TooManyPlacements { .. } => " (raise it with --max-instances)",
            FlattenError::SingularTransform => "",
        };
        InputError(format!("{e}{hint}")).into()
    })
}

/// Flattens the scene and builds the acceleration structure, or builds it
/// into nested levels, as the options' instancing plans it (errors of
/// nesting name the file `path`).
fn build(options: &RenderOptions, scene: &Scene, path: Option<&Path>) -> anyhow::Result<Built> {
    let flat = match arbor::render::plan(scene, options) {
        Plan::Flat => flatten(scene, options)?,
        Plan::Nested { flatten_budget } => {
            return build_nested(options, scene, path, flatten_budget)
        }
    };
    let (unique, instanced) = (flat.unique_primitives(), flat.instanced_primitives());
    let start = Instant::now();
    let tracer = arbor::render::build_tracer(flat, options);
    Ok(Built {
        tracer,
        unique: unique.into(),
        instanced: instanced.into(),
        took: start.elapsed(),
    })
}

/// [`build`] for a nested plan: the counts are the census's.
fn build_nested(
    options: &RenderOptions,
    scene: &Scene,
    path: Option<&Path>,
    flatten_budget: u64,
) -> anyhow::Result<Built> {
    let name = path.map_or_else(|| "the default scene".into(), |p| p.display().to_string());
    let start = Instant::now();
    let tracer = arbor::render::build_nested(scene, options, flatten_budget)
        .map_err(|e| InputError(format!("{name}: {e}")))?;
    let took = start.elapsed();
    let census = arbor::census::Census::new(&scene.surfaces, scene.variant)
        .map_err(|e| InputError(format!("{name}: {e}")))?;
    Ok(Built {
        tracer,
        unique: census.unique_primitives,
        instanced: census.placed_primitives,
        took,
    })
}

/// A finished film, its ray statistics (with `--stats`) and the render time.
type Traced = (arbor::film::Film, Option<RenderStats>, std::time::Duration);

/// Renders the job's pixels with a progress bar. On Ctrl-C: with
/// `--partial`, writes the tiles done so far and fails; otherwise fails
/// having written nothing.
fn trace_image(args: &RenderArgs, job: &Job, tracer: &Tracer) -> anyhow::Result<Traced> {
    let cancel = Arc::new(AtomicBool::new(false));
    install_interrupt_handler(cancel.clone());
    let total = job.region.area();
    let bar = progress_bar(total, args.quiet);
    let spp = u64::from(job.scene.samples_per_side * job.scene.samples_per_side);
    let warned = AtomicBool::new(args.quiet);
    let start = Instant::now();
    let progress = |n: u64| {
        bar.inc(n);
        let secs = start.elapsed().as_secs_f64();
        let done = bar.position().max(1);
        bar.set_message(format!(
            "{:.2} M camera rays/s",
            (done * spp) as f64 / secs.max(1e-9) / 1e6
        ));
        // Judged once, after a couple of seconds of real progress.
        if secs > SLOW_JUDGED_AFTER_SECONDS && !warned.swap(true, Ordering::Relaxed) {
            let estimate = secs * total as f64 / done as f64;
            if estimate > SLOW_RENDER_SECONDS {
                let why = slow_render_warning(args, &job.scene, tracer, estimate);
                bar.suspend(|| eprintln!("{why}"));
            }
        }
    };
    // Previews for --preview-every and SIGUSR1 (pictures only: a `.part`
    // output has no picture to show).
    let preview = Preview::new();
    let film = std::thread::scope(|threads| {
        if job.part.is_none() {
            let preview = &preview;
            threads.spawn(move || preview.keep_writing(args.preview_every, job));
        }
        let film = render_counted(
            &job.scene,
            tracer,
            job.region,
            &progress,
            &|_, film| preview.tile_done(film),
            &cancel,
            args.stats,
        );
        preview.stop();
        film
    });
    bar.finish_and_clear();
    match film {
        Ok((film, stats)) => Ok((film, stats, start.elapsed())),
        Err(cancelled) if args.partial && job.part.is_none() => {
            crate::output::stage_film(&job.output, &cancelled.partial, job.scene.variant)?
                .commit()?;
            anyhow::bail!(
                "interrupted: wrote the finished tiles to {} (--partial)",
                job.output.display()
            )
        }
        Err(_) => {
            preview.remove(job);
            anyhow::bail!("interrupted: no image written")
        }
    }
}

/// Writes the picture (or part) and the heatmap: all of them or none.
fn write_outputs(
    args: &RenderArgs,
    job: &Job,
    tracer: &Tracer,
    film: arbor::film::Film,
) -> anyhow::Result<Option<(arbor::heatmap::CostMap, std::time::Duration)>> {
    let scene = &job.scene;
    let mut staged = vec![match job.part {
        // A part records where it belongs and what it was rendered from.
        Some(tile) => {
            let part = arbor::partial::Partial {
                header: arbor::partial::PartHeader {
                    width: scene.width,
                    height: scene.height,
                    region: job.region,
                    tile,
                    variant: scene.variant,
                    scene_hash: arbor::partial::scene_hash(scene),
                },
                film,
            };
            crate::output::stage(&job.output, |w| part.encode(w))?
        }
        None => crate::output::stage_film(&job.output, &film, scene.variant)?,
    }];
    let heatmap = match &args.heatmap {
        Some(path) => {
            let start = Instant::now();
            let map = arbor::heatmap::primary_cost(scene, tracer);
            let canvas = arbor::heatmap::heatmap_canvas(&map);
            staged.push(crate::output::stage(path, |w| {
                arbor::film::encode_png(w, canvas.width, canvas.height, &canvas.rgb)
            })?);
            Some((map, start.elapsed()))
        }
        None => None,
    };
    crate::output::commit_all(staged)?;
    Ok(heatmap)
}

/// The `--stats` lines about the scene's primitives and structures.
fn print_build_stats(args: &RenderArgs, built: &Built) {
    let tracer = &built.tracer;
    if let Some(nested) = tracer.nested() {
        eprintln!(
            "primitives: {} unique, {} as placed",
            built.unique, built.instanced
        );
        eprintln!(
            "accel {}: nested, {} definitions built once, {} child placements, {} instance levels; all levels {} bytes",
            tracer.kind(),
            nested.definitions(),
            nested.children(),
            nested.depth(),
            tracer.accel_memory_bytes()
        );
        return;
    }
    let s = arbor_accel::Accelerator::stats(tracer.accel());
    eprintln!(
        "primitives: {} unique, {} of shared geometry, {} as placed",
        built.unique,
        plural(tracer.placements() as u64, "placement", "placements"),
        built.instanced
    );
    eprintln!(
        "accel {}: top level {}, {}, depth {}; all levels {} bytes",
        tracer.kind(),
        plural(s.nodes as u64, "node", "nodes"),
        plural(s.leaves as u64, "leaf", "leaves"),
        s.max_depth,
        tracer.accel_memory_bytes()
    );
    if let Some(volume) = args.bvol {
        let v = tracer.volume_stats();
        let load = |a: &std::sync::atomic::AtomicU64| a.load(Ordering::Relaxed);
        eprintln!(
            "bounding volumes ({volume:?}): {} tests, {} missed, {} surface tests saved",
            load(&v.tests),
            load(&v.misses),
            load(&v.saved)
        );
    }
}

/// `1 sample`, `2 samples`: the count with the word that fits it.
pub fn plural(n: impl Into<u128>, one: &str, many: &str) -> String {
    let n = n.into();
    format!("{n} {}", if n == 1 { one } else { many })
}

// --- `--stats` (rays by kind) and `--heatmap` -------------------------------

/// Renders `region`, counting every ray by kind when `count` is set. The two
/// cases are two monomorphisations of the integrator, chosen once here, so
/// an uncounted render pays nothing for the option.
fn render_counted(
    scene: &arbor::scene::Scene,
    tracer: &Tracer,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
    on_tile: &(dyn Fn(Region, &arbor::film::Film) + Sync),
    cancel: &AtomicBool,
    count: bool,
) -> Result<(arbor::film::Film, Option<RenderStats>), arbor::render::Cancelled> {
    if count {
        render_region_observed::<RenderStats>(scene, tracer, region, progress, on_tile, cancel)
            .map(|(film, stats)| (film, Some(stats)))
    } else {
        render_region_observed::<NoStats>(scene, tracer, region, progress, on_tile, cancel)
            .map(|(film, _)| (film, None))
    }
}

/// `--preview-every` and SIGUSR1: the tiles finished so far, written to
/// the output now and then while the render runs. The render keeps the one
/// film; a preview is a copy of it taken when the next tile finishes after
/// the writer asked, so a render nobody previews copies nothing.
struct Preview {
    /// Set by the writer when a preview is due, cleared by the tile that
    /// answers it.
    wanted: AtomicBool,
    /// What the writer waits for; the condition variable wakes it at once
    /// when either changes, so a short render does not wait out its polling
    /// interval.
    state: (std::sync::Mutex<PreviewState>, std::sync::Condvar),
    written: AtomicBool,
}

#[derive(Default)]
struct PreviewState {
    /// Set by [`Preview::stop`].
    done: bool,
    /// The film so far, copied for the writer.
    snapshot: Option<arbor::film::Film>,
}

impl Preview {
    fn new() -> Preview {
        Preview {
            wanted: AtomicBool::new(false),
            state: Default::default(),
            written: AtomicBool::new(false),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, PreviewState> {
        self.state.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Called as each tile finishes, with the film so far: copies it if
    /// the writer asked for a preview.
    fn tile_done(&self, film: &arbor::film::Film) {
        if self.wanted.swap(false, Ordering::Relaxed) {
            self.lock().snapshot = Some(film.clone());
            self.state.1.notify_all();
        }
    }

    /// Writes the preview every `every` seconds (if given) and whenever
    /// SIGUSR1 asks, until [`Preview::stop`].
    fn keep_writing(&self, every: Option<f64>, job: &Job) {
        let wake = &self.state.1;
        let mut last = Instant::now();
        loop {
            // Checks for SIGUSR1 every 50 ms (a signal handler cannot notify).
            let (state, _) = wake
                .wait_timeout_while(self.lock(), std::time::Duration::from_millis(50), |s| {
                    !s.done
                })
                .unwrap_or_else(|e| e.into_inner());
            if state.done {
                return;
            }
            drop(state);
            let due = every.is_some_and(|e| last.elapsed().as_secs_f64() >= e);
            if !(crate::preview_signal::take() || due) {
                continue;
            }
            last = Instant::now();
            self.wanted.store(true, Ordering::Relaxed);
            let mut state = wake
                .wait_while(self.lock(), |s| !s.done && s.snapshot.is_none())
                .unwrap_or_else(|e| e.into_inner());
            let Some(film) = state.snapshot.take() else {
                return;
            };
            drop(state);
            // The render goes on even if a preview cannot be written.
            if crate::output::stage_film(&job.output, &film, job.scene.variant)
                .and_then(|s| s.commit())
                .is_ok()
            {
                self.written.store(true, Ordering::Relaxed);
            }
        }
    }

    fn stop(&self) {
        self.lock().done = true;
        self.state.1.notify_all();
    }

    /// After an interrupt without `--partial`: no picture is left.
    fn remove(&self, job: &Job) {
        if self.written.load(Ordering::Relaxed) {
            let _ = std::fs::remove_file(&job.output);
        }
    }
}

/// Parses `--preview-every SECONDS` (for clap): a number above 0.
fn parse_seconds(text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|s| s.is_finite() && *s > 0.0)
        .ok_or_else(|| format!("`{text}`: expected a number of seconds above 0, e.g. 5"))
}

/// `--heatmap` writes an 8-bit PNG; anything else is refused before rendering.
fn check_heatmap_path(path: &Path) -> Result<(), InputError> {
    if crate::output::has_png_extension(path) {
        Ok(())
    } else {
        Err(InputError(format!(
            "{}: --heatmap writes a .png file",
            path.display()
        )))
    }
}

/// The `--stats` lines about rays: count, nodes, tests and instance levels
/// entered per ray, by kind.
fn print_ray_stats(
    stats: &RenderStats,
    heatmap: Option<&(arbor::heatmap::CostMap, std::time::Duration)>,
) {
    for kind in RayKind::ALL {
        let k = stats.kind(kind);
        eprintln!(
            "rays {:<10} {:>12}  {:>7.2} nodes/ray  {:>7.2} tests/ray  {:>6.2} levels/ray",
            kind.name(),
            k.rays,
            k.nodes_per_ray(),
            k.tests_per_ray(),
            k.levels_per_ray()
        );
    }
    let t = stats.total();
    eprintln!(
        "rays {:<10} {:>12}  {:>7.2} nodes/ray  {:>7.2} tests/ray  {:>6.2} levels/ray",
        "all",
        t.rays,
        t.nodes_per_ray(),
        t.tests_per_ray(),
        t.levels_per_ray()
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

/// A render estimated to take longer than this says so, with the reason.
const SLOW_RENDER_SECONDS: f64 = 300.0;
/// When the estimate is made (earlier ones are mostly start-up).
const SLOW_JUDGED_AFTER_SECONDS: f64 = 2.0;

/// The early warning for a long render: the estimate, what the camera rays
/// cost (nodes visited plus primitives tested, measured on a small copy of
/// the view) and the faster choice.
fn slow_render_warning(args: &RenderArgs, scene: &Scene, tracer: &Tracer, estimate: f64) -> String {
    let mut probe = scene.clone();
    crate::overrides::resize(
        &mut probe,
        40,
        (40 * scene.height / scene.width.max(1)).max(1),
    );
    let cost = arbor::heatmap::primary_cost(&probe, tracer).mean();
    let faster = if args.accel == AccelKind::DEFAULT {
        "--quick, or a smaller --size or --spp, previews it faster".to_string()
    } else {
        format!("--accel {} is usually much faster", AccelKind::DEFAULT)
    };
    format!(
        "warning: this render will take about {:.0} min: each camera ray costs {cost:.0} nodes and tests with --accel {}; {faster}",
        (estimate / 60.0).ceil(),
        args.accel
    )
}

/// The progress bar of long work (hidden when `quiet`).
pub(crate) fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    // indicatif hides a stderr bar by itself when stderr is not a terminal.
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise}, {eta} left, {msg}")
            .expect("valid template"),
    );
    bar
}

/// The first Ctrl-C asks the render to stop (no file is written); a second
/// one exits at once.
fn install_interrupt_handler(cancel: Arc<AtomicBool>) {
    let _ = ctrlc::set_handler(move || {
        if cancel.swap(true, Ordering::SeqCst) {
            crate::output::remove_pending();
            std::process::exit(130);
        }
    });
}

/// Whether `path` has an image extension we write (for argument checks).
#[allow(dead_code)]
pub fn is_image_path(path: &Path) -> bool {
    ImageFormat::from_path(path).is_ok()
}
