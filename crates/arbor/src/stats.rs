//! Render statistics that cost nothing when switched off.
//!
//! The integrator is generic over a [`RayStats`] sink and is monomorphised
//! once per sink: with [`NoStats`] every query goes through the tracer with
//! `NoCounters` and every `record` call is an empty inline function, so the
//! code is the same as if statistics did not exist (no runtime branch in the
//! hot loop). [`RenderStats`] counts rays by kind and the traversal work
//! (nodes visited, primitive tests) they caused.

use arbor_accel::{Counters, NoCounters, RayCounts};

use crate::tracer::SplitCounters;

/// What a traced ray was for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// A ray from the camera through a pixel sample.
    Camera,
    /// A shadow ray toward a light.
    Shadow,
    /// A mirror reflection (glazed and glass surfaces, total internal reflection).
    Reflection,
    /// A refracted ray through glass.
    Refraction,
}

impl RayKind {
    /// Every kind, in the order reports list them.
    pub const ALL: [RayKind; 4] = [
        RayKind::Camera,
        RayKind::Shadow,
        RayKind::Reflection,
        RayKind::Refraction,
    ];

    /// The name reports use.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Camera => "camera",
            RayKind::Shadow => "shadow",
            RayKind::Reflection => "reflection",
            RayKind::Refraction => "refraction",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// A sink for per-ray statistics, one per worker (merged at the end).
pub trait RayStats: Default + Send {
    /// The traversal counters handed to the tracer for each ray.
    type Counters: SplitCounters;
    /// One ray of `kind` was traced and caused the work in `counts`.
    fn record(&mut self, kind: RayKind, counts: Self::Counters);
    /// Adds another worker's statistics to these.
    fn merge(&mut self, other: Self);
}

/// Collects nothing; the default, and free.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl RayStats for NoStats {
    type Counters = NoCounters;
    #[inline(always)]
    fn record(&mut self, _: RayKind, _: NoCounters) {}
    #[inline(always)]
    fn merge(&mut self, _: Self) {}
}

/// The traversal work of one ray: nodes and tests as arbor-accel counts
/// them, and the instance levels it entered (one per placement entered,
/// at any depth).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayWork {
    /// Nodes visited and primitives tested, every level.
    pub counts: RayCounts,
    /// Placements entered.
    pub levels: u64,
}

impl Counters for RayWork {
    #[inline(always)]
    fn node(&mut self) {
        self.counts.node();
    }
    #[inline(always)]
    fn test(&mut self) {
        self.counts.test();
    }
}

impl SplitCounters for RayWork {
    fn merge(&mut self, other: Self) {
        self.counts += other.counts;
        self.levels += other.levels;
    }
    #[inline(always)]
    fn enter_level(&mut self) {
        self.levels += 1;
    }
}

/// Rays and traversal work of one kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KindStats {
    /// Rays traced.
    pub rays: u64,
    /// Nodes (or grid cells) visited, both levels.
    pub nodes: u64,
    /// Exact primitive tests, both levels.
    pub tests: u64,
    /// Placements entered (instance levels, at any depth).
    pub levels: u64,
}

impl KindStats {
    /// Nodes visited per ray (0 without rays).
    pub fn nodes_per_ray(&self) -> f64 {
        per(self.nodes, self.rays)
    }

    /// Primitive tests per ray (0 without rays).
    pub fn tests_per_ray(&self) -> f64 {
        per(self.tests, self.rays)
    }

    /// Placements (instance levels) entered per ray (0 without rays).
    pub fn levels_per_ray(&self) -> f64 {
        per(self.levels, self.rays)
    }
}

fn per(n: u64, rays: u64) -> f64 {
    if rays == 0 {
        0.0
    } else {
        n as f64 / rays as f64
    }
}

/// Counts rays by kind with their traversal work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    kinds: [KindStats; 4],
}

impl RenderStats {
    /// The statistics of one ray kind.
    pub fn kind(&self, kind: RayKind) -> KindStats {
        self.kinds[kind.index()]
    }

