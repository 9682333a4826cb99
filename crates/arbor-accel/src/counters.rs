//! Traversal statistics that cost nothing when switched off: traversal is
//! generic over [`Counters`], and [`NoCounters`]' empty methods vanish when
//! monomorphised.

/// Receives one call per node visited and per primitive test.
pub trait Counters {
    /// A node (or grid cell) was visited.
    fn node(&mut self);
    /// A primitive was handed to the caller's exact test.
    fn test(&mut self);
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
