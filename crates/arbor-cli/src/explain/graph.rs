//! The `scene_graph` section: the loaded scene before flattening (groups,
//! their transforms, instances pointing at shared definitions drawn once)
//! and what flattening made of it.

use std::collections::HashMap;
use std::sync::Arc;

use arbor::flatten::FlattenedScene;
use arbor::scene::Scene;
use arbor::surface::Surface;
use glam::DMat4;
use serde_json::{json, Value};

/// Most graph nodes written; a larger graph is cut (and says so).
const MAX_GRAPH_NODES: usize = 2000;

/// The graph under construction.
struct Graph {
    nodes: Vec<Value>,
    /// Definition node of each shared surface, by its address.
    definitions: HashMap<usize, usize>,
    /// Instance node of each reference, by the address of its
    /// `Surface::Instance` (each is drawn once: a definition's insides
    /// are drawn once however often it is placed).
    instances: HashMap<usize, usize>,
    left_out: usize,
}

/// The scene graph's nodes, and which node drew each shared surface and
/// each reference (by address, as [`arbor::nested::Sources`] names them).
pub struct GraphNodes {
    /// `root`, `nodes` and `left_out` of the `scene_graph` object.
    pub value: Value,
    /// The root node (the scene).
    pub root: usize,
    /// Definition node of each shared surface drawn.
    pub definitions: HashMap<usize, usize>,
    /// Instance node of each reference drawn.
    pub instances: HashMap<usize, usize>,
}

impl Graph {
    /// Adds a node; its children are filled in afterwards.
    fn push(&mut self, kind: &str, label: String, transform: Value) -> Option<usize> {
        if self.nodes.len() >= MAX_GRAPH_NODES {
            self.left_out += 1;
            return None;
        }
        let id = self.nodes.len();
        self.nodes.push(json!({
            "id": id, "kind": kind, "label": label,
            "transform": transform, "children": [],
        }));
        Some(id)
    }

    fn add_child(&mut self, parent: usize, child: usize) {
        if let Some(list) = self.nodes[parent]["children"].as_array_mut() {
            list.push(json!(child));
        }
    }

    /// The node of `s` (and everything below it), if it fit.
    fn surface(&mut self, s: &Surface) -> Option<usize> {
        match s {
            Surface::Group(g) => {
                let (kind, transform) = if g.transform == DMat4::IDENTITY {
                    ("group", Value::Null)
                } else {
                    ("transform", rows(&g.transform))
                };
                let label = format!("group of {}", g.children.len());
                let id = self.push(kind, label, transform)?;
                for c in &g.children {
                    if let Some(k) = self.surface(c) {
                        self.add_child(id, k);
                    }
                }
                Some(id)
            }
            Surface::Instance(inner) => {
                let id = self.push("instance", "instance".into(), Value::Null)?;
                self.instances.insert(s as *const Surface as usize, id);
                let key = Arc::as_ptr(inner) as usize;
                let def = match self.definitions.get(&key) {
                    Some(&d) => Some(d),
                    None => {
                        let n = self.definitions.len() + 1;
                        let d = self.push("definition", format!("definition #{n}"), Value::Null);
                        if let Some(d) = d {
                            self.definitions.insert(key, d);
                            if let Some(k) = self.surface(inner) {
                                self.add_child(d, k);
                            }
                        }
                        d
                    }
                };
                if let Some(d) = def {
                    self.add_child(id, d);
                }
                Some(id)
            }
            leaf => self.push("surface", leaf_label(leaf), Value::Null),
        }
    }
}

/// A leaf surface in a few words.
fn leaf_label(s: &Surface) -> String {
    match s {
        Surface::Sphere(x) => format!("sphere r={}", x.radius),
        Surface::Box(_) => "box".into(),
        Surface::Cylinder(c) => format!("cylinder r={} h={}", c.radius, c.height),
        Surface::Mesh(m) => format!(
            "mesh of {}",
            crate::render::plural(m.data.triangles.len() as u64, "triangle", "triangles")
        ),
        Surface::Group(_) | Surface::Instance(_) => unreachable!("not a leaf"),
    }
}