    /// All kinds together.
    pub fn total(&self) -> KindStats {
        self.kinds
            .iter()
            .fold(KindStats::default(), |a, k| KindStats {
                rays: a.rays + k.rays,
                nodes: a.nodes + k.nodes,
                tests: a.tests + k.tests,
                levels: a.levels + k.levels,
            })
    }
}

impl RayStats for RenderStats {
    type Counters = RayWork;
    #[inline]
    fn record(&mut self, kind: RayKind, work: RayWork) {
        let k = &mut self.kinds[kind.index()];
        k.rays += 1;
        k.nodes += work.counts.nodes;
        k.tests += work.counts.tests;
        k.levels += work.levels;
    }

    fn merge(&mut self, other: Self) {
        for (a, b) in self.kinds.iter_mut().zip(other.kinds) {
            a.rays += b.rays;
            a.nodes += b.nodes;
            a.tests += b.tests;
            a.levels += b.levels;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One ray's work: `nodes`, `tests` and `levels` instance levels.
    fn work(nodes: u64, tests: u64, levels: u64) -> RayWork {
        RayWork {
            counts: RayCounts { nodes, tests },
            levels,
        }
    }

    #[test]
    fn records_and_merges_by_kind() {
        let mut a = RenderStats::default();
        a.record(RayKind::Camera, work(4, 2, 1));
        a.record(RayKind::Camera, work(2, 0, 2));
        let mut b = RenderStats::default();
        b.record(RayKind::Shadow, work(3, 1, 0));
        a.merge(b);
        assert_eq!(
            a.kind(RayKind::Camera),
            KindStats {
                rays: 2,
                nodes: 6,
                tests: 2,
                levels: 3,
            }
        );
        assert_eq!(a.kind(RayKind::Camera).levels_per_ray(), 1.5);
        assert_eq!(a.kind(RayKind::Camera).nodes_per_ray(), 3.0);
        assert_eq!(a.kind(RayKind::Shadow).rays, 1);
        assert_eq!(a.kind(RayKind::Refraction).nodes_per_ray(), 0.0);
        assert_eq!(a.total().rays, 3);
        assert_eq!(a.total().levels, 3);
    }
}

#[cfg(test)]
mod image_tests {
    use std::sync::atomic::AtomicBool;

    use super::*;
    use crate::flatten::{FlattenedScene, DEFAULT_MAX_PLACEMENTS};
    use crate::render::{render_region, render_region_with, Region};
    use crate::tracer::{Tracer, TracerOptions};

    /// Counting goes through a different monomorphisation of the integrator;
    /// the pixels must not notice.
    #[test]
    fn counting_does_not_change_the_image() {
        // The classroom has Lambertian, Phong, a glass globe and a glazed
        // ball, so every ray kind is traced.
        let scene = crate::default_scene::classroom();
        let flat = FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS).unwrap();
        let tracer = Tracer::build(flat, &TracerOptions::default());
        let region = Region {
            x0: 0,
            y0: 0,
            x1: scene.width,
            y1: scene.height,
        };
        let cancel = AtomicBool::new(false);
        let plain = render_region(&scene, &tracer, region, &|_| {}, &cancel).unwrap();
        let (counted, stats) =
            render_region_with::<RenderStats>(&scene, &tracer, region, &|_| {}, &cancel).unwrap();
        let (none, _) =
            render_region_with::<NoStats>(&scene, &tracer, region, &|_| {}, &cancel).unwrap();
        assert!(plain == counted, "counting changed the image");
        assert!(plain == none);
        let s = scene.samples_per_side as u64;
        let camera = stats.kind(RayKind::Camera);
        assert_eq!(camera.rays, region.area() * s * s);
        assert!(camera.nodes_per_ray() >= 1.0);
        assert!(camera.tests_per_ray() > 0.0);
        for kind in [RayKind::Shadow, RayKind::Reflection, RayKind::Refraction] {
            assert!(stats.kind(kind).rays > 0, "no {} rays", kind.name());
        }
    }
}
