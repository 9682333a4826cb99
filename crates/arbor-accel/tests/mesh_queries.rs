//! `MeshAccel`'s queries against brute force, for every structure, and the
//! crossing rule on closed meshes: counts through shared edges and vertices
//! even, inside/outside and signed distance against analytic shapes.

use arbor_accel::numerics::{intersect_triangle_owned, intersect_triangle_sheared, RayShear};
use arbor_accel::{
    AccelKind, AccelParams, BuildQuality, MeshAccel, MeshHit, Ray, Vec3, INSIDE_DIRECTION,
};
mod common;

use glam::DVec3;
use proptest::prelude::*;

/// Coordinates on a coarse lattice (shared vertices, flat and axis-aligned
/// triangles, rays in face planes and through edges) or continuous.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => -4.0f32..4.0,
        3 => (-3i32..=3).prop_map(|i| i as f32),
        1 => (-6i32..=6).prop_map(|i| i as f32 * 0.5),
    ]
}

fn point() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A random mesh: vertices from a small pool (so triangles share them).
fn mesh() -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> {
    prop::collection::vec(point(), 3..24).prop_flat_map(|vertices| {
        let n = vertices.len() as u32;
        let tri = (0..n, 0..n, 0..n).prop_map(|(a, b, c)| [a, b, c]);
        (Just(vertices), prop::collection::vec(tri, 1..40))
    })
}

/// A larger random mesh, for the spatial-split builds (which cut only
/// nodes of 64 triangles and more): triangles between vertices of a pool,
/// and slivers from one pool vertex to another, whose boxes overlap the
/// most, sharing the pool's vertices.
fn large_mesh() -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> {
    prop::collection::vec(point(), 12..60).prop_flat_map(|pool| {
        let n = pool.len() as u32;
        let tri = (0..n, 0..n, 0..n, any::<bool>(), point());
        (Just(pool), prop::collection::vec(tri, 64..160)).prop_map(|(mut vertices, specs)| {
            let mut triangles = Vec::new();
            for (a, b, c, sliver, nudge) in specs {
                if sliver {
                    let tip = vertices[a as usize] + nudge * 0.02;
                    vertices.push(tip);
                    triangles.push([a, b, vertices.len() as u32 - 1]);
                } else {
                    triangles.push([a, b, c]);
                }
            }
            (vertices, triangles)
        })
    })
}

/// Every way to build a `MeshAccel`: each kind with its parameters, and
/// the kinds with a high-quality build with spatial splits (allowed as many
/// extra references as there are triangles, so that small meshes are cut).
fn builds() -> Vec<(String, AccelKind, AccelParams)> {
    let mut all: Vec<_> = AccelKind::ALL
        .iter()
        .map(|&k| (k.to_string(), k, MeshAccel::params(k)))
        .collect();
    all.extend(spatial_builds());
    all
}

/// The high-quality builds of [`builds`].
fn spatial_builds() -> Vec<(String, AccelKind, AccelParams)> {
    AccelKind::ALL
        .iter()
        .filter(|k| k.has_high_quality())
        .map(|&k| {
            let mut params = MeshAccel::params(k).with_quality(BuildQuality::High);
            params.bvh.spatial_splits = 1.0;
            (format!("{k} high"), k, params)
        })
        .collect()
}

/// Asserts that `mesh` answers every ray query on `rays` as brute force
/// does: the same crossings in the same order (single and batch), counts,
/// the closest hit's distance and occlusion.
fn assert_ray_queries_equal_brute_force(
    name: &str,
    mesh: &MeshAccel,
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    rays: &[Ray],
) -> Result<(), TestCaseError> {
    let batch = mesh.all_hits_batch(rays);
    let offsets = batch.offsets();
    for (i, ray) in rays.iter().enumerate() {
        let want = brute_all_hits(vertices, triangles, ray);
        prop_assert_eq!(&mesh.all_hits(ray), &want, "{} ray {:?}", name, ray);
        prop_assert_eq!(batch.of(&offsets, i), &want[..], "{} batch", name);
        prop_assert_eq!(mesh.count(ray) as usize, want.len(), "{} count", name);
        let t = mesh.closest(ray).map(|h| h.hit.t);
        prop_assert_eq!(
            t,
            brute_closest_t(vertices, triangles, ray),
            "{} closest",
            name
        );
        prop_assert_eq!(mesh.occluded(ray), t.is_some(), "{} occluded", name);
    }
    prop_assert_eq!(
        mesh.count_batch(rays),
        rays.iter().map(|r| mesh.count(r)).collect::<Vec<_>>()
    );
    Ok(())
}

