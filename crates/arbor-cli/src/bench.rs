//! `arbor bench`: build every acceleration structure over one input and trace
//! the same deterministic ray sets through each, reporting build time, size,
//! shape, speed and traversal work side by side.
//!
//! Two kinds of input:
//!
//! * a triangle mesh (`.msh`, `.obj`, `.ply`, `.stl`, `.gltf`, `.glb`) is
//!   read and benched as `arbor trace` reads and traces it: the same loader,
//!   `f32` rays, and the timed passes are [`MeshAccel`]'s batch calls (camera
//!   rays in packets) that `arbor trace` times (what the Embree comparison
//!   measures);
//! * a scene (`.xml`) is benched through the renderer's two-level
//!   [`Tracer`] over the flattened world primitives and placements, with
//!   `f64` rays and exact tests (what `arbor render` pays per ray).
//!
//! Speed is timed without counting; nodes and tests per ray come from a
//! separate counted pass, one ray at a time with `RayCounts`, so counting
//! never slows the timed pass.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use arbor::flatten::{FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use arbor::load::Format;
use arbor::scene::Scene;
use arbor::tracer::{SplitCounters, Tracer, TracerOptions};
use arbor_accel::{
    AccelKind, AccelStats, Accelerator, BuildQuality, MeshAccel, NoCounters, Ray, RayCounts, Vec3,
};
use clap::Args;
use glam::DVec3;
use rayon::prelude::*;
use serde_json::{json, Value};

use crate::accel_arg::{AccelChoice, QualityArg};
use crate::input::{load_input, Input, ReadAs};
use crate::InputError;

mod plot;

/// Rays per rayon task: enough that scheduling is free next to tracing.
const RAYS_PER_TASK: usize = 256;

/// Arguments of `arbor bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A triangle mesh (`.msh`, `.obj`, `.ply`, `.stl`, `.gltf`, `.glb`,
    /// read as `arbor trace` reads it) or a Cornell XML scene (`.xml`,
    /// benched through the renderer's tracer).
    pub input: PathBuf,
    /// Accelerators: `all` (every one except the brute-force `list`) or a
    /// comma-separated list of names (`all` may be one of them).
    #[arg(
        long,
        value_name = "all|NAME,NAME",
        default_value = "all",
        value_delimiter = ',',
        value_parser = crate::accel_arg::parse_choice
    )]
    pub accel: Vec<AccelChoice>,
    /// Ray kinds, comma-separated: `primary`, `shadow`, `diffuse` (default: all three).
    #[arg(long, value_name = "KINDS")]
    pub rays: Option<String>,
    /// Also write the results as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Draw the comparison (Mrays/s per accelerator and ray kind, build
    /// time) to an `.svg` or `.png` file.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub threads: Option<u32>,
    /// Primary rays per side for a mesh (N x N camera rays); a scene uses its
    /// own camera and resolution.
    #[arg(long, value_name = "N", default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub size: u32,
    /// Timed passes per ray kind; the fastest counts.
    #[arg(long, value_name = "K", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
    #[command(flatten)]
    pub build: QualityArg,
}

/// The kinds of rays benched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// Camera rays framing the input.
    Primary,
    /// One ray per primary hit toward a point light above the input.
    Shadow,
    /// One cosine-weighted bounce per primary hit.
    Diffuse,
}

impl RayKind {
    /// Every kind, in report order.
    pub const ALL: [RayKind; 3] = [RayKind::Primary, RayKind::Shadow, RayKind::Diffuse];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Diffuse => "diffuse",
        }
    }
}

/// Parses `--rays`: a comma-separated list of ray kinds, kept in report order.
pub fn parse_rays(spec: Option<&str>) -> Result<Vec<RayKind>, InputError> {
    let Some(spec) = spec else {
        return Ok(RayKind::ALL.to_vec());
    };
    let mut wanted = Vec::new();
    for name in spec.split(',').map(str::trim) {
        let kind = RayKind::ALL
            .into_iter()
            .find(|k| k.name() == name)
            .ok_or_else(|| {
                InputError(format!(
                    "--rays: unknown ray kind '{name}'; expected a comma-separated list of \
                     primary, shadow, diffuse"
                ))
            })?;
        wanted.push(kind);
    }
    Ok(RayKind::ALL
        .into_iter()
        .filter(|k| wanted.contains(k))
        .collect())
}

