//! Ray queries against a flattened scene through an acceleration structure.
//!
//! The conservative `f32` traversal under `f64` exact tests is
//! [`crate::level`]'s (see its Precision section).
//!
//! ## Two levels
//!
//! A [`Tracer`] indexes the world-space primitives and the placements of
//! shared geometry in one top-level structure; each shared geometry has its
//! own bottom-level structure in its own space. A ray entering a placement's
//! box is transformed once into that space (not renormalised, so `t` is the
//! same in both) and traced through the bottom level, culled by the best hit
//! so far. Each level applies the precision argument above to its own
//! coordinates.

use std::sync::atomic::{AtomicU64, Ordering};

// The accelerators' `f32` ray, which traversal uses; the queries take `f64` [`Ray`]s.
use arbor_accel::Ray as TraversalRay;
use arbor_accel::{Aabb, Accel, AccelKind, Accelerator, BoundingSphere, NoCounters, Obb};
use glam::DVec3;
use rayon::prelude::*;

use crate::flatten::{to_f32_box, FlatGeometry, FlattenedScene, Hit, Placement};
pub use crate::level::SplitCounters;
use crate::level::{beats, cull_distance, local_ray, placed_hit, world_box, Frame, Level};
use crate::nested::NestedTracer;
use crate::ray::Ray;
use crate::scene::Variant;
use crate::surface::Candidate;

/// Which primitive a ray hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HitId {
    /// The top-level primitive: a world primitive's index, or the number
    /// of world primitives plus the placement (as the statistics count).
    pub primitive: u32,
    /// For a placement: the placement and the primitive within its shared
    /// geometry.
    pub shared: Option<(u32, u32)>,
}

/// Where the nearest hit of a top-level query lies.
#[derive(Clone, Copy)]
enum Found {
    World(u32, Candidate),
    Shared {
        placement: u32,
        prim: u32,
        candidate: Candidate,
    },
}

impl Found {
    fn t(&self) -> f64 {
        match self {
            Found::World(_, c) => c.t,
            Found::Shared { candidate, .. } => candidate.t,
        }
    }
}

/// The bounding volume wrapped around each top-level object by
/// `arbor render --bvol` (the lecture's bounded surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoundingVolumeKind {
    /// A bounding sphere (Ritter's fit).
    Sphere,
    /// An axis-aligned box (slab test).
    Aabb,
    /// An oriented box along the principal axes of the object's points.
    Obb,
}

impl std::str::FromStr for BoundingVolumeKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let names = [
            ("sphere", BoundingVolumeKind::Sphere),
            ("aabb", BoundingVolumeKind::Aabb),
            ("obb", BoundingVolumeKind::Obb),
        ];
        crate::option_names::parse(s, "bounding volume", &names)
    }
}

/// A bounding volume fitted around one object of `--bvol`, in world space;
/// its tests are conservative (`arbor-accel`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FittedVolume {
    /// A bounding sphere.
    Sphere(BoundingSphere),
    /// An axis-aligned box.
    Aabb(Aabb),
    /// An oriented box (an axis-aligned one when the points give no axes).
    Obb(Obb),
}

impl FittedVolume {
    fn fit(kind: BoundingVolumeKind, boxes: &[Aabb]) -> FittedVolume {
        let all = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let corners = || boxes.iter().flat_map(|b| b.corners()).collect::<Vec<_>>();
        match kind {
            BoundingVolumeKind::Aabb => FittedVolume::Aabb(all),
            BoundingVolumeKind::Sphere => {
                FittedVolume::Sphere(BoundingSphere::from_points(&corners()))
            }
            BoundingVolumeKind::Obb => match Obb::from_points(&corners()) {
                Some(obb) => FittedVolume::Obb(obb),
                None => FittedVolume::Aabb(all),
            },
        }
    }

    fn hit(&self, ray: &TraversalRay) -> bool {
        match self {
            FittedVolume::Sphere(s) => s.intersect(ray).is_some(),
            FittedVolume::Aabb(b) => b.intersect(ray, ray.inv_dir()).is_some(),
            FittedVolume::Obb(o) => o.intersect(ray).is_some(),
        }
    }
}

