//! Traversal recording: a [`Recorder`] sees exactly what the counters
//! count (entered visits = nodes, tests = tests), in an order that walks the
//! structure's [`Layout`] from its root, for every structure.

use arbor_accel::{
    Accel, AccelKind, Accelerator, Layout, Ray, RayCounts, Recorder, TriangleMesh, Vec3,
};
use proptest::prelude::*;

/// A deterministic soup of small triangles in a 10-unit cube.
fn soup(n: usize) -> TriangleMesh {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut vertices = Vec::new();
    for _ in 0..n {
        let a = Vec3::new(next(), next(), next()) * 10.0;
        for _ in 0..2 {
            vertices.push(a);
            vertices.push(a + Vec3::new(next(), next(), next()) - 0.5);
            vertices.push(a + Vec3::new(next(), next(), next()) - 0.5);
        }
        vertices.truncate(vertices.len() - 3);
    }
    let triangles = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    TriangleMesh::new(vertices, triangles)
}

/// Rays from outside the cube through it, and from inside it.
fn rays(n: usize) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let f = i as f32 / n as f32;
            let origin = if i % 3 == 0 {
                Vec3::splat(5.0)
            } else {
                Vec3::new(-5.0, 20.0 * f - 5.0, 3.0)
            };
            let target = Vec3::new(10.0 * f, 5.0 + 4.0 * (7.0 * f).sin(), 10.0 * (1.0 - f));
            Ray::new(origin, target - origin, 0.0, f32::INFINITY)
        })
        .collect()
}

/// Checks one ray on one structure; returns the number of entered visits.
fn check(kind: AccelKind, a: &Accel, layout: &Layout, mesh: &TriangleMesh, ray: &Ray) -> u64 {
    let exact = |p: u32, r: &Ray| mesh.intersect(p, r).map(|h| h.t);
    let mut counts = RayCounts::default();
    a.closest(ray, &mut counts, exact);
    let mut rec = Recorder::default();
    let mut best: Option<(f32, u32)> = None;
    a.closest(ray, &mut rec, |p, r| {
        let t = exact(p, r)?;
        if best.is_none_or(|(b, _)| t < b) {
            best = Some((t, p));
        }
        Some(t)
    });
    assert_eq!(rec.counts, counts, "{kind}: recorder counts");
    let entered: Vec<u32> = rec
        .visits
        .iter()
        .filter(|v| v.entered)
        .map(|v| layout.index(v.node))
        .collect();
    assert_eq!(entered.len() as u64, counts.nodes, "{kind}: entered visits");
    assert_eq!(rec.tests.len() as u64, counts.tests, "{kind}: tests");
    if let Some((_, p)) = best {
        assert!(rec.tests.contains(&p), "{kind}: the hit was tested");
    }
    check_order(kind, layout, &rec);

    let mut occ_counts = RayCounts::default();
    let occ = a.occluded(ray, &mut occ_counts, |p, r| exact(p, r).is_some());
    let mut occ_rec = Recorder::default();
    let occ2 = a.occluded(ray, &mut occ_rec, |p, r| exact(p, r).is_some());
    assert_eq!(occ, occ2);
    assert_eq!(occ_rec.counts, occ_counts, "{kind}: occluded counts");
    let occ_entered = occ_rec.visits.iter().filter(|v| v.entered).count() as u64;
    assert_eq!(occ_entered, occ_counts.nodes, "{kind}: occluded visits");
    assert_eq!(occ_rec.tests.len() as u64, occ_counts.tests);
    check_order(kind, layout, &occ_rec);
    counts.nodes
}