/// Measurements of one ray kind through one structure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayResult {
    /// The ray kind.
    pub kind: RayKind,
    /// Rays traced.
    pub rays: usize,
    /// Millions of rays per second in the fastest timed pass.
    pub mrays_per_s: f64,
    /// Nodes (grid cells) visited per ray, from the counted pass.
    pub nodes_per_ray: f64,
    /// Exact primitive tests per ray, from the counted pass.
    pub tests_per_ray: f64,
}

/// Measurements of one structure.
#[derive(Clone, Debug, PartialEq)]
pub struct AccelResult {
    /// Which structure.
    pub accel: AccelKind,
    /// Build time in milliseconds.
    pub build_ms: f64,
    /// Size and shape of the structure.
    pub stats: AccelStats,
    /// One entry per benched ray kind.
    pub rays: Vec<RayResult>,
}

/// Everything `arbor bench` measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The input as given.
    pub input: String,
    /// Primitives indexed (triangles of a mesh; world primitives plus
    /// placements of a scene).
    pub primitives: usize,
    /// Worker threads.
    pub threads: usize,
    /// How carefully the structures were built.
    pub quality: BuildQuality,
    /// One entry per structure.
    pub results: Vec<AccelResult>,
}

/// One ray in `f64`; each subject turns it into what it traces.
#[derive(Clone, Copy, Debug)]
struct Ray64 {
    o: DVec3,
    d: DVec3,
    tmin: f64,
    tmax: f64,
}

/// Something to bench: build structures over it, trace rays through them.
trait Subject: Sync {
    /// A built structure, with whatever the exact test needs.
    type Built: Sync;
    /// The ray as traced.
    type Ray: Sync + Send;
    fn primitives(&self) -> usize;
    fn stats(built: &Self::Built) -> AccelStats;
    fn ray(r: &Ray64) -> Self::Ray;
    /// The distance of the nearest hit.
    fn closest<C: SplitCounters>(&self, b: &Self::Built, r: &Self::Ray, c: &mut C) -> Option<f64>;
    /// Whether anything lies on the ray.
    fn occluded<C: SplitCounters>(&self, b: &Self::Built, r: &Self::Ray, c: &mut C) -> bool;
    /// The nearest hit's distance and geometric normal, for making the
    /// secondary rays (not timed).
    fn surface(&self, b: &Self::Built, r: &Ray64) -> Option<(f64, DVec3)>;
    /// Camera rays.
    fn primary_rays(&self, size: u32) -> Vec<Ray64>;
    /// The fastest of `repeat` timed passes of `rays` in seconds: by
    /// default one ray at a time in parallel, without counting.
    fn fastest_pass(&self, b: &Self::Built, kind: RayKind, rays: &[Self::Ray], repeat: u32) -> f64
    where
        Self: Sized,
    {
        fastest(repeat, || {
            let (hits, _) = trace_pass::<Self, NoCounters>(self, b, kind, rays);
            std::hint::black_box(hits);
        })
    }
}

/// The fastest of `repeat` runs of `pass`, in seconds.
fn fastest(repeat: u32, mut pass: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let start = Instant::now();
        pass();
        best = best.min(start.elapsed().as_secs_f64());
    }
    best
}

/// A triangle mesh, traced exactly as `arbor trace` traces it (the same
/// [`MeshAccel`] batch queries, timed the same way).
struct MeshSubject {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Subject for MeshSubject {
    type Built = MeshAccel;
    type Ray = Ray;

    fn primitives(&self) -> usize {
        self.triangles.len()
    }

    fn stats(built: &MeshAccel) -> AccelStats {
        built.stats()
    }

    fn ray(r: &Ray64) -> Ray {
        Ray::new(
            r.o.as_vec3(),
            r.d.as_vec3(),
            r.tmin as f32,
            if r.tmax.is_finite() {
                r.tmax as f32
            } else {
                f32::INFINITY
            },
        )
    }

    #[inline]
    fn closest<C: SplitCounters>(&self, b: &MeshAccel, r: &Ray, c: &mut C) -> Option<f64> {
        b.closest_counted(r, c).map(|h| f64::from(h.hit.t))
    }

