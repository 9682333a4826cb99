//! Every structure must answer exactly what brute force answers: the same
//! closest distance, the same primitive (unless several tie at that
//! distance), the same occlusion verdict, and no primitive offered twice
//! (except by trees with spatial splits, which may hold one in several
//! leaves).

use arbor_accel::list::List;
use arbor_accel::{
    Aabb, Accel, AccelKind, AccelParams, Accelerator, BuildQuality, NoCounters, Primitives, Ray,
    TriangleMesh, Vec3,
};
use proptest::prelude::*;
use std::fmt;

/// Coordinates mixing a continuous range, a coarse lattice (coincident
/// vertices, axis-aligned and flat triangles, rays in face planes) and huge
/// values.
fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        3 => (-4i32..=4).prop_map(|i| i as f32),
        1 => prop_oneof![Just(-1000.0f32), Just(1000.0f32), -1.0e5f32..1.0e5],
    ]
}

fn point() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Direction components including exact zeros of both signs.
fn dir_component() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0f32..1.0,
        2 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(1.0f32),
        1 => Just(-1.0f32),
    ]
}

/// A ray description: origin, direction (or a vertex index to aim at), and
/// an interval.
#[derive(Clone, Debug)]
struct RaySpec {
    origin: Vec3,
    dir: Vec3,
    aim: Option<usize>,
    tmin: f32,
    tmax: f32,
}

fn ray_spec() -> impl Strategy<Value = RaySpec> {
    (
        point(),
        (dir_component(), dir_component(), dir_component()),
        prop::option::weighted(0.3, any::<usize>()),
        // Mostly rays leaving their origin; some that also look behind it
        // (`tmin < 0`: the structures' slow path, where a box's exit
        // behind the origin is widened by its sign).
        prop_oneof![3 => Just(0.0f32), 1 => 0.0f32..2.0, 1 => -30.0f32..0.0],
        prop_oneof![3 => Just(f32::INFINITY), 1 => 0.0f32..30.0],
    )
        .prop_map(|(origin, (x, y, z), aim, tmin, tmax)| RaySpec {
            origin,
            dir: Vec3::new(x, y, z),
            aim,
            tmin,
            tmax,
        })
}

/// The closest hit as brute force and as `a` see it, asserting agreement.
fn check(
    name: &str,
    a: &Accel,
    list: &List,
    n: usize,
    ray: &Ray,
    exact: &impl Fn(u32, &Ray) -> Option<f32>,
) -> Result<(), TestCaseError> {
    // Brute force, with every primitive's own hit for tie detection.
    let mut all = Vec::new();
    let mut want: Option<(f32, u32)> = None;
    list.closest(ray, &mut NoCounters, |p, r| {
        let t = exact(p, r)?;
        if closer(want, t) {
            want = Some((t, p));
        }
        Some(t)
    });
    for p in 0..n as u32 {
        if let Some(t) = exact(p, ray) {
            all.push((t, p));
        }
    }
    let mut got: Option<(f32, u32)> = None;
    let mut offered = vec![false; n];
    let mut twice = false;
    a.closest(ray, &mut NoCounters, |p, r| {
        twice |= std::mem::replace(&mut offered[p as usize], true);
        let t = exact(p, r)?;
        assert_in_interval(t, r);
        if closer(got, t) {
            got = Some((t, p));
        }
        Some(t)
    });
    prop_assert!(
        !twice || a.offers_repeats(),
        "{name}: a primitive was offered twice"
    );
    prop_assert_eq!(got.map(|g| g.0), want.map(|w| w.0), "{}: closest t", name);
    if let (Some((t, p)), Some((_, q))) = (got, want) {
        let ties = all.iter().filter(|h| h.0 == t).count();
        prop_assert!(p == q || ties > 1, "{}: primitive {} vs {}", name, p, q);
    }
    let occ_a = a.occluded(ray, &mut NoCounters, |p, r| exact(p, r).is_some());
    let occ_l = list.occluded(ray, &mut NoCounters, |p, r| exact(p, r).is_some());
    prop_assert_eq!(occ_a, occ_l, "{}: occluded", name);
    Ok(())
}

