//! `arbor explain` on a nested plan: the scene traced as a DAG, never
//! flattened. The page shows the picture the nested tracer renders, the
//! scene graph with its exact counts as placed, the nested levels (one per
//! definition, built once) and each pick ray's way through them
//! ([`super::level_path`]); the flat page's primitives, bounding volumes,
//! per-node structure views and heatmaps have no nested meaning and are
//! left out (a `notes` line says so).

use arbor::nested::{DefinitionSummary, NestedTracer};
use arbor::render::RenderOptions;
use arbor::scene::Scene;
use arbor::tracer::Tracer;
use arbor_accel::AccelStats;
use glam::DVec3;
use serde_json::{json, Value};

use super::graph::{graph_nodes, GraphNodes};
use super::level_path::pixel_path;
use super::{picks, ExplainArgs, Outputs};
use crate::InputError;

/// One item taken on a ray's way down: from which definition's level,
/// which child placement (or that definition's own geometry), into which
/// definition.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    /// The definition whose level offered the item.
    pub parent: u32,
    /// The child placement taken (`None`: the parent's own geometry).
    pub child: Option<usize>,
    /// The definition reached.
    pub definition: u32,
}

/// The levels' shape and the scene graph's nodes behind them: which node
/// each definition and each child placement was drawn as.
pub struct Names {
    root: u32,
    root_node: usize,
    /// Per definition: its graph node (`None`: not drawn, or not traced
    /// back to the scene).
    definition_nodes: Vec<Option<usize>>,
    /// Per definition: the item number of its first child.
    first_child: Vec<u32>,
    /// Per definition, per child: the definition it places.
    child_definitions: Vec<Vec<u32>>,
    /// Per definition, per child: the instance node of its reference.
    child_nodes: Vec<Vec<Option<usize>>>,
}

impl Names {
    /// The names of `nested`'s levels, built from `scene`, in `graph`;
    /// notes when the levels could not be traced back to the scene.
    fn new(
        nested: &NestedTracer,
        scene: &Scene,
        graph: &GraphNodes,
        notes: &mut Vec<String>,
    ) -> Names {
        let n = nested.definitions();
        let sources = nested.sources(scene);
        if sources.is_none() {
            notes.push(
                "nested levels: not traced back to the scene graph (no graph nodes named)".into(),
            );
        }
        let summaries: Vec<DefinitionSummary> = (0..n as u32).map(|d| nested.summary(d)).collect();
        let mut definition_nodes = vec![None; n];
        let mut child_nodes: Vec<Vec<Option<usize>>> = summaries
            .iter()
            .map(|s| vec![None; s.children.len()])
            .collect();
        if let Some(src) = &sources {
            for (d, key) in src.definitions.iter().enumerate() {
                definition_nodes[d] = key.and_then(|k| graph.definitions.get(&k).copied());
            }
            for (d, refs) in src.children.iter().enumerate() {
                for (k, at) in refs.iter().enumerate() {
                    child_nodes[d][k] = graph.instances.get(at).copied();
                }
            }
        }
        definition_nodes[nested.root() as usize] = Some(graph.root);
        Names {
            root: nested.root(),
            root_node: graph.root,
            definition_nodes,
            first_child: summaries.iter().map(|s| s.first_child).collect(),
            child_definitions: summaries
                .iter()
                .map(|s| s.children.iter().map(|c| c.definition).collect())
                .collect(),
            child_nodes,
        }
    }

    /// The items of `path` (one per level from the world down) as steps.
    pub fn walk(&self, path: &[u32]) -> Vec<Step> {
        let mut d = self.root;
        let mut steps = Vec::with_capacity(path.len());
        for &item in path {
            let child = item.checked_sub(self.first_child[d as usize]);
            let step = Step {
                parent: d,
                child: child.map(|k| k as usize),
                definition: child.map_or(d, |k| self.child_definitions[d as usize][k as usize]),
            };
            d = step.definition;
            steps.push(step);
        }
        steps
    }

    /// The graph node of a step: the reference's instance node, or for a
    /// definition's own geometry that definition's node.
    pub fn step_node(&self, step: &Step) -> Option<usize> {
        match step.child {
            Some(k) => self.child_nodes[step.parent as usize][k],
            None => self.definition_nodes[step.definition as usize],
        }
    }

    /// The scene graph's root node (the world's level).
    pub fn root_node(&self) -> Option<usize> {
        Some(self.root_node)
    }
}

/// The outputs of a nested plan: `scene` built into nested levels of the
/// first `--accel` structure, each level flattening subtrees within
/// `flatten_budget` children (as `arbor render` builds it).
pub(super) fn outputs(
    args: &ExplainArgs,
    scene: &Scene,
    options: &RenderOptions,
    flatten_budget: u64,
    want_page: bool,
) -> anyhow::Result<Outputs> {
    let accel = args.accel.first().copied().unwrap_or(options.accel);
    let options = RenderOptions { accel, ..*options };
    let tracer = arbor::render::build_nested(scene, &options, flatten_budget)
        .map_err(|e| InputError(format!("{}: {e}", super::input_label(args))))?;
    let nested = tracer.nested().expect("built nested");
    let mut notes = Vec::new();
    let graph = graph_nodes(scene, &mut notes);
    let names = Names::new(nested, scene, &graph, &mut notes);
    let ray = args
        .ray
        .map(|pixel| pixel_path(scene, &tracer, &names, pixel));
    let page = want_page
        .then(|| document(args, scene, &tracer, graph, &names, notes))
        .transpose()?;
    Ok(Outputs { ray, page })
}

