//! The `structures` section: each structure's nodes (or cells) for
//! drawing, its statistics and its cost heatmap.
//!
//! A tree's nodes are numbered for the page breadth-first from the root
//! down to a depth that keeps the page small, then the deeper nodes that
//! picks visit (breadth-first too), then the rest, which the page does not
//! get: its `nodes` list is exactly the drawn ones, `left_out` counts the
//! others.

use std::collections::HashSet;

use arbor::scene::Scene;
use arbor::tracer::Tracer;
use arbor_accel::{AccelKind, Accelerator, Layout, LayoutNode, RayCounts};
use rayon::prelude::*;
use serde_json::{json, Value};

use super::base64;
use super::traversal::{box_json, first_camera_ray};

/// Most tree nodes drawn per structure, whole levels at a time (nodes a
/// pick visits come on top).
const MAX_DRAWN_NODES: usize = 2000;

/// Most occupied grid cells listed.
const MAX_LISTED_CELLS: usize = 50_000;

/// One structure built over the scene, with its layout and page numbering.
pub struct View {
    /// Which structure.
    pub kind: AccelKind,
    /// The tracer built with it (both levels).
    pub tracer: Tracer,
    /// The top level's shape.
    pub layout: Layout,
    /// Layout indices breadth-first.
    breadth_first: Vec<u32>,
    /// Deepest level drawn whole.
    depth_cut: u32,
    /// Page number of each layout index.
    page_number: Vec<u32>,
    /// Layout index of each page number.
    layout_index: Vec<u32>,
    /// How many page numbers are drawn (a prefix).
    drawn: usize,
}

impl View {
    /// The view of `tracer`, built with `kind`, numbered with no node
    /// named by picks yet ([`View::renumber`]).
    pub fn new(kind: AccelKind, tracer: Tracer) -> View {
        let layout = tracer.accel().layout();
        let breadth_first = match &layout {
            Layout::Tree { nodes, .. } => breadth_first(nodes),
            _ => Vec::new(),
        };
        // Whole levels while they fit.
        let mut depth_cut = 0;
        if let Layout::Tree { nodes, .. } = &layout {
            for (count, &i) in breadth_first.iter().enumerate() {
                let d = nodes[i as usize].depth;
                if d > depth_cut {
                    if count >= MAX_DRAWN_NODES {
                        break;
                    }
                    depth_cut = d;
                }
            }
        }
        let mut view = View {
            kind,
            tracer,
            layout,
            breadth_first,
            depth_cut,
            page_number: Vec::new(),
            layout_index: Vec::new(),
            drawn: 0,
        };
        view.renumber(&HashSet::new());
        view
    }

    /// Numbers the nodes: those down to the depth cut, then `named`
    /// (layout indices that picks visit), then the rest.
    pub fn renumber(&mut self, named: &HashSet<u32>) {
        let Layout::Tree { nodes, .. } = &self.layout else {
            return;
        };
        let depth = |i: u32| nodes[i as usize].depth;
        let order = &self.breadth_first;
        let mut index: Vec<u32> = order
            .iter()
            .copied()
            .filter(|&i| depth(i) <= self.depth_cut)
            .collect();
        index.extend(
            order
                .iter()
                .filter(|&&i| depth(i) > self.depth_cut && named.contains(&i)),
        );
        self.drawn = index.len();
        index.extend(
            order
                .iter()
                .filter(|&&i| depth(i) > self.depth_cut && !named.contains(&i)),
        );
        let mut number = vec![0; index.len()];
        for (page, &i) in index.iter().enumerate() {
            number[i as usize] = page as u32;
        }
        self.page_number = number;
        self.layout_index = index;
    }

    /// The page's number of layout index `index` (a grid cell keeps its
    /// index).
    pub fn number(&self, index: u32) -> u32 {
        self.page_number
            .get(index as usize)
            .copied()
            .unwrap_or(index)
    }
}

/// Node indices in breadth-first order from the root.
fn breadth_first(nodes: &[LayoutNode]) -> Vec<u32> {
    let mut order = Vec::with_capacity(nodes.len());
    if !nodes.is_empty() {
        order.push(0u32);
    }
    let mut i = 0;
    while i < order.len() {
        order.extend_from_slice(&nodes[order[i] as usize].children);
        i += 1;
    }
    order
}