/// Hits handed back must respect the ray's interval (a check on the test
/// closure itself, which all structures share).
fn assert_in_interval(t: f32, r: &Ray) {
    assert!(t >= r.tmin && t <= r.tmax);
}

/// Whether `t` beats the best hit so far.
fn closer(best: Option<(f32, u32)>, t: f32) -> bool {
    match best {
        None => true,
        Some((b, _)) => t < b,
    }
}

fn make_ray(spec: &RaySpec, targets: &[Vec3]) -> Ray {
    let dir = match spec.aim {
        // A ray that may look behind its origin is aimed away from its
        // target, which it then passes at t = -1: through a vertex or an
        // edge, on the boundary of boxes it may only touch.
        Some(i) if !targets.is_empty() && spec.tmin < 0.0 => {
            spec.origin - targets[i % targets.len()]
        }
        Some(i) if !targets.is_empty() => targets[i % targets.len()] - spec.origin,
        _ => spec.dir,
    };
    Ray::new(spec.origin, dir, spec.tmin, spec.tmax.max(spec.tmin))
}

/// [`check`]s each of `built` (structures over `prims`) against brute
/// force on the rays of `specs`, aimed at `targets`; `exact` is a
/// primitive's own hit test.
fn check_rays<P: Primitives + ?Sized>(
    prims: &P,
    built: &[(impl fmt::Display, Accel)],
    specs: &[RaySpec],
    targets: &[Vec3],
    exact: impl Fn(u32, &Ray) -> Option<f32>,
) -> Result<(), TestCaseError> {
    let list = List::build(prims);
    for spec in specs {
        let ray = make_ray(spec, targets);
        for (name, a) in built {
            check(&name.to_string(), a, &list, prims.len(), &ray, &exact)?;
        }
    }
    Ok(())
}

/// Every structure except brute force itself.
fn structures<P: Primitives + ?Sized>(prims: &P) -> Vec<(AccelKind, Accel)> {
    AccelKind::ALL
        .iter()
        .filter(|k| **k != AccelKind::List)
        .map(|&k| (k, Accel::build(k, prims)))
        .collect()
}

fn triangles() -> impl Strategy<Value = TriangleMesh> {
    soup(0..48)
}

