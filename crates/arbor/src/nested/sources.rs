//! Which scene surfaces each built definition and child placement came
//! from, for `arbor explain` (which draws the scene graph and names the
//! levels a ray entered by its nodes).
//!
//! The tracer keeps no pointers into the scene, so this walks the scene
//! again in the order [`super::build`] walks it (the world's references
//! placed once inlined, every other reference one child, or its copies
//! when its subtree was flattened into the level) and lays it over the
//! definitions as built, checking each step: any disagreement (a rule of
//! the build this walk does not follow) gives `None`, never a wrong name.

use std::sync::Arc;

use crate::flatten;
use crate::hash_map::HashMap;
use crate::scene::Scene;
use crate::surface::Surface;

use super::NestedTracer;

/// The scene surfaces behind a [`NestedTracer`]'s definitions, by address
/// (`Arc::as_ptr` of a shared surface; the address of a reference's
/// `Surface::Instance`), which stay valid as long as the scene does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sources {
    /// Per definition: the shared surface it was built from (`None` for
    /// the world, and for a definition no child places).
    pub definitions: Vec<Option<usize>>,
    /// Per definition, per child placement in item order: the reference
    /// that places it.
    pub children: Vec<Vec<usize>>,
}

/// The walk: a cursor over each definition's children.
struct Walk<'t> {
    tracer: &'t NestedTracer,
    uses: HashMap<usize, (u64, Arc<Surface>)>,
    sources: Sources,
    walked: Vec<bool>,
}

impl NestedTracer {
    /// The scene surfaces behind each definition and child of this tracer,
    /// built from `scene`; `None` when the walk cannot account for them.
    pub fn sources(&self, scene: &Scene) -> Option<Sources> {
        let n = self.definitions.len();
        let mut walk = Walk {
            tracer: self,
            uses: flatten::placement_counts(&scene.surfaces),
            sources: Sources {
                definitions: vec![None; n],
                children: vec![Vec::new(); n],
            },
            walked: vec![false; n],
        };
        walk.walked[self.root as usize] = true;
        for s in &scene.surfaces {
            walk.root(s)?;
        }
        walk.finished()?;
        Some(walk.sources)
    }
}

impl Walk<'_> {
    /// The world level: references placed once are inlined.
    fn root(&mut self, s: &Surface) -> Option<()> {
        match s {
            Surface::Group(g) => g.children.iter().try_for_each(|c| self.root(c)),
            Surface::Instance(shared) if self.uses.get(&flatten::key(shared))?.0 <= 1 => {
                self.root(shared)
            }
            Surface::Instance(shared) => self.place(self.tracer.root, s, shared),
            _ => Some(()),
        }
    }

    /// The references inside `s` (through groups), placed into `d`.
    fn collect(&mut self, d: u32, s: &Surface) -> Option<()> {
        match s {
            Surface::Group(g) => g.children.iter().try_for_each(|c| self.collect(d, c)),
            Surface::Instance(shared) => self.place(d, s, shared),
            _ => Some(()),
        }
    }

    /// Reference `at` to `shared`, placed into definition `d`: the next
    /// child of `d` places it whole, or `shared` was flattened into `d`
    /// (its own geometry one child, if any, then its references').
    fn place(&mut self, d: u32, at: &Surface, shared: &Arc<Surface>) -> Option<()> {
        let def = &self.tracer.definitions[d as usize];
        let next = def.children.get(self.sources.children[d as usize].len());
        let whole = next.is_some_and(|c| !c.geometry_only);
        if whole || flatten::has_direct_geometry(shared) {
            let child = next?;
            if child.geometry_only == whole {
                return None;
            }
            self.source(child.definition, shared)?;
            self.sources.children[d as usize].push(at as *const Surface as usize);
            if whole {
                return self.definition(child.definition, shared);
            }
        }
        self.collect(d, shared)
    }

    /// Definition `i` is `shared`'s (checked against earlier steps).
    fn source(&mut self, i: u32, shared: &Arc<Surface>) -> Option<()> {
        let slot = &mut self.sources.definitions[i as usize];
        let key = flatten::key(shared);
        match *slot {
            Some(k) if k != key => None,
            _ => {
                *slot = Some(key);
                Some(())
            }
        }
    }

    /// Walks definition `i`'s own children (once).
    fn definition(&mut self, i: u32, shared: &Arc<Surface>) -> Option<()> {
        if std::mem::replace(&mut self.walked[i as usize], true) {
            return Some(());
        }
        self.collect(i, shared)
    }

    /// Every walked definition's children are all accounted for.
    fn finished(&self) -> Option<()> {
        let defs = &self.tracer.definitions;
        let complete = (0..defs.len())
            .filter(|&i| self.walked[i])
            .all(|i| self.sources.children[i].len() == defs[i].children.len());
        complete.then_some(())
    }
}
