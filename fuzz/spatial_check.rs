//! The spatial-split fuzz check, shared by the fuzz target
//! (`fuzz_targets/accel_spatial.rs`) and the test that replays its committed
//! corpus (`crates/arbor-accel/tests/fuzz_regressions.rs`).
//!
//! The accelerator check (`accel_check.rs`) meets at most eight triangles,
//! too few for spatial splits, which are tried only in nodes of 64
//! references and more. Here a few seed triangles from the input are copied
//! into a crowd of about a hundred: each copy scaled about its centre by one
//! of four factors (1/4 to 2), shifted by a fixed scatter of a step from
//! the input and turned by a swap of the axes, so that large copies lie
//! across small ones and across each other, the overlap that spatial splits
//! cut. Every build with spatial splits (`BuildQuality::High`, and the same with
//! room for as many cut references as triangles) must then
//! answer closest hits, occlusion, counts and every hit as brute force does.

use arbor_accel::{
    Accel, AccelKind, AccelParams, Accelerator, BuildQuality, MeshAccel, NoCounters, Ray,
    TriangleMesh, Vec3,
};

// The includer also includes `accel_check.rs` as `accel_check`, at its root.
use crate::accel_check::{assert_mesh_closest, closest, floats, ray_pairs};

/// Triangles in the crowd, at least (spatial splits start at 64
/// references per node).
const CROWD: usize = 96;

/// Scale factors of the copies about their seed's centre, in turn.
const SCALES: [f32; 4] = [1.0, 0.5, 0.25, 2.0];

/// Extra references allowed per triangle in the generous builds (the
/// high-quality default allows a tenth).
const GENEROUS: f32 = 1.0;

/// Ray records read per input, at most (each ray also checked looking
/// behind its origin).
const MAX_RAYS: usize = 16;

/// What one input exercised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Checked {
    /// Rays checked (each decoded ray twice: as decoded and looking behind
    /// its origin).
    pub rays: usize,
    /// Whether some build with spatial splits holds a triangle in more than
    /// one leaf (a spatial split was taken).
    pub split: bool,
}

/// The crowd of triangle corners an input decodes to, and the rest of the
/// input (the rays).
pub fn crowd(data: &[u8]) -> Option<(Vec<Vec3>, &[u8])> {
    if data.len() < 2 {
        return None;
    }
    let seeds = data[0] as usize % 8 + 1;
    let take = ((seeds * 9 + 3) * 4).min(data.len() - 1);
    let (geo, rays) = data[1..].split_at(take);
    let v = floats(geo);
    if v.len() < 12 {
        return None;
    }
    let step = Vec3::new(v[0], v[1], v[2]);
    let seeds: Vec<[Vec3; 3]> = v[3..]
        .chunks_exact(9)
        .map(|c| {
            [
                Vec3::new(c[0], c[1], c[2]),
                Vec3::new(c[3], c[4], c[5]),
                Vec3::new(c[6], c[7], c[8]),
            ]
        })
        .collect();
    let copies = CROWD.div_ceil(seeds.len());
    let mut corners = Vec::with_capacity(3 * copies * seeds.len());
    for k in 0..copies {
        let shift = step * Vec3::new(scatter(k), scatter(k + 7), scatter(k + 13));
        let scale = SCALES[k / 3 % SCALES.len()];
        for seed in &seeds {
            let centre = (seed[0] + seed[1] + seed[2]) / 3.0;
            corners.extend(seed.map(|p| {
                let q = centre + (p - centre) * scale + shift;
                // Copies turned by a cyclic swap of the axes, so that long
                // seeds cross each other instead of lying side by side.
                match k % 3 {
                    0 => q,
                    1 => Vec3::new(q.y, q.z, q.x),
                    _ => Vec3::new(q.z, q.x, q.y),
                }
            }));
        }
    }
    Some((corners, rays))
}

/// A fixed scatter of copy `k` along one axis, in `[-1, 1]`.
fn scatter(k: usize) -> f32 {
    (k * 37 % 17) as f32 / 8.0 - 1.0
}

/// Decodes a crowd and rays from `data` and asserts that every build with
/// spatial splits answers as brute force does.
pub fn check(data: &[u8]) -> Checked {
    let Some((vertices, rays)) = crowd(data) else {
        return Checked::default();
    };
    let triangles: Vec<[u32; 3]> = (0..vertices.len() as u32 / 3)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let mesh = TriangleMesh::new(vertices.clone(), triangles.clone());
    let list = Accel::build(AccelKind::List, &mesh);
    let brute = MeshAccel::build(vertices.clone(), triangles.clone(), AccelKind::List)
        .expect("indices in range");
    // The high-quality build as users get it, and with room for as many
    // cut references as triangles, so that more splits are taken.
    let high = AccelParams::default().with_quality(BuildQuality::High);
    let generous = |mut p: AccelParams| {
        p.bvh.spatial_splits = GENEROUS;
        p
    };
    let builds: Vec<(AccelKind, AccelParams, AccelParams)> = AccelKind::ALL
        .iter()
        .filter(|k| k.has_high_quality())
        .flat_map(|&k| {
            let mesh_high = MeshAccel::params(k).with_quality(BuildQuality::High);
            [
                (k, high, mesh_high),
                (k, generous(high), generous(mesh_high)),
            ]
        })
        .collect();
    let kinds: Vec<AccelKind> = builds.iter().map(|b| b.0).collect();
    let built: Vec<Accel> = builds
        .iter()
        .map(|(k, p, _)| Accel::build_with(*k, &mesh, p))
        .collect();
    let meshes: Vec<MeshAccel> = builds
        .iter()
        .map(|(k, _, p)| {
            MeshAccel::build_with(vertices.clone(), triangles.clone(), *k, p)
                .expect("indices in range")
        })
        .collect();
    let split =
        built.iter().any(Accel::offers_repeats) || meshes.iter().any(|m| m.offers_repeats());
    let mut checked = Checked { rays: 0, split };
    for ray in ray_pairs(rays).take(MAX_RAYS).flatten().flatten() {
        check_ray(&mesh, &list, &brute, &kinds, &built, &meshes, &ray);
        checked.rays += 1;
    }
    checked
}

/// Asserts that the builds with spatial splits answer `ray` as brute force
/// (`list`, `brute`) does.
fn check_ray(
    mesh: &TriangleMesh,
    list: &Accel,
    brute: &MeshAccel,
    kinds: &[AccelKind],
    built: &[Accel],
    meshes: &[MeshAccel],
    ray: &Ray,
) {
    let expected = closest(list, mesh, ray);
    let test = |p: u32, r: &Ray| mesh.intersect(p, r).is_some();
    let occluded = list.occluded(ray, &mut NoCounters, test);
    let (count, hits) = (brute.count(ray), brute.all_hits(ray));
    for ((a, m), kind) in built.iter().zip(meshes).zip(kinds) {
        assert_eq!(closest(a, mesh, ray), expected, "{kind} high {ray:?}");
        assert_eq!(
            a.occluded(ray, &mut NoCounters, test),
            occluded,
            "{kind} high"
        );
        assert_mesh_closest(mesh, m, ray, expected, &format!("{kind} high mesh"));
        assert_eq!(m.occluded(ray), occluded, "{kind} high mesh");
        assert_eq!(m.count(ray), count, "{kind} high mesh count {ray:?}");
        assert_eq!(m.all_hits(ray), hits, "{kind} high mesh all hits {ray:?}");
    }
}