    #[inline]
    fn occluded<C: SplitCounters>(&self, b: &MeshAccel, r: &Ray, c: &mut C) -> bool {
        b.occluded_counted(r, c)
    }

    fn surface(&self, b: &MeshAccel, r: &Ray64) -> Option<(f64, DVec3)> {
        let hit = b.closest(&Self::ray(r))?;
        let [a, bb, cc] = b.triangle(hit.prim);
        let n = (bb - a).cross(cc - a).as_dvec3();
        Some((f64::from(hit.hit.t), n))
    }

    fn primary_rays(&self, size: u32) -> Vec<Ray64> {
        let (lo, hi) = self.vertices.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p.as_dvec3()), hi.max(p.as_dvec3())),
        );
        framing_rays(lo, hi, size)
    }

    /// What `arbor trace` times: the closest hits into an answer buffer
    /// made once, occlusion as a fresh answer vector per pass.
    fn fastest_pass(&self, b: &MeshAccel, kind: RayKind, rays: &[Ray], repeat: u32) -> f64 {
        match kind {
            RayKind::Shadow => fastest(repeat, || {
                std::hint::black_box(b.occluded_batch(rays));
            }),
            _ => {
                let mut hits = vec![None; rays.len()];
                fastest(repeat, || {
                    b.closest_batch_into(rays, &mut hits);
                    std::hint::black_box(&hits);
                })
            }
        }
    }
}

/// A scene, traced through the renderer's two-level tracer.
struct SceneSubject {
    scene: Scene,
    primitives: usize,
}

impl SceneSubject {
    fn flatten(&self) -> anyhow::Result<FlattenedScene> {
        FlattenedScene::new(&self.scene, DEFAULT_MAX_PLACEMENTS)
            .map_err(|e| InputError(e.to_string()).into())
    }
}

/// A scene's tracer, built from a flattening made before the clock starts
/// (flattening is the same for every structure).
struct SceneBuilt {
    tracer: Tracer,
}

impl Subject for SceneSubject {
    type Built = SceneBuilt;
    type Ray = arbor::ray::Ray;

    fn primitives(&self) -> usize {
        self.primitives
    }

    fn stats(built: &SceneBuilt) -> AccelStats {
        AccelStats {
            memory_bytes: built.tracer.accel_memory_bytes(),
            ..built.tracer.accel().stats()
        }
    }

    fn ray(r: &Ray64) -> arbor::ray::Ray {
        arbor::ray::Ray::new(r.o, r.d, r.tmin, r.tmax)
    }

    #[inline]
    fn closest<C: SplitCounters>(
        &self,
        b: &SceneBuilt,
        r: &arbor::ray::Ray,
        c: &mut C,
    ) -> Option<f64> {
        b.tracer.closest_counted(r, c).map(|h| h.t)
    }

    #[inline]
    fn occluded<C: SplitCounters>(&self, b: &SceneBuilt, r: &arbor::ray::Ray, c: &mut C) -> bool {
        b.tracer.occluded_counted(r, c)
    }

    fn surface(&self, b: &SceneBuilt, r: &Ray64) -> Option<(f64, DVec3)> {
        b.tracer.closest(&Self::ray(r)).map(|h| (h.t, h.normal))
    }

    /// The scene's own camera, one ray through each pixel centre.
    fn primary_rays(&self, _size: u32) -> Vec<Ray64> {
        let camera = self.scene.camera.prepare();
        let (w, h) = (self.scene.width, self.scene.height);
        let mut one = self.scene.clone();
        one.samples_per_side = 1;
        (0..h)
            .flat_map(|row| (0..w).map(move |col| (col, row)))
            .map(|(col, row)| {
                let r = arbor::render::camera_ray(&one, &camera, col, row, 0, 0);
                Ray64 {
                    o: r.origin,
                    d: r.direction,
                    tmin: r.tmin,
                    tmax: r.tmax,
                }
            })
            .collect()
    }
}

