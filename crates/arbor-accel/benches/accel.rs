//! Micro-benchmarks: the ray/box and ray/triangle tests, and closest-hit
//! traversal of a generated 100k-triangle mesh with every structure.
//!
//! `cargo bench -p arbor-accel --bench accel`

use std::hint::black_box;

use arbor_accel::{
    intersect_triangle, Aabb, Accel, AccelKind, Accelerator, NoCounters, Ray, TriangleMesh, Vec3,
};
use criterion::{criterion_group, criterion_main, Criterion};

/// A bumpy torus of about `tris` triangles (the same shape as the
/// `buildstats` example).
fn torus(tris: usize) -> TriangleMesh {
    let m = ((tris / 2) as f64 / 3.0).sqrt().max(3.0) as usize;
    let (nu, nv) = (3 * m, m);
    let mut vertices = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let u = i as f32 / nu as f32 * std::f32::consts::TAU;
            let v = j as f32 / nv as f32 * std::f32::consts::TAU;
            let r = 0.3 + 0.02 * (13.0 * u).sin() * (7.0 * v).cos();
            vertices.push(Vec3::new(
                (1.0 + r * v.cos()) * u.cos(),
                (1.0 + r * v.cos()) * u.sin(),
                r * v.sin(),
            ));
        }
    }
    let idx = |i: usize, j: usize| ((j % nv) * nu + (i % nu)) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1));
            triangles.push([a, b, c]);
            triangles.push([b, d, c]);
        }
    }
    TriangleMesh::new(vertices, triangles)
}

/// Deterministic rays from outside towards points inside the bounds.
fn rays(b: &Aabb, n: usize) -> Vec<Ray> {
    let (c, r) = (b.center(), b.extent().length());
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize_or(Vec3::X);
            let o = c + d * r;
            let t = b.min + b.extent() * Vec3::new(rnd(), rnd(), rnd());
            Ray::new(o, t - o, 0.0, f32::INFINITY)
        })
        .collect()
}

fn primitives(c: &mut Criterion) {
    let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
    let rs = rays(&Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0)), 1024);
    c.bench_function("ray_box_1024", |bench| {
        bench.iter(|| {
            rs.iter()
                .filter(|r| black_box(&b).intersect(r, r.inv_dir()).is_some())
                .count()
        })
    });
    let (p0, p1, p2) = (
        Vec3::new(-1.0, -1.0, 0.1),
        Vec3::new(1.0, -1.0, -0.1),
        Vec3::new(0.0, 1.0, 0.0),
    );
    c.bench_function("ray_triangle_1024", |bench| {
        bench.iter(|| {
            rs.iter()
                .filter(|r| intersect_triangle(r, black_box(p0), p1, p2).is_some())
                .count()
        })
    });
}

fn traversal(c: &mut Criterion) {
    let mesh = torus(100_000);
    let bounds = Aabb::from_points(mesh.vertices.iter().copied());
    let rs = rays(&bounds, 1024);
    let mut group = c.benchmark_group("closest_100k_1024rays");
    group.sample_size(10);
    for &kind in AccelKind::ALL {
        if kind == AccelKind::List {
            continue;
        }
        let accel = Accel::build(kind, &mesh);
        group.bench_function(kind.name(), |bench| {
            bench.iter(|| {
                let mut hits = 0;
                for r in &rs {
                    let mut found = false;
                    accel.closest(r, &mut NoCounters, |p, ray| {
                        let t = mesh.intersect(p as usize, ray)?.t;
                        found = true;
                        Some(t)
                    });
                    hits += usize::from(found);
                }
                hits
            })
        });
    }
    group.finish();
}

criterion_group!(benches, primitives, traversal);
criterion_main!(benches);
