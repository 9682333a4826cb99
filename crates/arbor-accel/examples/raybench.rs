//! Traces a ray file (the `../shared/peers/FORMAT.md` records) through
//! [`MeshAccel`], as `arbor trace` does, for quick speed comparisons of the
//! structures and their build parameters without building the whole CLI.
//!
//! ```text
//! cargo run --release -p arbor-accel --example raybench -- MESH.{msh,obj} RAYS KIND[,KIND..] [--occluded] [--threads N] [--repeat K] [--leaf N] [--ct-percent P] [--block B] [--bins N] [--spatial-percent S] [--packets]
//! ```
//!
//! `KIND` is an accelerator name (`triangles` is accepted for `bvh-wide`).
//! Closest hits are traced ray by ray, or with `--packets` through
//! `MeshAccel::closest_batch`, which offers camera-like streams to the
//! eight-ray packets (as `arbor trace` does). The checksum (triangle id and
//! distance bits of every answer) tells whether two runs answered alike.

use std::time::Instant;

use arbor_accel::{AccelKind, MeshAccel, MeshHit, Ray, RayCounts, Vec3};
use rayon::prelude::*;

mod common;

/// A `.msh` or `.obj` file's vertices and triangles (OBJ polygons as fans),
/// read without error handling: this is a measuring tool, not a loader.
fn read_mesh(path: &str) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).expect("read mesh");
    if path.ends_with(".msh") {
        return common::parse_msh(&text);
    }
    let (mut v, mut t) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let mut f = || w.next().unwrap().parse::<f32>().unwrap();
                v.push(Vec3::new(f(), f(), f()));
            }
            Some("f") => {
                let idx: Vec<u32> = w
                    .map(|s| s.split('/').next().unwrap().parse::<u32>().unwrap() - 1)
                    .collect();
                for k in 1..idx.len() - 1 {
                    t.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, t)
}

/// One answer's contribution to the checksum.
fn answer(h: Option<MeshHit>) -> u64 {
    h.map_or(
        u64::from(u32::MAX) ^ u64::from(f32::INFINITY.to_bits()),
        |h| u64::from(h.prim) ^ u64::from(h.hit.t.to_bits()),
    )
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (vertices, triangles) = read_mesh(&args[0]);
    let bytes = std::fs::read(&args[1]).expect("read rays");
    let f = |r: &[u8], i: usize| f32::from_le_bytes(r[4 * i..4 * i + 4].try_into().unwrap());
    let rays: Vec<Ray> = bytes
        .chunks_exact(32)
        .map(|r| {
            Ray::new(
                Vec3::new(f(r, 0), f(r, 1), f(r, 2)),
                Vec3::new(f(r, 4), f(r, 5), f(r, 6)),
                f(r, 3),
                f(r, 7),
            )
        })
        .collect();
    let occluded = args.iter().any(|a| a == "--occluded");
    let packets = args.iter().any(|a| a == "--packets");
    let opt = |name: &str, default: usize| {
        args.iter()
            .position(|a| a == name)
            .map_or(default, |i| args[i + 1].parse().unwrap())
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opt("--threads", 2))
        .build()
        .unwrap();
    let repeat = opt("--repeat", 5);
    for name in args[2].split(',') {
        let kind: AccelKind = if name == "triangles" {
            AccelKind::BvhWide
        } else {
            name.parse().unwrap()
        };
        let mut params = MeshAccel::params(kind);
        let bvh = &mut params.bvh;
        bvh.max_leaf_size = opt("--leaf", bvh.max_leaf_size);
        bvh.leaf_block = opt("--block", bvh.leaf_block);
        bvh.bins = opt("--bins", bvh.bins);
        bvh.traversal_cost =
            opt("--ct-percent", (bvh.traversal_cost * 100.0) as usize) as f32 / 100.0;
        // Spatial splits' extra references, in percent of the triangles.
        bvh.spatial_splits = opt("--spatial-percent", 0) as f32 / 100.0;
        let (v, t) = (vertices.clone(), triangles.clone());
        let start = Instant::now();
        let mesh = pool.install(|| MeshAccel::build_with(v, t, kind, &params).expect("valid mesh"));
        let build = start.elapsed().as_secs_f64() * 1e3;
        let mut times = Vec::new();
        let mut sum = 0u64;
        for _ in 0..repeat {
            let start = Instant::now();
            sum = pool.install(|| {
                if occluded {
                    mesh.occluded_batch(&rays).into_iter().map(u64::from).sum()
                } else if packets {
                    mesh.closest_batch(&rays).into_iter().map(answer).sum()
                } else {
                    rays.par_iter()
                        .with_min_len(256)
                        .map(|ray| answer(mesh.closest(ray)))
                        .sum()
                }
            });
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        let med = times[times.len() / 2];
        let mut counts = RayCounts::default();
        for ray in &rays {
            if occluded {
                mesh.occluded_counted(ray, &mut counts);
            } else {
                mesh.closest_counted(ray, &mut counts);
            }
        }
        println!(
            "  per ray: {:.2} node visits (leaves included), {:.2} triangle tests",
            counts.nodes as f64 / rays.len() as f64,
            counts.tests as f64 / rays.len() as f64
        );
        println!(
            "{kind:12} build {build:8.1} ms  trace median {med:8.1} ms  min {:8.1} ms  {:6.2} Mrays/s  {:5.1} B/tri  checksum {sum:x}",
            times[0],
            rays.len() as f64 / (med * 1e3),
            mesh.stats().memory_bytes as f64 / triangles.len() as f64
        );
    }
}
