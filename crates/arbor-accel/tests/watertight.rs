//! Rays aimed exactly at the shared edges and vertices of closed meshes never
//! slip through, whichever structure finds the candidates.

mod common;

use arbor_accel::{Accel, AccelKind, Accelerator, NoCounters, Ray, TriangleMesh, Vec3};
use common::icosphere;

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
                    let t = m.intersect(p, ray)?.t;
                    best = Some(best.map_or(t, |b: f32| b.min(t)));
                    Some(t)
                });
                assert!(best.is_some(), "{k}: ray from {o} to {target} escaped");
                assert!(a.occluded(&r, &mut NoCounters, |p, ray| m.intersect(p, ray).is_some()));
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
