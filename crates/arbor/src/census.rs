//! Counting a scene as placed without enumerating its placements.
//!
//! The surface graph is a DAG: an [`Surface::Instance`] refers to a shared
//! definition, which may hold instances in turn. Every count "as placed" is
//! a sum over definitions of (times the definition is placed) x (what it
//! holds itself), so it is computed with one visit per definition
//! (memoised by its `Arc` pointer), in time linear in the graph's size
//! however many copies the references multiply out to. Counts are `u128`
//! with checked arithmetic: ten levels of a hundred references to a
//! 10,000-triangle mesh already exceed 64 bits.
//!
//! The counts follow [`crate::flatten::FlattenedScene`]'s policy: a
//! placement is one placement of a definition placed more than once that
//! holds geometry of its own, and primitives are counted as flattening makes
//! them (a 2015 box is twelve triangles; primitives with non-finite
//! coordinates are dropped).

use std::sync::Arc;

use glam::{DMat4, DVec3};

use crate::hash_map::HashMap;
use crate::surface::Surface;
use crate::variant::Variant;

/// Deepest nesting accepted: groups and references along any path from a
/// top-level surface to a leaf. Deeper graphs are refused rather than
/// walked (the walk is recursive).
pub const MAX_DEPTH: usize = 2_000;

/// One step down the graph: the `index`-th (from 1) child surface of the
/// element above, and whether it is a `<surface ref>` (the steps after it
/// are inside the referenced definition).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Step {
    index: u32,
    reference: bool,
}

/// Where an element is: the path of child indices from the top-level
/// surfaces, through references into their definitions (the first path by
/// which the walk reached it, in document order).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Location(Vec<Step>);

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            return f.write_str("the top level");
        }
        // A long path is shown by its ends: where it starts, and the
        // element itself.
        let (head, tail) = (6, 6);
        let n = self.0.len();
        for (k, step) in self.0.iter().enumerate() {
            if n > head + tail + 1 && k >= head && k < n - tail {
                if k == head {
                    write!(f, " > ({} more)", n - head - tail)?;
                }
                continue;
            }
            let sep = if k == 0 { "" } else { " > " };
            let r = if step.reference { " (ref)" } else { "" };
            let what = if k == 0 {
                "top-level surface"
            } else {
                "surface"
            };
            write!(f, "{sep}{what} {}{r}", step.index)?;
        }
        Ok(())
    }
}

/// Why a scene cannot be counted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CensusError {
    /// A reference leads back to a definition that contains it.
    Cycle(Location),
    /// Groups and references nested deeper than [`MAX_DEPTH`].
    TooDeep(Location),
    /// A group's transform cannot be inverted (a zero scale).
    SingularTransform(Location),
    /// A count exceeds `u128::MAX`.
    Overflow {
        /// What was being counted.
        what: &'static str,
        /// The element whose count overflowed.
        at: Location,
    },
}

impl std::fmt::Display for CensusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CensusError::Cycle(at) => {
                write!(f, "{at}: the reference leads back to itself (a cycle)")
            }
            CensusError::TooDeep(at) => write!(
                f,
                "{at}: groups and references are nested more than {MAX_DEPTH} deep"
            ),
            CensusError::SingularTransform(at) => {
                write!(f, "{at}: the transform cannot be inverted (a zero scale)")
            }
            CensusError::Overflow { what, at } => write!(
                f,
                "{at}: the number of {what} exceeds 2^128 - 1 ({})",
                u128::MAX
            ),
        }
    }
}

impl std::error::Error for CensusError {}

/// One shared definition.
struct Def<'s> {
    surface: &'s Arc<Surface>,
    /// Times placed in all (the number of paths from the top to it).
    uses: u128,
    /// Primitives it holds itself (outside nested instances).
    direct: u64,
    /// Whether it holds any leaf itself (such a definition, placed more than
    /// once, is one placement per use).
    has_leaves: bool,
    /// Longest nesting inside it, itself included.
    height: usize,
    /// Longest chain of references inside it, itself included.
    refs: usize,
    /// The definitions it places, once per reference, in document order.
    children: Vec<usize>,
    /// The definition holding the reference that first reached it (`None`:
    /// the top level), and the path from there.
    parent: Option<usize>,
    local: Vec<Step>,
}

