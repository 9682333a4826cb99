//! The generalised winding number of the mesh at a point (Jacobson et al.,
//! "Robust inside-outside segmentation using generalized winding numbers",
//! 2013), summed fast over the point queries' BVH as Barill et al. do
//! ("Fast winding numbers for soups and clouds", 2018).
//!
//! The winding number is the signed solid angle the surface subtends at the
//! point, over `4 pi`: 1 inside a closed, outward-oriented mesh, 0 outside,
//! and in between where the mesh has holes, falling off smoothly with the
//! size of the hole. So `w >= 0.5` is an inside test that degrades
//! gracefully on open meshes and soups, where ray parity answers by the
//! side of one ray.
//!
//! Near the point every triangle's solid angle is summed exactly (the
//! formula of Van Oosterom and Strackee, in `f64`). A subtree whose
//! triangles all lie within radius `r` of their area-weighted centre `c`
//! (a leaf's largest vertex distance, bounded through the children above,
//! or the distance to the box's farthest corner where that is less), with
//! `|c - p| > BETA r`, is summed at once as one dipole: the sum `N` of its
//! triangles' area vectors at `c`, `N . (c - p) / (4 pi |c - p|^3)`. Its
//! relative error falls as `(r / |c - p|)^2`. Measured on a 1,280-triangle
//! sphere at 2,000 points inside and out (`tests/mesh_queries.rs`), largest
//! error from the exact sum: `BETA` 3, 4, 5, 6 gave 1.1e-2, 7.1e-3, 5.0e-3,
//! 3.9e-3; with Barill et al.'s second-order term added (and the box-corner
//! radius) it was worse (6.3e-2, 2.7e-2, 1.5e-2 for `BETA` 2, 3, 4, against
//! 3.0e-2, 1.1e-2, 6.8e-3 without), so the expansion stops at the dipole,
//! with `BETA = 4`.

use glam::DVec3;

use super::{MeshAccel, PER_TASK};
use crate::bvh2::Bvh;
use crate::morton;
use glam::Vec3;

/// A subtree is summed by its moments when the point lies farther than
/// `BETA` times the radius of its triangles from their centre.
const BETA: f64 = 4.0;

const FOUR_PI: f64 = 4.0 * std::f64::consts::PI;

/// Levels of the traversal stack (see `closest_point.rs`).
const STACK: usize = 128;

/// What a subtree's far field needs, per node of the point queries' BVH.
#[derive(Clone, Copy, Debug)]
struct Moments {
    /// Area-weighted centre of the subtree's triangles.
    center: DVec3,
    /// `(BETA r)^2`, `r` the distance from `center` within which every
    /// triangle lies: points farther (squared) take the far field.
    reach2: f64,
    /// Sum of the triangles' area vectors, `(b - a) x (c - a) / 2`.
    normal: DVec3,
    /// Sum of the triangles' areas (for combining centres).
    area: f64,
}

/// The point queries' BVH with each node's moments.
#[derive(Debug)]
pub(super) struct WindingTree {
    moments: Vec<Moments>,
}

impl WindingTree {
    /// Moments of every node of `bvh` (children follow their parents in
    /// its node order, so one backward pass combines them).
    pub(super) fn build(bvh: &Bvh, triangle: impl Fn(u32) -> [Vec3; 3]) -> Self {
        let nodes = bvh.nodes();
        let prims = bvh.prim_indices();
        let empty = Moments {
            center: DVec3::ZERO,
            reach2: 0.0,
            normal: DVec3::ZERO,
            area: 0.0,
        };
        let mut moments = vec![empty; nodes.len()];
        // Distance from each node's centre within which its triangles lie.
        let mut radius = vec![0.0f64; nodes.len()];
        for i in (0..nodes.len()).rev() {
            let node = &nodes[i];
            let lo = node.min.as_dvec3();
            let hi = node.max.as_dvec3();
            let m = if node.is_leaf() {
                let first = node.offset as usize;
                let tris: Vec<[DVec3; 3]> = prims[first..first + node.count as usize]
                    .iter()
                    .map(|&p| triangle(p).map(|v| v.as_dvec3()))
                    .filter(|t| t.iter().all(|v| v.is_finite()))
                    .collect();
                // Per triangle its area vector and, weighted by its area,
                // its centroid.
                let (mut normal, mut area, mut weighted) = (DVec3::ZERO, 0.0, DVec3::ZERO);
                for &[a, b, c] in &tris {
                    let vector = 0.5 * (b - a).cross(c - a);
                    let size = vector.length();
                    normal += vector;
                    area += size;
                    weighted += (a + b + c) / 3.0 * size;
                }
                let center = if area > 0.0 {
                    weighted / area
                } else {
                    0.5 * (lo + hi)
                };
                radius[i] = tris
                    .iter()
                    .flatten()
                    .map(|&v| (v - center).length())
                    .fold(0.0, f64::max);
                Moments {
                    center,
                    reach2: 0.0,
                    normal,
                    area,
                }
            } else {
                let (l, r) = (moments[i + 1], moments[node.offset as usize]);
                let area = l.area + r.area;
                let center = if area > 0.0 {
                    (l.center * l.area + r.center * r.area) / area
                } else {
                    0.5 * (lo + hi)
                };
                let (rl, rr) = (radius[i + 1], radius[node.offset as usize]);
                radius[i] =
                    (rl + (l.center - center).length()).max(rr + (r.center - center).length());
                Moments {
                    center,
                    reach2: 0.0,
                    normal: l.normal + r.normal,
                    area,
                }
            };
            // Every triangle also lies in the node's box, so within the
            // distance of its farthest corner.
            let corner = (m.center - lo).abs().max((hi - m.center).abs()).length();
            radius[i] = radius[i].min(corner);
            moments[i] = Moments {
                reach2: (BETA * radius[i]).powi(2),
                ..m
            };
        }
        WindingTree { moments }
    }
}

