//! Building a scene into nested levels: each definition once, children
//! first, subtrees of few copies flattened into their parent's level
//! within that level's budget.

use std::sync::Arc;

use arbor_accel::AccelKind;
use glam::{DAffine3, DMat4, DVec3};

use super::{Child, Definition, NestError, NestedTracer, MAX_INSTANCE_LEVELS};
use crate::census::Census;
use crate::flatten::{self, FlatGeometry};
use crate::hash_map::{HashMap, HashSet};
use crate::level::{world_box, Frame, Level};
use crate::scene::{Scene, Variant};
use crate::surface::Surface;

/// Builds `scene` into nested levels with structures of `kind` at every
/// level. Each level (the world, and every definition placed as a level)
/// may take in up to `flatten_budget` children from flattened subtrees: a
/// flattened child definition becomes, for each of its placements there,
/// one child per copy of geometry in its subtree, with its chain of
/// transforms, instead of one level to enter. The level's child
/// definitions are taken in by their cost (placements there times copies
/// per placement), smallest first, while the budget lasts; a definition of
/// at most one copy (only geometry) is always taken in, as it costs no
/// more than the level it would be. `1` therefore nests everything else;
/// a budget beyond the scene's placements flattens the world into one
/// level, as the flat tracer does.
///
/// The scene is first counted ([`Census`]): a cycle, a singular group
/// transform or a count beyond 128 bits is an error naming the element, as
/// is a chain of references deeper than [`MAX_INSTANCE_LEVELS`].
pub fn build(
    scene: &Scene,
    kind: AccelKind,
    flatten_budget: u64,
) -> Result<NestedTracer, NestError> {
    let census = Census::new(&scene.surfaces, scene.variant).map_err(NestError::Census)?;
    let (depth, at) = census.reference_depth();
    if depth > MAX_INSTANCE_LEVELS {
        let at = at.expect("a chain of references starts somewhere");
        return Err(NestError::TooDeep { depth, at });
    }
    let mut builder = Builder {
        kind,
        variant: scene.variant,
        flatten_budget,
        uses: flatten::placement_counts(&scene.surfaces),
        copies: HashMap::default(),
        flattened: HashMap::default(),
        levels: HashSet::default(),
        index: HashMap::default(),
        definitions: Vec::new(),
    };
    let mut direct = Vec::new();
    for s in &scene.surfaces {
        builder.root_instances(s, &mut direct);
    }
    let own = scene.surfaces.iter().any(|s| builder.world_geometry(s));
    let root = builder.choose_flattened(&direct, own);
    builder.mark_levels(&direct, &root);
    let mut world = FlatGeometry::empty(scene.variant);
    let mut children = Vec::new();
    for s in &scene.surfaces {
        builder.walk_root(
            s,
            DMat4::IDENTITY,
            &mut Vec::new(),
            &root,
            &mut world,
            &mut children,
        )?;
    }
    world.finish();
    let root = builder.assemble(world, children);
    Ok(NestedTracer {
        definitions: builder.definitions,
        root,
        depth,
    })
}

/// The child definitions (by key) a level flattens into itself.
type Flattened = HashSet<usize>;

/// Builds definitions once each, children first.
struct Builder {
    kind: AccelKind,
    variant: Variant,
    flatten_budget: u64,
    uses: HashMap<usize, (u64, Arc<Surface>)>,
    /// Per definition, the copies of geometry its subtree places per copy
    /// of it (flatten's placements), saturating.
    copies: HashMap<usize, u64>,
    /// Per definition placed as a level, the child definitions flattened
    /// into it.
    flattened: HashMap<usize, Flattened>,
    /// The definitions placed as a level somewhere (built with children).
    levels: HashSet<usize>,
    index: HashMap<usize, u32>,
    definitions: Vec<Definition>,
}

