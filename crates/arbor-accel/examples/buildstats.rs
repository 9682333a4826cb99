//! Builds every acceleration structure over a generated (or loaded) mesh and
//! prints build time, shape, SAH cost and ray throughput.
//!
//! ```text
//! cargo run --release -p arbor-accel --example buildstats -- [--tris N] [--msh FILE] [--rays R] [--kinds a,b,...] [--lambda L]
//! ```
//!
//! `--msh` reads the Cornell `.msh` format (point count, triangle count,
//! `vertices` then 3 numbers per point, `triangles` then 3 zero-based indices
//! per triangle, one number per line).

use std::time::Instant;

use arbor_accel::{Accel, AccelKind, AccelParams, Accelerator, NoCounters, Ray, TriangleMesh};
use rayon::prelude::*;

mod common;

/// Reads a Cornell `.msh` file.
fn read_msh(path: &str) -> TriangleMesh {
    let (vertices, triangles) =
        common::parse_msh(&std::fs::read_to_string(path).expect("read .msh"));
    TriangleMesh::new(vertices, triangles)
}

/// Deterministic rays from a sphere around the mesh towards points inside it.
fn rays(mesh: &TriangleMesh, n: usize) -> Vec<Ray> {
    let b = arbor_accel::Aabb::from_points(mesh.vertices.iter().copied());
    common::rays_into(&b, n, 0x2545_f491_4f6c_dd1d)
}

/// CPU seconds (user + system) this process has used, from `/proc/self/stat`;
/// 0 where that is unavailable. On a shared machine wall time includes
/// waiting for a core, CPU time does not.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields overall, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let mesh = match arg("--msh") {
        Some(p) => read_msh(&p),
        None => common::torus(arg("--tris").map_or(100_000, |s| s.parse().unwrap())),
    };
    let nrays: usize = arg("--rays").map_or(200_000, |s| s.parse().unwrap());
    let kinds: Vec<AccelKind> = match arg("--kinds") {
        Some(k) => k.split(',').map(|s| s.parse().unwrap()).collect(),
        None => AccelKind::ALL
            .iter()
            .copied()
            .filter(|k| *k != AccelKind::List)
            .collect(),
    };
    let mut params = AccelParams::default();
    if let Some(l) = arg("--lambda") {
        params.grid.lambda = l.parse().unwrap();
    }
    let rays = rays(&mesh, nrays);
    println!(
        "{} triangles, {} rays, {} threads",
        mesh.triangles.len(),
        rays.len(),
        rayon::current_num_threads()
    );
    println!(
        "| structure | build ms (wall) | build ms (CPU) | Mtris/s (wall) | nodes | leaves | depth | MB | SAH cost | Mrays/s (1 thread) | Mrays/s (all) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for kind in kinds {
        let (t, cpu) = (Instant::now(), cpu_seconds());
        let accel = Accel::build_with(kind, &mesh, &params);
        let build = t.elapsed().as_secs_f64();
        let build_cpu = cpu_seconds() - cpu;
        let s = accel.stats();
        let trace = |r: &Ray| {
            let mut best = f32::INFINITY;
            accel.closest(r, &mut NoCounters, |p, ray| {
                let h = mesh.intersect(p, ray)?;
                best = h.t;
                Some(h.t)
            });
            best
        };
        let t = Instant::now();
        let hits1: usize = rays.iter().map(trace).filter(|t| t.is_finite()).count();
        let single = rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6;
        let t = Instant::now();
        let hits2: usize = rays.par_iter().map(trace).filter(|t| t.is_finite()).count();
        let all = rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6;
        assert_eq!(hits1, hits2);
        println!(
            "| {} | {:.0} | {:.0} | {:.2} | {} | {} | {} | {:.1} | {} | {:.2} | {:.2} |",
            kind,
            build * 1e3,
            build_cpu * 1e3,
            mesh.triangles.len() as f64 / build / 1e6,
            s.nodes,
            s.leaves,
            s.max_depth,
            s.memory_bytes as f64 / 1e6,
            s.sah_cost.map_or("-".into(), |c| format!("{c:.2}")),
            single,
            all
        );
    }
}
