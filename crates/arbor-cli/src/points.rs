//! `arbor inside` and `arbor nearest`: batch point queries against a
//! triangle mesh, through point files laid out like the ray files of
//! `shared/peers/FORMAT.md` (formats in docs/queries.md).

use std::io::Write;
use std::path::{Path, PathBuf};

use arbor_accel::{MeshAccel, Vec3};
use clap::Args;
use serde_json::json;

use crate::batch::{self, f32_at};
use crate::InputError;

/// Size of one point record: x, y, z, max_distance, all `f32`.
const POINT_BYTES: usize = 16;
/// Size of one `nearest` answer: point, triangle, u, v, distance, padding.
const NEAREST_BYTES: usize = 32;
/// The triangle index when nothing lies within the point's `max_distance`.
const NONE: u32 = u32::MAX;

/// Arguments shared by the point queries.
#[derive(Args, Debug)]
pub struct PointArgs {
    /// Triangle mesh: a Cornell `.msh`, a Wavefront `.obj` (polygons split
    /// as fans), a `.ply` or an `.stl`; triangles numbered in file order.
    #[arg(long, value_name = "FILE")]
    pub mesh: PathBuf,
    /// Points: 16-byte little-endian records (x, y, z, max_distance as f32).
    #[arg(long, value_name = "FILE")]
    pub points: PathBuf,
    /// Where to write the answers.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Threads, repetitions, structure.
    #[command(flatten)]
    pub run: batch::RunArgs,
}

/// Arguments of `arbor inside`.
#[derive(Args, Debug)]
pub struct InsideArgs {
    #[command(flatten)]
    pub common: PointArgs,
    /// Inside where the generalised winding number is at least 0.5, instead
    /// of one ray's parity: degrades gracefully on meshes with holes and
    /// on soups (docs/queries.md).
    #[arg(long)]
    pub winding: bool,
}

/// Arguments of `arbor nearest`.
#[derive(Args, Debug)]
pub struct NearestArgs {
    #[command(flatten)]
    pub common: PointArgs,
    /// Negative distances for points inside the mesh (the inside test's
    /// answer).
    #[arg(long)]
    pub signed: bool,
}

/// Runs `arbor inside`: one byte per point, 1 inside, 0 outside.
pub fn run_inside(args: InsideArgs) -> anyhow::Result<()> {
    let winding = args.winding;
    let query = Query {
        name: if winding { "inside_winding" } else { "inside" },
        closest: false,
        inside: !winding,
        winding,
    };
    run(&args.common, query, move |mesh, points, _| {
        let inside: Vec<u8> = if winding {
            let w = mesh.winding_number_batch(points);
            w.into_iter().map(|w| u8::from(w >= 0.5)).collect()
        } else {
            let inside = mesh.contains_batch(points);
            inside.into_iter().map(u8::from).collect()
        };
        let found = inside.iter().filter(|&&i| i == 1).count();
        (inside, found)
    })
}

