//! # arbor-accel
//!
//! Ray casting building blocks that know nothing of scenes, shaders or files:
//! rays, bounding boxes, a watertight ray/triangle test, and acceleration
//! structures that index *any* set of primitives through the [`Primitives`]
//! trait. The caller supplies the exact primitive test as a closure at query
//! time, so the same structure serves triangle soups, analytic spheres or
//! whole transformed instances.
//!
//! Every structure answers exactly what the brute-force [`List`] answers; they
//! differ only in speed. Traversal runs in `f32`, conservatively: a box test
//! never rejects a box that the ray touches in exact arithmetic (see
//! [`Aabb::intersect`]), so a caller whose exact test runs in `f64` loses no hit
//! as long as its primitive boxes (and [`Primitives::clipped_bounds`]) enclose
//! what its test can hit, i.e. the test reports hits only where the primitive
//! really is ([`intersect_triangle`] guarantees this for triangles).
//!
//! Structures ([`AccelKind`] names them): [`List`] (brute force), [`Bvh`] with
//! five builders ([`BvhBuilder`]), the 8-wide [`WideBvh`] collapsed from the
//! binned-SAH tree, the uniform [`Grid`] and the SAH [`KdTree`];
//! [`Accel`] holds any of them. Bounding volumes: [`Aabb`], [`BoundingSphere`],
//! [`Obb`]. The design, error bounds, constants and measurements are written up
//! in `docs/acceleration.md`.

#![warn(missing_docs)]

mod aabb;
mod accel;
mod bvh;
mod counters;
mod grid;
mod kdtree;
mod list;
mod mesh;
mod obb;
mod primitives;
mod ray;
mod sphere;
mod triangle;
mod triangle_lanes;
mod util;

pub use aabb::{widen_exit, Aabb, SLAB_TFAR_SCALE, SLAB_TFAR_SCALE_NEGATIVE};
pub use accel::{Accel, AccelKind, AccelParams, AccelStats, Accelerator, UnknownAccel};
pub use bvh::{one_octant, Bvh, BvhBuilder, BvhNode, BvhParams, TriangleBvh, WideBvh, PACKET};
pub use counters::{Counters, NoCounters, RayCounts};
pub use grid::{Grid, GridParams};
pub use kdtree::{KdParams, KdTree};
pub use list::List;
pub use mesh::{AllHits, ClosestPoint, MeshAccel, MeshError, MeshHit, INSIDE_DIRECTION};
pub use obb::Obb;
pub use primitives::Primitives;
pub use ray::Ray;
pub use sphere::BoundingSphere;
pub use triangle::{
    clip_triangle_bounds, intersect_triangle, intersect_triangle_owned, intersect_triangle_sheared,
    is_degenerate, RayShear, TriangleHit, TriangleMesh,
};

/// The vector type of the public API (re-exported so users need not depend on glam).
pub use glam::Vec3;
