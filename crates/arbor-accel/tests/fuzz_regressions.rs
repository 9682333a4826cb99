//! Inputs the fuzz target `fuzz/fuzz_targets/accel.rs` once broke, replayed
//! against every structure.
// The literals are the fuzzer's exact values (all exact in f32: k/64).
#![allow(clippy::excessive_precision)]

use arbor_accel::{Accel, AccelKind, Accelerator, NoCounters, Ray, TriangleMesh, Vec3};

fn closest(a: &Accel, mesh: &TriangleMesh, ray: &Ray) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    a.closest(ray, &mut NoCounters, |prim, r| {
        let hit = mesh.intersect(prim as usize, r)?;
        if best.is_some_and(|(t, p)| hit.t > t || (hit.t == t && prim > p)) {
            return None;
        }
        best = Some((hit.t, prim));
        Some(hit.t)
    });
    best
}

/// `fuzz/artifacts/accel/crash-3f3d88450c822a01926e8a9cfa196aebfb76ce94`: a
/// triangle with a vertex at 1e30 and a ray whose line passes through
/// another of its vertices, behind the origin. The f64 plane normal lost the
/// small edge components next to 1e30, the plane distance cancelled to
/// t = 0 and the test reported a hit at the ray origin, where the triangle
/// is not; structures that only offer the triangle where it is disagreed
/// with brute force.
#[test]
fn huge_vertex_plane_cancellation() {
    let mesh = TriangleMesh::new(
        vec![
            Vec3::new(1e30, 453.765625, 453.765625),
            Vec3::new(425.765625, 0.0, 0.0),
            Vec3::new(511.984375, -4.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.359375, 0.0, 0.0),
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let ray = Ray::new(Vec3::ZERO, Vec3::new(-4.0, 0.0, 0.0), 0.0, 1.0);
    // The ray's line meets the triangle's plane at vertex 1, t = -106.44.
    assert_eq!(mesh.intersect(0, &ray), None);
    let behind = Ray::new(Vec3::ZERO, Vec3::new(-4.0, 0.0, 0.0), -200.0, 1.0);
    let h = mesh
        .intersect(0, &behind)
        .expect("vertex 1 is on the ray's line");
    assert!((h.t + 106.441_41).abs() < 1e-3, "{h:?}");
    let list = Accel::build(AccelKind::List, &mesh);
    for r in [ray, behind] {
        let expected = closest(&list, &mesh, &r);
        let test = |p: u32, r: &Ray| mesh.intersect(p as usize, r).is_some();
        let occluded = list.occluded(&r, &mut NoCounters, test);
        for &kind in AccelKind::ALL {
            let a = Accel::build(kind, &mesh);
            assert_eq!(closest(&a, &mesh, &r), expected, "{kind}");
            assert_eq!(a.occluded(&r, &mut NoCounters, test), occluded, "{kind}");
        }
    }
}