/// Asserts that each of `builds` of the mesh answers the rays of `specs`
/// as brute force does ([`assert_ray_queries_equal_brute_force`]).
fn assert_builds_equal_brute_force(
    builds: Vec<(String, AccelKind, AccelParams)>,
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    specs: &[(Vec3, Vec3, u8, usize, usize)],
) -> Result<(), TestCaseError> {
    let rays = rays(vertices, specs);
    for (name, kind, params) in builds {
        let mesh =
            MeshAccel::build_with(vertices.to_vec(), triangles.to_vec(), kind, &params).unwrap();
        assert_ray_queries_equal_brute_force(&name, &mesh, vertices, triangles, &rays)?;
    }
    Ok(())
}

/// Rays: free, or aimed at a vertex or an edge midpoint of the mesh.
fn rays(vertices: &[Vec3], specs: &[(Vec3, Vec3, u8, usize, usize)]) -> Vec<Ray> {
    specs
        .iter()
        .map(|&(origin, dir, kind, i, j)| {
            let (a, b) = (vertices[i % vertices.len()], vertices[j % vertices.len()]);
            let dir = match kind % 3 {
                0 => dir,
                1 => a - origin,
                _ => (a + b) * 0.5 - origin,
            };
            Ray::new(origin, dir, 0.0, f32::INFINITY)
        })
        .collect()
}

fn ray_specs() -> impl Strategy<Value = Vec<(Vec3, Vec3, u8, usize, usize)>> {
    prop::collection::vec(
        (
            point(),
            point(),
            any::<u8>(),
            any::<usize>(),
            any::<usize>(),
        ),
        1..24,
    )
}

/// Every owned hit, by testing every triangle: the reference.
fn brute_all_hits(vertices: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> Vec<MeshHit> {
    let shear = RayShear::new(ray);
    let mut hits: Vec<MeshHit> = triangles
        .iter()
        .enumerate()
        .filter_map(|(i, t)| {
            let [a, b, c] = t.map(|k| vertices[k as usize]);
            let hit = intersect_triangle_owned(ray, &shear, a, b, c)?;
            Some(MeshHit {
                prim: i as u32,
                hit,
            })
        })
        .collect();
    hits.sort_by(|x, y| x.hit.t.total_cmp(&y.hit.t).then(x.prim.cmp(&y.prim)));
    hits
}

/// The closest plain hit's distance, by testing every triangle.
fn brute_closest_t(vertices: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> Option<f32> {
    let shear = RayShear::new(ray);
    triangles
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|k| vertices[k as usize]);
            intersect_triangle_sheared(ray, &shear, a, b, c).map(|h| h.t)
        })
        .min_by(f32::total_cmp)
}

