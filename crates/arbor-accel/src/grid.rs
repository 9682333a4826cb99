//! The uniform grid: space cut into equal cells, each listing the primitives
//! that overlap it, walked cell by cell along the ray (Amanatides and Woo,
//! "A Fast Voxel Traversal Algorithm for Ray Tracing", 1987).

use glam::Vec3;
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::accel::{AccelStats, Accelerator};
use crate::counters::count_node;
use crate::counters::Counters;
use crate::layout::{GridLayout, Layout};
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;
use crate::util::{prepare, Mailbox};

/// Grid build parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridParams {
    /// Cells per primitive: the grid gets about `lambda * N` cells, shaped to
    /// the scene bounds so cells are close to cubes. Default 4; 2-8 trade
    /// memory and build time against tests per ray.
    pub lambda: f32,
    /// Upper bound on the number of cells. Default 2^24.
    pub max_cells: usize,
    /// Upper bound on the resolution along one axis. Default 1024.
    pub max_resolution: u32,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            lambda: 4.0,
            max_cells: 1 << 24,
            max_resolution: 1024,
        }
    }
}

/// Cells are widened by this fraction of the largest cell extent when
/// deciding which primitives they hold. Traversal computes the cell crossing
/// distances in `f32`; a crossing is off by at most about `3 ulp` of the
/// distance from the ray origin to the crossed plane, which this margin covers
/// for origins within about 20 000 cell widths of the grid, so rounding can
/// never walk the ray past a cell that holds a hit.
const DILATION: f32 = 1.0 / 256.0;

/// The cell boundaries of a grid being built and what is needed to find
/// the cells a primitive overlaps.
struct Cells<'a> {
    /// Cell boundaries per axis.
    planes: &'a [Vec<f32>; 3],
    /// The grid's lower corner.
    min: Vec3,
    inv_cell: Vec3,
    /// How far cells are widened ([`DILATION`] of the largest cell extent).
    dil: f32,
    /// Cells along x and y.
    rx: usize,
    ry: usize,
}

impl Cells<'_> {
    /// The cells (widened by `dil`) that primitive `id` with box `pb`
    /// overlaps, in cell order: every cell of its box when that is one
    /// cell, else those its clipped bounds reach.
    fn of<P: Primitives + ?Sized>(&self, prims: &P, &(id, pb): &(u32, Aabb)) -> Vec<u32> {
        let (planes, dil) = (self.planes, self.dil);
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for a in 0..3 {
            (lo[a], hi[a]) = self.range(a, &pb);
        }
        let single = lo == hi;
        let mut out = Vec::new();
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let keep = single || {
                        let cell = Aabb::new(
                            Vec3::new(planes[0][x], planes[1][y], planes[2][z]) - dil,
                            Vec3::new(planes[0][x + 1], planes[1][y + 1], planes[2][z + 1]) + dil,
                        );
                        prims.clipped_bounds(id, &cell).is_some()
                    };
                    if keep {
                        out.push(((z * self.ry + y) * self.rx + x) as u32);
                    }
                }
            }
        }
        out
    }

    /// The first and last cell along axis `a` whose widened slab overlaps
    /// box `pb`: a guess from the cell size, corrected against the planes.
    fn range(&self, a: usize, pb: &Aabb) -> (usize, usize) {
        let (p, dil) = (&self.planes[a], self.dil);
        let r = p.len() - 1;
        let guess = |x: f32| (((x - self.min[a]) * self.inv_cell[a]).max(0.0) as usize).min(r - 1);
        // Cell i (widened) overlaps [pb.min, pb.max] iff
        // p[i] - dil <= pb.max and p[i + 1] + dil >= pb.min.
        let mut l = guess(pb.min[a] - dil);
        while l > 0 && p[l] + dil >= pb.min[a] {
            l -= 1;
        }
        while l + 1 < r && p[l + 1] + dil < pb.min[a] {
            l += 1;
        }
        let mut h = guess(pb.max[a] + dil).max(l);
        while h + 1 < r && p[h + 1] - dil <= pb.max[a] {
            h += 1;
        }
        while h > l && p[h] - dil > pb.max[a] {
            h -= 1;
        }
        (l, h)
    }
}

