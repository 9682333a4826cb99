//! Ray queries against a flattened scene through an acceleration structure.
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
//!    box, at `t0`; only then is it rounded to `f32`. Rounding the origin
//!    (now within `M` of the scene) and the direction moves the point at any
//!    parameter inside the scene by at most about `9 u M = 2^-20.8 M`
//!    (`u = 2^-24`; the origin contributes `u M`, the direction `u t |d|` with
//!    `t |d|` at most the box diagonal `2 sqrt(3) M`, doubled for the
//!    arithmetic), which is less than `p`. So wherever the `f64` ray is inside
//!    a primitive's box, the `f32` ray is inside the padded `f32` box at the
//!    same parameter (shifted by `t0`).
//! 3. The slab test itself is conservative to its rounding (Ize 2013, see
//!    `arbor_accel::Aabb::intersect`), and the culling distance handed back
//!    to traversal is the best `f64` hit rounded *up* to `f32`.
//!
//! Candidates are re-evaluated exactly in `f64`; ties between primitives at
//! the same `t` go to the lower primitive index, so every accelerator gives
//! the same answer as brute force.

use arbor_accel::{Accel, AccelKind, Accelerator, Counters, NoCounters, Ray, Vec3};
use glam::DVec3;

use crate::flatten::{to_f32_box, FlatScene, Hit};

/// A flattened scene with an acceleration structure over it.
pub struct Tracer {
    scene: FlatScene,
    accel: Accel,
    kind: AccelKind,
    /// Padded scene bounds in `f64` (empty scene: `None`).
    bounds: Option<(DVec3, DVec3)>,
}

/// Relative size of the box pad, see the module documentation.
const PAD_SCALE: f64 = 1.0 / (1u64 << 19) as f64;

impl Tracer {
    /// Builds an acceleration structure of `kind` over `scene`.
    pub fn new(scene: FlatScene, kind: AccelKind) -> Tracer {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for i in 0..scene.len() {
            let (a, b) = scene.bounds(i);
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let magnitude = lo.abs().max(hi.abs()).max_element();
        let (bounds, pad) = if scene.is_empty() || !magnitude.is_finite() {
            (None, 0.0)
        } else {
            let pad = magnitude * PAD_SCALE + f64::MIN_POSITIVE;
            (Some((lo - 2.0 * pad, hi + 2.0 * pad)), pad)
        };
        let boxes: Vec<_> = (0..scene.len())
            .map(|i| {
                let (a, b) = scene.bounds(i);
                to_f32_box(a, b, pad)
            })
            .collect();
        let accel = Accel::build(kind, &boxes);
        Tracer {
            scene,
            accel,
            kind,
            bounds,
        }
    }

    /// The flattened scene.
    pub fn scene(&self) -> &FlatScene {
        &self.scene
    }

    /// The acceleration structure.
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// Which structure this is.
    pub fn kind(&self) -> AccelKind {
        self.kind
    }

    /// The nearest hit of `o + t d` with `t` in `(tmin, tmax)`.
    pub fn closest(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<Hit<'_>> {
        self.closest_counted(o, d, tmin, tmax, &mut NoCounters)
    }

    /// [`Tracer::closest`], counting traversal work into `counters`.
    pub fn closest_counted<C: Counters>(
        &self,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
        counters: &mut C,
    ) -> Option<Hit<'_>> {
        let (ray, t0) = self.f32_ray(o, d, tmin, tmax)?;
        let mut best: Option<(u32, crate::surface::Candidate)> = None;
        self.accel.closest(&ray, counters, |prim, _| {
            let c = self.scene.intersect(prim as usize, o, d, tmin, tmax)?;
            let better = match best {
                None => true,
                Some((p, b)) => c.t < b.t || (c.t == b.t && prim < p),
            };
            if !better {
                return None;
            }
            best = Some((prim, c));
            Some(cull_distance(c.t - t0))
        });
        best.map(|(prim, c)| self.scene.hit(prim as usize, o, d, c))
    }

    /// Whether anything lies on `o + t d` with `t` in `(tmin, tmax)`.
    pub fn occluded(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        self.occluded_counted(o, d, tmin, tmax, &mut NoCounters)
    }

    /// [`Tracer::occluded`], counting traversal work into `counters`.
    pub fn occluded_counted<C: Counters>(
        &self,
        o: DVec3,
        d: DVec3,
        tmin: f64,
        tmax: f64,
        counters: &mut C,
    ) -> bool {
        let Some((ray, _)) = self.f32_ray(o, d, tmin, tmax) else {
            return false;
        };
        self.accel.occluded(&ray, counters, |prim, _| {
            self.scene
                .intersect(prim as usize, o, d, tmin, tmax)
                .is_some()
        })
    }

    /// The `f32` ray for traversal, starting where the `f64` ray enters the
    /// padded scene box, and that entry parameter `t0`; `None` when the ray
    /// misses the scene.
    fn f32_ray(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Option<(Ray, f64)> {
        let (lo, hi) = self.bounds?;
        let inv = d.recip();
        let a = (lo - o) * inv;
        let b = (hi - o) * inv;
        let on_plane = a.is_nan_mask() | b.is_nan_mask();
        let near = DVec3::select(on_plane, DVec3::NEG_INFINITY, a.min(b)).max_element();
        let far = DVec3::select(on_plane, DVec3::INFINITY, a.max(b)).min_element();
        let t0 = near.max(tmin);
        if t0 > far.min(tmax) {
            return None;
        }
        let start = o + t0 * d;
        let ray = Ray::new(
            Vec3::new(start.x as f32, start.y as f32, start.z as f32),
            Vec3::new(d.x as f32, d.y as f32, d.z as f32),
            // tmin relative to the shifted origin (zero or negative), rounded down.
            -cull_distance(t0 - tmin),
            cull_distance(tmax - t0),
        );
        Some((ray, t0))
    }
}

/// `t` rounded up to `f32` and one step more, so that rounding in the
/// subtraction that produced it can never make culling reject a box holding
/// a hit at exactly `t`.
fn cull_distance(t: f64) -> f32 {
    if t == f64::INFINITY {
        return f32::INFINITY;
    }
    let f = t as f32;
    let up = if (f as f64) < t { f.next_up() } else { f };
    up.next_up()
}