/// The f64 distance from `p` to triangle `abc`, by sampling nothing: the
/// minimum over the face (when the projection falls inside) and the three
/// edges, written independently of the library's region tests.
fn brute_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f64 {
    let (p, a, b, c) = (p.as_dvec3(), a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let segment = |s: DVec3, e: DVec3| {
        let d = e - s;
        let t = if d.length_squared() > 0.0 {
            ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (s + d * t)).length()
    };
    let mut best = segment(a, b).min(segment(b, c)).min(segment(c, a));
    let n = (b - a).cross(c - a);
    if n.length_squared() > 0.0 {
        let q = p - n * ((p - a).dot(n) / n.length_squared());
        let inside = [(a, b), (b, c), (c, a)]
            .iter()
            .all(|&(s, e)| (e - s).cross(q - s).dot(n) >= 0.0);
        if inside {
            best = best.min((p - q).length());
        }
    }
    best
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    /// Every structure reports exactly brute force's crossings (same
    /// triangles, same distances and barycentrics, same order), the same
    /// counts, and the closest hit at brute force's distance.
    #[test]
    fn ray_queries_equal_brute_force((vertices, triangles) in mesh(), specs in ray_specs()) {
        assert_builds_equal_brute_force(builds(), &vertices, &triangles, &specs)?;
    }

    /// Streams of camera rays, which the batches trace as packets (of
    /// sixteen on an AVX-512 CPU, of eight with AVX2), answer as brute
    /// force: the closest distance of every ray, whether it is blocked, its
    /// crossings and their count (on the builds with spatial splits too,
    /// whose crossings packets leave to single rays). Every other group of
    /// sixteen has its second half mirrored into another octant, so that
    /// the sixteen are no packet and each half is traced as one of eight.
    #[test]
    fn camera_ray_batches_equal_brute_force(
        (vertices, triangles) in mesh(),
        eye in (-0.9f32..0.9, -0.9f32..0.9, 6.0f32..9.0),
        window in 0.5f32..3.0,
    ) {
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let mut rays = Vec::new();
        for y in 0..8 {
            for x in 0..32 {
                let target = Vec3::new(
                    window * (x as f32 / 31.0 - 0.5),
                    window * (y as f32 / 7.0 - 0.5),
                    0.0,
                );
                let mut dir = target - eye;
                if (x / 16 + y) % 2 == 1 && x % 16 >= 8 {
                    dir.x = -dir.x - 0.01;
                }
                rays.push(Ray::new(eye, dir, 0.0, f32::INFINITY));
            }
        }
        for (name, kind, params) in builds() {
            let mesh =
                MeshAccel::build_with(vertices.clone(), triangles.clone(), kind, &params).unwrap();
            let batch = mesh.closest_batch(&rays);
            let blocked = mesh.occluded_batch(&rays);
            let counts = mesh.count_batch(&rays);
            let every = mesh.all_hits_batch(&rays);
            let offsets = every.offsets();
            let answers = rays.iter().zip(batch).zip(blocked).zip(counts).enumerate();
            for (i, (((ray, got), blocked), count)) in answers {
                let want = brute_closest_t(&vertices, &triangles, ray);
                prop_assert_eq!(got.map(|h| h.hit.t), want, "{} {:?}", name, ray);
                prop_assert_eq!(blocked, want.is_some(), "{} {:?}", name, ray);
                let crossings = brute_all_hits(&vertices, &triangles, ray);
                prop_assert_eq!(count, crossings.len() as u32, "{} {:?}", name, ray);
                prop_assert_eq!(every.of(&offsets, i), &crossings[..], "{} {:?}", name, ray);
            }
        }
    }

    /// The same on meshes large enough for spatial splits, whose trees
    /// offer a cut triangle once per leaf holding a part of it: the
    /// crossing queries still report each crossing once.
    #[test]
    fn spatial_split_builds_answer_ray_queries_like_brute_force(
        (vertices, triangles) in large_mesh(),
        specs in ray_specs(),
    ) {
        assert_builds_equal_brute_force(spatial_builds(), &vertices, &triangles, &specs)?;
    }

    /// The closest point is at brute force's minimum distance (the same
    /// `f64` value, rounded once), on the smallest-index triangle at that
    /// distance, and really on that triangle.
    #[test]
    fn closest_point_equals_brute_force(
        (vertices, triangles) in mesh(),
        points in prop::collection::vec(point(), 1..16),
        limit in prop_oneof![Just(f32::INFINITY), 0.0f32..3.0],
    ) {
        let mesh = MeshAccel::build(vertices.clone(), triangles.clone(), AccelKind::DEFAULT).unwrap();
        let limits = vec![limit; points.len()];
        let batch = mesh.closest_point_batch(&points, &limits);
        for (p, got) in points.iter().zip(batch) {
            prop_assert_eq!(got, mesh.closest_point(*p, limit));
            let dists: Vec<f64> = triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|k| vertices[k as usize]);
                    brute_distance(*p, a, b, c)
                })
                .collect();
            let min = dists.iter().copied().fold(f64::INFINITY, f64::min);
            match got {
                None => prop_assert!(min > f64::from(limit) * (1.0 + 1e-9), "missed {min} within {limit}"),
                Some(c) => {
                    // Two independent f64 formulas: equal to about 1e-12.
                    let tol = 1e-9 * (1.0 + min);
                    prop_assert!((f64::from(c.distance) - min).abs() <= tol + f64::from(c.distance) * 1e-7,
                        "distance {} against {}", c.distance, min);
                    prop_assert!((dists[c.prim as usize] - min).abs() <= tol, "prim {} not nearest", c.prim);
                    let [a, b, cc] = triangles[c.prim as usize].map(|k| vertices[k as usize]);
                    let on = a * (1.0 - c.u - c.v) + b * c.u + cc * c.v;
                    prop_assert!((on - c.point).length() <= 1e-4 * (1.0 + c.point.length()));
                }
            }
        }
    }
}