/// The cell lists as compressed sparse rows (`start`, primitive ids): a
/// counting sort in primitive order, so the layout does not depend on
/// scheduling.
fn compressed_rows(
    lists: &[Vec<u32>],
    refs: &[(u32, Aabb)],
    ncells: usize,
) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; ncells + 1];
    for l in lists {
        for &c in l {
            start[c as usize + 1] += 1;
        }
    }
    for i in 0..ncells {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut cell_prims = vec![0u32; start[ncells] as usize];
    for (l, &(id, _)) in lists.iter().zip(refs) {
        for &c in l {
            cell_prims[fill[c as usize] as usize] = id;
            fill[c as usize] += 1;
        }
    }
    (start, cell_prims)
}

/// A uniform grid over any [`Primitives`], with cells in compressed sparse
/// row form: cell `c` holds `prims[start[c]..start[c + 1]]`.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    bounds: Aabb,
    res: [u32; 3],
    /// Cell boundaries per axis (`res + 1` values, ending exactly at the
    /// bounds), so neighbouring cells share their boundary bit for bit.
    planes: [Vec<f32>; 3],
    inv_cell: Vec3,
    start: Vec<u32>,
    prims: Vec<u32>,
    unbounded: Vec<u32>,
}

impl Grid {
    /// Builds a grid over `prims`. Primitives with empty boxes are left out;
    /// those with NaN or infinite boxes are offered to every ray.
    pub fn build<P: Primitives + ?Sized>(prims: &P, params: &GridParams) -> Self {
        let prep = prepare(prims);
        let mut grid = Grid {
            unbounded: prep.unbounded,
            ..Grid::default()
        };
        if prep.refs.is_empty() {
            return grid;
        }
        let b = prep.bounds;
        let ext = b.extent();
        let res = fitted_resolution(&b, &prep.refs, params);
        let planes: [Vec<f32>; 3] = std::array::from_fn(|a| {
            let r = res[a] as usize;
            let mut p: Vec<f32> = (0..r)
                .map(|i| b.min[a] + ext[a] * (i as f32 / r as f32))
                .collect();
            p.push(b.max[a]);
            p
        });
        let inv_cell = Vec3::from_array(std::array::from_fn(|a| {
            if ext[a] > 0.0 {
                res[a] as f32 / ext[a]
            } else {
                0.0
            }
        }));
        let cell_ext = Vec3::from_array(std::array::from_fn(|a| ext[a] / res[a] as f32));
        let cells = Cells {
            planes: &planes,
            min: b.min,
            inv_cell,
            dil: cell_ext.max_element() * DILATION,
            rx: res[0] as usize,
            ry: res[1] as usize,
        };
        let lists: Vec<Vec<u32>> = prep.refs.par_iter().map(|r| cells.of(prims, r)).collect();
        let ncells = cells.rx * cells.ry * res[2] as usize;
        let (start, cell_prims) = compressed_rows(&lists, &prep.refs, ncells);
        grid.bounds = b;
        grid.res = res;
        grid.planes = planes;
        grid.inv_cell = inv_cell;
        grid.start = start;
        grid.prims = cell_prims;
        grid
    }

    /// Cells along x, y and z.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    /// The cells for drawing, numbered as traversal reports them.
    pub fn layout(&self) -> Layout {
        Layout::Grid(GridLayout {
            bounds: self.bounds,
            resolution: self.res,
            planes: self.planes.clone(),
            occupied: (0..self.start.len().saturating_sub(1))
                .filter(|&c| self.start[c + 1] > self.start[c])
                .map(|c| c as u32)
                .collect(),
        })
    }

