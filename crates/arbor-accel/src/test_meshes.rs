//! Meshes and checks the unit tests of several structures share.

use crate::accel::Accelerator;
use crate::counters::NoCounters;
use crate::list::List;
use crate::primitives::PrimitiveId;
use crate::ray::Ray;
use crate::triangle::mesh::TriangleMesh;
use glam::Vec3;

/// A bumpy `n` x `n` grid of triangles over the unit square.
pub(crate) fn bumpy_grid(n: u32) -> TriangleMesh {
    let (vertices, triangles) = bumpy_grid_parts(n);
    TriangleMesh::new(vertices, triangles)
}

/// The vertices and triangles of [`bumpy_grid`]: height
/// `0.1 sin(7x) cos(5y)`, two triangles per cell.
pub(crate) fn bumpy_grid_parts(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut vertices = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            vertices.push(Vec3::new(x, y, 0.1 * ((7.0 * x).sin() * (5.0 * y).cos())));
        }
    }
    let at = |i: u32, j: u32| i * (n + 1) + j;
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (vertices, triangles)
}

/// Point `i` of a sequence spread through the unit cube by irrational
/// strides, which keep the points apart without a generator.
pub(crate) fn scattered(i: u32) -> Vec3 {
    let f = i as f32;
    Vec3::new(
        (f * 0.618).fract(),
        (f * 0.414).fract(),
        (f * 0.732).fract(),
    )
}

/// `n` triangles of assorted sizes and slopes scattered through a box of
/// side 10 (an irrational stride keeps them apart without a generator).
pub(crate) fn soup(n: u32) -> TriangleMesh {
    let mut v = Vec::new();
    let mut t = Vec::new();
    for i in 0..n {
        let f = i as f32;
        let c = scattered(i) * 10.0;
        v.push(c);
        v.push(c + Vec3::new((f * 1.3).sin(), 0.5, (f * 0.7).cos()));
        v.push(c + Vec3::new(0.3, (f * 2.1).cos(), 0.8));
        t.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    TriangleMesh::new(v, t)
}

/// 2,000 small triangles scattered in a cube of side 10 and 40 long
/// slivers across it: the case spatial splits are for, where a few
/// large boxes inflate every node they fall into.
pub(crate) fn slivers() -> TriangleMesh {
    let mut next = crate::util::unit_sequence(5);
    let mut vertices = Vec::new();
    for _ in 0..2000 {
        let a = Vec3::new(next(), next(), next()) * 10.0;
        let d = Vec3::new(next(), next(), next()) * 0.2;
        vertices.extend([a, a + d, a + Vec3::new(d.z, d.x, d.y)]);
    }
    for _ in 0..40 {
        let a = Vec3::new(next(), next(), 0.0) * 10.0;
        let b = Vec3::new(next(), next(), 1.0) * 10.0;
        vertices.extend([a, b, b + Vec3::splat(0.02)]);
    }
    let triangles = (0..2040).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    TriangleMesh::new(vertices, triangles)
}

/// The nearest hit distance `accel` finds for `ray` on `mesh` (infinity
/// when none).
pub(crate) fn nearest_t(accel: &impl Accelerator, mesh: &TriangleMesh, ray: &Ray) -> f32 {
    let mut best = f32::INFINITY;
    accel.closest(ray, &mut NoCounters, |p, ray| {
        let t = mesh.intersect(p, ray)?.t;
        best = best.min(t);
        Some(t)
    });
    best
}

/// The primitives `accel` offers for `ray` when it hits none, in the
/// order offered: every one in the regions the ray passes through.
pub(crate) fn offered(accel: &impl Accelerator, ray: &Ray) -> Vec<PrimitiveId> {
    let mut seen = Vec::new();
    accel.closest(ray, &mut NoCounters, |p, _| {
        seen.push(p);
        None
    });
    seen
}

/// Asserts that `accel` answers `ray`'s closest and occlusion queries on
/// `mesh` as brute force (`list`) does.
pub(crate) fn assert_agrees_with_list(
    accel: &impl Accelerator,
    list: &List,
    mesh: &TriangleMesh,
    ray: &Ray,
    label: &str,
) {
    assert_eq!(
        nearest_t(accel, mesh, ray),
        nearest_t(list, mesh, ray),
        "{label}"
    );
    let test = |p: u32, ray: &Ray| mesh.intersect(p, ray).is_some();
    assert_eq!(
        accel.occluded(ray, &mut NoCounters, test),
        list.occluded(ray, &mut NoCounters, test),
        "{label}"
    );
}