/// [`icosphere`] with its vertices' radii scaled by `bumps` (in turn),
/// then the whole scaled by `scale` and moved by `offset`: closed, still
/// outward-facing, and where rounding is at its worst when far and small.
fn bumpy_icosphere(
    levels: usize,
    bumps: &[f32],
    scale: f32,
    offset: Vec3,
) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (v, t) = icosphere(levels);
    let v = v
        .iter()
        .zip(bumps.iter().cycle())
        .map(|(&p, &r)| p * r * scale + offset)
        .collect();
    (v, t)
}

/// Where [`bumpy_icosphere`]s stand: at the origin or far from it.
fn offset() -> impl Strategy<Value = Vec3> {
    prop_oneof![Just(Vec3::ZERO), Just(Vec3::new(1000.0, -2000.0, 500.0))]
}

/// How large [`bumpy_icosphere`]s are: of radius about 1 or a thousandth.
fn scale() -> impl Strategy<Value = f32> {
    prop_oneof![Just(1.0f32), Just(1e-3)]
}

/// A closed, consistently oriented icosphere of radius 1.
fn icosphere(levels: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mesh = common::icosphere(levels);
    (mesh.vertices, mesh.triangles)
}

/// The cube `[0, 1]^3` as twelve outward-facing triangles.
fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let t = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    (v, t)
}

/// Rays from outside through every vertex and every edge midpoint of a
/// closed mesh, from many origins: every count is even, for every
/// structure, and a ray that crosses the solid has at least two.
fn assert_even_counts(vertices: &[Vec3], triangles: &[[u32; 3]], origins: &[Vec3]) {
    let mut targets: Vec<Vec3> = vertices.to_vec();
    for t in triangles {
        for k in 0..3 {
            targets.push((vertices[t[k] as usize] + vertices[t[(k + 1) % 3] as usize]) * 0.5);
        }
    }
    let rays: Vec<Ray> = origins
        .iter()
        .flat_map(|&o| {
            targets
                .iter()
                .map(move |&p| Ray::new(o, p - o, 0.0, f32::INFINITY))
        })
        .collect();
    for (name, kind, params) in builds() {
        let mesh =
            MeshAccel::build_with(vertices.to_vec(), triangles.to_vec(), kind, &params).unwrap();
        assert_eq!(mesh.open_edges(), 0);
        let mut odd = 0;
        for (ray, n) in rays.iter().zip(mesh.count_batch(&rays)) {
            odd += n % 2;
            assert!(n % 2 == 0, "{name}: {n} crossings for {ray:?}");
        }
        assert_eq!(odd, 0);
    }
}

#[test]
fn counts_through_shared_edges_and_vertices_are_even() {
    let origins = [
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 5.0),
        Vec3::new(3.0, 4.0, -2.0),
        Vec3::new(-2.5, 0.5, 1.0),
        Vec3::new(1.0, -6.0, 3.0),
    ];
    let (v, t) = icosphere(2);
    assert_even_counts(&v, &t, &origins);
    let (v, t) = cube();
    let cube_origins = [
        Vec3::new(0.5, 0.5, 3.0),
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(2.0, 0.5, 0.5),
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::new(3.0, 2.0, 1.0),
    ];
    assert_even_counts(&v, &t, &cube_origins);
}

