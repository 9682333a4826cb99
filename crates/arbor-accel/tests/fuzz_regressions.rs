//! Inputs the fuzz target `fuzz/fuzz_targets/accel.rs` once broke, replayed
//! against every structure.
// The literals are the fuzzer's exact values (all exact in f32: k/64).
#![allow(clippy::excessive_precision)]

use arbor_accel::{Accel, AccelKind, Accelerator, NoCounters, Ray, TriangleMesh, Vec3};

/// The fuzz target's own check, so that a replay decodes an input exactly
/// as the fuzzer did.
#[path = "../../../fuzz/accel_check.rs"]
mod accel_check;

use accel_check::closest;

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
        let test = |p: u32, r: &Ray| mesh.intersect(p, r).is_some();
        let occluded = list.occluded(&r, &mut NoCounters, test);
        for &kind in AccelKind::ALL {
            let a = Accel::build(kind, &mesh);
            assert_eq!(closest(&a, &mesh, &r), expected, "{kind}");
            assert_eq!(a.occluded(&r, &mut NoCounters, test), occluded, "{kind}");
        }
    }
}

/// `fuzz/artifacts/accel/crash-038c98fce6cb2e9049cf04d898cba4f203c94bfe`: a
/// ray starting a subnormal distance `d` off a triangle's edge, on the side
/// away from the triangle, and moving further away. Its line meets the
/// plane about `160 d` behind the origin, but the distance, accurate only
/// to a tiny fraction of the vertices' scale, came out as `t = 0`: brute
/// force reported a hit at the origin, outside the triangle's box, where no
/// structure offers the triangle. A hit now stands only where the
/// structures' own slab test finds the triangle's box.
#[test]
fn subnormal_offset_from_an_edge() {
    let d = f32::MIN_POSITIVE / 8.0;
    let mesh = TriangleMesh::new(
        vec![
            Vec3::new(3.828125, -236.0, -236.0),
            Vec3::new(0.0, 0.0, -341.34375),
            Vec3::new(0.0, 0.0, 0.0),
        ],
        vec![[0, 1, 2]],
    );
    let ray = Ray::new(
        Vec3::new(d, d, -1.0),
        Vec3::new(0.0, 0.390625, 0.609375),
        0.0,
        1.0,
    );
    assert_eq!(mesh.intersect(0, &ray), None);
    // Started further back, the ray does meet the triangle.
    let back = Ray::new(ray.at(-1.0), ray.dir, 0.0, 2.0);
    let hit = mesh.intersect(0, &back).expect("hit from behind");
    assert!((hit.t - 1.0).abs() < 1e-6, "{hit:?}");
    for r in [ray, back] {
        let expected = closest(&Accel::build(AccelKind::List, &mesh), &mesh, &r);
        for &kind in AccelKind::ALL {
            let a = Accel::build(kind, &mesh);
            assert_eq!(closest(&a, &mesh, &r), expected, "{kind}");
        }
    }
}

/// `fuzz/artifacts/accel/crash-0977a2f7afe98010a968db9bf5d387d633e63bbc`:
/// a ray from the origin, a triangle whose box starts a subnormal distance
/// along it (next to a vertex at 1e30, whose plane distance cancels to
/// `t = 0`), and a second triangle really hit at `t = 0`. The first hit used
/// to be reported at `t = 0`, before its box's entry: tested first (brute
/// force) it stood and won the tie by index, tested after the second (whose
/// hit shrinks `tmax` to 0) its box check failed, and `bvh-sah` answered the
/// other triangle. A hit is now reported no earlier than its box's entry, so
/// it stands for every `tmax` from its distance up.
#[test]
fn hit_before_its_box_entry() {
    let mesh = TriangleMesh::new(
        vec![
            Vec3::new(1e30, 7.078125, 263.07813),
            Vec3::new(-348.0, 1.469368e-39, 1.469368e-39),
            Vec3::new(-1.0, 0.0, 100.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 256.0),
            Vec3::new(-512.0, -512.0, -512.0),
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let ray = Ray::new(Vec3::ZERO, Vec3::new(256.0, 3.796875, 3.796875), 0.0, 1.0);
    let first = mesh.intersect(0, &ray).expect("the box is entered");
    assert!(first.t > 0.0, "{first:?}");
    let at_its_distance = Ray {
        tmax: first.t,
        ..ray
    };
    assert_eq!(mesh.intersect(0, &at_its_distance), Some(first));
    let second = mesh.intersect(1, &ray).expect("hit at the origin");
    assert_eq!(second.t, 0.0);
    let expected = closest(&Accel::build(AccelKind::List, &mesh), &mesh, &ray);
    assert_eq!(expected, Some((0.0, 1)));
    for &kind in AccelKind::ALL {
        let a = Accel::build(kind, &mesh);
        assert_eq!(closest(&a, &mesh, &ray), expected, "{kind}");
    }
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
        .map(|f| accel_check::check(&std::fs::read(f).expect("read a kept input")))
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

#[path = "../../../fuzz/spatial_check.rs"]
mod spatial_check;

/// Every committed input of the spatial-split fuzz target
/// (`fuzz/corpus/accel_spatial/`) answers like brute force, and the crowds
/// they decode to do make the builds cut triangles (a target whose inputs
/// never took a spatial split would check nothing of them).
#[test]
fn spatial_split_fuzz_corpus_answers_like_brute_force() {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fuzz/corpus/accel_spatial"
    );
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .expect("the spatial-split corpus")
        .map(|e| e.expect("directory entry").path())
        .collect();
    files.sort();
    let checked: Vec<_> = files
        .iter()
        .map(|f| spatial_check::check(&std::fs::read(f).expect("read a corpus input")))
        .collect();
    assert!(
        checked.iter().any(|c| c.split),
        "no input took a spatial split: {files:?}"
    );
    assert!(checked.iter().all(|c| c.rays > 0), "{checked:?}");
}
