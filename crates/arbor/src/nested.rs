//! Nested instancing: the scene DAG traced as a DAG.
//!
//! [`crate::tracer::Tracer`] flattens every chain of references into one
//! placement per copy, so its memory follows the number of copies. Here
//! each shared definition (a surface placed more than once, keyed by its
//! `Arc` pointer as flatten and census do) is built ONCE into a
//! [`Definition`]: its own geometry in its own space with its own structure
//! (one item), and its child placements' boxes (one item each), indexed by
//! one structure of any [`AccelKind`]. The root is the world: the geometry
//! placed once, baked as flatten bakes it, and the top-level placements.
//! Each level may take subtrees of few copies into itself instead, within
//! a budget of children (`flatten_budget`, see [`build`]): their copies
//! become children of that level with their chains of transforms, as the
//! flat tracer's placements are.
//!
//! A ray entering a child placement continues in the child's structure,
//! level after level: the instance frames of a ray (each level's world
//! matrix and its inverse) live on the call stack of the traversal, at most
//! [`MAX_INSTANCE_LEVELS`] deep (checked when building). The closest hit so far
//! culls every level.
//!
//! ## Exactness
//!
//! Flat and nested give bit-identical answers. On entering a placement its
//! world-from-local matrix is composed in `f64` from the root, one group
//! transform at a time in document order, exactly as flatten composes a
//! chained placement, and the *world* ray is transformed into the leaf's
//! space by that matrix's inverse, as the flat tracer does. The exact
//! primitive tests therefore see the same rays; the `f32` culling at every
//! level is conservative (boxes padded as in the tracer, each level's ray
//! advanced to its bounds before rounding), so it can only offer more
//! candidates, never change the hit. Among hits at exactly the same `t` the
//! flat tracer keeps the world primitive, else the placement made first
//! (flatten places a definition's own geometry before its children, in
//! document order), then the lower primitive: the nested tracer compares
//! the [`Path`] of items that led to each hit, which orders hits the same
//! way.
//!
//! ## Far from the camera
//!
//! Exact tests are `f64` on the world ray transformed by the composed
//! inverse, so a placement `10^9` away is tested with `10^-7` absolute
//! error; each level's `f32` ray starts where the `f64` ray enters that
//! level's box, so the `f32` rounding follows the level's size, not the
//! distance from the camera.

mod build;
mod inspect;
mod instancing;
mod record;
mod sources;
#[cfg(test)]
mod tests;

pub use build::build;
pub use inspect::{ChildPlacement, DefinitionSummary};
pub use instancing::{
    auto_flat_at_most, Instancing, Plan, AUTO_FLATTEN_BUDGET, AUTO_FLAT_AT_MOST,
    AUTO_FLAT_FOR_RAYS_AT_MOST,
};
pub use record::{LevelReached, NestedRecord, RecordedHit};
pub use sources::Sources;

use arbor_accel::{Accel, Accelerator};
use glam::{DAffine3, DMat4};

use crate::census::{CensusError, Location};
use crate::flatten::{Hit, Placement, SingularTransform};
use crate::level::{cull_distance, local_ray, placed_hit, Frame, Level, SplitCounters};
use crate::ray::Ray;
use crate::surface::Candidate;

pub use crate::limits::MAX_INSTANCE_LEVELS;

/// Why a scene could not be built into nested levels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NestError {
    /// The scene graph is malformed (a cycle, a singular group transform,
    /// counts beyond 128 bits), with the element.
    Census(CensusError),
    /// References nest deeper than [`MAX_INSTANCE_LEVELS`].
    TooDeep {
        /// The chain's depth.
        depth: usize,
        /// The reference that starts the chain.
        at: Location,
    },
    /// A leaf's composed transform cannot be inverted.
    SingularTransform,
}

impl std::fmt::Display for NestError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NestError::Census(e) => e.fmt(f),
            NestError::TooDeep { depth, at } => write!(
                f,
                "{at}: references nest {depth} deep from here; nested instancing follows at most {MAX_INSTANCE_LEVELS}"
            ),
            NestError::SingularTransform => {
                f.write_str("the scene has a transform that cannot be inverted (a zero scale)")
            }
        }
    }
}

impl std::error::Error for NestError {}

impl From<SingularTransform> for NestError {
    fn from(_: SingularTransform) -> Self {
        NestError::SingularTransform
    }
}

/// The items a ray went through, one per level from the root: the order
/// of two paths is the flat tracer's order of the same two hits (item 0 of
/// a level is its own geometry, placed before its children).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Path {
    items: [u32; MAX_INSTANCE_LEVELS + 1],
    len: u8,
}

impl Path {
    const EMPTY: Path = Path {
        items: [0; MAX_INSTANCE_LEVELS + 1],
        len: 0,
    };

    fn push(&mut self, item: u32) {
        self.items[self.len as usize] = item;
        self.len += 1;
    }