/// What the bounding volumes of `--bvol` did.
#[derive(Debug, Default)]
pub struct VolumeStats {
    /// Rays tested against an object's volume.
    pub tests: AtomicU64,
    /// Of those, rays that missed it.
    pub misses: AtomicU64,
    /// Primitive tests skipped because the ray missed the volume (the
    /// object's primitive count, per miss: what brute force inside it would cost).
    pub saved: AtomicU64,
}

/// How [`Tracer::build`] builds; [`Default`] is what `arbor render` builds
/// without options.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TracerOptions {
    /// The acceleration structure of both levels (`--accel`).
    pub accel: AccelKind,
    /// A bounding volume around each object of [`FlattenedScene::bounded`],
    /// tested before anything inside it (`--bvol`); `None` for none. A
    /// flattening without objects ([`FlattenedScene::new`]) gets none either way.
    pub bounding_volume: Option<BoundingVolumeKind>,
}

impl Default for TracerOptions {
    fn default() -> Self {
        TracerOptions {
            accel: AccelKind::DEFAULT,
            bounding_volume: None,
        }
    }
}

impl TracerOptions {
    /// The default options with structures of `accel`.
    pub fn with_accel(accel: AccelKind) -> TracerOptions {
        TracerOptions {
            accel,
            ..TracerOptions::default()
        }
    }
}

/// A flattened scene with its acceleration structures: ray queries in `f64`.
pub struct Tracer {
    world: FlatGeometry,
    shared: Vec<Level>,
    placements: Vec<Placement>,
    top: Accel,
    frame: Frame,
    kind: AccelKind,
    /// Per placement, the bounding volume that gates it (`--bvol`); empty
    /// when there are none.
    volumes: Vec<Option<FittedVolume>>,
    volume_stats: VolumeStats,
    /// Nested levels ([`Tracer::from_nested`]): when present, every query
    /// goes there and the two flat levels above are empty.
    nested: Option<Box<NestedTracer>>,
}

impl Tracer {
    /// Builds the structures `options` ask for over `flat`: one per shared
    /// geometry, one over the world primitives and the placements, and the
    /// bounding volumes of its objects if asked for.
    pub fn build(flat: FlattenedScene, options: &TracerOptions) -> Tracer {
        let objects = flat.objects.clone();
        let mut tracer = Tracer::build_levels(flat, options.accel);
        if let Some(volume) = options.bounding_volume {
            tracer.volumes = tracer.fit_volumes(&objects, volume);
        }
        tracer
    }

    /// Per placement, the bounding volume of kind `volume` around it if it
    /// is one of `objects`.
    fn fit_volumes(
        &self,
        objects: &[u32],
        volume: BoundingVolumeKind,
    ) -> Vec<Option<FittedVolume>> {
        let mut volumes: Vec<Option<FittedVolume>> =
            (0..self.placements.len()).map(|_| None).collect();
        for &o in objects {
            let level = &self.shared[self.placements[o as usize].geometry as usize];
            // Objects are placed by the identity: their boxes are world boxes.
            let boxes: Vec<Aabb> = (0..level.scene.len())
                .map(|i| {
                    let (a, b) = level.scene.bounds(i);
                    to_f32_box(a, b, self.frame.pad)
                })
                .collect();
            volumes[o as usize] = Some(FittedVolume::fit(volume, &boxes));
        }
        volumes
    }

    /// The bounding volumes of `--bvol`, each with the placement it gates
    /// (its top-level primitive is the world's primitive count plus the
    /// placement); none without `--bvol`.
    pub fn bounding_volumes(&self) -> impl Iterator<Item = (usize, &FittedVolume)> {
        self.volumes
            .iter()
            .enumerate()
            .filter_map(|(p, v)| v.as_ref().map(|v| (p, v)))
    }

    /// What the bounding volumes did so far (all zero without `--bvol`).
    pub fn volume_stats(&self) -> &VolumeStats {
        &self.volume_stats
    }

