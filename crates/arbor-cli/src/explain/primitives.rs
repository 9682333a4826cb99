//! The `primitives` section: the flattened scene's primitives for drawing
//! (triangles, plain spheres, anything else as its box), numbered as the
//! top level numbers them (world primitives, then one per placement),
//! decimated above a cap.

use arbor::flatten::{FlatGeometry, FlattenedScene};
use glam::{DAffine3, DVec3};
use serde_json::{json, Value};

/// Most triangles drawn; above it every k-th is kept.
const MAX_TRIANGLES: usize = 12_000;

/// One drawable piece.
enum Piece {
    Triangle([DVec3; 3]),
    Sphere(DVec3, f64),
    Box(DVec3, DVec3),
}

/// Primitive `i` of `scene` under `m` (the identity for world geometry).
fn piece(scene: &FlatGeometry, i: usize, m: &DAffine3) -> Piece {
    if let Some(p) = scene.triangle_corners(i) {
        return Piece::Triangle(p.map(|q| m.transform_point3(q)));
    }
    if let (Some((c, r)), true) = (scene.plain_sphere(i), *m == DAffine3::IDENTITY) {
        return Piece::Sphere(c, r);
    }
    let (lo, hi) = scene.bounds(i);
    if *m == DAffine3::IDENTITY {
        return Piece::Box(lo, hi);
    }
    // The box of the transformed box's corners.
    let corners = (0..8).map(|k| {
        let pick = |bit: usize, a: f64, b: f64| if k >> bit & 1 == 0 { a } else { b };
        m.transform_point3(DVec3::new(
            pick(0, lo.x, hi.x),
            pick(1, lo.y, hi.y),
            pick(2, lo.z, hi.z),
        ))
    });
    let (a, b) = corners.fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(a, b), p| (a.min(p), b.max(p)),
    );
    Piece::Box(a, b)
}

/// `v` as `f32`s (all the page can draw, and shorter JSON).
fn f32s(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The `primitives` object of `flat`.
pub fn primitives_json(flat: &FlattenedScene, notes: &mut Vec<String>) -> Value {
    let world = flat.world.len();
    // (top-level number, scene, index, placement matrix)
    let mut all: Vec<(usize, &FlatGeometry, usize, DAffine3)> = (0..world)
        .map(|i| (i, &flat.world, i, DAffine3::IDENTITY))
        .collect();
    for (p, placement) in flat.placements.iter().enumerate() {
        let geometry = &flat.shared[placement.geometry as usize];
        let m = placement.inverse.inverse();
        all.extend((0..geometry.len()).map(|i| (world + p, geometry, i, m)));
    }
    let triangles_total = all
        .iter()
        .filter(|(_, s, i, _)| s.triangle_corners(*i).is_some())
        .count();
    let keep_every = triangles_total.div_ceil(MAX_TRIANGLES).max(1);
    let (mut triangles, mut ids, mut spheres, mut other) = (vec![], vec![], vec![], vec![]);
    let (mut seen, mut left_out) = (0usize, 0usize);
    for (number, scene, i, m) in all {
        match piece(scene, i, &m) {
            Piece::Triangle(p) => {
                seen += 1;
                if (seen - 1) % keep_every != 0 {
                    left_out += 1;
                    continue;
                }
                triangles.extend(p.iter().flat_map(|&q| f32s(q)));
                ids.push(number);
            }
            Piece::Sphere(c, r) => {
                let c = f32s(c);
                spheres.push(json!([c[0], c[1], c[2], r as f32, number]))
            }
            Piece::Box(a, b) => {
                other.push(json!({ "primitive": number, "box": [f32s(a), f32s(b)] }))
            }
        }
    }
    if left_out > 0 {
        notes.push(format!(
            "primitives: every {keep_every}th of {triangles_total} triangles drawn ({left_out} left out)"
        ));
    }
    json!({
        "total": world + flat.placements.len(),
        "placed": all_placed(flat),
        "left_out": left_out,
        "triangles": triangles,
        "triangle_ids": ids,
        "spheres": spheres,
        "other": other,
    })
}

/// Primitives as placed (each placement's geometry counted per placement).
fn all_placed(flat: &FlattenedScene) -> u64 {
    flat.instanced_primitives()
}