/// A ray through a cube's edge crosses once into the solid... and out: 2.
/// A ray that only touches a silhouette edge or vertex: 0 or 2, never 1.
#[test]
fn silhouette_touches_count_zero_or_two() {
    let (v, t) = cube();
    let through = [
        // Along the diagonal plane through the vertical edge x = y = 0.
        Ray::new(
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(1.0, 1.0, 0.0),
            0.0,
            f32::INFINITY,
        ),
        // Through two opposite vertices.
        Ray::new(Vec3::splat(-1.0), Vec3::ONE, 0.0, f32::INFINITY),
    ];
    let touching = [
        // Grazes the vertical edge x = y = 0 only.
        Ray::new(
            Vec3::new(-1.0, 1.0, 0.5),
            Vec3::new(1.0, -1.0, 0.0),
            0.0,
            f32::INFINITY,
        ),
        // Grazes the vertex (0, 0, 0) only.
        Ray::new(
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            0.0,
            f32::INFINITY,
        ),
        Ray::new(
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(1.0, -1.0, 1.0),
            0.0,
            f32::INFINITY,
        ),
    ];
    for (name, kind, params) in builds() {
        let mesh = MeshAccel::build_with(v.clone(), t.clone(), kind, &params).unwrap();
        for ray in &through {
            assert_eq!(mesh.count(ray), 2, "{name}: {ray:?}");
        }
        for ray in &touching {
            let n = mesh.count(ray);
            assert!(n == 0 || n == 2, "{name}: {n} for {ray:?}");
        }
    }
}

/// Points on a grid against the unit sphere and the unit cube: inside as
/// the analytic shape says (away from the surface, where the mesh and the
/// shape differ), signed distance within the mesh's deviation.
#[test]
fn inside_and_signed_distance_match_analytic_shapes() {
    let (v, t) = icosphere(3);
    // The icosphere's flat faces lie inside the sphere by at most this.
    let sag = 1.0 - 0.986;
    let sphere = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
    let (v, t) = cube();
    let cube = MeshAccel::build(v, t, AccelKind::BvhSah).unwrap();
    let mut points = Vec::new();
    for i in 0..=20 {
        for j in 0..=20 {
            for k in 0..=20 {
                points.push(Vec3::new(i as f32, j as f32, k as f32) * 0.15 - Vec3::splat(1.5));
            }
        }
    }
    let inside = sphere.contains_batch(&points);
    let signed = sphere.signed_distance_batch(&points);
    let mut checked = 0;
    for ((p, inside), sd) in points.iter().zip(inside).zip(signed) {
        let r = p.length();
        let analytic = r - 1.0;
        assert!(
            (sd - analytic).abs() <= sag + 1e-5,
            "{p}: {sd} against {analytic}"
        );
        assert_eq!(inside, sd < 0.0, "{p}");
        if (r - 1.0).abs() > sag {
            assert_eq!(inside, r < 1.0, "{p}");
            checked += 1;
        }
    }
    assert!(checked > 8000);
    for p in &points {
        let q = *p + Vec3::splat(0.5);
        let outside = (q - q.clamp(Vec3::ZERO, Vec3::ONE)).length();
        let inside_depth = q.min(Vec3::ONE - q).min_element();
        let analytic = if outside > 0.0 {
            outside
        } else {
            -inside_depth
        };
        let sd = cube.signed_distance(q);
        assert!(
            (sd - analytic).abs() <= 1e-6,
            "{q}: {sd} against {analytic}"
        );
        if analytic.abs() > 1e-6 {
            assert_eq!(cube.contains(q), analytic < 0.0, "{q}");
        }
    }
}

#[test]
fn open_meshes_report_their_open_edges() {
    let (v, mut t) = cube();
    t.pop();
    let mesh = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
    assert_eq!(mesh.open_edges(), 3);
}

#[test]
fn indices_out_of_range_are_refused() {
    let err =
        MeshAccel::build(vec![Vec3::ZERO; 3], vec![[0, 1, 3]], AccelKind::DEFAULT).unwrap_err();
    assert_eq!(
        err.to_string(),
        "triangle 0 names vertex 3, but the mesh has 3 vertices"
    );
}

#[test]
fn empty_meshes_answer_nothing() {
    let mesh = MeshAccel::build(Vec::new(), Vec::new(), AccelKind::DEFAULT).unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
    assert_eq!(mesh.closest(&ray), None);
    assert_eq!(mesh.count(&ray), 0);
    assert!(!mesh.contains(Vec3::ZERO));
    assert_eq!(mesh.closest_point(Vec3::ZERO, f32::INFINITY), None);
    assert_eq!(mesh.signed_distance(Vec3::ZERO), f32::INFINITY);
}

/// The parity of the crossings along the inside test's ray from `p`: what
/// `contains` must answer, however it finds it.
fn ray_parity(mesh: &MeshAccel, p: Vec3) -> bool {
    mesh.count(&Ray::new(p, INSIDE_DIRECTION, 0.0, f32::INFINITY)) % 2 == 1
}

