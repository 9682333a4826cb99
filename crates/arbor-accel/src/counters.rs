//! Traversal statistics that cost nothing when switched off: traversal is
//! generic over [`Counters`], and [`NoCounters`]' empty methods vanish when
//! monomorphised. The same mechanism records a ray's whole traversal
//! ([`Recorder`]): the recording calls sit behind the compile-time constant
//! [`Counters::RECORDS`], so for every other implementation they are not
//! even compiled in.

use crate::primitives::PrimitiveId;

/// Receives one call per node visited and per primitive test.
pub trait Counters {
    /// Whether [`Counters::visit`] and [`Counters::tested`] are wanted.
    /// Traversal guards them (and any work to name a node) with this
    /// constant, so counters that leave it `false` pay nothing for them.
    const RECORDS: bool = false;
    /// A node (or grid cell) was visited.
    fn node(&mut self);
    /// A primitive was handed to the caller's exact test.
    fn test(&mut self);
    /// With [`Counters::RECORDS`]: node `node` (in the structure's
    /// traversal numbering, see [`crate::layout::Layout::index`]) was visited
    /// (`entered`, right after the matching [`Counters::node`]) or its box
    /// was tested and skipped (`!entered`: no [`Counters::node`] call).
    #[inline(always)]
    fn visit(&mut self, _node: u32, _entered: bool) {}
    /// With [`Counters::RECORDS`]: primitive `prim` was tested (right after
    /// the matching [`Counters::test`]).
    #[inline(always)]
    fn tested(&mut self, _prim: PrimitiveId) {}
}

/// Counts a visit of `node` and records it when `C` records.
#[inline(always)]
pub(crate) fn count_node<C: Counters>(counters: &mut C, node: u32) {
    counters.node();
    if C::RECORDS {
        counters.visit(node, true);
    }
}

/// Records (when `C` records) that `node`'s box was tested and skipped.
#[inline(always)]
pub(crate) fn skip_node<C: Counters>(counters: &mut C, node: u32) {
    if C::RECORDS {
        counters.visit(node, false);
    }
}

/// Counts a test of `prim` and records it when `C` records.
#[inline(always)]
pub(crate) fn count_test<C: Counters>(counters: &mut C, prim: PrimitiveId) {
    counters.test();
    if C::RECORDS {
        counters.tested(prim);
    }
}

/// Counts nothing; the default for speed.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCounters;

impl Counters for NoCounters {
    #[inline(always)]
    fn node(&mut self) {}
    #[inline(always)]
    fn test(&mut self) {}
}

/// Counts nodes visited and primitive tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Nodes or cells visited.
    pub nodes: u64,
    /// Primitive tests performed.
    pub tests: u64,
}

impl Counters for RayCounts {
    #[inline(always)]
    fn node(&mut self) {
        self.nodes += 1;
    }
    #[inline(always)]
    fn test(&mut self) {
        self.tests += 1;
    }
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, other: RayCounts) {
        self.nodes += other.nodes;
        self.tests += other.tests;
    }
}

/// One step of a recorded traversal: a node (or grid cell) visited, or a
/// box tested and skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Visit {
    /// The node, in the structure's traversal numbering
    /// ([`crate::layout::Layout::index`] gives its index in the structure's layout).
    pub node: u32,
    /// Whether traversal went inside (counted as a node) or skipped it.
    pub entered: bool,
}

/// Records a ray's traversal in order: every visit and skipped box, every
/// primitive tested, and the counts [`RayCounts`] would give, for every
/// [`crate::accel::Accel`] structure. (`MeshAccel`'s triangle-specialised queries
/// count but do not record their triangle tests.)
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Recorder {
    /// What [`RayCounts`] counts; `counts.nodes` equals the entered visits.
    pub counts: RayCounts,
    /// Visits and skipped boxes, in traversal order.
    pub visits: Vec<Visit>,
    /// Primitives tested, in order (`counts.tests` of them).
    pub tests: Vec<PrimitiveId>,
}

impl Counters for Recorder {
    const RECORDS: bool = true;
    fn node(&mut self) {
        self.counts.nodes += 1;
    }
    fn test(&mut self) {
        self.counts.tests += 1;
    }
    fn visit(&mut self, node: u32, entered: bool) {
        self.visits.push(Visit { node, entered });
    }
    fn tested(&mut self, prim: PrimitiveId) {
        self.tests.push(prim);
    }
}
