//! Micro-benchmarks: the ray/box and ray/triangle tests, and closest-hit
//! traversal of a generated 100k-triangle mesh with every structure.
//!
//! `cargo bench -p arbor-accel --bench accel`

use std::hint::black_box;

use arbor_accel::{intersect_triangle, Aabb, Accel, AccelKind, Accelerator, NoCounters, Ray, Vec3};
use criterion::{criterion_group, criterion_main, Criterion};

#[path = "../examples/common/mod.rs"]
mod common;

/// Deterministic rays from outside towards points inside the bounds.
fn rays(b: &Aabb, n: usize) -> Vec<Ray> {
    common::rays_into(b, n, 0x9e37_79b9_7f4a_7c15)
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
    let mesh = common::torus(100_000);
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
                        let t = mesh.intersect(p, ray)?.t;
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