/// Marks a definition whose contents are being walked (to catch cycles).
const IN_PROGRESS: usize = usize::MAX;

/// The counts of a scene's surfaces as placed, computed over the DAG.
pub struct Census<'s> {
    roots: &'s [Surface],
    defs: Vec<Def<'s>>,
    index: HashMap<usize, usize>,
    meshes: HashMap<usize, u64>,
    variant: Variant,
    top_direct: u64,
    top_children: Vec<usize>,
    /// Placements of shared geometry (what flattening makes one transform each).
    pub placements: u128,
    /// Primitives stored once (the top level plus one copy of each definition).
    pub unique_primitives: u128,
    /// Primitives as placed (every placement's primitives).
    pub placed_primitives: u128,
}

fn key(shared: &Arc<Surface>) -> usize {
    Arc::as_ptr(shared) as usize
}

impl<'s> Census<'s> {
    /// Counts the top-level `surfaces` of a scene of `variant`.
    pub fn new(surfaces: &'s [Surface], variant: Variant) -> Result<Census<'s>, CensusError> {
        let mut census = Census {
            roots: surfaces,
            defs: Vec::new(),
            index: HashMap::default(),
            meshes: HashMap::default(),
            variant,
            top_direct: 0,
            top_children: Vec::new(),
            placements: 0,
            unique_primitives: 0,
            placed_primitives: 0,
        };
        let mut order = Vec::new();
        let mut contents = Contents::default();
        let mut path = Vec::new();
        for (i, s) in surfaces.iter().enumerate() {
            path.push(step(i, s));
            census.scan(s, None, &mut path, 1, &mut contents, &mut order)?;
            path.pop();
        }
        census.top_direct = contents.direct;
        census.top_children = contents.children;
        census.count(&order)?;
        Ok(census)
    }

    /// The top-level surfaces counted.
    pub fn roots(&self) -> &'s [Surface] {
        self.roots
    }

    /// The location of `local` inside definition `owner` (`None`: the top).
    fn location(&self, mut owner: Option<usize>, local: &[Step]) -> Location {
        let mut parts = vec![local.to_vec()];
        while let Some(d) = owner {
            parts.push(self.defs[d].local.clone());
            owner = self.defs[d].parent;
        }
        Location(parts.into_iter().rev().flatten().collect())
    }

    /// Walks `s` (at nesting `depth`, reached by `path` inside `owner`),
    /// adding what it holds to `contents`; returns its height.
    fn scan(
        &mut self,
        s: &'s Surface,
        owner: Option<usize>,
        path: &mut Vec<Step>,
        depth: usize,
        contents: &mut Contents,
        order: &mut Vec<usize>,
    ) -> Result<usize, CensusError> {
        if depth > MAX_DEPTH {
            return Err(CensusError::TooDeep(self.location(owner, path)));
        }
        match s {
            Surface::Group(g) => {
                if g.transform.determinant() == 0.0 || !g.transform.inverse().is_finite() {
                    return Err(CensusError::SingularTransform(self.location(owner, path)));
                }
                let mut height = 0;
                for (i, c) in g.children.iter().enumerate() {
                    path.push(step(i, c));
                    let h = self.scan(c, owner, path, depth + 1, contents, order)?;
                    path.pop();
                    height = height.max(h);
                }
                Ok(height + 1)
            }
            Surface::Instance(shared) => {
                let d = self.define(shared, owner, path, depth, order)?;
                contents.children.push(d);
                Ok(self.defs[d].height + 1)
            }
            leaf => {
                contents.direct += self.leaf_primitives(leaf);
                contents.has_leaves = true;
                Ok(1)
            }
        }
    }

