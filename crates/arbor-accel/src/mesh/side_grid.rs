//! The side grid: a uniform grid over a mesh's box whose cells that no
//! triangle comes near are each known to lie inside or outside, so that
//! most inside/outside queries are a lookup instead of a ray.
//!
//! Why the lookup answers what the ray answers. The parity of the
//! crossings along the inside test's ray (direction `d`) changes only where
//! the point crosses a triangle, or crosses the *strip* `e - t d` (`t > 0`)
//! of an edge `e` that an odd number of triangles share (sweeping the ray
//! across such an edge adds or removes an odd number of crossings; a
//! closed mesh has none). The float test gets the parity right for every
//! point farther than rounding distance from these *walls*. A cell is
//! *near* when its box, grown by a margin thousands of times that rounding
//! distance, may meet a wall (a conservative test: it marks a superset of
//! the cells a wall touches). Face-adjacent cells that are not near lie in
//! one region of constant parity, so one ray per connected set of them
//! (from the first cell's centre) decides the whole set. Points in near
//! cells take the ray, and so do points outside the grid when there are
//! strips (which run on beyond it).

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::INSIDE_DIRECTION;
use glam::Vec3;

/// Cells per triangle the grid aims at: finer grids leave fewer points to
/// the ray but cost more to build and more cache (measured in
/// docs/perf-log/2026-12-02-side-grid.md).
const CELLS_PER_TRIANGLE: f64 = 4.0;

/// Bounds on the number of cells, whatever the triangle count.
const MIN_CELLS: f64 = 4096.0;
const MAX_CELLS: f64 = 16_777_216.0;

/// The margin, as a fraction of the box's largest extent: the float ray
/// test's error in the distance along the ray is a few units of f32
/// rounding (2^-24) of the distances involved, so 2^-12 leaves a factor of
/// thousands.
const MARGIN: f64 = 1.0 / 4096.0;

/// What the grid knows of a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Side {
    Inside,
    Outside,
    /// Near the surface: the ray decides.
    Near,
}

/// The grid (see the module documentation).
#[derive(Debug)]
pub(crate) struct SideGrid {
    /// Lower corner of cell (0, 0, 0).
    origin: DVec3,
    /// Cells per unit length (the same on every axis).
    per_unit: f64,
    dims: [usize; 3],
    /// Whether there are strips (then points outside the grid take the
    /// ray).
    strips: bool,
    /// One bit per cell: near the surface.
    near: Vec<u64>,
    /// One bit per cell: inside (meaningful where `near` is clear).
    inside: Vec<u64>,
}

