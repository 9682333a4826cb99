//! Rays aimed exactly at the shared edges and vertices of closed meshes never
//! slip through, whichever structure finds the candidates.

use std::collections::HashMap;

use arbor_accel::{Accel, AccelKind, Accelerator, NoCounters, Ray, TriangleMesh, Vec3};

/// An icosahedron subdivided `levels` times, projected to the unit sphere.
fn icosphere(levels: usize) -> TriangleMesh {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut t: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in t {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push(((v[i as usize] + v[j as usize]) * 0.5).normalize());
                    (v.len() - 1) as u32
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        t = next;
    }
    TriangleMesh::new(v, t)
}

/// The cube [-1, 1]^3 with each face cut into `n` x `n` squares of two
/// triangles each.
fn cube(n: usize) -> TriangleMesh {
    let mut v = Vec::new();
    let mut t = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let base = v.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let a = -1.0 + 2.0 * i as f32 / n as f32;
                    let b = -1.0 + 2.0 * j as f32 / n as f32;
                    let mut p = [0.0f32; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = a;
                    p[(axis + 2) % 3] = b;
                    v.push(Vec3::from_array(p));
                }
            }
            let w = (n + 1) as u32;
            for j in 0..n as u32 {
                for i in 0..n as u32 {
                    let q = base + j * w + i;
                    t.push([q, q + 1, q + w + 1]);
                    t.push([q, q + w + 1, q + w]);
                }
            }
        }
    }
    TriangleMesh::new(v, t)
}

/// Points on the mesh's edges and vertices.
fn targets(m: &TriangleMesh) -> Vec<Vec3> {
    let mut out = m.vertices.clone();
    for tri in &m.triangles {
        for k in 0..3 {
            let (a, b) = (
                m.vertices[tri[k] as usize],
                m.vertices[tri[(k + 1) % 3] as usize],
            );
            for s in [0.5f32, 0.25, 1.0 / 3.0] {
                out.push(a + (b - a) * s);
            }
        }
    }
    out
}

fn check(m: &TriangleMesh, origins: impl Fn(Vec3, usize) -> Vec<Vec3>) {
    let structures: Vec<(AccelKind, Accel)> = AccelKind::ALL
        .iter()
        .map(|&k| (k, Accel::build(k, m)))
        .collect();
    for (i, target) in targets(m).into_iter().enumerate() {
        for o in origins(target, i) {
            // The target lies on the surface at t = 1 (up to rounding of the
            // direction); past it the ray is inside the closed mesh, so a hit
            // by t = 1.001 is certain.
            let r = Ray::new(o, target - o, 0.0, 1.001);
            let mut want = None;
            for (k, a) in &structures {
                let mut best: Option<f32> = None;
                a.closest(&r, &mut NoCounters, |p, ray| {
                    let t = m.intersect(p as usize, ray)?.t;
                    best = Some(best.map_or(t, |b: f32| b.min(t)));
                    Some(t)
                });
                assert!(best.is_some(), "{k}: ray from {o} to {target} escaped");
                assert!(a.occluded(&r, &mut NoCounters, |p, ray| m
                    .intersect(p as usize, ray)
                    .is_some()));
                if *k == AccelKind::List {
                    want = best;
                } else {
                    assert_eq!(best, want, "{k}: ray from {o} to {target}");
                }
            }
        }
    }
}

#[test]
fn icosphere_edges_and_vertices_are_sealed() {
    let m = icosphere(3);
    assert_eq!(m.triangles.len(), 1280);
    check(&m, |target, i| {
        // From outside, along the normal and from skewed directions. The
        // skew stays small enough that the origin is in front of every face
        // around the target: from behind one of them the ray would only
        // graze the surface, and a miss would be right.
        let f = i as f32;
        let skew = Vec3::new((f * 0.7).sin(), (f * 1.3).cos(), (f * 2.1).sin()) * 0.28;
        vec![target * 3.0, target * 3.0 + skew]
    });
}

#[test]
fn cube_edges_and_vertices_are_sealed() {
    let m = cube(4);
    check(&m, |target, i| {
        // Axis-parallel rays straight at a face (exactly along the shared
        // edges' planes), and skewed ones.
        let mut out = Vec::new();
        for a in 0..3 {
            if target[a].abs() == 1.0 {
                let mut o = target;
                o[a] *= 4.0;
                out.push(o);
            }
        }
        let f = i as f32;
        out.push(target * 2.5 + Vec3::new((f * 0.37).sin(), (f * 0.53).cos(), 0.3) * 0.5);
        out
    });
}
