use std::fmt;
use std::str::FromStr;

use crate::bvh2::{Bvh, BvhBuilder, BvhParams};
use crate::counters::Counters;
use crate::grid::{Grid, GridParams};
use crate::kdtree::{KdParams, KdTree};
use crate::layout::Layout;
use crate::list::List;
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;
use crate::util::{offer_any, offer_closest};
use crate::wide::WideBvh;

/// What every acceleration structure answers: the candidates a ray may hit.
///
/// The caller's closure does the exact primitive test, so the structure never
/// needs to know what a primitive is. A structure names the primitives it
/// offers to every ray ([`Accelerator::unbounded`]: those without a finite
/// box) and walks the others ([`Accelerator::closest_bounded`],
/// [`Accelerator::occluded_bounded`]); [`Accelerator::closest`] and
/// [`Accelerator::occluded`] offer the first, then walk.
pub trait Accelerator: Send + Sync {
    /// Offers `hit` every primitive the ray may hit, nearest regions first.
    /// `hit(prim, ray)` returns `Some(t)` when `prim` is hit at `t` within
    /// `[ray.tmin, ray.tmax]`; traversal then shrinks `tmax` to `t`, so later
    /// calls see the shrunk ray. The caller keeps whatever it needs of the
    /// nearest hit. Every primitive whose exact hit lies within the final
    /// interval is offered (each at most once for BVHs built without spatial
    /// splits, possibly more than once for spatial subdivision and spatial
    /// splits: [`Accel::offers_repeats`]). The unbounded primitives come
    /// first, so the walk starts with `tmax` shrunk to their nearest hit.
    fn closest<C, F>(&self, ray: &Ray, counters: &mut C, mut hit: F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        let mut ray = *ray;
        offer_closest(self.unbounded(), &mut ray, counters, &mut hit);
        self.closest_bounded(ray, counters, &mut hit);
    }

    /// Whether any primitive is hit within `[ray.tmin, ray.tmax]`; stops at the
    /// first `hit(prim, ray) == true` (the unbounded primitives first).
    fn occluded<C, F>(&self, ray: &Ray, counters: &mut C, mut hit: F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        offer_any(self.unbounded(), ray, counters, &mut hit)
            || self.occluded_bounded(ray, counters, &mut hit)
    }

    /// The primitives offered to every ray before the walk: those without a
    /// finite box (infinite or NaN bounds), which no walk can cull; empty for
    /// a structure that walks every primitive (the list).
    fn unbounded(&self) -> &[PrimitiveId];

    /// [`Accelerator::closest`] over the primitives not in
    /// [`Accelerator::unbounded`]: the structure's own walk, with `ray` as
    /// the unbounded ones left it.
    fn closest_bounded<C, F>(&self, ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>;

    /// [`Accelerator::occluded`] over the primitives not in
    /// [`Accelerator::unbounded`].
    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool;

    /// Size and shape of the structure.
    fn stats(&self) -> AccelStats;
}

/// Size and shape of a built structure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AccelStats {
    /// Nodes (for the grid: cells).
    pub nodes: usize,
    /// Leaves (for the grid: non-empty cells).
    pub leaves: usize,
    /// Deepest leaf (root = 0).
    pub max_depth: usize,
    /// Heap and inline bytes of the structure, primitive references included.
    pub memory_bytes: usize,
    /// Surface area heuristic cost where it applies.
    pub sah_cost: Option<f64>,
}

/// The acceleration structures, by the names users pick them with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AccelKind {
    /// Brute force (`list`).
    List,
    /// BVH split at the middle of the centroid bounds (`bvh-center`).
    BvhCenter,
    /// BVH split at the centroid median (`bvh-median`).
    BvhMedian,
    /// BVH by binned SAH (`bvh-sah`), the readable reference of `bvh-wide`.
    BvhSah,
    /// BVH by full-sweep SAH (`bvh-sweep`), the quality reference.
    BvhSweep,
    /// BVH by bottom-up PLOC clustering (`bvh-cluster`).
    BvhCluster,
    /// 8-wide BVH collapsed from the binned-SAH tree, SIMD box tests
    /// (`bvh-wide`), the default and the fastest.
    BvhWide,
    /// Uniform grid (`grid`).
    Grid,
    /// SAH k-d tree (`kdtree`).
    KdTree,
}