/// Soups large enough for spatial splits (which cut only nodes of 64
/// references and more): small triangles with long slivers across them,
/// the case spatial splits are for, and a few arbitrary ones.
fn large_soups() -> impl Strategy<Value = TriangleMesh> {
    // Without the far outliers of `point`, beside which every overlap is
    // too small to try spatial splits.
    let near = || {
        let c = || prop_oneof![3 => -10.0f32..10.0, 1 => (-4i32..=4).prop_map(|i| i as f32)];
        (c(), c(), c()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    };
    let small = (near(), near(), near()).prop_map(|(a, b, c)| [a, a + b * 0.1, a + c * 0.1]);
    let sliver = (near(), near()).prop_map(|(a, b)| [a, b, b + (b - a).cross(Vec3::Z) * 0.01]);
    (
        prop::collection::vec(small, 64..160),
        prop::collection::vec(sliver, 4..24),
        soup(0..8),
    )
        .prop_map(|(mut tris, slivers, soup)| {
            tris.extend(slivers);
            tris.extend((0..soup.triangles.len() as u32).map(|i| soup.triangle(i)));
            mesh_of(&tris)
        })
}

/// A soup of `sizes` triangles: large ones, small clusters, degenerate ones.
fn soup(sizes: std::ops::Range<usize>) -> impl Strategy<Value = TriangleMesh> {
    prop::collection::vec(
        prop_oneof![
            6 => (point(), point(), point()).prop_map(|(a, b, c)| [a, b, c]),
            // Small triangles near a point, so structures get real depth.
            6 => (point(), point(), point()).prop_map(|(a, b, c)| [a, a + b * 0.1, a + c * 0.1]),
            // Degenerate: a repeated vertex or collinear points.
            1 => (point(), point()).prop_map(|(a, b)| [a, b, a]),
            1 => (point(), point()).prop_map(|(a, b)| [a, b, a * 0.5 + b * 0.5]),
        ],
        sizes,
    )
    .prop_map(|tris| mesh_of(&tris))
}

/// A mesh of separate triangles.
fn mesh_of(tris: &[[Vec3; 3]]) -> TriangleMesh {
    let vertices: Vec<Vec3> = tris.iter().flatten().copied().collect();
    let triangles = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    TriangleMesh::new(vertices, triangles)
}

/// The builds with spatial splits: `bvh-sah` and `bvh-wide` at
/// [`BuildQuality::High`], allowed as many extra references as there are
/// primitives (the default's tenth would rarely let sets this small cut).
fn spatial_structures<P: Primitives + ?Sized>(prims: &P) -> Vec<(String, Accel)> {
    let mut params = AccelParams::default().with_quality(BuildQuality::High);
    params.bvh.spatial_splits = 1.0;
    AccelKind::ALL
        .iter()
        .filter(|k| k.has_high_quality())
        .map(|&k| (format!("{k} high"), Accel::build_with(k, prims, &params)))
        .collect()
}

/// A sphere inscribed in each box, tested in `f64` and rounded up to `f32`
/// as a careful caller might.
fn sphere_hit(b: &Aabb, r: &Ray) -> Option<f32> {
    let c = b.center().as_dvec3();
    let rad = f64::from(b.extent().min_element()) * 0.5;
    let (o, d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
    let a = d.length_squared();
    if a == 0.0 {
        return None;
    }
    let oc = o - c;
    let tc = -oc.dot(d) / a;
    let l = oc + d * tc;
    let disc = rad * rad - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let h = (disc / a).sqrt();
    let t = if tc - h >= f64::from(r.tmin) {
        tc - h
    } else {
        tc + h
    };
    let mut t32 = t as f32;
    if f64::from(t32) < t {
        t32 = next_up(t32);
    }
    (t32 >= r.tmin && t32 <= r.tmax).then_some(t32)
}

fn next_up(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        x
    } else if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}

fn boxes() -> impl Strategy<Value = Vec<Aabb>> {
    prop::collection::vec(
        (point(), (0.0f32..3.0, 0.0f32..3.0, 0.0f32..3.0)).prop_map(|(p, (x, y, z))| {
            let q = Vec3::new(x, y, z);
            Aabb::new(p.min(p + q), p.max(p + q))
        }),
        0..48,
    )
}

/// Many long, overlapping boxes (rods along the axes) without far outliers
/// (which would make every overlap too small to try spatial splits): cut
/// across their length, they shrink, so many are.
fn crowded_boxes() -> impl Strategy<Value = Vec<Aabb>> {
    let corner = || (-8.0f32..8.0, -8.0f32..8.0, -8.0f32..8.0);
    prop::collection::vec(
        (corner(), 0usize..3, 4.0f32..12.0, 0.0f32..0.5).prop_map(
            |((x, y, z), axis, long, thin)| {
                let p = Vec3::new(x, y, z);
                let mut size = Vec3::splat(thin);
                size[axis] = long;
                Aabb::new(p, p + size)
            },
        ),
        64..160,
    )
}

proptest! {
    // 256 cases keep the suite fast; set PROPTEST_CASES for a deeper search.
    #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

    #[test]
    fn triangle_soups_match_brute_force(mesh in triangles(), rays in prop::collection::vec(ray_spec(), 1..24)) {
        let exact = |p: u32, r: &Ray| mesh.intersect(p, r).map(|h| h.t);
        check_rays(&mesh, &structures(&mesh), &rays, &mesh.vertices, exact)?;
    }

    #[test]
    fn boxed_spheres_match_brute_force(bs in boxes(), rays in prop::collection::vec(ray_spec(), 1..24)) {
        let exact = |p: u32, r: &Ray| sphere_hit(&bs[p as usize], r);
        let centers: Vec<Vec3> = bs.iter().map(Aabb::center).collect();
        check_rays(&bs, &structures(&bs), &rays, &centers, exact)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases() / 4, ..ProptestConfig::default() })]

    /// Trees with spatial splits answer as brute force does, over triangles
    /// (cut as triangles) and over boxes (cut as boxes).
    #[test]
    fn spatial_split_trees_match_brute_force(
        mesh in large_soups(),
        bs in crowded_boxes(),
        rays in prop::collection::vec(ray_spec(), 1..24),
    ) {
        let exact = |p: u32, r: &Ray| mesh.intersect(p, r).map(|h| h.t);
        check_rays(&mesh, &spatial_structures(&mesh), &rays, &mesh.vertices, exact)?;
        let exact = |p: u32, r: &Ray| sphere_hit(&bs[p as usize], r);
        let centers: Vec<Vec3> = bs.iter().map(Aabb::center).collect();
        check_rays(&bs, &spatial_structures(&bs), &rays, &centers, exact)?;
    }
}

