//! # arbor-accel
//!
//! Ray casting building blocks that know nothing of scenes, shaders or files:
//! rays, bounding boxes, a watertight ray/triangle test, acceleration
//! structures, and [`MeshAccel`], which answers every common query against a
//! triangle mesh.
//!
//! ```
//! use arbor_accel::{AccelKind, MeshAccel, Ray, Vec3};
//!
//! // A unit square in the plane z = 0, as two triangles.
//! let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
//! let mesh = MeshAccel::build(vertices, vec![[0, 1, 2], [0, 2, 3]], AccelKind::DEFAULT)?;
//!
//! // The closest hit of one ray, and of many in parallel.
//! let down = Ray::new(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z, 0.0, f32::INFINITY);
//! let hit = mesh.closest(&down).expect("the ray hits the square");
//! assert_eq!((hit.prim, hit.hit.t), (1, 2.0));
//! let hits = mesh.closest_batch(&[down, Ray { origin: Vec3::splat(5.0), ..down }]);
//! assert!(hits[0].is_some() && hits[1].is_none());
//!
//! // Through the shared diagonal: one crossing, reported once.
//! let diagonal = Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
//! assert_eq!(mesh.count(&diagonal), 1);
//!
//! // The closest point of the mesh to a point, and its distance.
//! let near = mesh.closest_point(Vec3::new(0.5, 0.5, 3.0), f32::INFINITY).unwrap();
//! assert_eq!((near.point, near.distance), (Vec3::new(0.5, 0.5, 0.0), 3.0));
//! # Ok::<(), arbor_accel::MeshError>(())
//! ```
//!
//! Every structure ([`AccelKind`] names them: brute force [`list::List`],
//! the binary [`bvh2::Bvh`] with five builders ([`bvh2::BvhBuilder`]), the
//! 8-wide [`wide::WideBvh`], the uniform [`grid::Grid`] and the SAH
//! [`kdtree::KdTree`]) answers exactly what brute force answers; they differ
//! only in speed. They index *any* set of primitives through the
//! [`Primitives`] trait, and the caller supplies the exact primitive test as
//! a closure at query time ([`Accelerator`]), so the same structure serves
//! triangle soups, analytic spheres or whole transformed instances
//! ([`Accel`] holds any of them). Traversal runs in `f32`, conservatively: a
//! box test never rejects a box that the ray touches in exact arithmetic
//! ([`Aabb::intersect`]), so a caller whose exact test reports hits only
//! where its primitive really is loses none ([`intersect_triangle`]
//! guarantees this for triangles; [`numerics`] has its parts for callers
//! writing their own loops). Bounding volumes: [`Aabb`], [`BoundingSphere`],
//! [`Obb`]. The design, error bounds and constants are written up in
//! `docs/acceleration.md`, the queries' rules and file formats in
//! `docs/queries.md`.
//!
//! ## Where things are
//!
//! The root re-exports what a caller of the common path needs: rays and
//! bounds, [`AccelKind`] and [`Accel`] to build any structure, the
//! [`Accelerator`] queries, [`MeshAccel`] and its answers, the triangle test
//! and mesh, and the statistics counters. Each structure form has its own
//! public module, one folder or file per form:
//!
//! | module | what it holds |
//! | --- | --- |
//! | [`bvh2`] | the binary BVH: node layout, traversal, and its builders (`topdown.rs`: centre, median, binned SAH; `sweep.rs`; `ploc.rs`; `spatial.rs`: spatial splits) |
//! | [`wide`] | the 8-wide BVH collapsed from it, its SIMD box lanes and the ray packets |
//! | [`grid`], [`kdtree`], [`list`] | the uniform grid (3D-DDA), the SAH k-d tree, brute force |
//! | [`counters`], [`layout`] | traversal statistics and recording; a built structure's shape for drawing |
//! | `triangle/` | the watertight test (`watertight.rs`), its SIMD edge stage (`lanes.rs`), [`TriangleMesh`] (`mesh.rs`), exact clipping (`clip.rs`) |
//! | `mesh/` | [`MeshAccel`] and its queries, with `TriangleBvh` (the wide tree owning its triangles) and the packet queries |

#![warn(missing_docs)]

mod aabb;
mod accel;
pub mod bvh2;
pub mod counters;
pub mod grid;
pub mod kdtree;
pub mod layout;
pub mod list;
mod mesh;
mod morton;
mod obb;
mod primitives;
mod ray;
mod rounding;
mod sphere;
#[cfg(test)]
mod test_meshes;
mod triangle;
mod util;
pub mod wide;

pub use aabb::Aabb;
pub use accel::{
    Accel, AccelKind, AccelParams, AccelStats, Accelerator, BuildQuality, UnknownAccel,
};
pub use bvh2::{Bvh, BvhBuilder, BvhNode, BvhParams};
pub use counters::{Counters, NoCounters, RayCounts, Recorder};
pub use layout::{Layout, LayoutNode};
pub use mesh::{AllHits, ClosestPoint, MeshAccel, MeshError, MeshHit, INSIDE_DIRECTION};
pub use obb::Obb;
pub use primitives::{PrimitiveId, Primitives};
pub use ray::Ray;
pub use sphere::BoundingSphere;
pub use triangle::mesh::TriangleMesh;
pub use triangle::watertight::{intersect_triangle, TriangleHit};
pub use wide::WideBvh;

/// The exact arithmetic under the structures, for callers that write their
/// own traversal or triangle loop: the watertight test with the ray's shear
/// computed once ([`numerics::RayShear`]), its once-per-crossing form, the
/// slab test's exit widening and the exact clipping of a triangle to a box.
/// `docs/acceleration.md` ("Robustness") derives the bounds.
pub mod numerics {
    pub use crate::aabb::{widen_exit, SLAB_TFAR_SCALE, SLAB_TFAR_SCALE_NEGATIVE};
    pub use crate::rounding::{f32_at_or_above, f32_at_or_below};
    pub use crate::triangle::clip::clip_triangle_bounds;
    pub use crate::triangle::watertight::{
        intersect_triangle_owned, intersect_triangle_sheared, is_degenerate, RayShear,
    };
}

/// The vector type of the public API (re-exported so users need not depend on glam).
pub use glam::Vec3;

// The documentation's examples are compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/acceleration.md")]
mod acceleration_md {}
#[cfg(doctest)]
#[doc = include_str!("../../../docs/queries.md")]
mod queries_md {}
