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

/// The fuzz target's decoding of its input (`fuzz/fuzz_targets/accel.rs`):
/// some byte patterns stand for the values fuzzing should meet often.
fn fuzz_floats(data: &[u8]) -> Vec<f32> {
    data.chunks_exact(4)
        .map(|c| match c[0] {
            0xF0 => f32::NAN,
            0xF1 => f32::INFINITY,
            0xF2 => -f32::INFINITY,
            0xF3 => 0.0,
            0xF4 => f32::MIN_POSITIVE / 8.0,
            0xF5 => 1e30,
            _ => (i16::from_le_bytes([c[1], c[2]]) as f32) / 64.0,
        })
        .collect()
}

/// Replays one fuzz input exactly as the target does; returns the number of
/// rays checked.
fn replay(data: &[u8]) -> usize {
    if data.len() < 8 {
        return 0;
    }
    let split = (data[0] as usize % 8 + 1) * 4 * 9;
    let (geo, rays) = data[1..].split_at(split.min(data.len() - 1));
    let v = fuzz_floats(geo);
    let vertices: Vec<Vec3> = v
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let triangles: Vec<[u32; 3]> = (0..vertices.len() as u32 / 3)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let mesh = TriangleMesh::new(vertices, triangles);
    let list = Accel::build(AccelKind::List, &mesh);
    let built: Vec<Accel> = AccelKind::ALL
        .iter()
        .map(|&k| Accel::build(k, &mesh))
        .collect();
    let mut checked = 0;
    for r in fuzz_floats(rays).chunks_exact(8) {
        let ray = Ray::new(
            Vec3::new(r[0], r[1], r[2]),
            Vec3::new(r[3], r[4], r[5]),
            r[6].abs().min(1.0),
            r[7].abs().max(1.0),
        );
        if !ray.origin.is_finite() || !ray.dir.is_finite() {
            continue;
        }
        let expected = closest(&list, &mesh, &ray);
        let test = |p: u32, r: &Ray| mesh.intersect(p as usize, r).is_some();
        let occluded = list.occluded(&ray, &mut NoCounters, test);
        for (a, kind) in built.iter().zip(AccelKind::ALL) {
            assert_eq!(closest(a, &mesh, &ray), expected, "{kind} {ray:?}");
            assert_eq!(a.occluded(&ray, &mut NoCounters, test), occluded, "{kind}");
        }
        checked += 1;
    }
    checked
}

/// Every input kept in `fuzz/artifacts/accel/` answers like brute force.
/// Two of them have rays whose direction components are subnormal
/// (`MIN_POSITIVE / 8`): their reciprocals overflowed to infinity, which put
/// box and split planes at infinite distance while the triangle was hit at
/// t = 6 (and t = 1); `Ray::inv_dir` now makes such components NaN, which
/// every structure reads as "unconstrained".
#[test]
fn every_kept_fuzz_input_answers_like_brute_force() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz/artifacts/accel");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .expect("the kept fuzz inputs")
        .map(|e| e.expect("directory entry").path())
        .collect();
    files.sort();
    assert!(files.len() >= 3, "kept inputs: {files:?}");
    let rays: usize = files
        .iter()
        .map(|f| replay(&std::fs::read(f).expect("read a kept input")))
        .sum();
    assert!(rays > 0);
}

/// The subnormal-direction case by hand: a box around the origin's
/// neighbourhood, crossed at t = 6 by a ray whose direction components are
/// all `MIN_POSITIVE / 8`.
#[test]
fn subnormal_direction_components() {
    let d = f32::MIN_POSITIVE / 8.0;
    let ray = Ray::new(Vec3::ZERO, Vec3::splat(d), 0.0, 10.0);
    assert!(ray.inv_dir().is_nan());
    let p = |k: f32| Vec3::splat(d * k);
    // A triangle in the plane x + y + z = 18 d, spanning the ray's point at
    // t = 6 (6 d, 6 d, 6 d).
    let mesh = TriangleMesh::new(
        vec![
            Vec3::new(d * 18.0, 0.0, 0.0),
            Vec3::new(0.0, d * 18.0, 0.0),
            Vec3::new(0.0, 0.0, d * 18.0),
            p(100.0),
            p(101.0) + Vec3::new(d, 0.0, 0.0),
            p(102.0) + Vec3::new(0.0, d, 0.0),
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let list = Accel::build(AccelKind::List, &mesh);
    let expected = closest(&list, &mesh, &ray);
    assert_eq!(expected.map(|(_, p)| p), Some(0), "brute force hits");
    for &kind in AccelKind::ALL {
        let a = Accel::build(kind, &mesh);
        assert_eq!(closest(&a, &mesh, &ray), expected, "{kind}");
    }
}