    /// The index of definition `shared` (referenced at `depth` by `path`
    /// inside `owner`), walking its contents on first use.
    fn define(
        &mut self,
        shared: &'s Arc<Surface>,
        owner: Option<usize>,
        path: &[Step],
        depth: usize,
        order: &mut Vec<usize>,
    ) -> Result<usize, CensusError> {
        if let Some(&d) = self.index.get(&key(shared)) {
            if d == IN_PROGRESS {
                return Err(CensusError::Cycle(self.location(owner, path)));
            }
            // Memoised: only the nesting along this new path is checked.
            if depth + self.defs[d].height > MAX_DEPTH {
                return Err(CensusError::TooDeep(self.location(owner, path)));
            }
            return Ok(d);
        }
        self.index.insert(key(shared), IN_PROGRESS);
        let d = self.defs.len();
        self.defs.push(Def {
            surface: shared,
            uses: 0,
            direct: 0,
            has_leaves: false,
            height: 0,
            refs: 0,
            children: Vec::new(),
            parent: owner,
            local: path.to_vec(),
        });
        let mut contents = Contents::default();
        let height = self.scan(
            shared,
            Some(d),
            &mut Vec::new(),
            depth + 1,
            &mut contents,
            order,
        )?;
        let refs = 1 + contents
            .children
            .iter()
            .map(|&c| self.defs[c].refs)
            .max()
            .unwrap_or(0);
        let def = &mut self.defs[d];
        def.refs = refs;
        def.direct = contents.direct;
        def.has_leaves = contents.has_leaves;
        def.children = contents.children;
        def.height = height;
        self.index.insert(key(shared), d);
        order.push(d);
        Ok(d)
    }

    /// Primitives flattening makes of `leaf` (non-finite ones dropped).
    fn leaf_primitives(&mut self, leaf: &Surface) -> u64 {
        let finite = |v: &[DVec3]| v.iter().all(|p| p.is_finite());
        match leaf {
            Surface::Sphere(s) => (s.center.is_finite() && s.radius.is_finite()) as u64,
            Surface::Box(b) if finite(&[b.min, b.max]) => match self.variant {
                Variant::Cornell2010 => 1,
                Variant::Cornell2015 => 12,
            },
            Surface::Box(_) => 0,
            Surface::Cylinder(c) => {
                (c.center.is_finite() && c.radius.is_finite() && c.height.is_finite()) as u64
            }
            Surface::Mesh(m) => *self
                .meshes
                .entry(Arc::as_ptr(&m.data) as usize)
                .or_insert_with(|| {
                    let d = &m.data;
                    let ok = |i: u32| d.positions.get(i as usize).is_some_and(|p| p.is_finite());
                    d.triangles
                        .iter()
                        .filter(|t| t.iter().all(|&i| ok(i)))
                        .count() as u64
                }),
            Surface::Group(_) | Surface::Instance(_) => 0,
        }
    }

    /// Propagates use counts down the DAG (`order`: children before
    /// parents) and sums the totals.
    fn count(&mut self, order: &[usize]) -> Result<(), CensusError> {
        let overflow = |c: &Census, what, d: usize| CensusError::Overflow {
            what,
            at: c.location(c.defs[d].parent, &c.defs[d].local),
        };
        for &d in &self.top_children {
            self.defs[d].uses += 1;
        }
        for &d in order.iter().rev() {
            let uses = self.defs[d].uses;
            for k in 0..self.defs[d].children.len() {
                let c = self.defs[d].children[k];
                self.defs[c].uses = self.defs[c]
                    .uses
                    .checked_add(uses)
                    .ok_or_else(|| overflow(self, "placements", c))?;
            }
        }
        self.unique_primitives = self.top_direct as u128;
        self.placed_primitives = self.top_direct as u128;
        for &d in order {
            let def = &self.defs[d];
            self.unique_primitives += def.direct as u128;
            if def.uses > 1 && def.has_leaves {
                self.placements = self
                    .placements
                    .checked_add(def.uses)
                    .ok_or_else(|| overflow(self, "placements", d))?;
            }
            self.placed_primitives = def
                .uses
                .checked_mul(def.direct as u128)
                .and_then(|n| n.checked_add(self.placed_primitives))
                .ok_or_else(|| overflow(self, "primitives as placed", d))?;
        }
        Ok(())
    }

