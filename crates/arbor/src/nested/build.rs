//! Building a scene into nested levels: each definition once, children
//! first, a subtree of few copies flattened into its parent's level.

use std::sync::Arc;

use arbor_accel::{Accel, AccelKind};
use glam::{DAffine3, DMat4, DVec3};

use super::{Child, Definition, NestError, NestedTracer, MAX_INSTANCE_LEVELS};
use crate::census::Census;
use crate::flatten::{self, FlatGeometry};
use crate::hash_map::HashMap;
use crate::level::{world_box, Frame, Level};
use crate::scene::{Scene, Variant};
use crate::surface::Surface;

/// Builds `scene` into nested levels with structures of `kind` at every
/// level. A shared definition whose subtree places at most
/// `flatten_at_most` copies of geometry (itself and everything below, per
/// copy of it) is flattened into its parent's level: each of those copies
/// becomes one child there, with its chain of transforms. `1` flattens only
/// definitions that place nothing else (nested throughout); the flat
/// tracer is the limit of a very large value.
///
/// The scene is first counted ([`Census`]): a cycle, a singular group
/// transform or a count beyond 128 bits is an error naming the element, as
/// is a chain of references deeper than [`MAX_INSTANCE_LEVELS`].
pub fn build(
    scene: &Scene,
    kind: AccelKind,
    flatten_at_most: u64,
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
        flatten_at_most,
        uses: flatten::placement_counts(&scene.surfaces),
        copies: HashMap::default(),
        index: HashMap::default(),
        definitions: Vec::new(),
    };
    let mut world = FlatGeometry::empty(scene.variant);
    let mut children = Vec::new();
    for s in &scene.surfaces {
        builder.walk_root(
            s,
            DMat4::IDENTITY,
            &mut Vec::new(),
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

/// Builds definitions once each, children first.
struct Builder {
    kind: AccelKind,
    variant: Variant,
    flatten_at_most: u64,
    uses: HashMap<usize, (u64, Arc<Surface>)>,
    /// Per definition, the copies of geometry its subtree places per copy
    /// of it (flatten's placements), saturating.
    copies: HashMap<usize, u64>,
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
        world: &mut FlatGeometry,
        children: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        match s {
            Surface::Group(g) => {
                steps.push(g.transform);
                let m = m * g.transform;
                for c in &g.children {
                    self.walk_root(c, m, steps, world, children)?;
                }
                steps.pop();
                Ok(())
            }
            Surface::Instance(shared) if self.uses[&flatten::key(shared)].0 <= 1 => {
                self.walk_root(shared, m, steps, world, children)
            }
            Surface::Instance(shared) => self.place(shared, steps, children),
            leaf => Ok(world.add_leaf(leaf, m)?),
        }
    }

    /// How many copies of geometry one copy of `s` places (itself if it
    /// holds leaves, and its children's, recursively), memoised.
    fn copies(&mut self, s: &Arc<Surface>) -> u64 {
        if let Some(&n) = self.copies.get(&flatten::key(s)) {
            return n;
        }
        let mut inner = Vec::new();
        direct_instances(s, &mut inner);
        let own = u64::from(flatten::has_direct_geometry(s));
        let n = inner
            .iter()
            .fold(own, |n, c| n.saturating_add(self.copies(c)));
        self.copies.insert(flatten::key(s), n);
        n
    }

    /// Places shared `s` (reached by `steps`) into `out`: one child for the
    /// whole definition, or, when its subtree is small, one child per copy
    /// of geometry in it, in flatten's order (its own geometry first).
    fn place(
        &mut self,
        s: &Arc<Surface>,
        steps: &mut Vec<DMat4>,
        out: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        let definition = self.definition(s)?;
        if self.copies(s) > self.flatten_at_most {
            out.push(child(steps, definition, false));
            return Ok(());
        }
        if self.definitions[definition as usize].geometry.is_some() {
            out.push(child(steps, definition, true));
        }
        self.collect(s, steps, out)
    }

    /// The definition of shared surface `s`, built on first use: its own
    /// geometry, and its children unless it is flattened wherever placed.
    fn definition(&mut self, s: &Arc<Surface>) -> Result<u32, NestError> {
        if let Some(&i) = self.index.get(&flatten::key(s)) {
            return Ok(i);
        }
        let mut geometry = FlatGeometry::empty(self.variant);
        flatten::add_direct_leaves(&mut geometry, s, DMat4::IDENTITY)?;
        geometry.finish();
        let mut children = Vec::new();
        if self.copies(s) > self.flatten_at_most {
            self.collect(s, &mut Vec::new(), &mut children)?;
        }
        let i = self.assemble(geometry, children);
        self.index.insert(flatten::key(s), i);
        Ok(i)
    }

    /// The child placements inside `s` (through groups; not inside its
    /// instances), with `steps` leading to `s`.
    fn collect(
        &mut self,
        s: &Surface,
        steps: &mut Vec<DMat4>,
        out: &mut Vec<Child>,
    ) -> Result<(), NestError> {
        match s {
            Surface::Group(g) => {
                steps.push(g.transform);
                for c in &g.children {
                    self.collect(c, steps, out)?;
                }
                steps.pop();
            }
            Surface::Instance(shared) => self.place(shared, steps, out)?,
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
        let frame = Frame::new(&boxes);
        let accel = Accel::build(self.kind, &frame.boxes(&boxes));
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

/// The instances directly inside `s` (through groups, not inside nested
/// instances).
fn direct_instances<'s>(s: &'s Surface, out: &mut Vec<&'s Arc<Surface>>) {
    match s {
        Surface::Group(g) => g.children.iter().for_each(|c| direct_instances(c, out)),
        Surface::Instance(shared) => out.push(shared),
        _ => {}
    }
}