    /// Walks the cells the ray passes, front to back, calling `visit` with
    /// each cell's primitives and the distance at which the ray leaves the
    /// cell, until `visit` returns `true` or the ray leaves the grid.
    #[inline(always)]
    fn walk<C: Counters>(
        &self,
        ray: &Ray,
        counters: &mut C,
        mut visit: impl FnMut(&[u32], f32, &mut C) -> bool,
    ) {
        if self.start.is_empty() {
            return;
        }
        let inv = ray.inv_dir();
        let Some((t0, _)) = self.bounds.intersect_widened(ray, inv) else {
            return;
        };
        if inv.is_nan() {
            // A subnormal direction component (see `Ray::inv_dir`): the
            // cells it crosses along that axis cannot be stepped through, so
            // every cell's primitives are offered, with no early exit.
            visit(&self.prims, f32::INFINITY, counters);
            return;
        }
        let mut p = ray.at(t0);
        if !p.is_finite() {
            // Only with a zero direction (t0 = -inf times 0): the ray stays
            // at its origin.
            p = ray.origin;
        }
        let mut cell = [0usize; 3];
        let mut step = [0isize; 3];
        let mut next = [f32::INFINITY; 3];
        for a in 0..3 {
            let r = self.res[a] as usize;
            cell[a] =
                (((p[a] - self.bounds.min[a]) * self.inv_cell[a]).max(0.0) as usize).min(r - 1);
            if !inv[a].is_finite() {
                // Parallel to this axis (or too slow along it to matter).
                continue;
            }
            if ray.dir[a] > 0.0 {
                step[a] = 1;
                next[a] = (self.planes[a][cell[a] + 1] - ray.origin[a]) * inv[a];
            } else if ray.dir[a] < 0.0 {
                step[a] = -1;
                next[a] = (self.planes[a][cell[a]] - ray.origin[a]) * inv[a];
            }
        }
        let (rx, ry) = (self.res[0] as usize, self.res[1] as usize);
        loop {
            let c = (cell[2] * ry + cell[1]) * rx + cell[0];
            count_node(counters, c as u32);
            let exit = next[0].min(next[1]).min(next[2]);
            let slice = &self.prims[self.start[c] as usize..self.start[c + 1] as usize];
            if visit(slice, exit, counters) {
                return;
            }
            let a = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            if step[a] == 0 {
                // Every remaining crossing is infinitely far: the ray never
                // leaves this cell.
                return;
            }
            let n = cell[a] as isize + step[a];
            if n < 0 || n >= self.res[a] as isize {
                return;
            }
            cell[a] = n as usize;
            let plane = if step[a] > 0 { cell[a] + 1 } else { cell[a] };
            next[a] = (self.planes[a][plane] - ray.origin[a]) * inv[a];
        }
    }
}

/// The largest crowding ([`crowding`]) the resolution rule accepts: a cell
/// a ray enters should hold a handful of primitives, not hundreds.
const MAX_CROWDING: f64 = 8.0;

/// The most cells per primitive the resolution rule may spend to uncrowd
/// the cells (a 4-byte cell start each, plus the references).
const MAX_CELLS_PER_PRIMITIVE: f64 = 1024.0;

/// Cells per axis for primitives `refs` (id, box) within `bounds`: the
/// classic rule (about `lambda * n` cells shaped like the bounds, see
/// [`shaped`]), then, while the primitives still crowd into few cells (a
/// small model on a large floor: the "teapot in a stadium"), eight times
/// as many cells, until the crowding is at most [`MAX_CROWDING`], stops
/// improving, or the cells would exceed [`MAX_CELLS_PER_PRIMITIVE`] per
/// primitive or `params.max_cells`. The grid stays uniform; only its size
/// adapts to where the primitives are.
fn fitted_resolution(bounds: &Aabb, refs: &[(u32, Aabb)], params: &GridParams) -> [u32; 3] {
    let ext = bounds.extent();
    let n = refs.len() as f64;
    let lambda = params.lambda.max(0.01) as f64;
    let budget = (n * lambda.max(MAX_CELLS_PER_PRIMITIVE)).min(params.max_cells.max(1) as f64);
    let mut target = lambda * n;
    let mut res = shaped(ext, target, params);
    let mut crowd = crowding(bounds, res, refs);
    while crowd > MAX_CROWDING && target * 8.0 <= budget {
        target *= 8.0;
        let finer = shaped(ext, target, params);
        let finer_crowd = crowding(bounds, finer, refs);
        if finer == res || finer_crowd >= crowd {
            break;
        }
        res = finer;
        crowd = finer_crowd;
    }
    res
}

