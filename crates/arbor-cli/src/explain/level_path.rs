//! One camera ray's way through the nested levels, as docs/explain-data.md
//! writes it (`nested` of a ray's traversal): every level it reached, at
//! each depth, through which child placement, where it entered that
//! level's box or that it was culled; the levels on the path to the hit
//! marked; and the hit.

use arbor::nested::{LevelReached, NestedRecord};
use arbor::ray::Ray;
use arbor::scene::Scene;
use arbor::tracer::Tracer;
use serde_json::{json, Value};

use super::levels::Names;
use super::traversal::first_camera_ray;

/// Most levels listed per ray besides those on the path to the hit (a ray
/// grazing a deep field reaches thousands); `left_out` counts the rest.
const MAX_LISTED_LEVELS: usize = 100;

/// The traversal of pixel `(x, y)`'s first camera ray through the nested
/// levels of `tracer`: the object of docs/explain-data.md ("One ray's
/// traversal", a nested plan).
pub fn pixel_path(scene: &Scene, tracer: &Tracer, names: &Names, (x, y): (u32, u32)) -> Value {
    let ray = first_camera_ray(scene, x, y);
    json!({
        "pixel": [x, y],
        "ray": { "origin": ray.origin.to_array(), "direction": ray.direction.to_array() },
        "structures": [],
        "nested": ray_path(tracer, names, &ray),
    })
}

/// `ray`'s recorded way through the levels, as JSON.
fn ray_path(tracer: &Tracer, names: &Names, ray: &Ray) -> Value {
    let mut rec = NestedRecord::default();
    let hit = tracer.closest_counted(ray, &mut rec);
    let hit_path = rec.hit().map_or(&[][..], |h| &h.path[..]);
    let on_path = |l: &LevelReached| hit.is_some() && hit_path.starts_with(&l.path);
    let mut listed = 0;
    let mut left_out = 0;
    let mut levels = Vec::new();
    for l in &rec.levels {
        let marked = on_path(l);
        if !marked && listed >= MAX_LISTED_LEVELS {
            left_out += 1;
            continue;
        }
        listed += usize::from(!marked);
        levels.push(level_json(names, l, marked));
    }
    let hit = hit.map_or(Value::Null, |h| {
        let chain = names.walk(hit_path);
        json!({
            "t": h.t,
            "point": h.point.to_array(),
            "path": hit_path,
            "definitions": chain.iter().map(|s| s.definition).collect::<Vec<_>>(),
            "graph_nodes": chain.iter().map(|s| names.step_node(s)).collect::<Vec<_>>(),
        })
    });
    json!({
        "accel": tracer.kind().name(),
        "levels": levels,
        "left_out": left_out,
        "hit": hit,
        "entered": rec.entered,
        "counts": { "nodes": rec.counts.nodes, "tests": rec.counts.tests },
    })
}

/// One level reached, as JSON.
fn level_json(names: &Names, l: &LevelReached, on_hit_path: bool) -> Value {
    let last = names.walk(&l.path).last().copied();
    let node = last.map_or(names.root_node(), |s| names.step_node(&s));
    json!({
        "depth": l.path.len(),
        "path": l.path,
        "definition": l.definition,
        "geometry": l.geometry,
        "parent": last.map(|s| s.parent),
        "child": last.and_then(|s| s.child),
        "graph_node": node,
        "t": l.t,
        "culled": l.t.is_none(),
        "on_hit_path": on_hit_path,
    })
}