/// `size` x `size` rays from a pinhole camera that frames the bounding
/// sphere of `lo..hi` from above and in front (a 45 degree field of view).
fn framing_rays(lo: DVec3, hi: DVec3, size: u32) -> Vec<Ray64> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let center = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let half = 22.5f64.to_radians();
    let back = DVec3::new(0.45, 0.35, 1.0).normalize();
    let eye = center + back * (radius / half.sin());
    let w = -back;
    let u = DVec3::Y.cross(back).normalize();
    let v = back.cross(u);
    let tan = half.tan();
    let n = size as f64;
    let mut rays = Vec::with_capacity(size as usize * size as usize);
    for j in 0..size {
        for i in 0..size {
            let x = ((i as f64 + 0.5) / n * 2.0 - 1.0) * tan;
            let y = (1.0 - (j as f64 + 0.5) / n * 2.0) * tan;
            rays.push(Ray64 {
                o: eye,
                d: (w + x * u + y * v).normalize(),
                tmin: 0.0,
                tmax: f64::INFINITY,
            });
        }
    }
    rays
}

/// SplitMix64: a fixed-seed hash turning a ray index into random bits, so
/// the ray sets are the same on every run and every machine.
fn hash(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in `[0, 1)` from 53 random bits.
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

/// A cosine-weighted direction about the unit normal `n` (Malley's method),
/// from two uniform numbers.
fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let (t, b) = n.any_orthonormal_pair();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

/// The ray sets of one input.
struct RaySets {
    primary: Vec<Ray64>,
    shadow: Vec<Ray64>,
    diffuse: Vec<Ray64>,
}

impl RaySets {
    fn get(&self, kind: RayKind) -> &[Ray64] {
        match kind {
            RayKind::Primary => &self.primary,
            RayKind::Shadow => &self.shadow,
            RayKind::Diffuse => &self.diffuse,
        }
    }
}

/// Makes the camera rays, finds their hits through `reference`, and from
/// each hit one shadow ray toward a light above and one diffuse bounce.
fn make_rays<S: Subject>(subject: &S, reference: &S::Built, size: u32) -> RaySets {
    let primary = subject.primary_rays(size);
    let hits: Vec<(usize, DVec3, DVec3)> = primary
        .par_iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let (t, n) = subject.surface(reference, r)?;
            let p = r.o + t * r.d;
            let n = n.normalize_or_zero();
            if n == DVec3::ZERO || !p.is_finite() {
                return None;
            }
            // The side the ray came from.
            let n = if n.dot(r.d) > 0.0 { -n } else { n };
            Some((i, p, n))
        })
        .collect();
    // The light sits above the bounds of what the camera sees.
    let (lo, hi) = hits.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), (_, p, _)| (lo.min(*p), hi.max(*p)),
    );
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let light = (lo + hi) / 2.0 + DVec3::Y * (2.0 * radius);
    // Secondary rays leave from just off the surface, as a renderer's would.
    let offset = 1e-4 * radius;
    let mut shadow = Vec::with_capacity(hits.len());
    let mut diffuse = Vec::with_capacity(hits.len());
    for &(i, p, n) in &hits {
        let o = p + n * offset;
        shadow.push(Ray64 {
            o,
            d: light - o,
            tmin: 0.0,
            tmax: 1.0,
        });
        let bits = hash(i as u64);
        let d = cosine_direction(n, unit(bits), unit(hash(bits)));
        diffuse.push(Ray64 {
            o,
            d,
            tmin: 0.0,
            tmax: f64::INFINITY,
        });
    }
    RaySets {
        primary,
        shadow,
        diffuse,
    }
}

/// Traces `rays` once in parallel; returns the number of hits (so the work
/// cannot be optimised away).
fn trace_pass<S: Subject, C: SplitCounters + Send>(
    subject: &S,
    built: &S::Built,
    kind: RayKind,
    rays: &[S::Ray],
) -> (usize, C) {
    rays.par_iter()
        .with_min_len(RAYS_PER_TASK)
        .fold(
            || (0usize, C::default()),
            |(hits, mut c), r| {
                let hit = match kind {
                    RayKind::Shadow => subject.occluded(built, r, &mut c),
                    _ => subject.closest(built, r, &mut c).is_some(),
                };
                (hits + usize::from(hit), c)
            },
        )
        .reduce(
            || (0usize, C::default()),
            |(h1, mut c1), (h2, c2)| {
                c1.merge(c2);
                (h1 + h2, c1)
            },
        )
}