impl AccelKind {
    /// Every kind, in the order tools list them.
    pub const ALL: &'static [AccelKind] = &[
        AccelKind::List,
        AccelKind::BvhCenter,
        AccelKind::BvhMedian,
        AccelKind::BvhSah,
        AccelKind::BvhSweep,
        AccelKind::BvhCluster,
        AccelKind::BvhWide,
        AccelKind::Grid,
        AccelKind::KdTree,
    ];

    /// The name users type.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::List => "list",
            AccelKind::BvhCenter => "bvh-center",
            AccelKind::BvhMedian => "bvh-median",
            AccelKind::BvhSah => "bvh-sah",
            AccelKind::BvhSweep => "bvh-sweep",
            AccelKind::BvhCluster => "bvh-cluster",
            AccelKind::BvhWide => "bvh-wide",
            AccelKind::Grid => "grid",
            AccelKind::KdTree => "kdtree",
        }
    }

    /// The structure used when the user names none.
    pub const DEFAULT: AccelKind = AccelKind::BvhWide;

    /// Whether this kind has a [`BuildQuality::High`] build: the two built
    /// by binned SAH, `bvh-sah` and `bvh-wide`.
    pub fn has_high_quality(self) -> bool {
        matches!(self, AccelKind::BvhSah | AccelKind::BvhWide)
    }

    /// Checks that this kind can be built at `quality`; the error reads
    /// after the caller's name for the quality ("--quality high builds
    /// spatial splits, ...").
    pub fn check_quality(self, quality: BuildQuality) -> Result<(), String> {
        if quality == BuildQuality::High && !self.has_high_quality() {
            return Err(format!(
                "builds spatial splits, which only bvh-wide and bvh-sah have, not {self}"
            ));
        }
        Ok(())
    }

    /// The BVH builder this kind names, if it is a BVH.
    pub fn bvh_builder(self) -> Option<BvhBuilder> {
        match self {
            AccelKind::BvhCenter => Some(BvhBuilder::Center),
            AccelKind::BvhMedian => Some(BvhBuilder::Median),
            AccelKind::BvhSah => Some(BvhBuilder::BinnedSah),
            AccelKind::BvhSweep => Some(BvhBuilder::SweepSah),
            AccelKind::BvhCluster => Some(BvhBuilder::Ploc),
            _ => None,
        }
    }
}