impl Builder {
    /// The world level: leaves (and instances placed once, inlined as
    /// flatten inlines them) baked under `m` into `world`; shared
    /// instances as children with their `steps` from the root.
    fn walk_root(
        &mut self,
        s: &Surface,
        m: DMat4,
        steps: &mut Vec<DMat4>,
        root: &Flattened,
        world: &mut FlatGeometry,
        children: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        match s {
            Surface::Group(g) => {
                steps.push(g.transform);
                let m = m * g.transform;
                for c in &g.children {
                    self.walk_root(c, m, steps, root, world, children)?;
                }
                steps.pop();
                Ok(())
            }
            Surface::Instance(shared) if self.placed_once(shared) => {
                self.walk_root(shared, m, steps, root, world, children)
            }
            Surface::Instance(shared) => self.place(shared, steps, Some(root), children),
            leaf => Ok(world.add_leaf(leaf, m)?),
        }
    }

    /// Whether `shared` is placed once in all: the world bakes it in, as
    /// flatten does.
    fn placed_once(&self, shared: &Arc<Surface>) -> bool {
        self.uses[&flatten::key(shared)].0 <= 1
    }

    /// The shared instances the world level places: through groups and
    /// through instances placed once (baked into the world), one entry a
    /// placement.
    fn root_instances<'s>(&self, s: &'s Surface, out: &mut Vec<&'s Arc<Surface>>) {
        match s {
            Surface::Group(g) => g.children.iter().for_each(|c| self.root_instances(c, out)),
            Surface::Instance(shared) if self.placed_once(shared) => {
                self.root_instances(shared, out)
            }
            Surface::Instance(shared) => out.push(shared),
            _ => {}
        }
    }

    /// Whether the world level holds geometry of its own under `s`.
    fn world_geometry(&self, s: &Surface) -> bool {
        match s {
            Surface::Group(g) => g.children.iter().any(|c| self.world_geometry(c)),
            Surface::Instance(shared) => self.placed_once(shared) && self.world_geometry(shared),
            _ => true,
        }
    }

    /// The child definitions flattened into a level whose own geometry is
    /// `own` and whose placements are `direct` (one entry a placement): the
    /// budget rule of [`build`].
    fn choose_flattened(&mut self, direct: &[&Arc<Surface>], own: bool) -> Flattened {
        // Per child definition, in order of first placement: its key and
        // what flattening it costs the level.
        let mut costs: Vec<(usize, u64)> = Vec::new();
        let mut position: HashMap<usize, usize> = HashMap::default();
        for s in direct {
            let copies = self.copies(s);
            let key = flatten::key(s);
            let i = *position.entry(key).or_insert_with(|| {
                costs.push((key, 0));
                costs.len() - 1
            });
            costs[i].1 = costs[i].1.saturating_add(copies);
        }
        let mut flattened = Flattened::default();
        let mut width = u64::from(own);
        let mut candidates = Vec::new();
        for (order, &(key, cost)) in costs.iter().enumerate() {
            if self.copies[&key] <= 1 {
                flattened.insert(key);
                width = width.saturating_add(cost);
            } else {
                candidates.push((cost, order, key));
            }
        }
        candidates.sort_unstable();
        for (cost, _, key) in candidates {
            if width.saturating_add(cost) > self.flatten_budget {
                break;
            }
            width += cost;
            flattened.insert(key);
        }
        flattened
    }

    /// Marks the definitions placed as a level by a level whose
    /// placements are `direct` and which flattens `flattened`, and the
    /// levels they place, recursively (each definition's rule once).
    fn mark_levels(&mut self, direct: &[&Arc<Surface>], flattened: &Flattened) {
        for c in direct {
            let key = flatten::key(c);
            // A flattened subtree is flattened whole: nothing in it is a level.
            if flattened.contains(&key) || !self.levels.insert(key) {
                continue;
            }
            let mut inner = Vec::new();
            flatten::direct_instances(c, &mut inner);
            let theirs = self.choose_flattened(&inner, flatten::has_direct_geometry(c));
            self.mark_levels(&inner, &theirs);
            self.flattened.insert(key, theirs);
        }
    }

    /// How many copies of geometry one copy of `s` places (itself if it
    /// holds leaves, and its children's, recursively), memoised.
    fn copies(&mut self, s: &Arc<Surface>) -> u64 {
        if let Some(&n) = self.copies.get(&flatten::key(s)) {
            return n;
        }
        let mut inner = Vec::new();
        flatten::direct_instances(s, &mut inner);
        let own = u64::from(flatten::has_direct_geometry(s));
        let n = inner
            .iter()
            .fold(own, |n, c| n.saturating_add(self.copies(c)));
        self.copies.insert(flatten::key(s), n);
        n
    }

    /// Places shared `s` (reached by `steps`) into `out`, a level that
    /// flattens `flattened` (`None`: inside a flattened subtree, which is
    /// flattened whole): one child for the whole definition, or, flattened,
    /// one child per copy of geometry in it, in flatten's order (its own
    /// geometry first).
    fn place(
        &mut self,
        s: &Arc<Surface>,
        steps: &mut Vec<DMat4>,
        flattened: Option<&Flattened>,
        out: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        if !flattened.is_none_or(|f| f.contains(&flatten::key(s))) {
            let definition = self.definition(s)?;
            out.push(child(steps, definition, false));
            return Ok(());
        }
        // Flattened: its own geometry (built once, if it has any), then its
        // children's, with no level of its own.
        if flatten::has_direct_geometry(s) {
            let definition = self.definition(s)?;
            if self.definitions[definition as usize].geometry.is_some() {
                out.push(child(steps, definition, true));
            }
        }
        self.collect(s, steps, None, out)
    }

    /// The definition of shared surface `s`, built on first use: its own
    /// geometry, and its children if it is placed as a level anywhere.
    fn definition(&mut self, s: &Arc<Surface>) -> Result<u32, NestError> {
        let key = flatten::key(s);
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        let mut geometry = FlatGeometry::empty(self.variant);
        flatten::add_direct_leaves(&mut geometry, s, DMat4::IDENTITY)?;
        geometry.finish();
        let mut children = Vec::new();
        if self.levels.contains(&key) {
            // Built once (memoised above), so its rule is not needed again.
            let flattened = self.flattened.remove(&key).unwrap_or_default();
            self.collect(s, &mut Vec::new(), Some(&flattened), &mut children)?;
        }
        let i = self.assemble(geometry, children);
        self.index.insert(key, i);
        Ok(i)
    }

    /// The child placements inside `s` (through groups; not inside its
    /// instances), with `steps` leading to `s`, in a level that flattens
    /// `flattened` (see [`Builder::place`]).
    fn collect(
        &mut self,
        s: &Surface,
        steps: &mut Vec<DMat4>,
        flattened: Option<&Flattened>,
        out: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        match s {
            Surface::Group(g) => {
                steps.push(g.transform);
                for c in &g.children {
                    self.collect(c, steps, flattened, out)?;
                }
                steps.pop();
            }
            Surface::Instance(shared) => self.place(shared, steps, flattened, out)?,
            _ => {}
        }
        Ok(())
    }

    /// One definition over its geometry (if any) and its children's boxes.
    fn assemble(&mut self, geometry: FlatGeometry, children: Vec<Child>) -> u32 {
        let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let geometry = (!geometry.is_empty()).then(|| Level::new(geometry, self.kind));
        let mut boxes: Vec<(DVec3, DVec3)> = Vec::with_capacity(children.len() + 1);
        if let Some(level) = &geometry {
            boxes.push(level.frame.bounds.unwrap_or(empty));
        }
        for c in &children {
            let placed = c.steps.iter().fold(DMat4::IDENTITY, |m, s| m * *s);
            let inner = &self.definitions[c.definition as usize];
            let bounds = match (c.geometry_only, &inner.geometry) {
                (true, Some(g)) => g.frame.bounds,
                (true, None) => None,
                (false, _) => inner.frame.bounds,
            };
            let placed = DAffine3::from_mat4(placed);
            boxes.push(bounds.map_or(empty, |(lo, hi)| world_box(&placed, lo, hi)));
        }
        let (frame, accel) = Frame::indexed(self.kind, &boxes);
        self.definitions.push(Definition {
            geometry,
            children,
            accel,
            frame,
        });
        (self.definitions.len() - 1) as u32
    }
}

fn child(steps: &[DMat4], definition: u32, geometry_only: bool) -> Child {
    Child {
        steps: steps.into(),
        definition,
        geometry_only,
    }
}
