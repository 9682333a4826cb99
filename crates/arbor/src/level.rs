//! One level of a traced scene: geometry in one space with its
//! acceleration structure and the frame that turns `f64` rays into
//! conservative `f32` ones, and the helpers the flat tracer
//! ([`crate::tracer`]) and the nested one ([`crate::nested`]) share to go
//! from one level into the next. Below both, so neither imports the other
//! for them.
//!
//! ## Precision
//!
//! The course's references are computed in `f64`, so every exact test here
//! is `f64`; the acceleration structures traverse in `f32` (as Embree does),
//! where they are fastest and most compact. Traversal only *culls*, so it
//! must be conservative: it may offer extra candidates but never skip one the
//! `f64` test would accept. Three things make it so:
//!
//! 1. Each primitive's `f64` box is rounded outward to `f32` and grown by a
//!    pad `p = 2^-19 M`, where `M` is the largest coordinate magnitude of the
//!    scene's bounds.
//! 2. The `f64` ray is first advanced to where it enters the (padded) scene
//!    box, at `t0` (`tmin` itself for a ray that starts inside, as every
//!    shadow ray does); only then is it rounded to `f32`. Rounding the origin
//!    (now within `M` of the scene) and the direction moves the point at any
//!    parameter inside the scene by at most about `9 u M = 2^-20.8 M`
//!    (`u = 2^-24`; the origin contributes `u M`, the direction `u t |d|` with
//!    `t |d|` at most the box diagonal `2 sqrt(3) M`, doubled for the
//!    arithmetic), which is less than `p`. So wherever the `f64` ray is inside
//!    a primitive's box, the `f32` ray is inside the padded `f32` box at the
//!    same parameter (shifted by `t0`).
//! 3. The slab test itself is conservative to its rounding (see
//!    `arbor_accel::Aabb::intersect`), and the culling distance handed back
//!    to traversal is the best `f64` hit rounded *up* to `f32`.
//!
//! Candidates are re-evaluated exactly in `f64`; ties between primitives at
//! the same `t` go to the lower primitive index, so every accelerator gives
//! the same answer as brute force.
//!

// The accelerators' `f32` ray, which traversal uses; the queries take `f64` [`Ray`]s.
use arbor_accel::numerics::f32_at_or_above;
use arbor_accel::Ray as TraversalRay;
use arbor_accel::{Accel, AccelKind, Accelerator, Counters, NoCounters, RayCounts, Vec3};
use glam::{DAffine3, DVec3};
use rayon::prelude::*;

use crate::flatten::{to_f32_box, FlatGeometry, Hit, Placement};
use crate::ray::Ray;
use crate::surface::{corner_bounds, Candidate};

/// Relative size of the box pad, see the module documentation.
const PAD_SCALE: f64 = 1.0 / (1u64 << 19) as f64;

/// Counters that can be split for a nested traversal and merged back.
pub trait SplitCounters: Counters + Default {
    /// Whether [`SplitCounters::reach_level`] is wanted where it takes work
    /// to say (a geometry level's entry); `false` leaves that work out.
    const RECORDS_LEVELS: bool = false;
    /// Adds `other`'s counts to these.
    fn merge(&mut self, other: Self);
    /// The counts that follow (on the split-off counters) are placement
    /// `placement`'s bottom-level traversal; for recorders
    /// ([`crate::traversal::TraversalRecord`]), which keep levels apart.
    #[inline(always)]
    fn enter_placement(&mut self, _placement: u32) {}
    /// The ray entered a placement: one instance level deeper (counted by
    /// `--stats`, [`crate::stats::RayWork`]).
    #[inline(always)]
    fn enter_level(&mut self) {}
    /// The nested tracer reached a level: through `path` (the item taken
    /// at each level from the world down), the level of definition
    /// `definition` (`geometry`: that definition's own geometry rather than
    /// its child placements), whose box the ray enters at `t`, or `None`
    /// when it misses the box before the closest hit so far (culled). For
    /// recorders ([`crate::nested::NestedRecord`]), which say where a ray
    /// went; a no-op for the render's counters.
    #[inline(always)]
    fn reach_level(&mut self, _path: &[u32], _definition: u32, _geometry: bool, _t: Option<f64>) {}
    /// The nested tracer found a hit at `t`, closer than any before, through
    /// the items `path`; for recorders, as [`SplitCounters::reach_level`].
    #[inline(always)]
    fn closer_hit(&mut self, _path: &[u32], _t: f64) {}
}

