//! Traces a ray file (the `../shared/peers/FORMAT.md` records) the way
//! `arbor trace` does, for quick speed comparisons of the structures without
//! building the whole CLI.
//!
//! ```text
//! cargo run --release -p arbor-accel --example raybench -- MESH.{msh,obj} RAYS KIND[,KIND..] [--occluded] [--threads N] [--repeat K] [--leaf N] [--ct-percent P] [--block B] [--bins N] [--packets]
//! ```

use std::time::Instant;

use arbor_accel::{
    intersect_triangle_sheared, Accel, AccelKind, AccelParams, Accelerator, BvhParams, NoCounters,
    Ray, RayShear, TriangleBvh, TriangleMesh, Vec3, PACKET,
};
use rayon::prelude::*;

fn read_mesh(path: &str) -> TriangleMesh {
    let text = std::fs::read_to_string(path).expect("read mesh");
    if path.ends_with(".msh") {
        let mut tok = text.split_whitespace();
        let np: usize = tok.next().unwrap().parse().unwrap();
        let nt: usize = tok.next().unwrap().parse().unwrap();
        assert_eq!(tok.next(), Some("vertices"));
        let mut num = || tok.next().unwrap().parse::<f32>().unwrap();
        let vertices = (0..np).map(|_| Vec3::new(num(), num(), num())).collect();
        assert_eq!(tok.next(), Some("triangles"));
        let mut idx = || tok.next().unwrap().parse::<u32>().unwrap();
        let triangles = (0..nt).map(|_| [idx(), idx(), idx()]).collect();
        return TriangleMesh::new(vertices, triangles);
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
    TriangleMesh::new(v, t)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mesh = read_mesh(&args[0]);
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
    let tris: Vec<[Vec3; 3]> = (0..mesh.triangles.len())
        .map(|i| mesh.triangle(i))
        .collect();
    for kind in args[2].split(',') {
        if kind == "triangles" {
            let mut params = TriangleBvh::params();
            params.max_leaf_size = opt("--leaf", params.max_leaf_size);
            params.leaf_block = opt("--block", params.leaf_block);
            params.bins = opt("--bins", params.bins);
            params.traversal_cost =
                opt("--ct-percent", (params.traversal_cost * 100.0) as usize) as f32 / 100.0;
            let packets = args.iter().any(|a| a == "--packets");
            bench_triangle_bvh(&mesh, &rays, &pool, &params, repeat, occluded, packets);
            continue;
        }
        let kind: AccelKind = kind.parse().unwrap();
        let start = Instant::now();
        let mut params = AccelParams::default();
        params.bvh.max_leaf_size = opt("--leaf", params.bvh.max_leaf_size);
        params.bvh.traversal_cost = opt("--ct-percent", 100) as f32 / 100.0;
        let accel = pool.install(|| Accel::build_with(kind, &mesh, &params));
        let build = start.elapsed().as_secs_f64() * 1e3;
        let mut times = Vec::new();
        let mut sum = 0u64;
        for _ in 0..repeat {
            let start = Instant::now();
            sum = pool.install(|| {
                rays.par_iter()
                    .with_min_len(256)
                    .map(|ray| {
                        let shear = RayShear::new(ray);
                        let test = |p: u32, r: &Ray| {
                            let [a, b, c] = tris[p as usize];
                            intersect_triangle_sheared(r, &shear, a, b, c)
                        };
                        if occluded {
                            u64::from(
                                accel.occluded(ray, &mut NoCounters, |p, r| test(p, r).is_some()),
                            )
                        } else {
                            let mut best = (f32::INFINITY, u32::MAX);
                            accel.closest(ray, &mut NoCounters, |p, r| {
                                let h = test(p, r)?;
                                if h.t < best.0 {
                                    best = (h.t, p);
                                }
                                Some(h.t)
                            });
                            u64::from(best.1) ^ u64::from(best.0.to_bits())
                        }
                    })
                    .sum()
            });
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        let med = times[times.len() / 2];
        let s = accel.stats();
        println!(
            "{kind:12} build {build:8.1} ms  trace median {med:8.1} ms  min {:8.1} ms  {:6.2} Mrays/s  {:5.1} B/tri  checksum {sum:x}",
            times[0],
            rays.len() as f64 / (med * 1e3),
            s.memory_bytes as f64 / mesh.triangles.len() as f64
        );
    }
}

/// The same measurement for [`TriangleBvh`] (`KIND` = `triangles`), which
/// owns its triangles and tests them four at a time.
fn bench_triangle_bvh(
    mesh: &TriangleMesh,
    rays: &[Ray],
    pool: &rayon::ThreadPool,
    params: &BvhParams,
    repeat: usize,
    occluded: bool,
    packets: bool,
) {
    let start = Instant::now();
    let bvh = pool.install(|| TriangleBvh::build(mesh, params));
    let build = start.elapsed().as_secs_f64() * 1e3;
    let mut times = Vec::new();
    let mut sum = 0u64;
    for _ in 0..repeat {
        let start = Instant::now();
        let answer = |h: Option<arbor_accel::MeshHit>| {
            h.map_or(
                u64::from(u32::MAX) ^ u64::from(f32::INFINITY.to_bits()),
                |h| u64::from(h.prim) ^ u64::from(h.hit.t.to_bits()),
            )
        };
        sum = pool.install(|| {
            if packets && !occluded {
                rays.par_chunks(PACKET)
                    .with_min_len(256 / PACKET)
                    .map(|chunk| {
                        let packet = <&[Ray; PACKET]>::try_from(chunk)
                            .ok()
                            .and_then(|rays| bvh.closest_packet(rays, &mut NoCounters));
                        match packet {
                            Some(hits) => hits.into_iter().map(answer).sum::<u64>(),
                            None => chunk
                                .iter()
                                .map(|ray| answer(bvh.closest(ray, &mut NoCounters)))
                                .sum(),
                        }
                    })
                    .sum()
            } else {
                rays.par_iter()
                    .with_min_len(256)
                    .map(|ray| {
                        if occluded {
                            u64::from(bvh.occluded(ray, &mut NoCounters))
                        } else {
                            answer(bvh.closest(ray, &mut NoCounters))
                        }
                    })
                    .sum()
            }
        });
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let med = times[times.len() / 2];
    let mut counts = arbor_accel::RayCounts::default();
    for ray in rays {
        if occluded {
            bvh.occluded(ray, &mut counts);
        } else {
            bvh.closest(ray, &mut counts);
        }
    }
    println!(
        "  per ray: {:.2} node visits (leaves included), {:.2} triangle lanes tested",
        counts.nodes as f64 / rays.len() as f64,
        counts.tests as f64 / rays.len() as f64
    );
    println!(
        "{:12} build {build:8.1} ms  trace median {med:8.1} ms  min {:8.1} ms  {:6.2} Mrays/s  {:5.1} B/tri  checksum {sum:x}",
        "triangles",
        times[0],
        rays.len() as f64 / (med * 1e3),
        bvh.stats().memory_bytes as f64 / mesh.triangles.len() as f64
    );
}
