//! `arbor trace`: batch ray casting against a triangle mesh, speaking the ray
//! and hit file interface of `shared/peers/FORMAT.md` so that its answers and
//! speed can be compared with Embree's `embree_trace` ray for ray.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use arbor::load::load_ray_mesh;
use arbor_accel::{
    intersect_triangle_sheared, one_octant, Accel, AccelKind, Accelerator, MeshHit, NoCounters,
    Ray, RayShear, TriangleBvh, TriangleMesh, Vec3, PACKET,
};
use clap::Args;
use rayon::prelude::*;

use crate::InputError;

/// Size of one ray record: origin, tnear, direction, tfar, all `f32`.
const RAY_BYTES: usize = 32;
/// Size of one closest-hit record: t, triangle, u, v.
const HIT_BYTES: usize = 16;
/// The triangle index of a miss.
const MISS: u32 = u32::MAX;
/// Rays per rayon task: large enough that scheduling costs nothing next to
/// tracing, small enough that both threads stay busy to the end.
const RAYS_PER_TASK: usize = 256;

/// Arguments of `arbor trace`.
#[derive(Args, Debug)]
pub struct TraceArgs {
    /// Triangle mesh: a Cornell `.msh` file or a Wavefront `.obj` (polygons
    /// split as fans, triangles numbered in file order).
    #[arg(long, value_name = "FILE")]
    pub mesh: PathBuf,
    /// Rays: 32-byte little-endian records (origin, tnear, direction, tfar).
    #[arg(long, value_name = "FILE")]
    pub rays: PathBuf,
    /// Where to write the answers: 16-byte closest-hit records (t, triangle,
    /// u, v), or 1-byte occlusion answers with `--occluded`.
    #[arg(long, value_name = "FILE")]
    pub hits: Option<PathBuf>,
    /// Answer "is anything between tnear and tfar?" instead of the closest hit.
    #[arg(long)]
    pub occluded: bool,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub threads: Option<u32>,
    /// Build and trace this many times; the best build and the median and
    /// fastest trace are reported.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
    /// Acceleration structure (default: the library's default).
    #[arg(long, value_name = "NAME")]
    pub accel: Option<String>,
}

/// One closest-hit answer, as written to the hit file.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Hit {
    t: f32,
    prim: u32,
    u: f32,
    v: f32,
}

impl Hit {
    const NONE: Hit = Hit {
        t: f32::INFINITY,
        prim: MISS,
        u: 0.0,
        v: 0.0,
    };
}