impl SplitCounters for NoCounters {
    #[inline(always)]
    fn merge(&mut self, _: Self) {}
}

impl SplitCounters for RayCounts {
    fn merge(&mut self, other: Self) {
        *self += other;
    }
}

/// The coordinate frame of one level: its padded `f64` bounds, for turning
/// `f64` rays into conservative `f32` ones.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub(crate) bounds: Option<(DVec3, DVec3)>,
    /// How far every box of this level is grown (`PAD_SCALE` times its largest coordinate magnitude).
    pub(crate) pad: f64,
}

impl Frame {
    pub(crate) fn new(boxes: &[(DVec3, DVec3)]) -> Frame {
        let (lo, hi) = boxes.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), (a, b)| (lo.min(*a), hi.max(*b)),
        );
        let magnitude = lo.abs().max(hi.abs()).max_element();
        if boxes.is_empty() || !magnitude.is_finite() {
            return Frame {
                bounds: None,
                pad: 0.0,
            };
        }
        let pad = magnitude * PAD_SCALE + f64::MIN_POSITIVE;
        Frame {
            bounds: Some((lo - 2.0 * pad, hi + 2.0 * pad)),
            pad,
        }
    }

    /// The frame of `boxes` and a structure of `kind` over them, padded
    /// as the frame pads: what every level indexes its items with.
    pub(crate) fn indexed(kind: AccelKind, boxes: &[(DVec3, DVec3)]) -> (Frame, Accel) {
        let frame = Frame::new(boxes);
        let accel = Accel::build(kind, &frame.boxes(boxes));
        (frame, accel)
    }

    pub(crate) fn boxes(&self, boxes: &[(DVec3, DVec3)]) -> Vec<arbor_accel::Aabb> {
        boxes
            .par_iter()
            .map(|(a, b)| to_f32_box(*a, *b, self.pad))
            .collect()
    }

    /// The `f32` ray for traversal, starting where the `f64` ray enters the
    /// padded bounds, and that entry parameter `t0`; `None` when the ray
    /// misses them.
    pub(crate) fn f32_ray(&self, ray: &Ray) -> Option<(TraversalRay, f64)> {
        let (lo, hi) = self.bounds?;
        let (o, d, tmin, tmax) = (ray.origin, ray.direction, ray.tmin, ray.tmax);
        let t0 = if tmin >= 0.0 && o.cmpge(lo).all() && o.cmple(hi).all() {
            // From inside the bounds (shadow and secondary rays, a camera
            // in the scene) the entry below is `tmin` itself, without its
            // three divisions. The test below would also drop a ray whose
            // `tmin` lies past its exit; no hit lies there (the bounds are
            // padded well beyond every primitive), so answers are the same.
            if tmin.partial_cmp(&tmax).is_none_or(|o| o.is_gt()) {
                return None;
            }
            tmin
        } else {
            let inv = d.recip();
            let a = (lo - o) * inv;
            let b = (hi - o) * inv;
            let on_plane = a.is_nan_mask() | b.is_nan_mask();
            let near = DVec3::select(on_plane, DVec3::NEG_INFINITY, a.min(b)).max_element();
            let far = DVec3::select(on_plane, DVec3::INFINITY, a.max(b)).min_element();
            let t0 = near.max(tmin);
            // Written so that a NaN (a degenerate ray) also misses.
            if t0.partial_cmp(&far.min(tmax)).is_none_or(|o| o.is_gt()) {
                return None;
            }
            t0
        };
        let start = ray.at(t0);
        let ray = TraversalRay::new(
            Vec3::new(start.x as f32, start.y as f32, start.z as f32),
            Vec3::new(d.x as f32, d.y as f32, d.z as f32),
            // tmin relative to the shifted origin (zero or negative), rounded down.
            -cull_distance(t0 - tmin),
            cull_distance(tmax - t0),
        );
        Some((ray, t0))
    }
}

