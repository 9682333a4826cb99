//! [`MeshAccel`]: one owned type for every query against a triangle mesh,
//! whichever structure answers it.
//!
//! Built from vertex positions and index triples for any [`AccelKind`], it
//! answers the closest hit and occlusion (the default `bvh-wide` through
//! [`TriangleBvh`]'s four-at-a-time leaf test, every other kind through the
//! generic [`Accel`] with the watertight test), every crossing along a ray
//! and their count (`crossings.rs`), inside/outside and signed distance
//! (`inside.rs`), and the closest point (`closest_point.rs`). Each query
//! has a batch form over a slice that runs in parallel on the current rayon
//! pool. All structures give the same answers; they differ in speed.

mod closest_point;
mod crossings;
mod edges;
mod inside;
pub(crate) mod packet_query;
mod side_grid;
pub(crate) mod triangle_bvh;
mod winding;

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::accel::{Accel, AccelKind, AccelParams, AccelStats, Accelerator};
use crate::bvh2::Bvh;
use crate::counters::{Counters, NoCounters};
use crate::mesh::triangle_bvh::TriangleBvh;
use crate::primitives::PrimitiveId;
use crate::ray::Ray;
use crate::triangle::mesh::TriangleMesh;
use crate::triangle::watertight::{
    intersect_triangle_owned, intersect_triangle_sheared, RayShear, TriangleHit,
};
use crate::wide::packet::{PACKET, PACKET16};
use glam::Vec3;
use packet_query::{Closest, Occluded, PacketQuery};

pub use closest_point::ClosestPoint;
pub use crossings::AllHits;
pub use inside::INSIDE_DIRECTION;

/// Queries per rayon task in the batch forms: enough that scheduling costs
/// nothing next to the queries, few enough that both threads stay busy to
/// the end.
pub(crate) const PER_TASK: usize = 256;

/// The closest hit of a ray on a mesh: which triangle, and where on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Index of the triangle in the mesh.
    pub prim: PrimitiveId,
    /// Distance and barycentrics.
    pub hit: TriangleHit,
}

/// Why a mesh cannot be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// A triangle names a vertex that does not exist.
    IndexOutOfRange {
        /// The triangle.
        triangle: PrimitiveId,
        /// The index it holds.
        index: u32,
        /// How many vertices there are.
        vertices: usize,
    },
    /// More triangles than a [`PrimitiveId`] can name.
    TooManyTriangles(usize),
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::IndexOutOfRange {
                triangle,
                index,
                vertices,
            } => write!(
                f,
                "triangle {triangle} names vertex {index}, but the mesh has {vertices} vertices"
            ),
            MeshError::TooManyTriangles(n) => {
                write!(f, "{n} triangles: at most {} can be indexed", u32::MAX)
            }
        }
    }
}

impl std::error::Error for MeshError {}

/// A triangle mesh with an acceleration structure over it, answering ray
/// and point queries.
///
/// ```
/// use arbor_accel::{AccelKind, MeshAccel, Ray, Vec3};
///
/// // One triangle in the plane z = 0.
/// let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
/// let mesh = MeshAccel::build(vertices, vec![[0, 1, 2]], AccelKind::DEFAULT).unwrap();
/// let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
/// let hit = mesh.closest(&ray).unwrap();
/// assert_eq!((hit.prim, hit.hit.t), (0, 1.0));
/// assert!(mesh.occluded(&ray));
/// let near = mesh.closest_point(Vec3::new(2.0, 0.0, 0.0), f32::INFINITY).unwrap();
/// assert_eq!(near.point, Vec3::X);
/// ```
#[derive(Debug)]
pub struct MeshAccel {
    mesh: TriangleMesh,
    kind: AccelKind,
    index: Index,
    /// The structure of the point queries, a binary SAH BVH whatever `kind`
    /// is (nearest-first search needs a tree), built on first use.
    points: OnceLock<Bvh>,
    /// [`MeshAccel::open_edges`], counted on first use.
    open_edges: OnceLock<usize>,
    /// The inside test's lookup grid, built on first use (`None` where it
    /// would not pay).
    sides: OnceLock<Option<side_grid::SideGrid>>,
    /// The winding numbers' moments over `points`' nodes, built on first use.
    winding: OnceLock<winding::WindingTree>,
}

/// What answers the ray queries.
#[derive(Debug)]
enum Index {
    /// `bvh-wide`: the mesh-specialised wide BVH.
    Wide(TriangleBvh),
    /// Any other structure, each offered triangle tested here from its own
    /// contiguous copy (one 36-byte read instead of an index triple and three
    /// scattered vertices).
    Generic(Accel, Vec<[Vec3; 3]>),
}