/// The top three rows of an affine matrix, row by row.
fn rows(m: &DMat4) -> Value {
    let r = |i: usize| json!([m.col(0)[i], m.col(1)[i], m.col(2)[i], m.col(3)[i]]);
    json!([r(0), r(1), r(2)])
}

/// The nodes of `scene`'s graph (the DAG: each shared definition drawn
/// once); notes what was cut.
pub fn graph_nodes(scene: &Scene, notes: &mut Vec<String>) -> GraphNodes {
    let mut g = Graph {
        nodes: Vec::new(),
        definitions: HashMap::new(),
        instances: HashMap::new(),
        left_out: 0,
    };
    let root = g
        .push("group", "scene".into(), Value::Null)
        .expect("the first node fits");
    for s in &scene.surfaces {
        if let Some(k) = g.surface(s) {
            g.add_child(root, k);
        }
    }
    if g.left_out > 0 {
        notes.push(format!(
            "scene graph: {} of {} nodes shown",
            g.nodes.len(),
            g.nodes.len() + g.left_out
        ));
    }
    let mut value = json!({ "root": root, "nodes": g.nodes, "left_out": g.left_out });
    if let Some(counts) = counts_json(scene) {
        value["counts"] = counts;
    }
    GraphNodes {
        value,
        root,
        definitions: g.definitions,
        instances: g.instances,
    }
}

/// The scene's placements and primitives as placed, counted over the DAG
/// (as `arbor info` counts them), as decimal strings: they can pass 64
/// bits. `None` when the census refuses the scene.
fn counts_json(scene: &Scene) -> Option<Value> {
    let c = arbor::census::Census::new(&scene.surfaces, scene.variant).ok()?;
    Some(json!({
        "placements": c.placements.to_string(),
        "primitives": c.placed_primitives.to_string(),
        "unique_primitives": c.unique_primitives.to_string(),
    }))
}

/// The `scene_graph` object of `scene`, which flattened into `flat`; notes
/// what was cut.
pub fn scene_graph(scene: &Scene, flat: &FlattenedScene, notes: &mut Vec<String>) -> Value {
    let mut value = graph_nodes(scene, notes).value;
    let mut placements = vec![0u64; flat.shared.len()];
    for p in &flat.placements {
        placements[p.geometry as usize] += 1;
    }
    let shared: Vec<Value> = flat
        .shared
        .iter()
        .zip(&placements)
        .enumerate()
        .map(|(i, (s, &k))| {
            json!({
                "geometry": i,
                "label": format!("shared geometry {i}: {}", crate::render::plural(s.len() as u64, "primitive", "primitives")),
                "primitives": s.len(),
                "placements": k,
            })
        })
        .collect();
    let mut summary = vec![format!(
        "{} baked into world space",
        crate::render::plural(flat.world.len() as u64, "primitive", "primitives")
    )];
    if !flat.shared.is_empty() {
        summary.push(format!(
            "{} kept shared, placed {} in all ({} primitives as placed)",
            crate::render::plural(flat.shared.len() as u64, "geometry", "geometries"),
            crate::render::plural(flat.placements.len() as u64, "time", "times"),
            flat.instanced_primitives()
        ));
    }
    value["flattening"] =
        json!({ "baked": flat.world.len(), "shared": shared, "summary": summary });
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shared_definition_is_drawn_once_with_an_arrow_per_instance() {
        let scene = arbor::default_scene::classroom();
        let flat = FlattenedScene::new(&scene, 1 << 20).unwrap();
        let mut notes = Vec::new();
        let v = scene_graph(&scene, &flat, &mut notes);
        let nodes = v["nodes"].as_array().unwrap();
        let defs: Vec<usize> = nodes
            .iter()
            .filter(|n| n["kind"] == "definition")
            .map(|n| n["id"].as_u64().unwrap() as usize)
            .collect();
        assert!(!defs.is_empty(), "the classroom instances its desks");
        for d in defs {
            let arrows = nodes
                .iter()
                .filter(|n| n["children"].as_array().unwrap().contains(&json!(d)))
                .count();
            assert!(arrows > 1, "definition {d} has {arrows} instance(s)");
        }
        let placed: u64 = v["flattening"]["shared"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["placements"].as_u64().unwrap())
            .sum();
        assert_eq!(placed, flat.placements.len() as u64);
    }
}
