//! One camera ray's traversal of each structure, as docs/explain-data.md
//! writes it: the `--ray X,Y --json FILE` output, and the page's picks.

use std::collections::HashMap;

use arbor::ray::Ray;
use arbor::scene::Scene;
use arbor::traversal::TraversalRecord;
use arbor_accel::{Aabb, Layout, Recorder};
use serde_json::{json, Value};

use super::structures::View;

/// A box as `[[min], [max]]`.
pub fn box_json(b: &Aabb) -> Value {
    json!([b.min.to_array(), b.max.to_array()])
}

/// The first camera ray of pixel `(x, y)` (row 0 at the top), as the
/// renderer and `--heatmap` cast it.
pub fn first_camera_ray(scene: &Scene, x: u32, y: u32) -> Ray {
    let camera = scene.camera.prepare();
    arbor::render::camera_ray(scene, &camera, x, y, 0, 0)
}

/// Layouts of the bottom-level structures, built on first use (keyed by
/// the structure's address: placements of one geometry share it).
#[derive(Default)]
pub struct InnerLayouts(HashMap<usize, Layout>);

/// The visits of `rec` as JSON: node numbers through `number` (the page's
/// numbering), boxes from `layout` when `boxes`.
fn visits_json(
    rec: &Recorder,
    layout: &Layout,
    number: impl Fn(u32) -> u32,
    boxes: bool,
) -> Vec<Value> {
    rec.visits
        .iter()
        .map(|v| {
            let index = layout.index(v.node);
            let mut o = json!({ "node": number(index), "entered": v.entered });
            if boxes {
                o["box"] = layout.bounds(index).map_or(Value::Null, |b| box_json(&b));
            }
            o
        })
        .collect()
}

/// One structure's traversal of `ray`: the object
/// of docs/explain-data.md ("One ray's traversal"), with each visit's box
/// when `boxes`.
pub fn structure_traversal(view: &View, inner: &mut InnerLayouts, ray: &Ray, boxes: bool) -> Value {
    let mut rec = TraversalRecord::default();
    let hit = view.tracer.closest_identified(ray, &mut rec);
    let counts = rec.counts();
    let placements: Vec<Value> = rec
        .placements
        .iter()
        .map(|p| {
            let accel = view.tracer.placement_accel(p.placement);
            let layout = inner
                .0
                .entry(accel as *const _ as usize)
                .or_insert_with(|| accel.layout());
            json!({
                "placement": p.placement,
                "visits": visits_json(&p.record, layout, |i| i, boxes),
                "tests": p.record.tests,
            })
        })
        .collect();
    let hit = hit.map_or(Value::Null, |(id, h)| {
        let mut o = json!({ "t": h.t, "primitive": id.primitive });
        if let Some((placement, prim)) = id.shared {
            o["placement"] = json!(placement);
            o["shared_primitive"] = json!(prim);
        }
        o
    });
    json!({
        "accel": view.kind.name(),
        "visits": visits_json(&rec.top, &view.layout, |i| view.number(i), boxes),
        "tests": rec.top.tests,
        "placements": placements,
        "hit": hit,
        "counts": { "nodes": counts.nodes, "tests": counts.tests },
    })
}

/// The layout indices of the top-level nodes `ray` visits or skips in `view`.
pub fn top_level_nodes(view: &View, ray: &Ray) -> Vec<u32> {
    let mut rec = TraversalRecord::default();
    view.tracer.closest_counted(ray, &mut rec);
    rec.top
        .visits
        .iter()
        .map(|v| view.layout.index(v.node))
        .collect()
}

/// The traversal of pixel `(x, y)`'s first camera ray through every view.
pub fn pixel_traversal(
    scene: &Scene,
    views: &[View],
    inner: &mut InnerLayouts,
    (x, y): (u32, u32),
    boxes: bool,
) -> Value {
    let ray = first_camera_ray(scene, x, y);
    let structures: Vec<Value> = views
        .iter()
        .map(|v| structure_traversal(v, inner, &ray, boxes))
        .collect();
    json!({
        "pixel": [x, y],
        "ray": { "origin": ray.origin.to_array(), "direction": ray.direction.to_array() },
        "structures": structures,
    })
}