    /// Whether placement `p` may be entered by `ray` (the top-level `f32`
    /// ray): always, unless a bounding volume gates it and the ray misses it.
    fn enters(&self, p: usize, ray: &TraversalRay) -> bool {
        let Some(Some(volume)) = self.volumes.get(p) else {
            return true;
        };
        self.volume_stats.tests.fetch_add(1, Ordering::Relaxed);
        if volume.hit(ray) {
            return true;
        }
        self.volume_stats.misses.fetch_add(1, Ordering::Relaxed);
        let level = &self.shared[self.placements[p].geometry as usize];
        self.volume_stats
            .saved
            .fetch_add(level.scene.len() as u64, Ordering::Relaxed);
        false
    }

    /// Builds structures of `kind` at both levels, without bounding volumes.
    fn build_levels(flat: FlattenedScene, kind: AccelKind) -> Tracer {
        let shared: Vec<Level> = flat
            .shared
            .into_par_iter()
            .map(|s| Level::new(s, kind))
            .collect();
        let world = flat.world;
        let placements = flat.placements;
        let mut boxes: Vec<(DVec3, DVec3)> = (0..world.len()).map(|i| world.bounds(i)).collect();
        let placement_boxes: Vec<(DVec3, DVec3)> = placements
            .par_iter()
            .map(|p| {
                let level = &shared[p.geometry as usize];
                match level.frame.bounds {
                    Some((lo, hi)) => world_box(&p.inverse.inverse(), lo, hi),
                    None => (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                }
            })
            .collect();
        boxes.extend(placement_boxes);
        let (frame, top) = Frame::indexed(kind, &boxes);
        Tracer {
            world,
            shared,
            placements,
            top,
            frame,
            kind,
            volumes: Vec::new(),
            volume_stats: VolumeStats::default(),
            nested: None,
        }
    }

    /// A tracer over the nested levels `nested` (built with structures of
    /// `kind` for a scene of `variant`): the same queries with the same
    /// answers as the flat tracer of the same scene; its flat levels
    /// ([`Tracer::scene`], [`Tracer::accel`], placements) are empty.
    pub fn from_nested(nested: NestedTracer, kind: AccelKind, variant: Variant) -> Tracer {
        let frame = Frame::new(&[]);
        Tracer {
            world: FlatGeometry::empty(variant),
            shared: Vec::new(),
            placements: Vec::new(),
            top: Accel::build(kind, &frame.boxes(&[])),
            frame,
            kind,
            volumes: Vec::new(),
            volume_stats: VolumeStats::default(),
            nested: Some(Box::new(nested)),
        }
    }

    /// The nested levels, when built so ([`Tracer::from_nested`]).
    pub fn nested(&self) -> Option<&NestedTracer> {
        self.nested.as_deref()
    }

    /// The world-space primitives.
    pub fn scene(&self) -> &FlatGeometry {
        &self.world
    }

    /// The top-level acceleration structure.
    pub fn accel(&self) -> &Accel {
        &self.top
    }

    /// The bottom-level structure of the shared geometry that placement
    /// `placement` places (in that geometry's own space).
    pub fn placement_accel(&self, placement: u32) -> &Accel {
        &self.shared[self.placements[placement as usize].geometry as usize].accel
    }

    /// Which structure this is.
    pub fn kind(&self) -> AccelKind {
        self.kind
    }

    /// Number of placements of shared geometry.
    pub fn placements(&self) -> usize {
        self.placements.len()
    }

    /// Bytes of all acceleration structures (both levels).
    pub fn accel_memory_bytes(&self) -> usize {
        self.nested.as_ref().map_or(0, |n| n.accel_memory_bytes())
            + self.top.stats().memory_bytes
            + self
                .shared
                .iter()
                .map(|l| l.accel.stats().memory_bytes)
                .sum::<usize>()
    }

    /// The nearest hit on `ray`.
    pub fn closest(&self, ray: &Ray) -> Option<Hit<'_>> {
        self.closest_counted(ray, &mut NoCounters)
    }

    /// [`Tracer::closest`], counting traversal work (both levels) into `counters`.
    pub fn closest_counted<C: SplitCounters>(
        &self,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<Hit<'_>> {
        if let Some(nested) = &self.nested {
            return nested.closest_counted(ray, counters);
        }
        let (_, found) = self.nearest(ray, counters)?;
        Some(self.hit_record(ray, found))
    }