/// Runs `arbor trace`.
pub fn run(args: TraceArgs) -> anyhow::Result<()> {
    // Everything the user can get wrong is checked before the slow part.
    let kind = match &args.accel {
        Some(name) => name
            .parse::<AccelKind>()
            .map_err(|e| InputError(format!("--accel: {e}")))?,
        None => AccelKind::DEFAULT,
    };
    let mesh = load_ray_mesh(&args.mesh).map_err(|e| InputError(e.to_string()))?;
    let mesh = TriangleMesh::new(mesh.positions, mesh.triangles);
    let rays = read_rays(&args.rays)?;
    let mut output = args.hits.as_deref().map(AtomicOutput::create).transpose()?;
    if let Some(out) = &output {
        // Ctrl-C ends the process without running destructors: remove the
        // temporary file ourselves so an interrupted run leaves nothing.
        let temp = out.temp.clone();
        let _ = ctrlc::set_handler(move || {
            let _ = std::fs::remove_file(&temp);
            std::process::exit(130);
        });
    }

    let threads = match args.threads {
        Some(n) => n as usize,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let repeat = args.repeat as usize;

    let (built, build_ms) = pool.install(|| {
        let mut best = f64::INFINITY;
        let mut built = None;
        for _ in 0..repeat {
            let start = Instant::now();
            let tracer = MeshTracer::build(kind, &mesh);
            best = best.min(ms_since(start));
            built = Some(tracer);
        }
        (built, best)
    });
    let Some(tracer) = built else {
        anyhow::bail!("internal error: no accelerator was built");
    };
    // The tracer holds every triangle it needs: the mesh's memory is not
    // part of what tracing costs.
    let triangle_count = mesh.triangles.len();
    drop(mesh);

    let mut times = Vec::with_capacity(repeat);
    let (answers, hits) = if args.occluded {
        let mut occ = vec![0u8; rays.len()];
        for _ in 0..repeat {
            let start = Instant::now();
            pool.install(|| trace_occluded(&tracer, &rays, &mut occ));
            times.push(ms_since(start));
        }
        let hits = occ.iter().filter(|&&o| o != 0).count();
        (occ, hits)
    } else {
        let mut found = vec![Hit::NONE; rays.len()];
        for _ in 0..repeat {
            let start = Instant::now();
            pool.install(|| trace_closest(&tracer, &rays, &mut found));
            times.push(ms_since(start));
        }
        let hits = found.iter().filter(|h| h.prim != MISS).count();
        let mut bytes = Vec::with_capacity(found.len() * HIT_BYTES);
        for h in &found {
            bytes.extend_from_slice(&h.t.to_le_bytes());
            bytes.extend_from_slice(&h.prim.to_le_bytes());
            bytes.extend_from_slice(&h.u.to_le_bytes());
            bytes.extend_from_slice(&h.v.to_le_bytes());
        }
        (bytes, hits)
    };

    if let Some(out) = output.take() {
        out.finish(&answers)?;
    }

    times.sort_by(f64::total_cmp);
    // The upper median for an even count, as embree_trace takes it.
    let median = times[times.len() / 2];
    let min = times[0];
    let mrays = if median > 0.0 {
        rays.len() as f64 / (median * 1e3)
    } else {
        0.0
    };
    println!(
        "{{\"tracer\": \"arbor\", \"triangles\": {}, \"rays\": {}, \"hits\": {}, \"threads\": {}, \
         \"query\": \"{}\", \"build_ms\": {:.3}, \"trace_ms_median\": {:.3}, \"trace_ms_min\": {:.3}, \
         \"mrays_per_s\": {:.3}}}",
        triangle_count,
        rays.len(),
        hits,
        pool.current_num_threads(),
        if args.occluded { "occluded" } else { "closest" },
        build_ms,
        median,
        min,
        mrays
    );
    Ok(())
}

/// Milliseconds since `start`.
fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// What traces the rays: the default structure's mesh-specialised form, or
/// any other structure with the caller-side triangle test.
enum MeshTracer {
    /// [`TriangleBvh`]: the default `bvh-wide`, owning its triangles in leaf
    /// order and testing four at a time; the same answers as `Generic` with
    /// `bvh-wide`.
    Triangles(TriangleBvh),
    /// Any structure, each offered triangle tested here.
    Generic(Accel, Triangles),
}

impl MeshTracer {
    /// Builds `kind` over `mesh` (timed by the caller, as Embree times its
    /// build including the copy of its buffers).
    fn build(kind: AccelKind, mesh: &TriangleMesh) -> Self {
        if kind == AccelKind::BvhWide {
            MeshTracer::Triangles(TriangleBvh::build(mesh, &TriangleBvh::params()))
        } else {
            let accel = Accel::build(kind, mesh);
            MeshTracer::Generic(accel, Triangles::new(mesh))
        }
    }
}

/// Whether `rays` look like a stream of camera rays, worth offering to
/// `TriangleBvh::closest_packet` in eights: at least half of the first 64
/// groups of eight have all their directions in one octant. Secondary rays
/// (random directions) do not, and keep the plain per-ray loop. (Measured,
/// paired runs: diffuse rays as fast as with the offer, camera rays 7-9 %
/// faster than when every stream is offered; `docs/performance.md`.)
fn looks_coherent(rays: &[Ray]) -> bool {
    let (mut groups, mut coherent) = (0, 0);
    for g in rays.chunks_exact(PACKET).take(64) {
        groups += 1;
        coherent += usize::from(one_octant(g));
    }
    groups > 0 && 2 * coherent >= groups
}

/// The closest hit of every ray, in parallel on the current pool.
fn trace_closest(tracer: &MeshTracer, rays: &[Ray], out: &mut [Hit]) {
    match tracer {
        // Consecutive rays in eights: `closest_packet` traces coherent ones
        // (neighbouring camera rays) together and the others one by one.
        MeshTracer::Triangles(bvh) if looks_coherent(rays) => out
            .par_chunks_mut(PACKET)
            .zip(rays.par_chunks(PACKET))
            .with_min_len(RAYS_PER_TASK / PACKET)
            .for_each(|(slots, rays)| {
                let packet = <&[Ray; PACKET]>::try_from(rays)
                    .ok()
                    .and_then(|rays| bvh.closest_packet(rays, &mut NoCounters));
                if let Some(hits) = packet {
                    for (slot, hit) in slots.iter_mut().zip(hits) {
                        *slot = mesh_hit(hit);
                    }
                } else {
                    for (slot, ray) in slots.iter_mut().zip(rays) {
                        *slot = mesh_hit(bvh.closest(ray, &mut NoCounters));
                    }
                }
            }),
        MeshTracer::Triangles(bvh) => out
            .par_iter_mut()
            .zip(rays.par_iter())
            .with_min_len(RAYS_PER_TASK)
            .for_each(|(slot, ray)| *slot = mesh_hit(bvh.closest(ray, &mut NoCounters))),
        MeshTracer::Generic(accel, tris) => out
            .par_iter_mut()
            .zip(rays.par_iter())
            .with_min_len(RAYS_PER_TASK)
            .for_each(|(slot, ray)| *slot = closest(accel, tris, ray)),
    }
}

/// A [`TriangleBvh`] answer as written to the hit file.
fn mesh_hit(hit: Option<MeshHit>) -> Hit {
    hit.map_or(Hit::NONE, |h| Hit {
        t: h.hit.t,
        prim: h.prim,
        u: h.hit.u,
        v: h.hit.v,
    })
}

/// The closest hit of one ray. The shear depends only on the direction, so it
/// is computed once per ray rather than once per triangle.
#[inline]
fn closest(accel: &Accel, tris: &Triangles, ray: &Ray) -> Hit {
    let shear = RayShear::new(ray);
    let mut best = Hit::NONE;
    accel.closest(ray, &mut NoCounters, |prim, r| {
        let [a, b, c] = tris.get(prim);
        let hit = intersect_triangle_sheared(r, &shear, a, b, c)?;
        // Spatial subdivision may offer a triangle again, and a neighbour at
        // a shared edge may tie; the first one found at the smallest t stays.
        if best.prim == MISS || hit.t < best.t {
            best = Hit {
                t: hit.t,
                prim,
                u: hit.u,
                v: hit.v,
            };
        }
        Some(hit.t)
    });
    best
}

/// Whether each ray is blocked, in parallel on the current pool.
fn trace_occluded(tracer: &MeshTracer, rays: &[Ray], out: &mut [u8]) {
    out.par_iter_mut()
        .zip(rays.par_iter())
        .with_min_len(RAYS_PER_TASK)
        .for_each(|(slot, ray)| {
            let blocked = match tracer {
                MeshTracer::Triangles(bvh) => bvh.occluded(ray, &mut NoCounters),
                MeshTracer::Generic(accel, tris) => {
                    let shear = RayShear::new(ray);
                    accel.occluded(ray, &mut NoCounters, |prim, r| {
                        let [a, b, c] = tris.get(prim);
                        intersect_triangle_sheared(r, &shear, a, b, c).is_some()
                    })
                }
            };
            *slot = u8::from(blocked);
        });
}

/// The vertices of every triangle, stored together: the exact test then reads
/// one contiguous 36-byte record instead of an index triple and three scattered
/// vertices. Built inside the timed build, as Embree copies its buffers there.
struct Triangles(Vec<[Vec3; 3]>);

impl Triangles {
    fn new(mesh: &TriangleMesh) -> Self {
        Triangles(
            (0..mesh.triangles.len())
                .map(|i| mesh.triangle(i))
                .collect(),
        )
    }

    /// Triangle `prim`; accelerators only offer indices below the count they
    /// were built over, and a degenerate answer beats a panic otherwise.
    #[inline(always)]
    fn get(&self, prim: u32) -> [Vec3; 3] {
        self.0.get(prim as usize).copied().unwrap_or([Vec3::NAN; 3])
    }
}

/// Reads a ray file: 32-byte little-endian records with no header.
fn read_rays(path: &Path) -> anyhow::Result<Vec<Ray>> {
    let bytes = std::fs::read(path)
        .map_err(|e| InputError(format!("{}: cannot read the ray file: {e}", path.display())))?;
    if bytes.len() % RAY_BYTES != 0 {
        return Err(InputError(format!(
            "{}: a ray file holds 32-byte records (origin, tnear, direction, tfar as \
             little-endian f32), but its length {} is not a multiple of 32",
            path.display(),
            bytes.len()
        ))
        .into());
    }
    Ok(bytes.chunks_exact(RAY_BYTES).map(decode_ray).collect())
}

/// One ray record.
fn decode_ray(record: &[u8]) -> Ray {
    let f = |i: usize| {
        let mut word = [0u8; 4];
        word.copy_from_slice(&record[4 * i..4 * i + 4]);
        f32::from_le_bytes(word)
    };
    Ray::new(
        Vec3::new(f(0), f(1), f(2)),
        Vec3::new(f(4), f(5), f(6)),
        f(3),
        f(7),
    )
}

/// An output file written under a temporary name in the same folder and
/// renamed into place when complete, so that a failure or interruption never
/// leaves a partial file under the final name (a rename within one folder is
/// atomic). The temporary file is removed if the output is dropped unfinished.
struct AtomicOutput {
    target: PathBuf,
    temp: PathBuf,
    file: Option<File>,
}

impl AtomicOutput {
    /// Creates the temporary file at once, so an unwritable destination is
    /// reported before any tracing is done.
    fn create(target: &Path) -> anyhow::Result<Self> {
        if target.is_dir() {
            return Err(InputError(format!(
                "{}: is a directory; expected an output file name",
                target.display()
            ))
            .into());
        }
        let name = target
            .file_name()
            .ok_or_else(|| {
                InputError(format!(
                    "{}: expected an output file name",
                    target.display()
                ))
            })?
            .to_string_lossy();
        let temp = target.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let file = File::create(&temp).map_err(|e| {
            InputError(format!(
                "{}: cannot create the output file: {e}",
                target.display()
            ))
        })?;
        Ok(AtomicOutput {
            target: target.to_path_buf(),
            temp,
            file: Some(file),
        })
    }

    /// Writes `bytes` and moves the file into place.
    fn finish(mut self, bytes: &[u8]) -> anyhow::Result<()> {
        let Some(file) = self.file.take() else {
            anyhow::bail!("internal error: output already finished");
        };
        let mut w = BufWriter::new(file);
        w.write_all(bytes)
            .and_then(|()| w.flush())
            .with_context(|| format!("cannot write {}", self.temp.display()))?;
        drop(w);
        std::fs::rename(&self.temp, &self.target).with_context(|| {
            format!(
                "cannot move {} to {}",
                self.temp.display(),
                self.target.display()
            )
        })?;
        Ok(())
    }
}

impl Drop for AtomicOutput {
    fn drop(&mut self) {
        // After a successful rename the temporary name no longer exists and
        // this fails harmlessly.
        let _ = std::fs::remove_file(&self.temp);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Camera rays through neighbouring pixels look coherent; rays in
    /// scattered directions do not; too few rays for a packet neither.
    #[test]
    fn camera_rays_look_coherent_and_scattered_rays_do_not() {
        let eye = Vec3::new(0.3, 0.2, 5.0);
        let camera: Vec<Ray> = (0..64 * 48)
            .map(|i| {
                let target = Vec3::new(
                    (i % 64) as f32 / 32.0 - 1.0,
                    (i / 64) as f32 / 24.0 - 1.0,
                    0.0,
                );
                Ray::new(eye, target - eye, 0.0, f32::INFINITY)
            })
            .collect();
        assert!(looks_coherent(&camera));
        let mut state = 5u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let scattered: Vec<Ray> = (0..4096)
            .map(|_| {
                Ray::new(
                    Vec3::ZERO,
                    Vec3::new(next(), next(), next()),
                    0.0,
                    f32::INFINITY,
                )
            })
            .collect();
        assert!(!looks_coherent(&scattered));
        assert!(!looks_coherent(&camera[..PACKET - 1]));
    }
}