/// Crossing slivers are cut: both high-quality builds place some triangle
/// in several leaves (so the property test above tests repeats), and still
/// answer every ray of a fan as brute force does.
#[test]
fn spatial_splits_cut_crossing_slivers() {
    let mut tris = Vec::new();
    for i in 0..300 {
        let f = i as f32;
        let a = Vec3::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.13).sin()) * 4.0;
        let b = a + Vec3::new((f * 0.53).cos(), (f * 0.29).sin(), (f * 0.61).cos()) * 1.5;
        tris.push([a, b, b + Vec3::new(0.0, 0.0, 0.05)]);
    }
    let mesh = mesh_of(&tris);
    let list = List::build(&mesh);
    let exact = |p: u32, r: &Ray| mesh.intersect(p, r).map(|h| h.t);
    for (name, a) in spatial_structures(&mesh) {
        assert!(a.offers_repeats(), "{name}: no triangle was cut");
        for k in 0..200 {
            let f = k as f32;
            let o = Vec3::new((f * 0.9).sin(), (f * 0.4).cos(), 3.0) * 3.0;
            let d = Vec3::new((f * 0.3).cos(), (f * 0.8).sin(), -3.0);
            let ray = Ray::new(o, d, 0.0, f32::INFINITY);
            check(&name, &a, &list, tris.len(), &ray, &exact).unwrap();
        }
    }
    // The plain builds hold each triangle once.
    for kind in [AccelKind::BvhSah, AccelKind::BvhWide] {
        assert!(!Accel::build(kind, &mesh).offers_repeats());
    }
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256)
}

#[test]
fn names_round_trip() {
    for k in AccelKind::ALL {
        assert_eq!(k.name().parse::<AccelKind>().unwrap(), *k);
    }
    assert_eq!(AccelKind::DEFAULT, AccelKind::BvhWide);
    assert!("octree".parse::<AccelKind>().is_err());
    assert_eq!(AccelKind::ALL.len(), 9);
}

#[test]
fn non_finite_vertices_neither_panic_nor_diverge() {
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let mut vertices = vec![
        Vec3::new(nan, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(inf, 0.0, 1.0),
        Vec3::new(0.0, -inf, 1.0),
        Vec3::new(nan, nan, nan),
    ];
    let mut triangles = vec![[0, 1, 2], [3, 1, 2], [3, 4, 2], [5, 5, 5], [1, 2, 4]];
    // Ordinary triangles around them.
    for i in 0..30u32 {
        let f = i as f32;
        let c = Vec3::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.13).sin()) * 3.0;
        let b = vertices.len() as u32;
        vertices.extend([c, c + Vec3::X * 0.5, c + Vec3::Y * 0.5]);
        triangles.push([b, b + 1, b + 2]);
    }
    let mesh = TriangleMesh::new(vertices, triangles);
    let n = mesh.triangles.len();
    let list = List::build(&mesh);
    let exact = |p: u32, r: &Ray| mesh.intersect(p, r).map(|h| h.t);
    for (kind, a) in structures(&mesh) {
        for k in 0..64 {
            let f = k as f32;
            let o = Vec3::new((f * 0.9).sin(), (f * 0.4).cos(), 4.0) * 2.0;
            let d = Vec3::new((f * 0.3).cos(), (f * 0.8).sin(), -3.0);
            let ray = Ray::new(o, d, 0.0, f32::INFINITY);
            check(kind.name(), &a, &list, n, &ray, &exact).unwrap();
        }
    }
}