/// Points near a mesh's features: its vertices and edge midpoints, nudged
/// by `nudge` along each axis both ways.
fn near_features(v: &[Vec3], t: &[[u32; 3]], nudge: f32) -> Vec<Vec3> {
    let mut features: Vec<Vec3> = v.to_vec();
    for tri in t {
        let [a, b, c] = tri.map(|i| v[i as usize]);
        features.extend([(a + b) * 0.5, (b + c) * 0.5, (a + b + c) / 3.0]);
    }
    let mut points = Vec::new();
    for f in features {
        points.push(f);
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            points.push(f + axis * nudge);
            points.push(f - axis * nudge);
        }
    }
    points
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// `contains` (a grid lookup where the grid knows, the ray elsewhere)
    /// answers the ray's parity everywhere: random open meshes (whose odd
    /// edges' strips the grid must respect), points anywhere, on and near
    /// vertices, edges and faces.
    #[test]
    fn inside_answers_the_rays_parity_on_random_meshes(
        (v, t) in mesh(),
        points in prop::collection::vec(point(), 1..64),
        nudge in prop_oneof![Just(1e-6f32), Just(1e-3), Just(0.05)],
    ) {
        let mesh = MeshAccel::build(v.clone(), t.clone(), AccelKind::DEFAULT).unwrap();
        for p in points.into_iter().chain(near_features(&v, &t, nudge)) {
            prop_assert_eq!(mesh.contains(p), ray_parity(&mesh, p), "{}", p);
        }
        // The batch form answers the same (it builds the grid too).
        let lattice: Vec<Vec3> = (0..512)
            .map(|i| Vec3::new((i % 8) as f32, ((i / 8) % 8) as f32, (i / 64) as f32) - Vec3::splat(3.5))
            .collect();
        let batch = mesh.contains_batch(&lattice);
        for (p, inside) in lattice.iter().zip(batch) {
            prop_assert_eq!(inside, ray_parity(&mesh, *p), "{}", p);
        }
    }

    /// The same on closed meshes with bumps (the grid without strips),
    /// far from the origin and small, so that rounding is at its worst.
    #[test]
    fn inside_answers_the_rays_parity_on_bumpy_closed_meshes(
        bumps in prop::collection::vec(0.7f32..1.3, 42),
        offset in offset(),
        scale in scale(),
        points in prop::collection::vec(point(), 1..64),
        nudge in prop_oneof![Just(1e-7f32), Just(1e-4), Just(0.02)],
    ) {
        let (v, t) = bumpy_icosphere(1, &bumps, scale, offset);
        let mesh = MeshAccel::build(v.clone(), t.clone(), AccelKind::DEFAULT).unwrap();
        prop_assert_eq!(mesh.open_edges(), 0);
        let scattered = points.iter().map(|&p| p * 0.4 * scale + offset);
        for p in scattered.chain(near_features(&v, &t, nudge * scale)) {
            prop_assert_eq!(mesh.contains(p), ray_parity(&mesh, p), "{}", p);
        }
    }
}