/// Every visit names a node of the layout; a tree's visits start at the
/// root and reach a node only through an entered parent; a grid's entered
/// cells are face neighbours one after the other.
fn check_order(kind: AccelKind, layout: &Layout, rec: &Recorder) {
    match layout {
        Layout::List => assert!(rec.visits.is_empty(), "{kind}: list visits"),
        Layout::Tree { nodes, .. } => {
            let mut parent = vec![u32::MAX; nodes.len()];
            for (i, n) in nodes.iter().enumerate() {
                for &c in &n.children {
                    parent[c as usize] = i as u32;
                }
            }
            let mut seen = vec![false; nodes.len()];
            for v in &rec.visits {
                let i = layout.index(v.node) as usize;
                assert!(i < nodes.len(), "{kind}: node {i} out of range");
                if i != 0 {
                    let p = parent[i] as usize;
                    assert!(p < nodes.len() && seen[p], "{kind}: {i} before its parent");
                }
                if v.entered {
                    assert!(!seen[i], "{kind}: node {i} entered twice");
                    seen[i] = true;
                }
            }
        }
        Layout::Grid(g) => {
            let cells: u32 = g.resolution.iter().product();
            let at = |c: u32| {
                let [nx, ny, _] = g.resolution;
                [c % nx, (c / nx) % ny, c / (nx * ny)]
            };
            let entered: Vec<u32> = rec.visits.iter().map(|v| v.node).collect();
            assert!(rec.visits.iter().all(|v| v.entered && v.node < cells));
            for w in entered.windows(2) {
                let (a, b) = (at(w[0]), at(w[1]));
                let d: u32 = (0..3).map(|k| a[k].abs_diff(b[k])).sum();
                assert_eq!(
                    d, 1,
                    "{kind}: cells {} and {} are not neighbours",
                    w[0], w[1]
                );
            }
        }
    }
}

/// One test per structure, on a fixed soup and fixed rays.
fn structure_records_what_it_counts(kind: AccelKind) {
    let mesh = soup(400);
    let a = Accel::build(kind, &mesh);
    let layout = a.layout();
    let visited: u64 = rays(120)
        .iter()
        .map(|r| check(kind, &a, &layout, &mesh, r))
        .sum();
    if kind != AccelKind::List {
        assert!(
            visited > 120,
            "{kind}: rays visited too little to check anything"
        );
    }
}

/// One test per structure, so that a failure names it.
macro_rules! records_what_it_counts {
    ($($test:ident: $kind:ident,)*) => {
        $(
            #[test]
            fn $test() {
                structure_records_what_it_counts(AccelKind::$kind);
            }
        )*
    };
}

records_what_it_counts! {
    list_records_what_it_counts: List,
    bvh_center_records_what_it_counts: BvhCenter,
    bvh_median_records_what_it_counts: BvhMedian,
    bvh_sah_records_what_it_counts: BvhSah,
    bvh_sweep_records_what_it_counts: BvhSweep,
    bvh_cluster_records_what_it_counts: BvhCluster,
    bvh_wide_records_what_it_counts: BvhWide,
    grid_records_what_it_counts: Grid,
    kdtree_records_what_it_counts: KdTree,
}

/// The layouts' trees are consistent: children one level deeper and inside
/// their parent's box, leaves holding the primitives.
#[test]
fn layouts_nest() {
    let mesh = soup(300);
    for &kind in AccelKind::ALL {
        let layout = Accel::build(kind, &mesh).layout();
        let Layout::Tree { nodes, .. } = &layout else {
            continue;
        };
        let mut reached = vec![false; nodes.len()];
        reached[0] = true;
        for (i, n) in nodes.iter().enumerate() {
            // A leaf: a k-d tree's has no split (and may be empty), a
            // BVH's holds primitives.
            let leaf = if kind == AccelKind::KdTree {
                n.split.is_none()
            } else {
                n.primitives > 0
            };
            assert_eq!(n.children.is_empty(), leaf, "{kind}: node {i}");
            for &c in &n.children {
                let c = &nodes[c as usize];
                assert_eq!(c.depth, n.depth + 1, "{kind}: depth under {i}");
                assert!(n.bounds.contains_box(&c.bounds), "{kind}: child box of {i}");
            }
            for &c in &n.children {
                reached[c as usize] = true;
            }
        }
        assert!(
            reached.iter().all(|&r| r),
            "{kind}: every node is some node's child"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random rays through the soup, every structure: recording agrees with
    /// the counters.
    #[test]
    fn random_rays_record_what_they_count(
        rays in prop::collection::vec(((-2.0f32..12.0, -2.0f32..12.0, -2.0f32..12.0), (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)), 1..16)
    ) {
        let mesh = soup(200);
        for &kind in AccelKind::ALL {
            let a = Accel::build(kind, &mesh);
            let layout = a.layout();
            for &((x, y, z), (dx, dy, dz)) in &rays {
                let ray = Ray::new(Vec3::new(x, y, z), Vec3::new(dx, dy, dz), 0.0, f32::INFINITY);
                check(kind, &a, &layout, &mesh, &ray);
            }
        }
    }
}
