//! Reading back what [`super::build`] made, for `arbor explain`: per
//! definition its own geometry, its child placements, its box and its
//! structures.

use arbor_accel::{AccelStats, Accelerator};
use glam::{DMat4, DVec3};

use super::NestedTracer;

/// One child placement of a definition, as built.
#[derive(Clone, Copy, Debug)]
pub struct ChildPlacement<'a> {
    /// The definition it places.
    pub definition: u32,
    /// Whether it places only that definition's own geometry (a subtree of
    /// few copies flattened into this level) rather than its whole level.
    pub geometry_only: bool,
    /// The group transforms from this definition's root down to the
    /// reference, in document order.
    pub steps: &'a [DMat4],
}

/// One definition (or the world) as built.
#[derive(Clone, Debug)]
pub struct DefinitionSummary<'a> {
    /// Primitives of its own geometry (in its own space).
    pub primitives: usize,
    /// The item number of its first child placement in its level's
    /// structure (1 when item 0 is its own geometry, else 0).
    pub first_child: u32,
    /// Its child placements, in item order.
    pub children: Vec<ChildPlacement<'a>>,
    /// Its level's padded box in its own space (`None`: empty).
    pub bounds: Option<(DVec3, DVec3)>,
    /// Its own geometry's padded box, when it has geometry.
    pub geometry_bounds: Option<(DVec3, DVec3)>,
    /// The structure over its items (its geometry and its children's boxes).
    pub stats: AccelStats,
    /// The structure over its own geometry's primitives, when it has any.
    pub geometry_stats: Option<AccelStats>,
}

impl NestedTracer {
    /// The world's definition (the level every ray starts in).
    pub fn root(&self) -> u32 {
        self.root
    }

    /// What definition `d` holds.
    pub fn summary(&self, d: u32) -> DefinitionSummary<'_> {
        let def = &self.definitions[d as usize];
        DefinitionSummary {
            primitives: def.geometry.as_ref().map_or(0, |g| g.scene.len()),
            first_child: def.first_child(),
            children: def
                .children
                .iter()
                .map(|c| ChildPlacement {
                    definition: c.definition,
                    geometry_only: c.geometry_only,
                    steps: &c.steps,
                })
                .collect(),
            bounds: def.frame.bounds,
            geometry_bounds: def.geometry.as_ref().and_then(|g| g.frame.bounds),
            stats: def.accel.stats(),
            geometry_stats: def.geometry.as_ref().map(|g| g.accel.stats()),
        }
    }
}