/// Whether a candidate at `t` from top-level primitive `prim` beats `best`:
/// nearer, or equally near and earlier in the scene.
pub(crate) fn beats(t: f64, prim: u32, best: Option<(u32, f64)>) -> bool {
    match best {
        None => true,
        Some((p, b)) => t < b || (t == b && prim < p),
    }
}

/// One level: geometry in one space with its acceleration structure.
pub(crate) struct Level {
    pub(crate) scene: FlatGeometry,
    pub(crate) accel: Accel,
    pub(crate) frame: Frame,
}

impl Level {
    pub(crate) fn new(scene: FlatGeometry, kind: AccelKind) -> Level {
        let boxes: Vec<_> = (0..scene.len()).map(|i| scene.bounds(i)).collect();
        let (frame, accel) = Frame::indexed(kind, &boxes);
        Level {
            scene,
            accel,
            frame,
        }
    }

    /// The nearest primitive hit in `(tmin, tmax)`, offering only candidates
    /// up to `cull` (a known hit elsewhere); `cull >= tmax` offers all.
    pub(crate) fn closest<C: Counters>(
        &self,
        ray: &Ray,
        cull: f64,
        counters: &mut C,
    ) -> Option<(u32, Candidate)> {
        let (ray32, t0) = self
            .frame
            .f32_ray(&ray.with_interval(ray.tmin, ray.tmax.min(cull)))?;
        let mut best: Option<(u32, Candidate)> = None;
        self.accel.closest(&ray32, counters, |prim, _| {
            let c = self.scene.intersect(prim as usize, ray)?;
            if c.t > cull || !beats(c.t, prim, best.map(|(p, b)| (p, b.t))) {
                return None;
            }
            best = Some((prim, c));
            Some(cull_distance(c.t - t0))
        });
        best
    }

    pub(crate) fn occluded<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        let Some((ray32, _)) = self.frame.f32_ray(ray) else {
            return false;
        };
        self.accel.occluded(&ray32, counters, |prim, _| {
            self.scene.intersect(prim as usize, ray).is_some()
        })
    }
}

/// The world-space hit record of primitive `prim` of `scene` (the geometry
/// `p` places) hit by the world `ray` at `candidate`; shared by the flat and
/// the nested tracer so that both shade a hit the same way.
pub(crate) fn placed_hit<'a>(
    p: &Placement,
    scene: &'a FlatGeometry,
    prim: u32,
    ray: &Ray,
    candidate: Candidate,
) -> Hit<'a> {
    let local = scene.hit(prim as usize, &local_ray(p, ray), candidate);
    Hit {
        t: candidate.t,
        point: ray.at(candidate.t),
        normal: p.normal_to_world(local.normal),
        uv: local.uv,
        color: local.color,
        // Geometry space to world: the inverse of the placement's.
        shadow_offset: if local.shadow_offset == DVec3::ZERO {
            DVec3::ZERO
        } else {
            p.inverse.matrix3.inverse() * local.shadow_offset
        },
        shader: local.shader,
    }
}

/// `ray` in the space of the geometry `p` places: transformed once, not
/// renormalised, so `t` names the same point in both spaces.
pub(crate) fn local_ray(p: &Placement, ray: &Ray) -> Ray {
    ray.with_line(
        p.inverse.transform_point3(ray.origin),
        p.inverse.transform_vector3(ray.direction),
    )
}

/// The world box of a local box under `m`: the box of its 8 transformed corners.
pub(crate) fn world_box(m: &DAffine3, lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    corner_bounds(lo, hi, |c| m.transform_point3(c))
}

/// `t` rounded up to `f32` and one step more, so that rounding in the
/// subtraction that produced it can never make culling reject a box holding
/// a hit at exactly `t`.
pub(crate) fn cull_distance(t: f64) -> f32 {
    if t == f64::INFINITY {
        return f32::INFINITY;
    }
    f32_at_or_above(t).next_up()
}
