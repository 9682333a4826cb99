//! `arbor trace`: batch ray casting against a triangle mesh, speaking the ray
//! and hit file interface of `shared/peers/FORMAT.md` so that its answers and
//! speed can be compared with Embree's `embree_trace` ray for ray; besides
//! closest hits and occlusion it answers every hit along each ray and hit
//! counts (`--query all|count`, formats in docs/queries.md).

use std::io::Write;
use std::path::PathBuf;

use arbor_accel::{AllHits, MeshAccel, MeshHit, Ray, Vec3};
use clap::{Args, ValueEnum};
use serde_json::json;

use crate::batch::{self, f32_at};

/// Size of one ray record: origin, tnear, direction, tfar, all `f32`.
const RAY_BYTES: usize = 32;
/// Size of one hit record: t, triangle, u, v.
const HIT_BYTES: usize = 16;
/// The triangle index of a miss.
const MISS: u32 = u32::MAX;

/// What `arbor trace` answers for each ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Query {
    /// The closest hit: a 16-byte record (t, triangle, u, v).
    Closest,
    /// Whether anything lies between tnear and tfar: one byte, 1 or 0.
    Occluded,
    /// Every crossing of the surface, sorted by t: a u32 count, then that
    /// many 16-byte hit records.
    All,
    /// How many crossings: one u32.
    Count,
}

impl Query {
    fn name(self) -> &'static str {
        match self {
            Query::Closest => "closest",
            Query::Occluded => "occluded",
            Query::All => "all",
            Query::Count => "count",
        }
    }
}

/// Arguments of `arbor trace`.
#[derive(Args, Debug)]
pub struct TraceArgs {
    /// Triangle mesh: a Cornell `.msh`, a Wavefront `.obj` (polygons split
    /// as fans), a `.ply` or an `.stl`, triangles numbered in file order; or
    /// a `.gltf`/`.glb`, every placed mesh with its node transforms, nodes
    /// depth first (docs/queries.md).
    #[arg(long, value_name = "FILE")]
    pub mesh: PathBuf,
    /// Rays: 32-byte little-endian records (origin, tnear, direction, tfar).
    #[arg(long, value_name = "FILE")]
    pub rays: PathBuf,
    /// Where to write the answers (see --query for their layout).
    #[arg(long, value_name = "FILE")]
    pub hits: Option<PathBuf>,
    /// What to answer for each ray (default: closest).
    #[arg(long, value_enum, value_name = "QUERY", conflicts_with = "occluded")]
    pub query: Option<Query>,
    /// The same as `--query occluded`.
    #[arg(long)]
    pub occluded: bool,
    /// Threads, repetitions, structure.
    #[command(flatten)]
    pub run: batch::RunArgs,
}

/// Runs `arbor trace`.
pub fn run(args: TraceArgs) -> anyhow::Result<()> {
    let query = match (args.query, args.occluded) {
        (Some(q), _) => q,
        (None, true) => Query::Occluded,
        (None, false) => Query::Closest,
    };
    let (structure, pool) = args.run.start()?;
    let repeat = args.run.repeat as usize;
    // Everything the user can get wrong is checked before the slow part.
    if let Some(path) = &args.hits {
        crate::output::check_writable(path, "--hits")?;
    }
    let (mesh, build_ms) = pool.install(|| batch::load_and_build(&args.mesh, structure, repeat))?;
    let rays = read_rays(&args.rays)?;

    // Only the queries are timed (as embree_trace times them): the answer
    // buffer is reused across passes and encoded afterwards.
    let mut answer = Answer::new(query, rays.len());
    let (median, min) = batch::timed(repeat, || pool.install(|| answer.compute(&mesh, &rays)));
    let (bytes, hits) = answer.encode();
    if let Some(path) = &args.hits {
        crate::output::write_atomic(path, |w| w.write_all(&bytes))?;
    }
    let summary = json!({
        "tracer": "arbor",
        "triangles": mesh.triangles().len(),
        "rays": rays.len(),
        "hits": hits,
        "threads": pool.current_num_threads(),
        "query": query.name(),
        "accel": structure.kind.name(),
        "quality": structure.quality.name(),
        "build_ms": batch::millis(build_ms),
        "trace_ms_median": batch::millis(median),
        "trace_ms_min": batch::millis(min),
        "mrays_per_s": batch::mega_per_s(rays.len(), median),
    });
    println!("{summary}");
    Ok(())
}