    fn pop(&mut self) {
        self.len -= 1;
    }

    /// The items, from the root.
    fn items(&self) -> &[u32] {
        &self.items[..self.len as usize]
    }

    /// Whether a hit reached by `self` comes before one reached by `other`
    /// (neither is a prefix of the other: both end in geometry).
    fn before(&self, other: &Path) -> bool {
        self.items() < other.items()
    }
}

/// A child placement of a definition: the group transforms from the
/// definition's root down to the reference, in document order (composed
/// one by one at traversal, as flatten composes them), and what it places:
/// the whole definition, or only its own geometry (a flattened subtree).
pub(crate) struct Child {
    steps: Box<[DMat4]>,
    definition: u32,
    geometry_only: bool,
}

/// One shared definition (or the world), built once.
pub(crate) struct Definition {
    /// Its own leaves in its own space (item 0 of `accel` when present).
    geometry: Option<Level>,
    /// Its child placements (the items after the geometry).
    children: Vec<Child>,
    accel: Accel,
    frame: Frame,
}

impl Definition {
    /// Index of the first child item in `accel`.
    fn first_child(&self) -> u32 {
        u32::from(self.geometry.is_some())
    }
}

/// Where a ray is: the world matrix of the current level and its inverse
/// (`None` at the root, the world itself).
#[derive(Clone, Copy)]
struct Frame64 {
    m: DMat4,
    inverse: Option<DAffine3>,
}

impl Frame64 {
    const ROOT: Frame64 = Frame64 {
        m: DMat4::IDENTITY,
        inverse: None,
    };

    /// The frame of `child` entered from this one, as flatten composes it;
    /// `None` when its matrix cannot be inverted (flatten refuses such
    /// scenes; the census has refused every singular group transform).
    fn enter(&self, child: &Child) -> Option<Frame64> {
        let m = child.steps.iter().fold(self.m, |m, s| m * *s);
        let inverse = DAffine3::from_mat4(m).inverse();
        (inverse.is_finite() && m.determinant() != 0.0).then_some(Frame64 {
            m,
            inverse: Some(inverse),
        })
    }

    /// The world `ray` in this frame's space.
    fn local(&self, ray: &Ray) -> Ray {
        match self.inverse {
            None => *ray,
            Some(inverse) => local_ray(
                &Placement {
                    inverse,
                    geometry: 0,
                },
                ray,
            ),
        }
    }
}

/// The closest hit so far: where it lies, the inverse of the composed
/// world matrix of its placement (`None` at the root) and its path.
#[derive(Clone, Copy)]
struct Best {
    candidate: Candidate,
    definition: u32,
    prim: u32,
    inverse: Option<DAffine3>,
    path: Path,
}

/// A closest-hit search in progress: the world ray, the best hit so far and
/// the path to the current level.
struct Search<'r> {
    ray: &'r Ray,
    best: Option<Best>,
    path: Path,
}

impl Search<'_> {
    /// The culling distance: the best hit's `t`, else the ray's end.
    fn cull(&self) -> f64 {
        self.best.map_or(self.ray.tmax, |b| b.candidate.t)
    }
}

/// A scene built into nested levels: ray queries in `f64`, the same
/// answers as [`crate::tracer::Tracer`].
pub struct NestedTracer {
    definitions: Vec<Definition>,
    root: u32,
    depth: usize,
}

impl NestedTracer {
    /// Number of definitions built (the world and each shared definition).
    pub fn definitions(&self) -> usize {
        self.definitions.len()
    }

    /// The most instance levels below the world a ray can enter.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Child placements over all definitions (each built once).
    pub fn children(&self) -> usize {
        self.definitions.iter().map(|d| d.children.len()).sum()
    }

    /// Bytes of all acceleration structures (every level's and geometry's).
    pub fn accel_memory_bytes(&self) -> usize {
        self.definitions
            .iter()
            .map(|d| {
                d.accel.stats().memory_bytes
                    + d.geometry
                        .as_ref()
                        .map_or(0, |g| g.accel.stats().memory_bytes)
            })
            .sum()
    }

    /// The nearest hit on `ray`, counting traversal work (every level)
    /// into `counters` (`NoCounters` counts nothing; a
    /// [`crate::tracer::Tracer::from_nested`] has the uncounted queries).
    pub fn closest_counted<C: SplitCounters>(
        &self,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit<'_>> {
        let mut search = Search {
            ray,
            best: None,
            path: Path::EMPTY,
        };
        self.closest_in(self.root, Frame64::ROOT, &mut search, counters);
        search.best.map(|b| self.hit_record(ray, b))
    }

    /// Whether anything lies on `ray`, counting traversal work into
    /// `counters`.
    pub fn occluded_counted<C: SplitCounters>(&self, ray: &Ray, counters: &mut C) -> bool {
        self.occluded_in(self.root, Frame64::ROOT, ray, counters)
    }