/// How crowded the cells of resolution `res` are: the mean, over the
/// primitives, of how many primitives share the cell holding their box's
/// centre (the sum of squared cell counts over their sum). It estimates
/// the primitives tested in a cell a ray enters near geometry; a few big
/// primitives (a floor) weigh as little as they count.
fn crowding(bounds: &Aabb, res: [u32; 3], refs: &[(u32, Aabb)]) -> f64 {
    if refs.is_empty() {
        return 0.0;
    }
    let ext = bounds.extent();
    let mut cells: Vec<u64> = refs
        .iter()
        .map(|(_, b)| {
            let c = b.center();
            let mut index = 0u64;
            for a in (0..3).rev() {
                let r = res[a] as u64;
                let x = if ext[a] > 0.0 {
                    ((c[a] - bounds.min[a]) / ext[a] * r as f32).max(0.0) as u64
                } else {
                    0
                };
                index = index * r + x.min(r - 1);
            }
            index
        })
        .collect();
    cells.sort_unstable();
    let mut squares = 0u64;
    let mut i = 0;
    while i < cells.len() {
        let j = i + cells[i..].iter().take_while(|&&c| c == cells[i]).count();
        squares += ((j - i) * (j - i)) as u64;
        i = j;
    }
    squares as f64 / refs.len() as f64
}

/// Cells per axis: about `cells` in total (at most `params.max_cells`),
/// proportioned like the bounds so that cells are close to cubes. Flat axes
/// (thinner than 1e-4 of the largest extent) get one cell.
fn shaped(ext: Vec3, cells: f64, params: &GridParams) -> [u32; 3] {
    let target = cells.min(params.max_cells as f64);
    let big = ext.max_element() as f64;
    let thick: Vec<usize> = (0..3)
        .filter(|&a| big > 0.0 && ext[a] as f64 > big * 1e-4)
        .collect();
    let mut res = [1u32; 3];
    if thick.is_empty() {
        return res;
    }
    let measure: f64 = thick.iter().map(|&a| ext[a] as f64 / big).product();
    let k = (target / measure).powf(1.0 / thick.len() as f64);
    for &a in &thick {
        let r = (ext[a] as f64 / big * k).round();
        res[a] = r.clamp(1.0, params.max_resolution.max(1) as f64) as u32;
    }
    while res.iter().map(|&r| r as usize).product::<usize>() > params.max_cells.max(1) {
        for r in &mut res {
            *r = (*r / 2).max(1);
        }
    }
    res
}

impl Accelerator for Grid {
    fn unbounded(&self) -> &[PrimitiveId] {
        &self.unbounded
    }

    // Inlined into `Accel`'s dispatch: callgrind counts 1% more render
    // instructions on a grid when it is a call.
    #[inline]
    fn closest_bounded<C, F>(&self, mut ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        let walk_ray = ray;
        let mut mailbox = Mailbox::new();
        self.walk(&walk_ray, counters, |prims, exit, counters| {
            mailbox.offer_closest(prims, &mut ray, counters, hit);
            // Every hit closer than the exit lies in a cell already visited
            // (up to the cell widening), so the nearest one is known.
            ray.tmax <= exit
        });
    }