impl SideGrid {
    /// The grid over `triangles`, with the strips of `odd_edges` (vertex
    /// index pairs of the edges an odd number of triangles share).
    /// `parity(p)` is the inside test's ray answer at `p`. `None` when the
    /// vertices are not all finite, span no extent, or the strips would make
    /// too much of the grid near to be worth it.
    pub(crate) fn build(
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        odd_edges: &[[u32; 2]],
        parity: impl Fn(Vec3) -> bool,
    ) -> Option<SideGrid> {
        if triangles.is_empty() || !vertices.iter().all(|v| v.is_finite()) {
            return None;
        }
        let (lo, hi) = vertices.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(v.as_dvec3()), hi.max(v.as_dvec3())),
        );
        let largest = (hi - lo).max_element();
        if largest.is_nan() || largest <= 0.0 {
            return None;
        }
        let margin = largest * MARGIN;
        let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
        let extent = (hi - lo).max(DVec3::splat(largest / 1024.0));
        let target = (triangles.len() as f64 * CELLS_PER_TRIANGLE).clamp(MIN_CELLS, MAX_CELLS);
        // A strip crosses about a grid's side of cells: past a few percent
        // of the grid near, the rays are cheaper than the grid.
        if odd_edges.len() as f64 > target.powf(2.0 / 3.0) / 8.0 {
            return None;
        }
        let cell = (extent.x * extent.y * extent.z / target).cbrt();
        // Two cells of room around the grown box: a triangle on its face
        // may mark the first (at equality), never the outer one, so that
        // with no strips a point outside the grid is in a region not near.
        let dims = ((hi - lo) / cell).ceil().max(DVec3::ONE);
        let dims = [
            dims.x as usize + 4,
            dims.y as usize + 4,
            dims.z as usize + 4,
        ];
        let mut grid = SideGrid {
            origin: lo - DVec3::splat(2.0 * cell),
            per_unit: 1.0 / cell,
            dims,
            strips: !odd_edges.is_empty(),
            near: Vec::new(),
            inside: Vec::new(),
        };
        let near: Vec<AtomicU64> = (0..grid.cells().div_ceil(64))
            .map(|_| AtomicU64::new(0))
            .collect();
        let corner = |i: u32| vertices[i as usize].as_dvec3();
        triangles.par_iter().with_min_len(1024).for_each(|t| {
            grid.mark_near(t.map(corner), &near, cell, margin);
        });
        // Far enough along -d to leave the grid from any point in it.
        let across = -INSIDE_DIRECTION.as_dvec3().normalize()
            * (DVec3::from(dims.map(|n| n as f64)) * cell).length();
        odd_edges.par_iter().for_each(|e| {
            let [a, b] = e.map(corner);
            grid.mark_near([a, b, b + across], &near, cell, margin);
            grid.mark_near([a, b + across, a + across], &near, cell, margin);
        });
        grid.near = near.into_iter().map(AtomicU64::into_inner).collect();
        grid.inside = grid.decide_regions(cell, parity);
        Some(grid)
    }

    fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    fn index(&self, [x, y, z]: [usize; 3]) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// `p` in cell units from the grid's corner.
    fn grid_coords(&self, p: DVec3) -> DVec3 {
        (p - self.origin) * self.per_unit
    }

    /// The cell at grid coordinates `q`, clamped to the grid.
    fn clamped_cell(&self, q: DVec3) -> [usize; 3] {
        let at = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        [
            at(q.x, self.dims[0]),
            at(q.y, self.dims[1]),
            at(q.z, self.dims[2]),
        ]
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell_of(&self, p: DVec3) -> [usize; 3] {
        self.clamped_cell(self.grid_coords(p))
    }

    /// What the grid knows of `p` (finite). Without strips a point outside
    /// the grid is in the region of the grid's outer layer (that layer is
    /// not near, and nothing separates it from the space around it).
    #[inline]
    pub(crate) fn side(&self, p: Vec3) -> Side {
        let q = self.grid_coords(p.as_dvec3());
        if self.strips {
            let dims = DVec3::from(self.dims.map(|n| n as f64));
            if !(q.cmpge(DVec3::ZERO).all() && q.cmplt(dims).all()) {
                return Side::Near;
            }
        }
        let i = self.index(self.clamped_cell(q));
        let bit = 1u64 << (i % 64);
        if self.near[i / 64] & bit != 0 {
            Side::Near
        } else if self.inside[i / 64] & bit != 0 {
            Side::Inside
        } else {
            Side::Outside
        }
    }

    /// Marks near every cell whose box grown by `margin` may meet the
    /// triangle `wall`: the cells of the triangle's grown bounding box,
    /// slab by slab in z (the triangle clipped to each grown slab, so that a
    /// long strip marks about as many cells as it crosses), whose grown box
    /// reaches the triangle's plane.
    fn mark_near(&self, wall: [DVec3; 3], near: &[AtomicU64], cell: f64, margin: f64) {
        let [a, b, c] = wall;
        let normal = (b - a).cross(c - a);
        // How far a grown cell's corners reach along the normal.
        let reach = DVec3::splat(cell / 2.0 + margin).dot(normal.abs());
        let grow = DVec3::splat(margin);
        let [_, _, z_first] = self.cell_of(a.min(b).min(c) - grow);
        let [_, _, z_last] = self.cell_of(a.max(b).max(c) + grow);
        for z in z_first..=z_last {
            let bottom = self.origin.z + z as f64 * cell - margin;
            let Some((lo, hi)) = clip_to_slab(wall, bottom, bottom + cell + 2.0 * margin) else {
                continue;
            };
            let first = self.cell_of(lo - grow);
            let last = self.cell_of(hi + grow);
            for y in first[1]..=last[1] {
                for x in first[0]..=last[0] {
                    let centre =
                        self.origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * cell;
                    // Also true for a degenerate triangle (no normal).
                    if normal.dot(centre - a).abs() <= reach {
                        let i = self.index([x, y, z]);
                        near[i / 64].fetch_or(1 << (i % 64), Ordering::Relaxed);
                    }
                }
            }
        }
    }

    /// The inside bits: each face-connected set of cells that are not near
    /// takes the parity of one ray from its first cell's centre.
    fn decide_regions(&self, cell: f64, parity: impl Fn(Vec3) -> bool) -> Vec<u64> {
        let words = self.near.len();
        let mut inside = vec![0u64; words];
        let mut seen = self.near.clone();
        let [nx, ny, nz] = self.dims;
        let mut stack: Vec<u32> = Vec::new();
        for start in 0..self.cells() {
            if seen[start / 64] & (1 << (start % 64)) != 0 {
                continue;
            }
            let coords = |i: usize| [i % nx, (i / nx) % ny, i / (nx * ny)];
            let [x, y, z] = coords(start);
            let centre = self.origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * cell;
            let is_inside = parity(centre.as_vec3());
            seen[start / 64] |= 1 << (start % 64);
            stack.push(start as u32);
            while let Some(i) = stack.pop() {
                let i = i as usize;
                if is_inside {
                    inside[i / 64] |= 1 << (i % 64);
                }
                let [x, y, z] = coords(i);
                let mut visit = |j: usize| {
                    if seen[j / 64] & (1 << (j % 64)) == 0 {
                        seen[j / 64] |= 1 << (j % 64);
                        stack.push(j as u32);
                    }
                };
                if x > 0 {
                    visit(i - 1);
                }
                if x + 1 < nx {
                    visit(i + 1);
                }
                if y > 0 {
                    visit(i - nx);
                }
                if y + 1 < ny {
                    visit(i + nx);
                }
                if z > 0 {
                    visit(i - nx * ny);
                }
                if z + 1 < nz {
                    visit(i + nx * ny);
                }
            }
        }
        inside
    }
}

