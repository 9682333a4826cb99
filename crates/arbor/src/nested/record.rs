//! [`NestedRecord`]: one ray's way through the nested levels, recorded in
//! order (for `arbor explain`): each level it reached through which items,
//! where it entered that level's box or that it was culled, and each closer
//! hit, the last of which is the hit.

use arbor_accel::{Counters, RayCounts};

use crate::level::SplitCounters;

/// One level the ray reached.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelReached {
    /// The item taken at each level from the world down to this one (item
    /// 0 of a definition with geometry is that geometry, the others its
    /// child placements in order); empty for the world itself.
    pub path: Vec<u32>,
    /// The definition whose level (or geometry) this is.
    pub definition: u32,
    /// Whether this is the definition's own geometry (primitives tested)
    /// rather than its level of child placements.
    pub geometry: bool,
    /// The ray parameter where the ray enters the level's (padded) box;
    /// `None` when it misses the box before the closest hit so far.
    pub t: Option<f64>,
}

/// A hit closer than every one before it.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedHit {
    /// The items that led to it, as [`LevelReached::path`] (the last one is
    /// the geometry hit).
    pub path: Vec<u32>,
    /// Its ray parameter.
    pub t: f64,
}

/// A ray's recorded traversal of the nested levels; as counters it counts
/// what [`RayCounts`] counts, and the instance levels entered as
/// `--stats` counts them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NestedRecord {
    /// The levels reached, in the order traversal reached them.
    pub levels: Vec<LevelReached>,
    /// The closer hits in the order found: the last is the ray's hit.
    pub hits: Vec<RecordedHit>,
    /// Placements entered ([`SplitCounters::enter_level`] calls).
    pub entered: u64,
    /// Nodes visited and primitives tested over every level.
    pub counts: RayCounts,
}

impl NestedRecord {
    /// The ray's hit: the last closer hit found.
    pub fn hit(&self) -> Option<&RecordedHit> {
        self.hits.last()
    }
}

impl Counters for NestedRecord {
    fn node(&mut self) {
        self.counts.node();
    }
    fn test(&mut self) {
        self.counts.test();
    }
}

impl SplitCounters for NestedRecord {
    const RECORDS_LEVELS: bool = true;

    fn merge(&mut self, other: Self) {
        // The split-off record holds what happened inside one item, after
        // everything recorded here so far: appending keeps the order.
        self.levels.extend(other.levels);
        self.hits.extend(other.hits);
        self.entered += other.entered;
        self.counts += other.counts;
    }

    fn enter_level(&mut self) {
        self.entered += 1;
    }

    fn reach_level(&mut self, path: &[u32], definition: u32, geometry: bool, t: Option<f64>) {
        self.levels.push(LevelReached {
            path: path.to_vec(),
            definition,
            geometry,
            t,
        });
    }

    fn closer_hit(&mut self, path: &[u32], t: f64) {
        self.hits.push(RecordedHit {
            path: path.to_vec(),
            t,
        });
    }
}