    #[inline]
    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        let mut found = false;
        let mut mailbox = Mailbox::new();
        self.walk(ray, counters, |prims, exit, counters| {
            found = mailbox.offer_any(prims, ray, counters, hit);
            found || ray.tmax <= exit
        });
        found
    }

    fn stats(&self) -> AccelStats {
        let cells = self.start.len().saturating_sub(1);
        AccelStats {
            nodes: cells,
            leaves: self.start.windows(2).filter(|w| w[1] > w[0]).count(),
            max_depth: 0,
            memory_bytes: std::mem::size_of::<Self>()
                + (self.start.len() + self.prims.len() + self.unbounded.len()) * 4
                + self.planes.iter().map(|p| p.len() * 4).sum::<usize>(),
            sah_cost: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::counters::{NoCounters, RayCounts};
    use crate::list::List;
    use crate::test_meshes::{assert_agrees_with_list, offered};
    use crate::triangle::mesh::TriangleMesh;

    fn soup() -> TriangleMesh {
        crate::test_meshes::soup(300)
    }

    #[test]
    fn grid_matches_list_and_tests_each_prim_once() {
        let m = soup();
        let g = Grid::build(&m, &GridParams::default());
        let cells: u32 = g.resolution().iter().product();
        assert!((600..=2400).contains(&cells), "{:?}", g.resolution());
        let list = List::build(&m);
        for k in 0..300 {
            let f = k as f32;
            let o = Vec3::new(-2.0, (f * 0.37).fract() * 12.0, (f * 0.91).fract() * 12.0);
            let d = Vec3::new(1.0, (f * 0.7).sin() * 0.5, (f * 0.3).cos() * 0.5);
            let r = Ray::new(o, d, 0.0, f32::INFINITY);
            assert_agrees_with_list(&g, &list, &m, &r, &format!("ray {k}"));
            let mut seen = Vec::new();
            g.closest(&r, &mut NoCounters, |p, ray| {
                seen.push(p);
                Some(m.intersect(p, ray)?.t)
            });
            let n = seen.len();
            seen.sort();
            seen.dedup();
            assert_eq!(seen.len(), n, "a primitive was tested twice");
        }
        let mut c = RayCounts::default();
        let r = Ray::new(Vec3::new(-20.0, 5.0, 5.0), Vec3::X, 0.0, 1.0);
        g.closest(&r, &mut c, |_, _| None);
        assert_eq!(c.nodes, 0);
    }

    /// A small cluster of primitives on a floor 50 times wider (the
    /// teapot in a stadium): the classic rule puts the cluster in a cell or
    /// two; the fitted one cuts finer, within the cell budget, until few
    /// share a cell.
    #[test]
    fn a_small_model_on_a_large_floor_gets_fine_cells() {
        let mut boxes: Vec<Aabb> = (0..1000)
            .map(|i| {
                let c = crate::test_meshes::scattered(i);
                Aabb::new(c, c + Vec3::splat(0.01))
            })
            .collect();
        boxes.push(Aabb::new(
            Vec3::new(-25.0, -0.1, -25.0),
            Vec3::new(25.0, 0.0, 25.0),
        ));
        let refs: Vec<(u32, Aabb)> = boxes
            .iter()
            .copied()
            .enumerate()
            .map(|(i, b)| (i as u32, b))
            .collect();
        let bounds = refs.iter().fold(Aabb::EMPTY, |a, (_, b)| a.union(b));
        let params = GridParams::default();
        let classic = shaped(bounds.extent(), 4.0 * refs.len() as f64, &params);
        assert!(crowding(&bounds, classic, &refs) > 100.0, "{classic:?}");
        let fitted = fitted_resolution(&bounds, &refs, &params);
        let crowd = crowding(&bounds, fitted, &refs);
        assert!(crowd < 20.0, "{fitted:?}: crowding {crowd}");
        let cells: usize = fitted.iter().map(|&r| r as usize).product();
        assert!(cells as f64 <= MAX_CELLS_PER_PRIMITIVE * refs.len() as f64);
        // A model alone keeps the classic size.
        let soup = soup();
        let prep = crate::util::prepare(&soup);
        assert_eq!(
            fitted_resolution(&prep.bounds, &prep.refs, &params),
            shaped(prep.bounds.extent(), 4.0 * prep.refs.len() as f64, &params)
        );
        // The grid over the stadium still answers as brute force does.
        let g = Grid::build(&boxes, &params);
        assert_eq!(g.resolution(), fitted);
    }

    #[test]
    fn empty_flat_and_zero_direction() {
        let none: Vec<Aabb> = Vec::new();
        let g = Grid::build(&none, &GridParams::default());
        let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0);
        assert!(!g.occluded(&r, &mut NoCounters, |_, _| true));
        let flat: Vec<Aabb> = (0..50)
            .map(|i| {
                let x = i as f32 * 0.1;
                Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.05, 1.0, 0.0))
            })
            .collect();
        let g = Grid::build(&flat, &GridParams::default());
        assert_eq!(g.resolution()[2], 1);
        let r = Ray::new(Vec3::new(1.01, 0.5, 0.0), Vec3::ZERO, 0.0, 1.0);
        assert!(offered(&g, &r).contains(&10));
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.0), Vec3::X, 0.0, f32::INFINITY);
        assert_eq!(offered(&g, &r).len(), 50);
    }
}