/// The answers of query `Q` for `rays` as one packet of `N`, when they are
/// `N` rays that form one on this CPU ([`TriangleBvh::packet`]).
fn packet_answers<const N: usize, Q: PacketQuery>(
    bvh: &TriangleBvh,
    rays: &[Ray],
) -> Option<[Q::Answer; N]> {
    let rays = <&[Ray; N]>::try_from(rays).ok()?;
    bvh.packet::<N, _, Q>(rays, &mut NoCounters)
}

/// Answers `rays` as one packet of `N` into `slots` when they form one
/// ([`packet_answers`]); `false`, with nothing written, otherwise.
fn trace_packet<const N: usize, Q: PacketQuery>(
    bvh: &TriangleBvh,
    rays: &[Ray],
    slots: &mut [Q::Answer],
) -> bool {
    match packet_answers::<N, Q>(bvh, rays) {
        Some(answers) => {
            for (slot, answer) in slots.iter_mut().zip(answers) {
                *slot = answer;
            }
            true
        }
        None => false,
    }
}

impl MeshAccel {
    /// Builds a structure of `kind` over the triangles `triangles` (indices
    /// into `vertices`). Triangles with non-finite vertices are kept (the
    /// structures offer them to every ray; the test decides), degenerate
    /// ones never hit.
    pub fn build(
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        kind: AccelKind,
    ) -> Result<Self, MeshError> {
        Self::build_with(vertices, triangles, kind, &Self::params(kind))
    }

    /// The build parameters [`MeshAccel::build`] uses for `kind`: the
    /// library's defaults, except that `bvh-wide`'s SAH counts a leaf of
    /// `n` triangles as `ceil(n / 4)` tests (`TriangleBvh::params`), as its
    /// leaves test four at a time.
    pub fn params(kind: AccelKind) -> AccelParams {
        let mut params = AccelParams::default();
        if kind == AccelKind::BvhWide {
            params.bvh = TriangleBvh::params();
        }
        params
    }