/// Times and counts every requested ray kind through `built`.
fn measure<S: Subject>(
    subject: &S,
    built: &S::Built,
    sets: &RaySets,
    kinds: &[RayKind],
    repeat: u32,
) -> Vec<RayResult> {
    kinds
        .iter()
        .map(|&kind| {
            let rays: Vec<S::Ray> = sets.get(kind).iter().map(S::ray).collect();
            let best = subject.fastest_pass(built, kind, &rays, repeat);
            let (_, counts) = trace_pass::<S, RayCounts>(subject, built, kind, &rays);
            let n = rays.len();
            let per = |x: u64| if n == 0 { 0.0 } else { x as f64 / n as f64 };
            RayResult {
                kind,
                rays: n,
                // A pass too fast to time (no rays) reports zero, not infinity.
                mrays_per_s: if best > 0.0 && n > 0 {
                    n as f64 / best / 1e6
                } else {
                    0.0
                },
                nodes_per_ray: per(counts.nodes),
                tests_per_ray: per(counts.tests),
            }
        })
        .collect()
}

/// What `arbor bench` times.
enum Benched {
    Mesh(MeshSubject),
    Scene(SceneSubject),
}

/// Reads the input as the CLI's one loader gives it for benching: a
/// Cornell `.xml` scene goes through the tracer; every mesh format (glTF as
/// one mesh with its node transforms) is read by `arbor trace`'s loader, so
/// triangle numbering and speed match.
fn load_subject(path: &Path) -> anyhow::Result<Benched> {
    match load_input(Some(path), ReadAs::SceneOrMesh, false)? {
        Input::Mesh(mesh) => {
            if mesh.triangles.is_empty() {
                return Err(
                    InputError(format!("{}: the mesh has no triangles", path.display())).into(),
                );
            }
            Ok(Benched::Mesh(MeshSubject {
                vertices: mesh.positions,
                triangles: mesh.triangles,
            }))
        }
        other => {
            let scene = other.into_scene()?;
            let flat = FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS)
                .map_err(|e| InputError(e.to_string()))?;
            let primitives = flat.world.len() + flat.placements.len();
            Ok(Benched::Scene(SceneSubject { scene, primitives }))
        }
    }
}

/// Runs `arbor bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    // Everything the user can get wrong is checked before the slow part.
    let accels = structures(&args.accel, args.build)?;
    let kinds = parse_rays(args.rays.as_deref())?;
    if let Some(p) = &args.plot {
        crate::output::check_writable(p, "--plot")?;
        plot::PlotFormat::from_path(p)?;
    }
    if let Some(p) = &args.json {
        crate::output::check_writable(p, "--json")?;
    }
    let scene = matches!(Format::from_path(&args.input), Ok(Format::Xml));
    if scene && args.build.quality != BuildQuality::Fast {
        return Err(InputError(format!(
            "--quality {}: a scene is benched through the renderer's tracer, which builds \
             fast structures only; --quality is for meshes",
            args.build.quality
        ))
        .into());
    }
    let pool = crate::thread_pool(args.threads.map(|n| n as usize))?;
    let input = load_subject(&args.input)?;
    let report = pool.install(|| -> anyhow::Result<Report> {
        let results = match &input {
            Benched::Mesh(m) => bench_with(m, &accels, &kinds, &args, |k| {
                let (vertices, triangles) = (m.vertices.clone(), m.triangles.clone());
                let params = MeshAccel::params(k).with_quality(args.build.quality);
                let start = Instant::now();
                let mesh = MeshAccel::build_with(vertices, triangles, k, &params)
                    .map_err(|e| InputError(format!("{}: {e}", args.input.display())))?;
                Ok((mesh, ms_since(start)))
            })?,
            // Flattening is the same for every structure: only the tracer's
            // build is timed.
            Benched::Scene(s) => bench_with(s, &accels, &kinds, &args, |k| {
                let flat = s.flatten()?;
                let start = Instant::now();
                let tracer = Tracer::build(flat, &TracerOptions::with_accel(k));
                Ok((SceneBuilt { tracer }, ms_since(start)))
            })?,
        };
        let primitives = match &input {
            Benched::Mesh(m) => m.primitives(),
            Benched::Scene(s) => s.primitives(),
        };
        Ok(Report {
            input: args.input.display().to_string(),
            primitives,
            threads: rayon::current_num_threads(),
            quality: args.build.quality,
            results,
        })
    })?;
    print!("{}", markdown(&report));
    if let Some(path) = &args.json {
        let text = json(&report);
        crate::output::write_text(path, &text)?;
    }
    if let Some(path) = &args.plot {
        plot::draw(&report, path).with_context(|| format!("drawing {}", path.display()))?;
    }
    Ok(())
}