impl fmt::Display for AccelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An accelerator name that is not one of [`AccelKind::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownAccel(pub String);

impl fmt::Display for UnknownAccel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<_> = AccelKind::ALL.iter().map(|k| k.name()).collect();
        write!(
            f,
            "unknown accelerator '{}'; expected one of: {}",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownAccel {}

/// The entry of `all` whose `name` is `s`: how the names users type are
/// parsed, for the kinds and the qualities alike.
fn by_name<T: Copy>(all: &[T], name: fn(T) -> &'static str, s: &str) -> Option<T> {
    all.iter().copied().find(|&k| name(k) == s)
}

impl FromStr for AccelKind {
    type Err = UnknownAccel;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        by_name(AccelKind::ALL, AccelKind::name, s).ok_or_else(|| UnknownAccel(s.to_string()))
    }
}

/// Any of the structures, chosen at run time; dispatches statically inside.
#[derive(Clone, Debug)]
pub enum Accel {
    /// Brute force.
    List(List),
    /// Any of the BVHs.
    Bvh(Bvh),
    /// The uniform grid.
    Grid(Grid),
    /// The k-d tree.
    KdTree(KdTree),
    /// The 8-wide BVH.
    Wide(WideBvh),
}

/// How a build trades its own time for the tree's quality.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildQuality {
    /// The default: the binned SAH build (`fast`).
    #[default]
    Fast,
    /// Spatial splits on top of it (SBVH, [`BvhParams::spatial_splits`];
    /// `high`): a triangle whose box overlaps its neighbours' may be cut
    /// and placed in several leaves. Only for the kinds of
    /// [`AccelKind::has_high_quality`]; builds several times slower for a
    /// few per cent faster tracing (docs/performance.md).
    High,
}

impl BuildQuality {
    /// Every quality, in the order tools list them.
    pub const ALL: &'static [BuildQuality] = &[BuildQuality::Fast, BuildQuality::High];

    /// The name users type.
    pub fn name(self) -> &'static str {
        match self {
            BuildQuality::Fast => "fast",
            BuildQuality::High => "high",
        }
    }
}

impl fmt::Display for BuildQuality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BuildQuality {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        by_name(BuildQuality::ALL, BuildQuality::name, s)
            .ok_or_else(|| format!("unknown build quality {s:?} (expected fast or high)"))
    }
}

/// Parameters of every structure, for [`Accel::build_with`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AccelParams {
    /// BVH builders.
    pub bvh: BvhParams,
    /// The uniform grid.
    pub grid: GridParams,
    /// The k-d tree.
    pub kdtree: KdParams,
}

impl AccelParams {
    /// These parameters at build quality `quality` (for
    /// [`BuildQuality::High`], spatial splits for the binned SAH builds;
    /// other kinds ignore them, see [`AccelKind::has_high_quality`]).
    pub fn with_quality(self, quality: BuildQuality) -> Self {
        let bvh = match quality {
            BuildQuality::Fast => BvhParams {
                spatial_splits: 0.0,
                ..self.bvh
            },
            BuildQuality::High => self.bvh.high_quality(),
        };
        AccelParams { bvh, ..self }
    }
}

impl Accel {
    /// Builds a structure of `kind` over `prims`.
    pub fn build<P: Primitives + ?Sized>(kind: AccelKind, prims: &P) -> Self {
        Self::build_with(kind, prims, &AccelParams::default())
    }

    /// Builds a structure of `kind` over `prims` with explicit parameters.
    pub fn build_with<P: Primitives + ?Sized>(
        kind: AccelKind,
        prims: &P,
        params: &AccelParams,
    ) -> Self {
        if let Some(b) = kind.bvh_builder() {
            return Accel::Bvh(Bvh::build(prims, b, &params.bvh));
        }
        match kind {
            AccelKind::List => Accel::List(List::build(prims)),
            AccelKind::Grid => Accel::Grid(Grid::build(prims, &params.grid)),
            AccelKind::KdTree => Accel::KdTree(KdTree::build(prims, &params.kdtree)),
            AccelKind::BvhWide => Accel::Wide(WideBvh::build(prims, &params.bvh)),
            _ => unreachable!("every other kind is a BVH"),
        }
    }
}

impl Accel {
    /// Whether traversal may offer a primitive more than once: the grid and
    /// the k-d tree place it in every cell or leaf it overlaps, BVHs built
    /// with spatial splits in every leaf that holds a part of it.
    pub fn offers_repeats(&self) -> bool {
        match self {
            Accel::List(_) => false,
            Accel::Bvh(a) => a.has_repeats(),
            Accel::Grid(_) | Accel::KdTree(_) => true,
            Accel::Wide(a) => a.has_repeats(),
        }
    }

    /// The structure's shape for drawing, in the numbering its traversal
    /// reports to a [`crate::counters::Recorder`] (see [`Layout::index`]).
    pub fn layout(&self) -> Layout {
        match self {
            Accel::List(_) => Layout::List,
            Accel::Bvh(a) => a.layout(),
            Accel::Grid(a) => a.layout(),
            Accel::KdTree(a) => a.layout(),
            Accel::Wide(a) => a.layout(),
        }
    }
}

impl Accelerator for Accel {
    fn unbounded(&self) -> &[PrimitiveId] {
        match self {
            Accel::List(a) => a.unbounded(),
            Accel::Bvh(a) => a.unbounded(),
            Accel::Grid(a) => a.unbounded(),
            Accel::KdTree(a) => a.unbounded(),
            Accel::Wide(a) => a.unbounded(),
        }
    }

    fn closest_bounded<C, F>(&self, ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        match self {
            Accel::List(a) => a.closest_bounded(ray, counters, hit),
            Accel::Bvh(a) => a.closest_bounded(ray, counters, hit),
            Accel::Grid(a) => a.closest_bounded(ray, counters, hit),
            Accel::KdTree(a) => a.closest_bounded(ray, counters, hit),
            Accel::Wide(a) => a.closest_bounded(ray, counters, hit),
        }
    }

    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        match self {
            Accel::List(a) => a.occluded_bounded(ray, counters, hit),
            Accel::Bvh(a) => a.occluded_bounded(ray, counters, hit),
            Accel::Grid(a) => a.occluded_bounded(ray, counters, hit),
            Accel::KdTree(a) => a.occluded_bounded(ray, counters, hit),
            Accel::Wide(a) => a.occluded_bounded(ray, counters, hit),
        }
    }

    fn stats(&self) -> AccelStats {
        match self {
            Accel::List(a) => a.stats(),
            Accel::Bvh(a) => a.stats(),
            Accel::Grid(a) => a.stats(),
            Accel::KdTree(a) => a.stats(),
            Accel::Wide(a) => a.stats(),
        }
    }
}