/// The page document of a nested plan (docs/explain-data.md).
fn document(
    args: &ExplainArgs,
    scene: &Scene,
    tracer: &Tracer,
    graph: GraphNodes,
    names: &Names,
    mut notes: Vec<String>,
) -> anyhow::Result<Value> {
    let nested = tracer.nested().expect("built nested");
    let (w, h) = (scene.width, scene.height);
    let bar = crate::render::progress_bar(u64::from(w) * u64::from(h), args.quiet);
    let picture = super::render_png(scene, tracer, &|n| bar.inc(n))?;
    bar.finish_and_clear();
    notes.push(format!(
        "nested instancing: {} built once each, traced level after level with {} at every level; the flattened primitives, bounding volumes, per-node structure views and cost heatmaps are left out (they belong to the flat tracer: see --instancing flat)",
        crate::render::plural(nested.definitions() as u64, "definition", "definitions"),
        tracer.kind().name()
    ));
    let mut trace = |pixel| pixel_path(scene, tracer, names, pixel);
    let picks = picks::traced_picks(picks::pick_pixels(scene), &mut trace, &mut notes);
    let mut scene_graph = graph.value;
    scene_graph["flattening"] = json!({ "summary": nesting_summary(nested) });
    Ok(json!({
        "format": "arbor-explain",
        "version": 1,
        "instancing": "nested",
        "input": super::input_label(args),
        "notes": notes,
        "image": { "width": w, "height": h, "png_base64": picture },
        "camera": super::camera_json(scene),
        "scene_graph": scene_graph,
        "structures": [],
        "nested": nested_json(tracer, nested, names),
        "picks": { "stride": picks.stride, "rays": picks.rays },
    }))
}

/// Lines saying what nesting made of the scene.
fn nesting_summary(nested: &NestedTracer) -> Vec<String> {
    vec![
        "nothing flattened: each shared definition is its own level, built once".to_string(),
        format!(
            "{} with {} in all, at most {} below the world",
            crate::render::plural(nested.definitions() as u64, "level", "levels"),
            crate::render::plural(
                nested.children() as u64,
                "child placement",
                "child placements"
            ),
            crate::render::plural(nested.depth() as u64, "level", "levels"),
        ),
    ]
}

/// The `nested` section: the levels, one per definition.
fn nested_json(tracer: &Tracer, nested: &NestedTracer, names: &Names) -> Value {
    let levels: Vec<Value> = (0..nested.definitions() as u32)
        .map(|d| level_json(nested, names, d))
        .collect();
    json!({
        "accel": tracer.kind().name(),
        "root": nested.root(),
        "depth": nested.depth(),
        "children": nested.children(),
        "memory_bytes": nested.accel_memory_bytes(),
        "levels": levels,
    })
}

/// One definition's level.
fn level_json(nested: &NestedTracer, names: &Names, d: u32) -> Value {
    let s = nested.summary(d);
    // The children grouped by what they place, in first-placed order.
    let mut places: Vec<(u32, bool, u64)> = Vec::new();
    for c in &s.children {
        match places
            .iter_mut()
            .find(|p| p.0 == c.definition && p.1 == c.geometry_only)
        {
            Some(p) => p.2 += 1,
            None => places.push((c.definition, c.geometry_only, 1)),
        }
    }
    let places: Vec<Value> = places
        .iter()
        .map(|&(definition, geometry_only, times)| {
            json!({ "definition": definition, "geometry_only": geometry_only, "times": times })
        })
        .collect();
    json!({
        "definition": d,
        "world": d == nested.root(),
        "graph_node": names.definition_nodes[d as usize],
        "children": s.children.len(),
        "first_child": s.first_child,
        "places": places,
        "primitives": s.primitives,
        "box": box_json(s.bounds),
        "geometry_box": box_json(s.geometry_bounds),
        "structure": stats_json(&s.stats),
        "geometry_structure": s.geometry_stats.as_ref().map(stats_json),
    })
}

/// A box as `[[min], [max]]`, `null` when empty.
fn box_json(b: Option<(DVec3, DVec3)>) -> Value {
    b.map_or(Value::Null, |(lo, hi)| {
        json!([lo.to_array(), hi.to_array()])
    })
}

/// A structure's statistics.
fn stats_json(s: &AccelStats) -> Value {
    json!({ "nodes": s.nodes, "leaves": s.leaves, "max_depth": s.max_depth, "memory_bytes": s.memory_bytes })
}
