//! One ray's traversal through both levels of a [`crate::tracer::Tracer`],
//! recorded in order: the top level's visits and tests, and for each
//! placement the ray entered, that placement's bottom-level traversal.

use arbor_accel::{Counters, RayCounts, Recorder};

use crate::tracer::SplitCounters;

/// A placement's bottom-level traversal, recorded.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PlacementTraversal {
    /// The placement (its top-level primitive is the number of world
    /// primitives plus this).
    pub placement: u32,
    /// Visits (numbered in the placement's own structure) and tests
    /// (primitives of its shared geometry).
    pub record: Recorder,
}

/// A ray's recorded traversal of both levels; as counters, it counts what
/// [`RayCounts`] counts ([`TraversalRecord::counts`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TraversalRecord {
    /// The top level.
    pub top: Recorder,
    /// Bottom-level traversals, in the order they happened: each right
    /// after the top level's test of its placement.
    pub placements: Vec<PlacementTraversal>,
}

impl TraversalRecord {
    /// Nodes and tests of both levels, as [`RayCounts`] counts them.
    pub fn counts(&self) -> RayCounts {
        let mut c = self.top.counts;
        for p in &self.placements {
            c += p.record.counts;
        }
        c
    }

    /// Where counts go now: the last placement entered, or the top level.
    #[inline(always)]
    fn current(&mut self) -> &mut Recorder {
        match self.placements.last_mut() {
            Some(p) => &mut p.record,
            None => &mut self.top,
        }
    }
}

impl Counters for TraversalRecord {
    const RECORDS: bool = true;
    fn node(&mut self) {
        self.current().node();
    }
    fn test(&mut self) {
        self.current().test();
    }
    fn visit(&mut self, node: u32, entered: bool) {
        self.current().visit(node, entered);
    }
    fn tested(&mut self, prim: u32) {
        self.current().tested(prim);
    }
}

impl SplitCounters for TraversalRecord {
    fn merge(&mut self, other: Self) {
        // The split-off record holds only placements' traversals (its top
        // level stays empty: it counts nothing outside a placement).
        debug_assert_eq!(other.top, Recorder::default());
        self.placements.extend(other.placements);
    }

    fn enter_placement(&mut self, placement: u32) {
        self.placements.push(PlacementTraversal {
            placement,
            record: Recorder::default(),
        });
    }
}
