//! The accelerator fuzz check, shared by the fuzz target
//! (`fuzz_targets/accel.rs`) and the test that replays its kept inputs
//! (`crates/arbor-accel/tests/fuzz_regressions.rs`), so that a replay
//! decodes and checks an input exactly as the fuzzer did.

use arbor_accel::{Accel, AccelKind, Accelerator, MeshAccel, NoCounters, Ray, TriangleMesh, Vec3};

/// Reads f32s from the bytes, mapping some byte patterns to the special
/// values fuzzing should meet often.
pub fn floats(data: &[u8]) -> Vec<f32> {
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

/// The closest hit `(t, triangle)` through `a`; ties go to the lower
/// index, whatever order traversal offers them in.
pub fn closest<A: Accelerator>(a: &A, mesh: &TriangleMesh, ray: &Ray) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    a.closest(ray, &mut NoCounters, |prim, r| {
        let hit = mesh.intersect(prim, r)?;
        if best.is_some_and(|(t, p)| hit.t > t || (hit.t == t && prim > p)) {
            return None;
        }
        best = Some((hit.t, prim));
        Some(hit.t)
    });
    best
}

/// Decodes triangles and rays from `data` and asserts that every structure
/// answers closest-hit and occlusion queries as brute force does. Returns
/// the number of rays checked.
pub fn check(data: &[u8]) -> usize {
    if data.len() < 8 {
        return 0;
    }
    let split = (data[0] as usize % 8 + 1) * 4 * 9;
    let (geo, rays) = data[1..].split_at(split.min(data.len() - 1));
    let v = floats(geo);
    let vertices: Vec<Vec3> = v
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let triangles: Vec<[u32; 3]> = (0..vertices.len() as u32 / 3)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    // The wide BVH that owns its triangles and tests four at a time (what
    // `arbor trace` uses by default).
    let packed = MeshAccel::build(vertices.clone(), triangles.clone(), AccelKind::BvhWide)
        .expect("indices in range");
    let mesh = TriangleMesh::new(vertices, triangles);
    let list = Accel::build(AccelKind::List, &mesh);
    let built: Vec<Accel> = AccelKind::ALL
        .iter()
        .map(|&k| Accel::build(k, &mesh))
        .collect();
    let mut checked = 0;
    for ray in ray_pairs(rays).flatten().flatten() {
        check_ray(&mesh, &list, &built, &packed, &ray);
        checked += 1;
    }
    checked
}

/// The rays of `bytes`, one per 32 bytes: `None` for one whose origin or
/// direction is not finite, otherwise the ray as decoded and the same ray
/// looking behind its origin as far as ahead (`tmin < 0`: the structures'
/// slow path, where a box's exit behind the origin must be widened by its
/// sign).
pub fn ray_pairs(bytes: &[u8]) -> impl Iterator<Item = Option<[Ray; 2]>> {
    let values = floats(bytes);
    (0..values.len() / 8).map(move |i| {
        let r = &values[8 * i..8 * i + 8];
        let ray = Ray::new(
            Vec3::new(r[0], r[1], r[2]),
            Vec3::new(r[3], r[4], r[5]),
            r[6].abs().min(1.0),
            r[7].abs().max(1.0),
        );
        if !ray.origin.is_finite() || !ray.dir.is_finite() {
            return None;
        }
        let behind = Ray {
            tmin: -ray.tmax,
            ..ray
        };
        Some([ray, behind])
    })
}

/// Asserts that every structure answers `ray`'s closest-hit and occlusion
/// queries as brute force (`list`) does.
fn check_ray(mesh: &TriangleMesh, list: &Accel, built: &[Accel], packed: &MeshAccel, ray: &Ray) {
    let expected = closest(list, mesh, ray);
    let test = |p: u32, r: &Ray| mesh.intersect(p, r).is_some();
    let occluded = list.occluded(ray, &mut NoCounters, test);
    for (a, kind) in built.iter().zip(AccelKind::ALL) {
        assert_eq!(closest(a, mesh, ray), expected, "{kind} {ray:?}");
        assert_eq!(a.occluded(ray, &mut NoCounters, test), occluded, "{kind}");
    }
    assert_mesh_closest(mesh, packed, ray, expected, "packed");
    assert_eq!(packed.occluded(ray), occluded, "packed");
}

/// Asserts that `m`'s closest hit on `ray` is brute force's `expected`
/// (`(t, triangle)`, ties to the lower index): of tied triangles a mesh
/// query keeps the first offered, so the same distance, on a triangle that
/// the scalar test hits there.
pub fn assert_mesh_closest(
    mesh: &TriangleMesh,
    m: &MeshAccel,
    ray: &Ray,
    expected: Option<(f32, u32)>,
    what: &str,
) {
    let got = m.closest(ray);
    assert_eq!(
        got.map(|h| h.hit.t),
        expected.map(|e| e.0),
        "{what} {ray:?}"
    );
    if let Some(h) = got {
        let own = mesh.intersect(h.prim, ray).map(|x| x.t);
        assert_eq!(own, Some(h.hit.t), "{what} {ray:?}");
    }
}