    /// [`Tracer::closest_counted`], also naming the primitive hit (over
    /// nested levels, which have no flat numbering, the primitive is
    /// `u32::MAX`).
    pub fn closest_identified<C: SplitCounters>(
        &self,
        ray: &Ray,
        counters: &mut C,
    ) -> Option<(HitId, Hit<'_>)> {
        if let Some(nested) = &self.nested {
            let unnamed = HitId {
                primitive: u32::MAX,
                shared: None,
            };
            return nested.closest_counted(ray, counters).map(|h| (unnamed, h));
        }
        let (top, found) = self.nearest(ray, counters)?;
        let id = HitId {
            primitive: top,
            shared: match found {
                Found::World(..) => None,
                Found::Shared {
                    placement, prim, ..
                } => Some((placement, prim)),
            },
        };
        Some((id, self.hit_record(ray, found)))
    }

    /// The nearest hit on `ray` as the search found it (its top-level
    /// primitive and where it lies), before the full hit record: kept
    /// small, so that only the one record built at the end is large.
    fn nearest<C: SplitCounters>(&self, ray: &Ray, counters: &mut C) -> Option<(u32, Found)> {
        let (ray32, t0) = self.frame.f32_ray(ray)?;
        let n_world = self.world.len() as u32;
        let mut best: Option<(u32, Found)> = None;
        let mut inner = C::default();
        self.top.closest(&ray32, counters, |prim, top_ray| {
            let best_so_far = best.map(|(p, f)| (p, f.t()));
            let found = if prim < n_world {
                let c = self.world.intersect(prim as usize, ray)?;
                Found::World(prim, c)
            } else {
                let placement = prim - n_world;
                if !self.enters(placement as usize, top_ray) {
                    return None;
                }
                let p = &self.placements[placement as usize];
                let cull = best_so_far.map_or(ray.tmax, |(_, t)| t);
                let level = &self.shared[p.geometry as usize];
                inner.enter_placement(placement);
                inner.enter_level();
                let (local, candidate) = level.closest(&local_ray(p, ray), cull, &mut inner)?;
                Found::Shared {
                    placement,
                    prim: local,
                    candidate,
                }
            };
            if !beats(found.t(), prim, best_so_far) {
                return None;
            }
            best = Some((prim, found));
            Some(cull_distance(found.t() - t0))
        });
        counters.merge(inner);
        best
    }