/// Runs `arbor nearest`: per point the closest point (x, y, z), its
/// triangle, barycentrics u, v and the distance (negative inside with
/// `--signed`), and 4 zero bytes.
pub fn run_nearest(args: NearestArgs) -> anyhow::Result<()> {
    let signed = args.signed;
    let query = Query {
        name: if signed { "signed_distance" } else { "nearest" },
        closest: true,
        inside: signed,
        winding: false,
    };
    run(&args.common, query, move |mesh, points, limits| {
        let near = mesh.closest_point_batch(points, limits);
        let inside = if signed {
            mesh.contains_batch(points)
        } else {
            Vec::new()
        };
        let mut bytes = Vec::with_capacity(points.len() * NEAREST_BYTES);
        let mut found = 0;
        for (i, near) in near.iter().enumerate() {
            let (point, prim, u, v, distance) = match near {
                Some(c) => {
                    found += 1;
                    let sign = if signed && inside[i] { -1.0 } else { 1.0 };
                    (c.point, c.prim, c.u, c.v, sign * c.distance)
                }
                None => (Vec3::ZERO, NONE, 0.0, 0.0, f32::INFINITY),
            };
            for x in point.to_array() {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            bytes.extend_from_slice(&prim.to_le_bytes());
            for x in [u, v, distance] {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            bytes.extend_from_slice(&[0; 4]);
        }
        (bytes, found)
    })
}

/// A point query as [`run`] needs to know it.
struct Query {
    /// Its name in the JSON summary.
    name: &'static str,
    /// Whether it answers closest points (their tree is built first).
    closest: bool,
    /// Whether it answers inside/outside by ray parity (the side grid is
    /// built first, and an open mesh is warned about).
    inside: bool,
    /// Whether it answers winding numbers (their moments are built first).
    winding: bool,
}

/// Loads, builds, reads the points, answers them `repeat` times with
/// `answer` and writes the answers and a one-line JSON summary. `answer`
/// returns the answer bytes and how many points it found something for.
fn run(
    args: &PointArgs,
    query: Query,
    answer: impl Fn(&MeshAccel, &[Vec3], &[f32]) -> (Vec<u8>, usize) + Sync,
) -> anyhow::Result<()> {
    let (structure, pool) = args.run.start()?;
    let repeat = args.run.repeat as usize;
    if let Some(path) = &args.out {
        crate::output::check_writable(path, "--out")?;
    }
    let (mesh, build_ms) = pool.install(|| {
        let (mesh, ms) = batch::load_and_build(&args.mesh, structure, repeat)?;
        let start = std::time::Instant::now();
        // Part of the build: the structures this query uses.
        if query.closest {
            mesh.prepare_closest_points();
        }
        if query.inside {
            mesh.prepare_inside();
        }
        if query.winding {
            mesh.prepare_winding_numbers();
        }
        anyhow::Ok((mesh, ms + batch::ms_since(start)))
    })?;
    if mesh.triangles().is_empty() {
        return Err(InputError(format!(
            "{}: the mesh has no triangles; a point query needs at least one",
            args.mesh.display()
        ))
        .into());
    }
    let (points, limits) = read_points(&args.points)?;
    if query.inside {
        warn_if_open(&args.mesh, &mesh);
    }
    let mut answers = (Vec::new(), 0);
    let (median, min) = batch::timed(repeat, || {
        answers = pool.install(|| answer(&mesh, &points, &limits));
    });
    if let Some(path) = &args.out {
        crate::output::write_atomic(path, |w| w.write_all(&answers.0))?;
    }
    let summary = json!({
        "tracer": "arbor",
        "query": query.name,
        "triangles": mesh.triangles().len(),
        "points": points.len(),
        "found": answers.1,
        "threads": pool.current_num_threads(),
        "accel": structure.kind.name(),
        "quality": structure.quality.name(),
        "build_ms": batch::millis(build_ms),
        "query_ms_median": batch::millis(median),
        "query_ms_min": batch::millis(min),
        "mqueries_per_s": batch::mega_per_s(points.len(), median),
    });
    println!("{summary}");
    Ok(())
}

/// Inside/outside is exact only for a closed mesh: say so when it is not.
fn warn_if_open(path: &Path, mesh: &MeshAccel) {
    let open = mesh.open_edges();
    if open > 0 {
        let edges = if open == 1 { "edge is" } else { "edges are" };
        eprintln!(
            "warning: {}: {open} {edges} not shared by exactly two triangles (the mesh is not \
             closed); inside/outside follows the crossings of one fixed ray per point",
            path.display()
        );
    }
}

/// Reads a point file: 16-byte records (x, y, z, max_distance); the
/// coordinates must be finite and max_distance non-negative (`+inf` for no
/// limit).
fn read_points(path: &Path) -> anyhow::Result<(Vec<Vec3>, Vec<f32>)> {
    let bytes = batch::read_records(
        path,
        POINT_BYTES,
        "point",
        "x, y, z, max_distance as little-endian f32",
    )?;
    let mut points = Vec::with_capacity(bytes.len() / POINT_BYTES);
    let mut limits = Vec::with_capacity(points.capacity());
    for (i, r) in bytes.chunks_exact(POINT_BYTES).enumerate() {
        let p = Vec3::new(f32_at(r, 0), f32_at(r, 1), f32_at(r, 2));
        let max = f32_at(r, 3);
        if !p.is_finite() {
            return Err(InputError(format!(
                "{}: point {i} (bytes {}..{}) has a coordinate that is not a finite number: {p}",
                path.display(),
                i * POINT_BYTES,
                (i + 1) * POINT_BYTES
            ))
            .into());
        }
        if max.is_nan() || max < 0.0 {
            return Err(InputError(format!(
                "{}: point {i} has max_distance {max}; expected a number >= 0 (or +inf)",
                path.display()
            ))
            .into());
        }
        points.push(p);
        limits.push(max);
    }
    Ok((points, limits))
}