/// The signed solid angle of triangle `abc` seen from `p`, over `4 pi`
/// (positive where `(b - a) x (c - a)` points away from `p`).
fn triangle_winding(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    let w = 2.0 * det.atan2(den) / FOUR_PI;
    // A point on a vertex (or a NaN vertex) adds nothing.
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// The far field of a subtree with moments `m` at the point `d` away from
/// its centre (`d = center - p`, `r2 = |d|^2`): its triangles as one dipole
/// at their centre.
fn far_field(d: DVec3, r2: f64, m: &Moments) -> f64 {
    m.normal.dot(d) / (r2 * r2.sqrt() * FOUR_PI)
}

impl MeshAccel {
    /// The generalised winding number of the mesh at `p` (see the module
    /// documentation of `mesh/winding.rs`): about 1 inside a closed mesh
    /// whose triangles face outwards, 0 outside, in between near holes;
    /// `w >= 0.5` is an inside test for open meshes and soups. Within about
    /// 1e-2 of the exact sum of solid angles (see `mesh/winding.rs`). NaN
    /// for a non-finite `p`; triangles with non-finite vertices add nothing.
    pub fn winding_number(&self, p: Vec3) -> f32 {
        if !p.is_finite() {
            return f32::NAN;
        }
        let bvh = self.point_bvh();
        let tree = self.winding_tree();
        let nodes = bvh.nodes();
        if nodes.is_empty() {
            return 0.0;
        }
        let prims = bvh.prim_indices();
        let p = p.as_dvec3();
        let mut w = 0.0;
        let mut stack = [0u32; STACK];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let index = stack[len] as usize;
            let m = &tree.moments[index];
            if m.area == 0.0 {
                continue;
            }
            let d = m.center - p;
            let r2 = d.length_squared();
            if r2 > m.reach2 {
                w += far_field(d, r2, m);
                continue;
            }
            let node = &nodes[index];
            if node.is_leaf() {
                let first = node.offset as usize;
                for &prim in &prims[first..first + node.count as usize] {
                    w += triangle_winding(p, self.triangle(prim).map(|v| v.as_dvec3()));
                }
            } else if len + 2 <= STACK {
                stack[len] = index as u32 + 1;
                stack[len + 1] = node.offset;
                len += 2;
            }
        }
        w as f32
    }

    /// [`MeshAccel::winding_number`] at every point, in parallel (in Morton
    /// order of the points; returned in their order).
    pub fn winding_number_batch(&self, points: &[Vec3]) -> Vec<f32> {
        // Built before the parallel loop, so no worker waits on another's build.
        self.winding_tree();
        morton::answer_in_order(points, PER_TASK, |i| self.winding_number(points[i]))
    }

    /// The exact sum of every triangle's solid angle at `p` over `4 pi`
    /// (no far field): what [`MeshAccel::winding_number`] approximates,
    /// for tests.
    #[doc(hidden)]
    pub fn winding_number_exact(&self, p: Vec3) -> f64 {
        let p = p.as_dvec3();
        (0..self.triangles().len() as u32)
            .map(|prim| triangle_winding(p, self.triangle(prim).map(|v| v.as_dvec3())))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;

    /// An axis-aligned cube `[0, 1]^3`, faces outwards, two triangles each;
    /// without its top face when `open`.
    fn cube(open: bool) -> MeshAccel {
        let v: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let mut t = vec![
            [0, 2, 1],
            [1, 2, 3], // z = 0, facing -z
            [0, 1, 4],
            [1, 5, 4], // y = 0
            [2, 6, 3],
            [3, 6, 7], // y = 1
            [0, 4, 2],
            [2, 4, 6], // x = 0
            [1, 3, 5],
            [3, 7, 5], // x = 1
        ];
        if !open {
            t.extend([[4, 5, 6], [5, 7, 6]]); // z = 1, facing +z
        }
        MeshAccel::build(v, t, AccelKind::DEFAULT).unwrap()
    }

    #[test]
    fn a_closed_cube_winds_once_around_its_inside_and_not_outside() {
        let mesh = cube(false);
        for (p, want) in [
            (Vec3::splat(0.5), 1.0),
            (Vec3::new(0.1, 0.9, 0.2), 1.0),
            (Vec3::new(1.5, 0.5, 0.5), 0.0),
            (Vec3::new(-3.0, 7.0, 2.0), 0.0),
        ] {
            let exact = mesh.winding_number_exact(p);
            assert!((exact - want).abs() < 1e-12, "{p}: {exact}");
            let fast = f64::from(mesh.winding_number(p));
            assert!((fast - want).abs() < 1e-2, "{p}: {fast}");
        }
    }

    #[test]
    fn an_open_box_winds_partly_near_its_hole() {
        let mesh = cube(true);
        let deep = mesh.winding_number(Vec3::new(0.5, 0.5, 0.05));
        let near_hole = mesh.winding_number(Vec3::new(0.5, 0.5, 0.95));
        assert!(deep > 0.8 && deep < 1.0, "{deep}");
        assert!(near_hole > 0.3 && near_hole < deep, "{near_hole}");
        assert!(mesh.winding_number(Vec3::new(0.5, 0.5, 3.0)).abs() < 0.1);
        assert!(mesh.winding_number(Vec3::NAN).is_nan());
    }
}