/// The family a structure is drawn as.
fn family(kind: AccelKind) -> &'static str {
    match kind {
        AccelKind::List => "list",
        AccelKind::Grid => "grid",
        AccelKind::KdTree => "kdtree",
        _ => "bvh",
    }
}

/// The structure object of `view`; `heatmap` is its heatmap object.
pub fn structure_json(view: &View, heatmap: Value, notes: &mut Vec<String>) -> Value {
    let s = view.tracer.accel().stats();
    let mut o = json!({
        "accel": view.kind.name(),
        "family": family(view.kind),
        "stats": { "nodes": s.nodes, "leaves": s.leaves, "max_depth": s.max_depth,
                   "memory_bytes": s.memory_bytes },
        "heatmap": heatmap,
    });
    let name = view.kind.name();
    match &view.layout {
        Layout::List => {
            o["nodes"] = json!([]);
            o["left_out"] = json!(0);
        }
        Layout::Tree { nodes, .. } => {
            let list: Vec<Value> = view.layout_index[..view.drawn]
                .iter()
                .map(|&i| node_json(view, &nodes[i as usize]))
                .collect();
            let left_out = nodes.len() - list.len();
            if left_out > 0 {
                notes.push(format!(
                    "{name}: {} of {} nodes drawn (down to depth {}, and every node a pick visits)",
                    list.len(),
                    nodes.len(),
                    view.depth_cut
                ));
            }
            o["nodes"] = json!(list);
            o["depth_drawn"] = json!(view.depth_cut);
            o["left_out"] = json!(left_out);
        }
        Layout::Grid(g) => {
            let listed = g.occupied.len().min(MAX_LISTED_CELLS);
            if listed < g.occupied.len() {
                notes.push(format!(
                    "{name}: {listed} of {} occupied cells listed",
                    g.occupied.len()
                ));
            }
            o["origin"] = json!(g.bounds.min.to_array());
            o["cell_size"] = json!(g.cell_size().to_array());
            o["resolution"] = json!(g.resolution);
            o["occupied"] = json!(g.occupied[..listed]);
            o["left_out"] = json!(g.occupied.len() - listed);
        }
    }
    o
}

/// One tree node for the page.
fn node_json(view: &View, n: &LayoutNode) -> Value {
    let children: Vec<u32> = n.children.iter().map(|&c| view.number(c)).collect();
    let mut o = json!({
        "box": box_json(&n.bounds), "depth": n.depth,
        "children": children, "primitives": n.primitives,
    });
    if view.kind == AccelKind::KdTree {
        o["axis"] = n.split.map_or(Value::Null, |(a, _)| json!(a));
        o["split"] = n.split.map_or(Value::Null, |(_, s)| json!(s));
    }
    o
}

/// The heatmap object: nodes and tests of every pixel's first camera ray
/// (both levels, as `--heatmap` counts them), row by row from the top.
pub fn heatmap_json(scene: &Scene, view: &View, progress: &(dyn Fn(u64) + Sync)) -> Value {
    let (w, h) = (scene.width, scene.height);
    let counts: Vec<RayCounts> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let row: Vec<RayCounts> = (0..w)
                .map(|x| {
                    let mut c = RayCounts::default();
                    view.tracer
                        .closest_counted(&first_camera_ray(scene, x, y), &mut c);
                    c
                })
                .collect();
            progress(u64::from(w));
            row
        })
        .collect();
    let nodes: Vec<u32> = counts.iter().map(|c| c.nodes as u32).collect();
    let tests: Vec<u32> = counts.iter().map(|c| c.tests as u32).collect();
    let max_nodes = nodes.iter().max().copied().unwrap_or(0);
    let max_tests = tests.iter().max().copied().unwrap_or(0);
    let (element, size) = base64::element_for(max_nodes.max(max_tests));
    json!({
        "element": element,
        "nodes_base64": base64::encode_narrow(&nodes, size),
        "tests_base64": base64::encode_narrow(&tests, size),
        "max_nodes": max_nodes,
        "max_tests": max_tests,
    })
}