/// The single-point queries build their structures on first use; called
/// first from many tasks of a parallel loop at once (the way users write
/// them), they must neither deadlock nor answer differently from the
/// batch forms, whose structures were built beforehand.
#[test]
fn first_single_point_queries_from_a_parallel_loop_finish() {
    use rayon::prelude::*;
    let (vertices, triangles) = icosphere(6);
    let points: Vec<Vec3> = (0..4000)
        .map(|i| {
            let a = i as f32 * 0.37;
            Vec3::new(a.sin(), (1.3 * a).cos(), (0.7 * a).sin()) * (0.2 + (i % 13) as f32 * 0.1)
        })
        .collect();
    let prepared =
        MeshAccel::build(vertices.clone(), triangles.clone(), AccelKind::DEFAULT).unwrap();
    prepared.prepare_point_queries();
    let want: Vec<(bool, f32)> = points
        .iter()
        .map(|&p| {
            (
                prepared.contains(p),
                prepared.closest_point(p, f32::INFINITY).unwrap().distance,
            )
        })
        .collect();
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mesh = MeshAccel::build(vertices, triangles, AccelKind::DEFAULT).unwrap();
        let got: Vec<(bool, f32)> = points
            .par_iter()
            .map(|&p| {
                (
                    mesh.contains(p),
                    mesh.closest_point(p, f32::INFINITY).unwrap().distance,
                )
            })
            .collect();
        done.send(got).unwrap();
    });
    let got = finished
        .recv_timeout(std::time::Duration::from_secs(120))
        .expect("the first point queries did not finish within 120 s (a deadlock?)");
    assert_eq!(got, want);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The fast winding number (far subtrees by their moments) stays within
    /// 1e-2 of the exact sum of solid angles, on random soups and at random
    /// points, and the batch form answers the same.
    #[test]
    fn winding_numbers_are_near_the_exact_sum(
        (v, t) in mesh(),
        points in prop::collection::vec(point(), 1..48),
    ) {
        let mesh = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
        let batch = mesh.winding_number_batch(&points);
        for (&p, &b) in points.iter().zip(&batch) {
            let fast = mesh.winding_number(p);
            let exact = mesh.winding_number_exact(p);
            prop_assert!((f64::from(fast) - exact).abs() <= 1e-2, "{}: {} vs {}", p, fast, exact);
            prop_assert_eq!(fast.to_bits(), b.to_bits());
        }
    }

    /// On closed, outward-facing meshes (bumpy icospheres, far from the
    /// origin and small too) the winding number is 1 where the ray's parity
    /// says inside and 0 outside, away from the surface.
    #[test]
    fn winding_numbers_agree_with_inside_on_closed_meshes(
        bumps in prop::collection::vec(0.7f32..1.3, 162),
        offset in offset(),
        scale in scale(),
        points in prop::collection::vec(point(), 1..64),
    ) {
        let (v, t) = bumpy_icosphere(2, &bumps, scale, offset);
        let mesh = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
        for p in points.iter().map(|&p| p * 0.4 * scale + offset) {
            let near = mesh.closest_point(p, f32::INFINITY).unwrap().distance;
            if near < 1e-3 * scale {
                continue;
            }
            let want = if mesh.contains(p) { 1.0 } else { 0.0 };
            let w = mesh.winding_number(p);
            prop_assert!((w - want).abs() < 1e-2, "{}: {} (inside {})", p, w, want);
        }
    }
}
/// The fast winding number's accuracy on a sphere, inside and out (the
/// figures in `mesh/winding.rs`): within 1e-2 of the exact sum everywhere.
#[test]
fn winding_numbers_on_a_sphere_are_within_a_hundredth() {
    let (v, t) = icosphere(3);
    let mesh = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..2000 {
        let a = i as f32 * 0.618;
        let r = 1.26 * (i % 97) as f32 / 97.0;
        let p = Vec3::new(a.sin(), (1.7 * a).cos(), (2.3 * a).sin()) * r;
        let e = (f64::from(mesh.winding_number(p)) - mesh.winding_number_exact(p)).abs();
        worst = worst.max(e);
    }
    assert!(worst < 1e-2, "largest error {worst}");
}

/// A ray through a hundred strips stacked above one another: every
/// crossing counted once by every build, including those that may offer a
/// triangle twice (the grid, the k-d tree, spatial splits) past the count's
/// inline list of 32 triangles.
#[test]
fn counts_through_a_hundred_strips_count_each_crossing_once() {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    for i in 0..100u32 {
        let (y, z) = ((i % 7) as f32 * 0.01, i as f32 * 0.1);
        let b = v.len() as u32;
        v.extend([
            Vec3::new(-10.0, y, z),
            Vec3::new(10.0, y, z),
            Vec3::new(10.0, y + 0.2, z),
            Vec3::new(-10.0, y + 0.2, z),
        ]);
        t.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
    }
    let ray = Ray::new(Vec3::new(0.3, 0.1, -1.0), Vec3::Z, 0.0, f32::INFINITY);
    let mut repeating = 0;
    for (name, kind, params) in builds() {
        let mesh = MeshAccel::build_with(v.clone(), t.clone(), kind, &params).unwrap();
        repeating += usize::from(mesh.offers_repeats());
        assert_eq!(mesh.count(&ray), 100, "{name}");
        assert_eq!(mesh.all_hits(&ray).len(), 100, "{name}");
    }
    assert!(repeating >= 2);
}