    /// Searches definition `d`, entered with `frame`, for a hit nearer than
    /// the search's best.
    fn closest_in<C: SplitCounters>(
        &self,
        d: u32,
        frame: Frame64,
        search: &mut Search,
        counters: &mut C,
    ) {
        let def = &self.definitions[d as usize];
        let local = frame.local(search.ray);
        let cull = search.cull();
        let entry = def
            .frame
            .f32_ray(&local.with_interval(local.tmin, local.tmax.min(cull)));
        counters.reach_level(search.path.items(), d, false, entry.map(|e| e.1));
        let Some((ray32, t0)) = entry else {
            return;
        };
        let first_child = def.first_child();
        let mut inner = C::default();
        def.accel.closest(&ray32, counters, |item, _| {
            let before = search.best.map(|b| b.candidate.t);
            search.path.push(item);
            if item < first_child {
                self.closest_geometry(d, frame.inverse, &local, search, &mut inner);
            } else {
                let child = &def.children[(item - first_child) as usize];
                if let Some(inside) = frame.enter(child) {
                    inner.enter_level();
                    if child.geometry_only {
                        let local = inside.local(search.ray);
                        self.closest_geometry(
                            child.definition,
                            inside.inverse,
                            &local,
                            search,
                            &mut inner,
                        );
                    } else {
                        self.closest_in(child.definition, inside, search, &mut inner);
                    }
                }
            }
            search.path.pop();
            let now = search.best.map(|b| b.candidate.t)?;
            (Some(now) != before).then(|| cull_distance(now - t0))
        });
        counters.merge(inner);
    }

    /// Tests the geometry of definition `d` (placed by `inverse`, seeing
    /// the world ray as `local`) against the search's best.
    fn closest_geometry<C: SplitCounters>(
        &self,
        d: u32,
        inverse: Option<DAffine3>,
        local: &Ray,
        search: &mut Search,
        counters: &mut C,
    ) {
        let level = self.definitions[d as usize]
            .geometry
            .as_ref()
            .expect("geometry items have geometry");
        if C::RECORDS_LEVELS {
            // Where the ray enters the geometry's box, as `Level::closest`
            // finds it; computed only for recorders.
            let cut = local.with_interval(local.tmin, local.tmax.min(search.cull()));
            let t = level.frame.f32_ray(&cut).map(|e| e.1);
            counters.reach_level(search.path.items(), d, true, t);
        }
        let Some((prim, candidate)) = level.closest(local, search.cull(), counters) else {
            return;
        };
        if let Some(b) = &search.best {
            let tie = candidate.t == b.candidate.t;
            if candidate.t > b.candidate.t || (tie && !search.path.before(&b.path)) {
                return;
            }
        }
        counters.closer_hit(search.path.items(), candidate.t);
        search.best = Some(Best {
            candidate,
            definition: d,
            prim,
            inverse,
            path: search.path,
        });
    }

    /// Whether anything in definition `d`, entered with `frame`, lies on
    /// the world `ray`.
    fn occluded_in<C: SplitCounters>(
        &self,
        d: u32,
        frame: Frame64,
        ray: &Ray,
        counters: &mut C,
    ) -> bool {
        let def = &self.definitions[d as usize];
        let local = frame.local(ray);
        let Some((ray32, _)) = def.frame.f32_ray(&local) else {
            return false;
        };
        let first_child = def.first_child();
        let mut inner = C::default();
        let hit = def.accel.occluded(&ray32, counters, |item, _| {
            if item < first_child {
                return self.occluded_geometry(d, &local, &mut inner);
            }
            let child = &def.children[(item - first_child) as usize];
            let Some(inside) = frame.enter(child) else {
                return false;
            };
            inner.enter_level();
            if child.geometry_only {
                self.occluded_geometry(child.definition, &inside.local(ray), &mut inner)
            } else {
                self.occluded_in(child.definition, inside, ray, &mut inner)
            }
        });
        counters.merge(inner);
        hit
    }

    fn occluded_geometry<C: SplitCounters>(&self, d: u32, local: &Ray, counters: &mut C) -> bool {
        let level = self.definitions[d as usize].geometry.as_ref();
        level.is_some_and(|g| g.occluded(local, counters))
    }

    /// The full hit record of `best` on the world `ray`, built as the flat
    /// tracer builds it.
    fn hit_record(&self, ray: &Ray, best: Best) -> Hit<'_> {
        let def = &self.definitions[best.definition as usize];
        let scene = &def.geometry.as_ref().expect("hits lie in geometry").scene;
        match best.inverse {
            None => scene.hit(best.prim as usize, ray, best.candidate),
            Some(inverse) => {
                let p = Placement {
                    inverse,
                    geometry: best.definition,
                };
                placed_hit(&p, scene, best.prim, ray, best.candidate)
            }
        }
    }
}
