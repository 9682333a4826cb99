//! Traversal of the shared course meshes (`buddha100k.msh`, `bunny10k.msh`)
//! through every acceleration structure, with criterion. The meshes live in
//! `../shared` beside the repository (or where `ARBOR_SHARED` points; found by
//! `arbor-test-data`); without them the bench says so and measures nothing,
//! so `cargo bench` still runs on a machine that lacks the data (unless
//! `ARBOR_REQUIRE_TEST_DATA=1`).
//!
//! Rays: a 128 x 128 pinhole camera framing the mesh, the same for every
//! structure, traced with the watertight `f32` triangle test as `arbor
//! trace` does.

use std::hint::black_box;

use arbor_accel::numerics::{intersect_triangle_sheared, RayShear};
use arbor_accel::{
    Accel, AccelKind, Accelerator, NoCounters, PrimitiveId, Ray, TriangleMesh, Vec3,
};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// Camera rays framing the bounding sphere of `tris` (45 degree field of view).
fn camera_rays(tris: &[[Vec3; 3]], side: u32) -> Vec<Ray> {
    let (lo, hi) = tris.iter().flatten().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let center = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let half = 22.5f32.to_radians();
    let back = Vec3::new(0.45, 0.35, 1.0).normalize();
    let eye = center + back * (radius / half.sin());
    let u = Vec3::Y.cross(back).normalize();
    let v = back.cross(u);
    let tan = half.tan();
    let n = side as f32;
    let mut rays = Vec::with_capacity((side * side) as usize);
    for j in 0..side {
        for i in 0..side {
            let x = ((i as f32 + 0.5) / n * 2.0 - 1.0) * tan;
            let y = (1.0 - (j as f32 + 0.5) / n * 2.0) * tan;
            let d = (-back + x * u + y * v).normalize();
            rays.push(Ray::new(eye, d, 0.0, f32::INFINITY));
        }
    }
    rays
}

/// Traces every ray to its closest hit; returns how many hit.
fn trace(accel: &Accel, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize {
    let mut hits = 0;
    for ray in rays {
        let shear = RayShear::new(ray);
        let mut hit = false;
        accel.closest(ray, &mut NoCounters, |prim, r| {
            let [a, b, c] = tris[prim as usize];
            let h = intersect_triangle_sheared(r, &shear, a, b, c)?;
            hit = true;
            Some(h.t)
        });
        hits += usize::from(hit);
    }
    hits
}

fn shared_meshes(c: &mut Criterion) {
    for name in ["buddha100k.msh", "bunny10k.msh"] {
        let Some(path) = arbor_test_data::test_b(name) else {
            continue;
        };
        let mesh = match arbor::load::load_ray_mesh(&path) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("skipping {name}: {e}");
                continue;
            }
        };
        let mesh = TriangleMesh::new(mesh.positions, mesh.triangles);
        let tris: Vec<[Vec3; 3]> = (0..mesh.triangles.len() as PrimitiveId)
            .map(|i| mesh.triangle(i))
            .collect();
        let rays = camera_rays(&tris, 128);
        let mut group = c.benchmark_group(format!("traverse/{name}"));
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.sample_size(10);
        for &kind in AccelKind::ALL {
            if kind == AccelKind::List {
                continue; // brute force over 100k triangles would take minutes
            }
            let accel = Accel::build(kind, &mesh);
            group.bench_function(kind.name(), |b| {
                b.iter(|| trace(black_box(&accel), &tris, black_box(&rays)))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, shared_meshes);
criterion_main!(benches);