    /// The longest chain of references from the top level (a definition
    /// placed inside a definition placed inside ...: the instance levels a
    /// nested tracer enters), with the reference that starts it (where the
    /// walk first reached its definition); `(0, None)` without references.
    pub fn reference_depth(&self) -> (usize, Option<Location>) {
        // Reversed: of equally deep chains, the first in document order.
        let deepest = (self.top_children.iter().rev()).max_by_key(|&&d| self.defs[d].refs);
        match deepest {
            None => (0, None),
            Some(&d) => {
                let def = &self.defs[d];
                (def.refs, Some(self.location(def.parent, &def.local)))
            }
        }
    }

    /// Calls `visit` with every leaf once, in document order (a shared
    /// definition entered at its first reference only), with the number of
    /// times it is placed: what enumerating every placement would report,
    /// less the repetitions.
    pub fn for_each_leaf_once(&self, visit: &mut dyn FnMut(&'s Surface, u128)) {
        let mut seen = vec![false; self.defs.len()];
        for s in self.roots {
            self.visit_once(s, 1, &mut seen, visit);
        }
    }

    fn visit_once(
        &self,
        s: &'s Surface,
        uses: u128,
        seen: &mut [bool],
        visit: &mut dyn FnMut(&'s Surface, u128),
    ) {
        match s {
            Surface::Group(g) => {
                for c in &g.children {
                    self.visit_once(c, uses, seen, visit);
                }
            }
            Surface::Instance(shared) => {
                let d = self.index[&key(shared)];
                if !std::mem::replace(&mut seen[d], true) {
                    self.visit_once(self.defs[d].surface, self.defs[d].uses, seen, visit);
                }
            }
            leaf => visit(leaf, uses),
        }
    }

    /// Bounds of the mesh vertices as placed, in world space: each
    /// definition's own box computed once and its corners carried up
    /// through the placements (so a rotated placement gets the box of its
    /// rotated box, a little larger than the exact bounds).
    pub fn mesh_bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut memo: Vec<Option<Box3>> = vec![None; self.defs.len()];
        let mut out = Box3::EMPTY;
        for s in self.roots {
            self.bound(s, DMat4::IDENTITY, &mut memo, &mut out);
        }
        (out.0.cmple(out.1).all()).then_some((out.0, out.1))
    }

    fn bound(&self, s: &Surface, m: DMat4, memo: &mut [Option<Box3>], out: &mut Box3) {
        match s {
            Surface::Group(g) => {
                let m = m * g.transform;
                for c in &g.children {
                    self.bound(c, m, memo, out);
                }
            }
            Surface::Instance(shared) => {
                let d = self.index[&key(shared)];
                let own = match memo[d] {
                    Some(b) => b,
                    None => {
                        let mut b = Box3::EMPTY;
                        self.bound(self.defs[d].surface, DMat4::IDENTITY, memo, &mut b);
                        memo[d] = Some(b);
                        b
                    }
                };
                if own.0.cmple(own.1).all() {
                    for k in 0..8 {
                        let pick =
                            |bit: usize, lo: f64, hi: f64| if k >> bit & 1 == 0 { lo } else { hi };
                        let c = DVec3::new(
                            pick(0, own.0.x, own.1.x),
                            pick(1, own.0.y, own.1.y),
                            pick(2, own.0.z, own.1.z),
                        );
                        out.add(m.transform_point3(c));
                    }
                }
            }
            Surface::Mesh(mesh) => {
                for p in mesh.data.used_positions() {
                    out.add(m.transform_point3(p));
                }
            }
            _ => {}
        }
    }
}

/// What one definition (or the top level) holds itself.
#[derive(Default)]
struct Contents {
    direct: u64,
    has_leaves: bool,
    children: Vec<usize>,
}

/// A growing box (empty: lower corner above the upper one).
#[derive(Clone, Copy, Debug)]
struct Box3(DVec3, DVec3);

impl Box3 {
    const EMPTY: Box3 = Box3(DVec3::INFINITY, DVec3::NEG_INFINITY);

    /// Adds `p` when it is finite (as `load::frame::bounds` does).
    fn add(&mut self, p: DVec3) {
        if p.is_finite() {
            self.0 = self.0.min(p);
            self.1 = self.1.max(p);
        }
    }
}

fn step(i: usize, s: &Surface) -> Step {
    Step {
        index: i as u32 + 1,
        reference: matches!(s, Surface::Instance(_)),
    }
}