/// The bounding box of the part of triangle `t` with `bottom <= z <= top`,
/// `None` if there is none.
fn clip_to_slab(t: [DVec3; 3], bottom: f64, top: f64) -> Option<(DVec3, DVec3)> {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut take = |p: DVec3| {
        lo = lo.min(p);
        hi = hi.max(p);
    };
    for (i, &p) in t.iter().enumerate() {
        if (bottom..=top).contains(&p.z) {
            take(p);
        }
        // Where the edge to the next corner crosses either plane.
        let q = t[(i + 1) % 3];
        for plane in [bottom, top] {
            if (p.z - plane) * (q.z - plane) < 0.0 {
                take(p + (q - p) * ((plane - p.z) / (q.z - p.z)));
            }
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::mesh::MeshAccel;

    /// The cube `[0, 1]^3`, each face an `n` x `n` grid of quads with its
    /// own vertices (welded by position), facing out; with `hole`, less its
    /// last quad.
    fn tiled_cube(n: usize, hole: bool) -> MeshAccel {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for face in 0..6 {
            let (axis, side) = (face / 2, (face % 2) as f32);
            let at = |i: usize, j: usize| {
                let mut p = [0.0; 3];
                p[axis] = side;
                p[(axis + 1) % 3] = i as f32 / n as f32;
                p[(axis + 2) % 3] = j as f32 / n as f32;
                Vec3::from(p)
            };
            let base = v.len() as u32;
            for j in 0..=n {
                for i in 0..=n {
                    v.push(at(i, j));
                }
            }
            let id = |i: usize, j: usize| base + (i + j * (n + 1)) as u32;
            for j in 0..n {
                for i in 0..n {
                    for mut tri in [
                        [id(i, j), id(i + 1, j), id(i + 1, j + 1)],
                        [id(i, j), id(i + 1, j + 1), id(i, j + 1)],
                    ] {
                        let [a, b, c] = tri.map(|k| v[k as usize]);
                        let out = (a + b + c) / 3.0 - Vec3::splat(0.5);
                        if (b - a).cross(c - a).dot(out) < 0.0 {
                            tri.swap(1, 2);
                        }
                        t.push(tri);
                    }
                }
            }
        }
        if hole {
            t.truncate(t.len() - 2);
        }
        MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap()
    }

    /// Points of a lattice around the unit cube, some on its faces and
    /// edges.
    fn lattice() -> Vec<Vec3> {
        let mut points = Vec::new();
        for i in 0..=28 {
            for j in 0..=28 {
                for k in 0..=28 {
                    points.push(Vec3::new(i as f32, j as f32, k as f32) / 20.0 - Vec3::splat(0.2));
                }
            }
        }
        points
    }

    /// Every point the grid decides is decided as the ray decides it; the
    /// fraction it decides.
    fn decided_as_the_ray_does(mesh: &MeshAccel) -> f64 {
        let grid = mesh.side_grid().expect("a grid");
        let points = lattice();
        let mut decided = 0;
        for &p in &points {
            let side = grid.side(p);
            if side != Side::Near {
                assert_eq!(side == Side::Inside, mesh.ray_parity(p), "{p}");
                decided += 1;
            }
        }
        decided as f64 / points.len() as f64
    }

    #[test]
    fn a_closed_mesh_is_decided_away_from_its_surface() {
        let cube = tiled_cube(8, false);
        assert_eq!(cube.open_edges(), 0);
        assert!(!cube.side_grid().unwrap().strips);
        assert!(decided_as_the_ray_does(&cube) > 0.5);
        // Far points need no ray either.
        let grid = cube.side_grid().unwrap();
        assert_eq!(grid.side(Vec3::splat(1e6)), Side::Outside);
        assert_eq!(grid.side(Vec3::splat(0.5)), Side::Inside);
    }

    #[test]
    fn strips_keep_an_open_mesh_answered_as_the_ray_does() {
        // A quad missing: its four sides are edges of one triangle each.
        let open = tiled_cube(8, true);
        assert_eq!(open.open_edges(), 4);
        assert!(open.side_grid().unwrap().strips);
        // (Lattice points beyond the grid are near here.)
        assert!(decided_as_the_ray_does(&open) > 0.2);
        // Beyond the grid the strips run on: the ray decides.
        assert_eq!(open.side_grid().unwrap().side(Vec3::splat(1e6)), Side::Near);
    }

    #[test]
    fn too_many_strips_leave_every_point_to_the_ray() {
        // Two thousand separate slivers: six thousand odd edges.
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..2000u32 {
            let p = Vec3::new((i % 13) as f32, (i % 17) as f32, (i % 19) as f32)
                + Vec3::splat(i as f32 * 1e-3);
            v.extend([p, p + Vec3::X * 0.1, p + Vec3::Y * 0.1]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let soup = MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap();
        assert!(soup.side_grid().is_none());
    }

    #[test]
    fn a_slab_clips_a_triangle_to_its_part() {
        let t = [
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 2.0),
            DVec3::new(0.0, 2.0, 2.0),
        ];
        let (lo, hi) = clip_to_slab(t, 0.5, 1.0).unwrap();
        assert_eq!(
            (lo, hi),
            (DVec3::new(0.0, 0.0, 0.5), DVec3::new(1.0, 1.0, 1.0))
        );
        assert!(clip_to_slab(t, 3.0, 4.0).is_none());
    }
}