/// The structures `--accel` names at build quality `quality`: at high
/// quality `all` means the kinds that have it, and a kind named that has
/// not is an error.
fn structures(choices: &[AccelChoice], build: QualityArg) -> Result<Vec<AccelKind>, InputError> {
    let mut kinds = Vec::new();
    for choice in choices {
        for k in crate::accel_arg::expand(std::slice::from_ref(choice)) {
            // A kind named outright must fit; `all` keeps those that do.
            match build.check(k) {
                Ok(()) if !kinds.contains(&k) => kinds.push(k),
                Ok(()) => {}
                Err(e) if matches!(choice, AccelChoice::One(_)) => return Err(e),
                Err(_) => {}
            }
        }
    }
    Ok(kinds)
}

/// Builds each structure with `build` (which returns it with its build time
/// in milliseconds) and measures it.
fn bench_with<S: Subject>(
    subject: &S,
    accels: &[AccelKind],
    kinds: &[RayKind],
    args: &BenchArgs,
    build: impl Fn(AccelKind) -> anyhow::Result<(S::Built, f64)>,
) -> anyhow::Result<Vec<AccelResult>> {
    // One reference structure makes the ray sets, so every structure traces
    // exactly the same rays.
    let (reference, _) = build(AccelKind::DEFAULT)?;
    let sets = make_rays(subject, &reference, args.size);
    drop(reference);
    let mut results = Vec::with_capacity(accels.len());
    for &kind in accels {
        let (built, build_ms) = build(kind)?;
        let stats = S::stats(&built);
        let rays = measure(subject, &built, &sets, kinds, args.repeat);
        results.push(AccelResult {
            accel: kind,
            build_ms,
            stats,
            rays,
        });
    }
    Ok(results)
}

/// Milliseconds since `start`.
fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The report as a Markdown table, one row per structure.
pub fn markdown(report: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {} primitives, {} threads, {} builds",
        report.input, report.primitives, report.threads, report.quality
    );
    if let Some(first) = report.results.first() {
        let counts: Vec<String> = first
            .rays
            .iter()
            .map(|r| format!("{} {} rays", r.rays, r.kind.name()))
            .collect();
        let _ = writeln!(s, "{}", counts.join(", "));
    }
    s.push('\n');
    let mut header = vec![
        "accel".to_string(),
        "build ms".into(),
        "memory B".into(),
        "B/prim".into(),
        "nodes".into(),
        "leaves".into(),
        "depth".into(),
        "SAH".into(),
    ];
    if let Some(first) = report.results.first() {
        for r in &first.rays {
            let k = r.kind.name();
            header.push(format!("{k} Mrays/s"));
            header.push(format!("{k} nodes/ray"));
            header.push(format!("{k} tests/ray"));
        }
    }
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let align: Vec<&str> = header
        .iter()
        .enumerate()
        .map(|(i, _)| if i == 0 { "---" } else { "---:" })
        .collect();
    let _ = writeln!(s, "| {} |", align.join(" | "));
    for r in &report.results {
        let per_prim = if report.primitives == 0 {
            0.0
        } else {
            r.stats.memory_bytes as f64 / report.primitives as f64
        };
        let mut row = vec![
            r.accel.name().to_string(),
            format!("{:.1}", r.build_ms),
            r.stats.memory_bytes.to_string(),
            format!("{per_prim:.1}"),
            r.stats.nodes.to_string(),
            r.stats.leaves.to_string(),
            r.stats.max_depth.to_string(),
            r.stats
                .sah_cost
                .map_or_else(|| "-".to_string(), |c| format!("{c:.1}")),
        ];
        for k in &r.rays {
            row.push(format!("{:.2}", k.mrays_per_s));
            row.push(format!("{:.1}", k.nodes_per_ray));
            row.push(format!("{:.1}", k.tests_per_ray));
        }
        let _ = writeln!(s, "| {} |", row.join(" | "));
    }
    s
}