    /// The full hit record of `found` on `ray`, in world space.
    fn hit_record(&self, ray: &Ray, found: Found) -> Hit<'_> {
        match found {
            Found::World(prim, c) => self.world.hit(prim as usize, ray, c),
            Found::Shared {
                placement,
                prim,
                candidate,
            } => {
                let p = &self.placements[placement as usize];
                placed_hit(
                    p,
                    &self.shared[p.geometry as usize].scene,
                    prim,
                    ray,
                    candidate,
                )
            }
        }
    }

    /// Whether anything lies on `ray`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_counted(ray, &mut NoCounters)
    }

    /// [`Tracer::occluded`], counting traversal work into `counters`.
    pub fn occluded_counted<C: SplitCounters>(&self, ray: &Ray, counters: &mut C) -> bool {
        if let Some(nested) = &self.nested {
            return nested.occluded_counted(ray, counters);
        }
        let Some((ray32, _)) = self.frame.f32_ray(ray) else {
            return false;
        };
        let n_world = self.world.len() as u32;
        let mut inner = C::default();
        let hit = self.top.occluded(&ray32, counters, |prim, _| {
            if prim < n_world {
                return self.world.intersect(prim as usize, ray).is_some();
            }
            let p = &self.placements[(prim - n_world) as usize];
            inner.enter_placement(prim - n_world);
            inner.enter_level();
            self.shared[p.geometry as usize].occluded(&local_ray(p, ray), &mut inner)
        });
        counters.merge(inner);
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::transformed::rotation_degrees;
    use glam::DAffine3;

    #[test]
    fn rotated_placement_box_contains_every_transformed_vertex() {
        // A thin tilted rod of vertices, its local box, and a rotated placement.
        let vertices: Vec<DVec3> = (0..50)
            .map(|i| {
                DVec3::new(
                    i as f64 * 0.1,
                    (i as f64 * 0.37).sin(),
                    -0.5 + (i % 7) as f64 * 0.1,
                )
            })
            .collect();
        let lo = vertices.iter().fold(DVec3::INFINITY, |a, v| a.min(*v));
        let hi = vertices.iter().fold(DVec3::NEG_INFINITY, |a, v| a.max(*v));
        for angles in [
            DVec3::new(30.0, 40.0, 50.0),
            DVec3::new(-90.0, 0.0, 45.0),
            DVec3::new(0.0, 180.0, 0.0),
        ] {
            let m = DAffine3::from_mat4(rotation_degrees(angles))
                * DAffine3::from_translation(DVec3::new(3.0, -1.0, 2.0));
            let (a, b) = world_box(&m, lo, hi);
            for v in &vertices {
                let w = m.transform_point3(*v);
                assert!(
                    w.cmpge(a - 1e-12).all() && w.cmple(b + 1e-12).all(),
                    "{angles}: {w} outside {a}..{b}"
                );
            }
        }
    }

    #[test]
    fn cull_distance_rounds_up() {
        for t in [0.0, 1e-9, 0.1, 1.0 / 3.0, 12345.678, 1e30] {
            assert!(cull_distance(t) as f64 > t, "{t}");
        }
        assert_eq!(cull_distance(f64::INFINITY), f32::INFINITY);
    }

    /// The tracer's culling (the `f32` ray from inside or outside the
    /// bounds, the box pad, the culling distance) loses no hit: against a
    /// plain loop over every primitive's exact test, on rays from inside
    /// the scene (as shadow rays start), from outside it and from far away,
    /// with open and closed intervals.
    #[test]
    fn culling_loses_nothing_against_every_exact_test() {
        let scene = crate::default_scene::classroom();
        let flat = FlatGeometry::new(&scene).unwrap();
        let tracer = Tracer::build(FlattenedScene::from_world(flat), &TracerOptions::default());
        let world = tracer.scene();
        let (lo, hi) = tracer.frame.bounds.unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = move || {
            // SplitMix64, as a fixed sequence of numbers in [0, 1).
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (z ^ (z >> 31)) as f64 / 2f64.powi(64)
        };
        let (mut hits, mut inside) = (0, 0);
        for k in 0..3000 {
            // Origins in the bounds grown by half their size on each side,
            // and every tenth ray from a hundred times as far.
            let grow = if k % 10 == 0 { 100.0 } else { 0.5 };
            let size = hi - lo;
            let o = lo - grow * size
                + DVec3::new(random(), random(), random()) * size * (1.0 + 2.0 * grow);
            // Half of them aimed at a point of the scene (hits), half anywhere.
            let d = if k % 2 == 0 {
                lo + DVec3::new(random(), random(), random()) * size - o
            } else {
                DVec3::new(random() - 0.5, random() - 0.5, random() - 0.5)
            };
            let (tmin, tmax) = match k % 3 {
                0 => (0.0, f64::INFINITY),
                1 => (1e-6, 1.0),
                _ => (random(), 1.0 + 10.0 * random()),
            };
            let ray = Ray::new(o, d, tmin, tmax);
            inside += usize::from(o.cmpge(lo).all() && o.cmple(hi).all());
            let brute = (0..world.len())
                .filter_map(|i| world.intersect(i, &ray).map(|c| (c.t, i)))
                .min_by(|a, b| a.partial_cmp(b).unwrap());
            let found = tracer.closest(&ray).map(|h| h.t);
            assert_eq!(found, brute.map(|(t, _)| t), "ray {k}: {ray:?}");
            assert_eq!(tracer.occluded(&ray), brute.is_some(), "ray {k}: {ray:?}");
            hits += usize::from(brute.is_some());
        }
        // Both kinds of origin, and enough hits to mean something.
        assert!(inside > 300 && inside < 2700, "{inside} origins inside");
        assert!(hits > 300, "{hits} hits");
    }
}
