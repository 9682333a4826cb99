//! The bounding volumes of `--bvol` (the lecture's bounded surfaces), as
//! the page draws them: the very volumes the tracer tests.

use arbor::tracer::{FittedVolume, Tracer};
use serde_json::{json, Value};

use super::traversal::box_json;

/// One object per bounding volume: its kind, the top-level primitive of the
/// object it gates (`world` primitives come first, then the placements) and
/// its shape in world space.
pub fn bounding_volumes_json(tracer: &Tracer, world: usize) -> Vec<Value> {
    tracer
        .bounding_volumes()
        .map(|(placement, volume)| {
            let surface = world + placement;
            match volume {
                FittedVolume::Sphere(s) => json!({
                    "kind": "sphere", "surface": surface,
                    "center": s.center.to_array(), "radius": s.radius,
                }),
                FittedVolume::Aabb(b) => json!({
                    "kind": "aabb", "surface": surface, "box": box_json(b),
                }),
                FittedVolume::Obb(o) => json!({
                    "kind": "obb", "surface": surface,
                    "center": o.center.to_array(),
                    "axes": o.axes.map(|a| a.to_array()),
                    "half": o.half.to_array(),
                }),
            }
        })
        .collect()
}