/// The report as the JSON document of `--json` (a number that is not
/// finite, which JSON cannot hold, is `null`).
pub fn json(report: &Report) -> String {
    let results: Vec<Value> = report
        .results
        .iter()
        .map(|r| {
            let rays: serde_json::Map<String, Value> = r
                .rays
                .iter()
                .map(|k| {
                    let measured = json!({
                        "rays": k.rays,
                        "mrays_per_s": k.mrays_per_s,
                        "nodes_per_ray": k.nodes_per_ray,
                        "tests_per_ray": k.tests_per_ray,
                    });
                    (k.kind.name().to_string(), measured)
                })
                .collect();
            json!({
                "accel": r.accel.name(),
                "build_ms": r.build_ms,
                "memory_bytes": r.stats.memory_bytes,
                "nodes": r.stats.nodes,
                "leaves": r.stats.leaves,
                "max_depth": r.stats.max_depth,
                "sah_cost": r.stats.sah_cost,
                "rays": rays,
            })
        })
        .collect();
    let doc = json!({
        "input": report.input,
        "primitives": report.primitives,
        "threads": report.threads,
        "quality": report.quality.name(),
        "results": results,
    });
    serde_json::to_string_pretty(&doc).expect("a JSON value always serialises") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_lists() {
        assert_eq!(parse_rays(None).unwrap(), RayKind::ALL.to_vec());
        assert_eq!(
            parse_rays(Some("diffuse,primary")).unwrap(),
            vec![RayKind::Primary, RayKind::Diffuse]
        );
        assert!(parse_rays(Some("primary,camera")).is_err());
        assert!(parse_rays(Some("")).is_err());
    }

    #[test]
    fn cosine_directions_stay_in_the_hemisphere() {
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let mut mean = 0.0;
        for i in 0..2000u64 {
            let bits = hash(i);
            let d = cosine_direction(n, unit(bits), unit(hash(bits)));
            assert!((d.length() - 1.0).abs() < 1e-9);
            assert!(d.dot(n) >= 0.0);
            mean += d.dot(n);
        }
        // E[cos] under a cosine-weighted distribution is 2/3.
        mean /= 2000.0;
        assert!((mean - 2.0 / 3.0).abs() < 0.02, "{mean}");
    }

    #[test]
    fn json_escapes_text_and_writes_non_finite_numbers_as_null() {
        let report = Report {
            input: "a\"b\\c\n.obj".into(),
            primitives: 12,
            threads: 3,
            quality: BuildQuality::High,
            results: vec![AccelResult {
                accel: AccelKind::Grid,
                build_ms: 1.5,
                stats: AccelStats {
                    nodes: 7,
                    leaves: 4,
                    max_depth: 2,
                    memory_bytes: 640,
                    sah_cost: None,
                },
                rays: vec![RayResult {
                    kind: RayKind::Shadow,
                    rays: 100,
                    mrays_per_s: f64::INFINITY,
                    nodes_per_ray: 2.25,
                    tests_per_ray: f64::NAN,
                }],
            }],
        };
        let doc: Value = serde_json::from_str(&json(&report)).unwrap();
        assert_eq!(doc["input"], "a\"b\\c\n.obj");
        assert_eq!(
            (doc["primitives"].as_u64(), doc["threads"].as_u64()),
            (Some(12), Some(3))
        );
        let r = &doc["results"][0];
        assert_eq!(r["accel"], "grid");
        assert_eq!(r["build_ms"].as_f64(), Some(1.5));
        assert_eq!(r["memory_bytes"].as_u64(), Some(640));
        assert_eq!(
            (r["nodes"].as_u64(), r["leaves"].as_u64()),
            (Some(7), Some(4))
        );
        assert_eq!(r["max_depth"].as_u64(), Some(2));
        assert!(r["sah_cost"].is_null());
        let shadow = &r["rays"]["shadow"];
        assert_eq!(shadow["rays"].as_u64(), Some(100));
        assert!(shadow["mrays_per_s"].is_null());
        assert_eq!(shadow["nodes_per_ray"].as_f64(), Some(2.25));
        assert!(shadow["tests_per_ray"].is_null());
    }
}
