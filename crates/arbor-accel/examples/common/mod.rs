//! What the measuring tools (the examples and the criterion bench) share:
//! a synthetic torus, a bare `.msh` reader and deterministic rays. Not loaders: no error
//! handling, a bad file panics.
// Each tool uses only some of these.
#![allow(dead_code)]

use arbor_accel::{Aabb, Ray, TriangleMesh, Vec3};

/// The vertices and triangles of a Cornell `.msh` text.
pub fn parse_msh(text: &str) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut tok = text.split_whitespace();
    let np: usize = tok.next().unwrap().parse().unwrap();
    let nt: usize = tok.next().unwrap().parse().unwrap();
    assert_eq!(tok.next(), Some("vertices"));
    let mut num = || tok.next().unwrap().parse::<f32>().unwrap();
    let vertices = (0..np).map(|_| Vec3::new(num(), num(), num())).collect();
    assert_eq!(tok.next(), Some("triangles"));
    let mut idx = || tok.next().unwrap().parse::<u32>().unwrap();
    let triangles = (0..nt).map(|_| [idx(), idx(), idx()]).collect();
    (vertices, triangles)
}

/// `n` deterministic rays (xorshift from `seed`) from a sphere around `b`
/// towards points inside it.
pub fn rays_into(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let (c, r) = (b.center(), b.extent().length());
    let mut s = seed;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize_or(Vec3::X);
            let o = c + d * r;
            let t = b.min + b.extent() * Vec3::new(rnd(), rnd(), rnd());
            Ray::new(o, t - o, 0.0, f32::INFINITY)
        })
        .collect()
}

/// A bumpy torus of about `tris` triangles.
pub fn torus(tris: usize) -> TriangleMesh {
    let m = ((tris / 2) as f64 / 3.0).sqrt().max(3.0) as usize;
    let (nu, nv) = (3 * m, m);
    let mut vertices = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let u = i as f32 / nu as f32 * std::f32::consts::TAU;
            let v = j as f32 / nv as f32 * std::f32::consts::TAU;
            let r = 0.3 + 0.02 * (13.0 * u).sin() * (7.0 * v).cos();
            vertices.push(Vec3::new(
                (1.0 + r * v.cos()) * u.cos(),
                (1.0 + r * v.cos()) * u.sin(),
                r * v.sin(),
            ));
        }
    }
    let idx = |i: usize, j: usize| ((j % nv) * nu + (i % nu)) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1));
            triangles.push([a, b, c]);
            triangles.push([b, d, c]);
        }
    }
    TriangleMesh::new(vertices, triangles)
}