/// The answers of one query for every ray.
enum Answer {
    Closest(Vec<Option<MeshHit>>),
    Occluded(Vec<bool>),
    All(AllHits),
    Count(Vec<u32>),
}

impl Answer {
    /// Room for the answers of `query` for `rays` rays.
    fn new(query: Query, rays: usize) -> Self {
        match query {
            Query::Closest => Answer::Closest(vec![None; rays]),
            Query::Occluded => Answer::Occluded(Vec::new()),
            Query::All => Answer::All(AllHits::default()),
            Query::Count => Answer::Count(Vec::new()),
        }
    }

    /// Answers every ray, in parallel on the current pool.
    fn compute(&mut self, mesh: &MeshAccel, rays: &[Ray]) {
        match self {
            Answer::Closest(hits) => mesh.closest_batch_into(rays, hits),
            Answer::Occluded(occluded) => *occluded = mesh.occluded_batch(rays),
            Answer::All(all) => *all = mesh.all_hits_batch(rays),
            Answer::Count(counts) => *counts = mesh.count_batch(rays),
        }
    }

    /// The answer file's bytes and the number of hits (rays hit or
    /// occluded, or crossings for `all` and `count`).
    fn encode(&self) -> (Vec<u8>, usize) {
        match self {
            Answer::Closest(hits) => {
                let mut bytes = Vec::with_capacity(hits.len() * HIT_BYTES);
                for h in hits {
                    push_hit(&mut bytes, h.as_ref());
                }
                (bytes, hits.iter().filter(|h| h.is_some()).count())
            }
            Answer::Occluded(occluded) => (
                occluded.iter().map(|&o| u8::from(o)).collect(),
                occluded.iter().filter(|&&o| o).count(),
            ),
            Answer::All(all) => {
                let mut bytes =
                    Vec::with_capacity(4 * all.counts.len() + HIT_BYTES * all.hits.len());
                let mut hits = all.hits.iter();
                for &n in &all.counts {
                    bytes.extend_from_slice(&n.to_le_bytes());
                    for h in hits.by_ref().take(n as usize) {
                        push_hit(&mut bytes, Some(h));
                    }
                }
                (bytes, all.hits.len())
            }
            Answer::Count(counts) => (
                counts.iter().flat_map(|n| n.to_le_bytes()).collect(),
                counts.iter().map(|&n| n as usize).sum(),
            ),
        }
    }
}

/// Appends one 16-byte hit record (a miss: t = inf, triangle = MISS).
fn push_hit(bytes: &mut Vec<u8>, hit: Option<&MeshHit>) {
    let (t, prim, u, v) = hit.map_or((f32::INFINITY, MISS, 0.0, 0.0), |h| {
        (h.hit.t, h.prim, h.hit.u, h.hit.v)
    });
    bytes.extend_from_slice(&t.to_le_bytes());
    bytes.extend_from_slice(&prim.to_le_bytes());
    bytes.extend_from_slice(&u.to_le_bytes());
    bytes.extend_from_slice(&v.to_le_bytes());
}

/// Reads a ray file: 32-byte little-endian records with no header.
fn read_rays(path: &std::path::Path) -> anyhow::Result<Vec<Ray>> {
    let bytes = batch::read_records(
        path,
        RAY_BYTES,
        "ray",
        "origin, tnear, direction, tfar as little-endian f32",
    )?;
    Ok(bytes
        .chunks_exact(RAY_BYTES)
        .map(|r| {
            let f = |i| f32_at(r, i);
            Ray::new(
                Vec3::new(f(0), f(1), f(2)),
                Vec3::new(f(4), f(5), f(6)),
                f(3),
                f(7),
            )
        })
        .collect())
}