    /// [`MeshAccel::build`] with explicit parameters (start from
    /// [`MeshAccel::params`]).
    pub fn build_with(
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        kind: AccelKind,
        params: &AccelParams,
    ) -> Result<Self, MeshError> {
        let Ok(count) = PrimitiveId::try_from(triangles.len()) else {
            return Err(MeshError::TooManyTriangles(triangles.len()));
        };
        for (triangle, t) in (0..count).zip(&triangles) {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(MeshError::IndexOutOfRange {
                    triangle,
                    index,
                    vertices: vertices.len(),
                });
            }
        }
        let mesh = TriangleMesh::new(vertices, triangles);
        let index = if kind == AccelKind::BvhWide {
            Index::Wide(TriangleBvh::build(&mesh, &params.bvh))
        } else {
            let tris = (0..count).map(|i| mesh.triangle(i)).collect();
            Index::Generic(Accel::build_with(kind, &mesh, params), tris)
        };
        Ok(MeshAccel {
            mesh,
            kind,
            index,
            points: OnceLock::new(),
            open_edges: OnceLock::new(),
            sides: OnceLock::new(),
            winding: OnceLock::new(),
        })
    }

    /// The vertex positions.
    pub fn vertices(&self) -> &[Vec3] {
        &self.mesh.vertices
    }

    /// The triangles, as indices into [`MeshAccel::vertices`].
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.mesh.triangles
    }

    /// The vertices of triangle `i`.
    pub fn triangle(&self, i: u32) -> [Vec3; 3] {
        self.mesh.triangle(i)
    }

    /// The structure answering the ray queries.
    pub fn kind(&self) -> AccelKind {
        self.kind
    }

    /// Size and shape of the ray queries' structure (triangle copies it
    /// holds included, the mesh itself not).
    pub fn stats(&self) -> AccelStats {
        match &self.index {
            Index::Wide(bvh) => bvh.stats(),
            Index::Generic(accel, tris) => {
                let mut stats = accel.stats();
                stats.memory_bytes += std::mem::size_of_val(tris.as_slice());
                stats
            }
        }
    }

    /// The closest hit within `[ray.tmin, ray.tmax]`. Of triangles hit at
    /// exactly the same distance (a shared edge), one is reported.
    pub fn closest(&self, ray: &Ray) -> Option<MeshHit> {
        self.closest_counted(ray, &mut NoCounters)
    }

    /// [`MeshAccel::closest`], counting nodes and tests into `counters`.
    #[inline]
    pub fn closest_counted<C: Counters>(&self, ray: &Ray, counters: &mut C) -> Option<MeshHit> {
        match &self.index {
            Index::Wide(bvh) => bvh.closest(ray, counters),
            Index::Generic(accel, tris) => {
                let shear = RayShear::new(ray);
                let mut best: Option<MeshHit> = None;
                accel.closest(ray, counters, |prim, r| {
                    let [a, b, c] = tris[prim as usize];
                    let hit = intersect_triangle_sheared(r, &shear, a, b, c)?;
                    // Spatial subdivision may offer a triangle again, and a
                    // neighbour at a shared edge may tie: the first one
                    // found at the smallest distance stays.
                    if best.is_none_or(|b| hit.t < b.hit.t) {
                        best = Some(MeshHit { prim, hit });
                    }
                    Some(hit.t)
                });
                best
            }
        }
    }

    /// Whether any triangle is hit within `[ray.tmin, ray.tmax]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_counted(ray, &mut NoCounters)
    }

    /// [`MeshAccel::occluded`], counting nodes and tests into `counters`.
    #[inline]
    pub fn occluded_counted<C: Counters>(&self, ray: &Ray, counters: &mut C) -> bool {
        match &self.index {
            Index::Wide(bvh) => bvh.occluded(ray, counters),
            Index::Generic(accel, tris) => {
                let shear = RayShear::new(ray);
                accel.occluded(ray, counters, |prim, r| {
                    let [a, b, c] = tris[prim as usize];
                    intersect_triangle_sheared(r, &shear, a, b, c).is_some()
                })
            }
        }
    }

    /// [`MeshAccel::closest`] for every ray, in parallel. Coherent rays
    /// (neighbouring camera rays: see [`MeshAccel::closest_batch_into`]) go
    /// through the wide BVH eight at a time.
    pub fn closest_batch(&self, rays: &[Ray]) -> Vec<Option<MeshHit>> {
        let mut out = vec![None; rays.len()];
        self.closest_batch_into(rays, &mut out);
        out
    }

    /// [`MeshAccel::closest_batch`] into `out` (`out.len() == rays.len()`).
    /// With `bvh-wide`, a stream that looks like camera rays (at least half
    /// of its first 64 groups of eight consecutive rays in one octant) is
    /// offered to the packet traversal in groups of sixteen (on a CPU with
    /// AVX-512; a group that is no packet tries its halves) or eight; the
    /// answers are each ray's closest hit either way.
    ///
    /// # Panics
    /// If `out` and `rays` differ in length.
    pub fn closest_batch_into(&self, rays: &[Ray], out: &mut [Option<MeshHit>]) {
        self.batch_into::<Closest>(rays, out, |ray| self.closest(ray));
    }

    /// [`MeshAccel::occluded`] for every ray, in parallel (coherent rays in
    /// packets, as in [`MeshAccel::closest_batch_into`]).
    pub fn occluded_batch(&self, rays: &[Ray]) -> Vec<bool> {
        let mut out = vec![false; rays.len()];
        self.occluded_batch_into(rays, &mut out);
        out
    }

    /// [`MeshAccel::occluded_batch`] into `out` (`out.len() == rays.len()`).
    ///
    /// # Panics
    /// If `out` and `rays` differ in length.
    pub fn occluded_batch_into(&self, rays: &[Ray], out: &mut [bool]) {
        self.batch_into::<Occluded>(rays, out, |ray| self.occluded(ray));
    }

    /// `single(ray)` for every ray into `out`, in parallel. With `bvh-wide`,
    /// a stream that looks like camera rays (at least half of its first 64
    /// groups of eight consecutive rays in one octant) goes through the
    /// packet query `Q` in groups of sixteen (on a CPU with AVX-512; a group
    /// that is no packet tries its halves) or eight, and the rays of groups
    /// that are no packet one by one; `Q` answers as `single` does.
    fn batch_into<Q: PacketQuery>(
        &self,
        rays: &[Ray],
        out: &mut [Q::Answer],
        single: impl Fn(&Ray) -> Q::Answer + Sync,
    ) {
        assert_eq!(rays.len(), out.len(), "one answer slot per ray");
        match &self.index {
            Index::Wide(bvh) if crate::wide::packet::looks_coherent(rays) => {
                let packet = crate::wide::packet::packet_width();
                out.par_chunks_mut(packet)
                    .zip(rays.par_chunks(packet))
                    .with_min_len(PER_TASK / packet)
                    .for_each(|(slots, rays)| {
                        if trace_packet::<PACKET16, Q>(bvh, rays, slots) {
                            return;
                        }
                        for (slots, rays) in slots.chunks_mut(PACKET).zip(rays.chunks(PACKET)) {
                            if !trace_packet::<PACKET, Q>(bvh, rays, slots) {
                                for (slot, ray) in slots.iter_mut().zip(rays) {
                                    *slot = single(ray);
                                }
                            }
                        }
                    })
            }
            _ => out
                .par_iter_mut()
                .zip(rays.par_iter())
                .with_min_len(PER_TASK)
                .for_each(|(slot, ray)| *slot = single(ray)),
        }
    }

    /// Calls `f` for every crossing of the surface within `ray`'s whole
    /// interval, each reported by the one triangle that owns it
    /// ([`intersect_triangle_owned`]), in no particular order; more than
    /// once where [`MeshAccel::offers_repeats`].
    fn for_each_crossing<C: Counters>(
        &self,
        ray: &Ray,
        counters: &mut C,
        mut f: impl FnMut(MeshHit),
    ) {
        match &self.index {
            // Four triangles at a time, as the closest-hit query.
            Index::Wide(bvh) => bvh.for_each_crossing(ray, counters, f),
            Index::Generic(accel, tris) => {
                let shear = RayShear::new(ray);
                // The callback never shrinks the ray, so every triangle whose
                // box the ray enters is offered; each is tested against the
                // whole ray (whatever part of it a cell passes), so a repeated
                // offer gives the same answer.
                accel.closest(ray, counters, |prim, _| {
                    let [a, b, c] = tris[prim as usize];
                    if let Some(hit) = intersect_triangle_owned(ray, &shear, a, b, c) {
                        f(MeshHit { prim, hit });
                    }
                    None
                })
            }
        }
    }

    /// Whether traversal may meet a triangle more than once (the grid and
    /// the k-d tree place a triangle in every cell or leaf it overlaps, a
    /// [`BuildQuality::High`](crate::accel::BuildQuality) tree in every leaf that
    /// holds a part of it); the crossing queries then drop the repeats.
    pub fn offers_repeats(&self) -> bool {
        match &self.index {
            Index::Wide(bvh) => bvh.has_repeats(),
            Index::Generic(accel, _) => accel.offers_repeats(),
        }
    }

    /// Builds the point queries' structures now rather than on the first
    /// point query (for timing the build apart from the queries): both of
    /// [`MeshAccel::prepare_closest_points`] and
    /// [`MeshAccel::prepare_inside`].
    pub fn prepare_point_queries(&self) {
        self.prepare_closest_points();
        self.prepare_inside();
    }

    /// Builds the closest-point tree now (it is otherwise built by the first
    /// closest-point or signed-distance query).
    pub fn prepare_closest_points(&self) {
        self.point_bvh();
    }

    /// Builds the inside test's grid now (where it pays: see
    /// [`MeshAccel::contains`]; otherwise built by the first inside or
    /// signed-distance query).
    pub fn prepare_inside(&self) {
        self.side_grid();
    }

    /// The inside test's lookup grid, built on first use; `None` where it
    /// would not pay (then the ray answers every point).
    fn side_grid(&self) -> Option<&side_grid::SideGrid> {
        self.sides
            .get_or_init(|| {
                let edges = edges::EdgeUses::of(self.vertices(), self.triangles());
                let _ = self.open_edges.set(edges.open());
                side_grid::SideGrid::build(self.vertices(), self.triangles(), &edges.odd(), |p| {
                    self.ray_parity(p)
                })
            })
            .as_ref()
    }

    /// Builds the winding numbers' moments (and the closest-point tree they
    /// sum over) now; otherwise built by the first winding-number query.
    pub fn prepare_winding_numbers(&self) {
        self.winding_tree();
    }

    /// The moments of [`MeshAccel::winding_number`], built on first use.
    fn winding_tree(&self) -> &winding::WindingTree {
        let bvh = self.point_bvh();
        self.winding
            .get_or_init(|| winding::WindingTree::build(bvh, |p| self.triangle(p)))
    }

    /// The binary BVH of the point queries (built on first use).
    fn point_bvh(&self) -> &Bvh {
        self.points.get_or_init(|| {
            Bvh::build(
                &self.mesh,
                crate::bvh2::BvhBuilder::BinnedSah,
                &crate::bvh2::BvhParams::default(),
            )
        })
    }
}
