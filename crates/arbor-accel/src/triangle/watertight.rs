//! Watertight ray/triangle intersection (Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2013) with its stated error bounds: the
//! `f32` edge functions where their signs are certain, `f64` where not, and
//! the distance in `f64`.

use glam::{DVec3, Vec3};

use crate::aabb::Aabb;
use crate::ray::Ray;
use crate::util::widen_up;

/// Where a ray hits a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weight of the second vertex.
    pub u: f32,
    /// Barycentric weight of the third vertex; the hit point is
    /// `(1 - u - v) p0 + u p1 + v p2`.
    pub v: f32,
}

/// The ray, sheared and permuted so that it runs along +z from the origin.
/// Computing it once per ray is what makes the test cheap for many triangles;
/// computing it identically for every triangle is what makes it watertight.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    pub(crate) kx: usize,
    pub(crate) ky: usize,
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    /// `1 / d[kz]`: scales distances along the dominant axis into ray
    /// parameters.
    pub(crate) sz: f32,
}

impl RayShear {
    /// The shear for `ray`'s direction.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        // The dominant axis becomes z so that the division below is by the
        // largest component.
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swapping keeps the winding, so the sign of the edge functions keeps
        // meaning "inside" regardless of the direction's sign.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        RayShear {
            kx,
            ky,
            kz,
            sx: d[kx] * sz,
            sy: d[ky] * sz,
            sz,
        }
    }
}

/// Watertight, two-sided ray/triangle test accepting `ray.tmin <= t <= ray.tmax`.
///
/// Rays through a shared edge or vertex of two triangles hit at least one of
/// them: each edge function depends only on the edge's two vertices and is
/// exactly antisymmetric in them. Beyond the paper's exact-zero fallback, an
/// edge function whose magnitude is within its `f32` error bound
/// (`2^-18 m s`, with `s` the largest L1 distance of a vertex from the
/// origin and `m` the largest sheared vertex coordinate), or whose bound is
/// not a normal `f32` (`m s < 2^-108`: a triangle within about 5e-17 of
/// the origin), is
/// recomputed in `f64`, so a reported hit really lies on the
/// triangle (to about `2^-48 s`), not merely near it; the distance `t` comes
/// from the triangle's plane in `f64`, or, when that point falls outside the
/// triangle's box (cancellation next to a huge vertex), from the barycentric
/// combination of the vertices' distances. A hit also has to pass the
/// conservative slab test ([`Aabb::intersect`]) against the triangle's own
/// box, which no true hit fails, and is never reported before that box's
/// entry, so that it depends on `tmax` only through `t <= tmax`. A plane
/// that certainly lies behind the origin is rejected in `f32` first, when
/// `tmin >= 0`. All of this matters to acceleration
/// structures, which can only promise to offer a primitive where it really
/// is. Degenerate (zero-area) triangles and zero directions never hit.
#[inline]
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    intersect_triangle_sheared(ray, &RayShear::new(ray), p0, p1, p2)
}

/// [`intersect_triangle`] with the ray's shear computed by the caller.
#[inline]
pub fn intersect_triangle_sheared(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    intersect::<false>(ray, s, p0, p1, p2)
}

/// [`intersect_triangle_sheared`] with each crossing of a surface owned by
/// exactly one triangle: where the ray passes exactly through an edge or a
/// vertex (an edge function is exactly zero), the triangle reports the hit
/// only if it contains the crossing point pushed an infinitesimal step in a
/// fixed direction of the ray's sheared plane (`(epsilon, 1)`: "up", ties
/// broken "right", as rasterisers' top-left rule). The rule depends only on
/// the edge's two sheared vertices, which every triangle sharing the edge
/// computes alike, so of the two triangles at an edge the ray crosses
/// exactly one reports it, and at a silhouette edge both or neither; around
/// a vertex exactly one triangle of a fan the ray passes through. Counting
/// these hits along a ray therefore counts crossings: even for a ray
/// through a closed, consistently oriented mesh (the basis of
/// [`crate::mesh::MeshAccel::contains`]). Everything else is the plain test.
#[inline]
pub fn intersect_triangle_owned(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    intersect::<true>(ray, s, p0, p1, p2)
}

/// The watertight test; `OWNED` applies the ownership rule of
/// [`intersect_triangle_owned`] to exactly zero edge functions.
#[inline(always)]
fn intersect<const OWNED: bool>(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    let a = p0 - ray.origin;
    let b = p1 - ray.origin;
    let c = p2 - ray.origin;
    let (ax, ay) = (a[s.kx] - s.sx * a[s.kz], a[s.ky] - s.sy * a[s.kz]);
    let (bx, by) = (b[s.kx] - s.sx * b[s.kz], b[s.ky] - s.sy * b[s.kz]);
    let (cx, cy) = (c[s.kx] - s.sx * c[s.kz], c[s.ky] - s.sy * c[s.kz]);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    // Error bound of the edge functions: with `s` the largest L1 norm of a
    // vertex relative to the origin and `m` the largest sheared coordinate,
    // each sheared coordinate is off by at most 5u s (u = 2^-24), so an edge
    // function is off by at most 4 m (5u s) + 4u m^2 <= 28u m s. Testing
    // against 64u m s = 2^-18 m s leaves a factor two of margin. That
    // analysis counts relative roundings only; it holds while the bound is
    // a normal number (then every subnormal rounding's absolute error,
    // 2^-150, is far below it), so a subnormal or zero bound (`m s <
    // 2^-108`: triangles within about 5e-17 of the origin) leaves the signs
    // to `f64`.
    let scale = a
        .abs()
        .element_sum()
        .max(b.abs().element_sum())
        .max(c.abs().element_sum());
    let m = ax
        .abs()
        .max(ay.abs())
        .max(bx.abs())
        .max(by.abs())
        .max(cx.abs())
        .max(cy.abs());
    let bound = m * scale * (1.0 / 262_144.0);
    let smallest = u.abs().min(v.abs()).min(w.abs());
    let (u, v, w) = if smallest > bound && bound >= f32::MIN_POSITIVE {
        // Signs are certain.
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        return hit_from_certain_edges(ray, s, p0, p1, p2, [u, v, w], scale);
    } else {
        edge_functions_f64::<OWNED>(ray, s, p0, p1, p2)?
    };
    hit_from_weights(ray, s, p0, p1, p2, || (u, v, w))
}

/// The end of [`intersect_triangle_sheared`] once the `f32` edge functions
/// `u, v, w` are known to have certain signs, none of them opposite: their
/// normalised weights, then the distance. Split out so that a test of several
/// triangles at once (`triangle/lanes.rs`) can finish a lane with exactly the
/// arithmetic of the one-triangle test. `scale` is the test's `s`, the
/// largest L1 norm of a vertex relative to the origin.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn hit_from_certain_edges(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    [u, v, w]: [f32; 3],
    scale: f32,
) -> Option<TriangleHit> {
    if ray.tmin >= 0.0 && certainly_behind(ray, s, [p0, p1, p2], [u, v, w], scale) {
        return None;
    }
    hit_ahead(ray, s, p0, p1, p2, [u, v, w])
}

/// [`hit_from_certain_edges`] for a triangle already known not to lie
/// certainly behind the origin (or for a ray with `tmin < 0`): the rest of
/// it, for lanes whose check was made in SIMD (`triangle/lanes.rs`).
#[inline(always)]
pub(crate) fn hit_ahead(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    [u, v, w]: [f32; 3],
) -> Option<TriangleHit> {
    hit_from_weights(ray, s, p0, p1, p2, || {
        let det = u + v + w;
        (f64::from(u / det), f64::from(v / det), f64::from(w / det))
    })
}

/// Whether the plane of a triangle whose edge functions `u, v, w` have
/// certain, equal signs certainly meets the ray's line behind the origin
/// (`t < 0`), so that a ray with `tmin >= 0` misses it. Rays leaving a
/// surface (shadow and bounce rays, offset from the triangle they start on)
/// meet that triangle's plane just behind their origin: the structures offer
/// it to nearly every such ray, and this `f32` test spares it the `f64`
/// distance.
///
/// The distance is `t = T / D` with `T = u z0 + v z1 + w z2`, `D = u + v + w`
/// and `zi` the vertices' relative coordinates along the dominant axis
/// divided by `d[kz]` (Woop et al.). `D` has the sign of `u` (all three
/// share it). The computed `T` is off from the exact one by at most
/// `6.1 2^-24 A + B Z (1 + 2^-22)`, with `A = sum |u_i z_i|`,
/// `Z = sum |z_i|` and `B` the edge functions' error bound `2^-18 s^2 C`
/// with `C = 1 + 2^-20`, never below the test's own `2^-18 m s` (`m` the
/// largest sheared coordinate): the shear divides by the dominant
/// component, so |sx|, |sy| <= 1 + 2^-23 (one rounding of the reciprocal,
/// one of the product), hence |p_kx - sx p_kz| is at most
/// (|p_kx| + |p_kz|) (1 + 2^-22) after its roundings, while the computed L1
/// sum is at least the exact one times (1 - 2^-23): `m <= s (1 + 2^-21) <=
/// fl(s C)` (subnormal sums and differences are exact, and overflow makes
/// `s` infinite), and rounding is monotonic; unit test in
/// `triangle/lanes.rs`. Each `z_i` carries three roundings (difference,
/// reciprocal, product), the products and sums three more, and each exact
/// edge function is within `B` of `u_i`. `E = (2^-21 A + B Z) (1 + 2^-10)` covers that and the
/// roundings of `E` itself; `T` beyond `E` on the side opposite to `D`
/// means `t < 0` exactly. A ray whose origin lies on the plane never gets
/// past the bound, so no hit at `t = 0` is lost. The AVX2 leaf test makes
/// the same check on eight lanes at once (`certainly_behind_lanes` in
/// `triangle/lanes.rs`, the same operations in the same order).
#[inline(always)]
pub(crate) fn certainly_behind(
    ray: &Ray,
    s: &RayShear,
    p: [Vec3; 3],
    uvw: [f32; 3],
    scale: f32,
) -> bool {
    Numerator::new(ray, s, p, uvw).behind(scale)
}

/// What `f32` decides, for an any-hit query, about a triangle whose edge
/// functions `u, v, w` have certain signs, none of them opposite:
/// `Some(false)` when `tmin >= 0` and its plane certainly lies behind the
/// origin (the check [`hit_from_certain_edges`] makes first), `Some(true)`
/// when it is certainly hit inside the interval ([`certainly_hit_within`]),
/// `None` when only the full test can tell. Both checks share one
/// numerator: a shadow ray's own triangle, which lies behind it, used to
/// have it computed twice.
#[inline(always)]
pub(crate) fn certain_any_hit(
    ray: &Ray,
    s: &RayShear,
    p: [Vec3; 3],
    uvw: [f32; 3],
    scale: f32,
) -> Option<bool> {
    let n = Numerator::new(ray, s, p, uvw);
    if ray.tmin >= 0.0 && n.behind(scale) {
        Some(false)
    } else if certainly_hit_within(&n, ray, uvw, scale) {
        Some(true)
    } else {
        None
    }
}

/// The second half of [`certain_any_hit`], for a triangle already known
/// not to lie certainly behind the origin: whether it is certainly hit
/// inside the interval.
#[inline(always)]
pub(crate) fn certainly_hit(
    ray: &Ray,
    s: &RayShear,
    p: [Vec3; 3],
    uvw: [f32; 3],
    scale: f32,
) -> bool {
    certainly_hit_within(&Numerator::new(ray, s, p, uvw), ray, uvw, scale)
}

/// 2^-100: the smallest magnitude [`Numerator::far_from_underflow`] and
/// [`certainly_hit_within`] accept as far from underflow.
pub(crate) const TINY: f32 = 1.0 / 1_267_650_600_228_229_401_496_703_205_376.0;

/// The distance's numerator `T` (see [`certainly_behind`]) and its parts.
struct Numerator {
    /// The vertices' coordinates along the dominant axis minus the origin's.
    diff: [f32; 3],
    /// `diff` divided by the direction's dominant component.
    z: [f32; 3],
    /// `u_i z_i`.
    terms: [f32; 3],
    /// `T`, signed as `D`.
    toward: f32,
}

impl Numerator {
    #[inline(always)]
    fn new(ray: &Ray, s: &RayShear, p: [Vec3; 3], [u, v, w]: [f32; 3]) -> Self {
        let (k, oz) = (s.kz, ray.origin[s.kz]);
        let diff = p.map(|p| p[k] - oz);
        let z = diff.map(|d| d * s.sz);
        let terms = [u * z[0], v * z[1], w * z[2]];
        let t_num = terms[0] + terms[1] + terms[2];
        let toward = if u < 0.0 { -t_num } else { t_num };
        Numerator {
            diff,
            z,
            terms,
            toward,
        }
    }

    /// Whether the relative bounds of [`Numerator::error_bounds`] hold: no
    /// quantity they cover is near underflow, where a rounding error is
    /// absolute (up to 2^-150), not relative. Then every product and sum is
    /// normal: the edge functions are off by at most `B >= 2^-98` for
    /// `scale >= 2^-40`, far above any subnormal error, and a vertex's `z`
    /// is exactly 0 (its coordinate equals the origin's) or at least
    /// 2^-100, and so is each term `u_i z_i`. (Without this check a ray
    /// with a direction component of 1e30 lost hits at `t` near 1e-36: its
    /// terms were subnormal, and `certainly_behind` misjudged the sign.)
    #[inline(always)]
    fn far_from_underflow(&self, scale: f32) -> bool {
        let normal = |i: usize| {
            self.diff[i] == 0.0 || (self.z[i].abs() >= TINY && self.terms[i].abs() >= TINY)
        };
        scale >= 1.0 / 1_099_511_627_776.0 && normal(0) && normal(1) && normal(2)
    }

    /// Whether `T` lies beyond its error bound on the side opposite to `D`
    /// and far from underflow: the plane certainly meets the ray's line
    /// behind the origin (see [`certainly_behind`]).
    #[inline(always)]
    fn behind(&self, scale: f32) -> bool {
        // `T` signed as `D`: negative beyond the bound means behind.
        self.toward < -self.error_bounds(scale).0 && self.far_from_underflow(scale)
    }

    /// `E`, the bound of `T`'s error, and `B`, the edge functions'.
    #[inline(always)]
    fn error_bounds(&self, scale: f32) -> (f32, f32) {
        let (t, z) = (self.terms, self.z);
        let a = t[0].abs() + t[1].abs() + t[2].abs();
        let zs = z[0].abs() + z[1].abs() + z[2].abs();
        let b = scale * (scale * (1.0 + 1.0 / 1_048_576.0)) * (1.0 / 262_144.0);
        let e = (a * (1.0 / 2_097_152.0) + b * zs) * (1.0 + 1.0 / 1024.0);
        (e, b)
    }
}

/// Whether a triangle whose edge functions `u, v, w` have certain signs,
/// none of them opposite, is certainly hit well inside the ray's interval,
/// so that an any-hit query may stop without [`hit_from_certain_edges`]'s
/// `f64` distance, which occluded rays would otherwise pay on nearly every
/// blocker (docs/perf-log/2026-11-24-sixth-round.md).
///
/// The exact distance is `T / D` (see [`certainly_behind`]): the exact `T`
/// lies within `E` of the computed one, and the exact `D` within
/// `3 B + 2^-22 |D|` of the computed sum (three edge functions each within
/// `B`, two roundings of a sum of like signs), both widened by `2^-10` for
/// the bounds' own roundings. So `t` lies in
/// `[(T - E) / (|D| + e_D), (T + E) / (|D| - e_D)]` (each quotient
/// widened by `2^-20` for its rounding), and the interval must lie `2^-20`
/// of `t` inside `[tmin, tmax]`. The full test's `f64` distance is then
/// accurate to far below that margin: `e_D < |D|` bounds how nearly the ray
/// grazes the plane (`|D|` is the ray's cosine with the normal times the
/// doubled sheared area, `e_D` at least `2^-18` of that area's scale), and
/// the `f64` plane equation loses only `2^-52` over that cosine; so its
/// distance lies in the interval, its hit point inside the triangle's box
/// (as the exact one does, within the `2^-30` margin the full test allows),
/// the box's slab test passes, and the answer is the one the full test
/// gives. Near underflow, where the relative bounds fail
/// ([`Numerator::far_from_underflow`]), and wherever a NaN fails a
/// comparison, it leaves the decision to the full test.
#[inline(always)]
fn certainly_hit_within(n: &Numerator, ray: &Ray, uvw: [f32; 3], scale: f32) -> bool {
    const SLACK: f32 = 1.0 / 1024.0;
    const QUOTIENT: f32 = 1.0 / 1_048_576.0;
    const MARGIN: f32 = 1.0 / 1_048_576.0;
    // Most candidates of an any-hit query that are no blockers lie behind
    // (the triangle a shadow ray leaves from): out before the rest.
    // (NaN goes on, and fails a comparison below.)
    if n.toward <= 0.0 || !n.far_from_underflow(scale) {
        return false;
    }
    let (e, b) = n.error_bounds(scale);
    let d = (uvw[0] + uvw[1] + uvw[2]).abs();
    if d < TINY {
        return false; // (NaN fails `den_lo > 0` below)
    }
    let e_d = (3.0 * b + d * (1.0 / 4_194_304.0)) * (1.0 + SLACK);
    let (num_lo, num_hi) = (n.toward - e, n.toward + e);
    let (den_lo, den_hi) = (d - e_d, d + e_d);
    if !(num_lo > 0.0 && den_lo > 0.0) {
        return false;
    }
    let lo = num_lo / den_hi * (1.0 - QUOTIENT);
    let hi = num_hi / den_lo * (1.0 + QUOTIENT);
    lo * (1.0 - MARGIN) >= ray.tmin && hi * (1.0 + MARGIN) <= ray.tmax && hi.is_finite()
}

/// The hit at the normalised edge weights `weights()` (of `p0, p1, p2`):
/// its distance in `f64`, checked against the ray's interval. The weights
/// are asked for only when needed (a hit, or the fallback distance below):
/// most candidates of a closest-hit traversal fail the interval check, and
/// normalising costs three divisions.
///
/// Not inlined: inlined into a traversal, its per-ray set-up (the ray in
/// `f64`, the reciprocal direction) was hoisted into every leaf visit of the
/// any-hit traversal, whether a candidate needed it or not
/// (docs/perf-log/2026-11-23-fourth-round.md).
#[inline(never)]
fn hit_from_weights(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    weights: impl Fn() -> (f64, f64, f64),
) -> Option<TriangleHit> {
    // The distance from the plane equation in f64: well conditioned unless
    // the ray grazes the plane, and exact in the common case of an
    // axis-aligned triangle.
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (q0, q1, q2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
    let n = (q1 - q0).cross(q2 - q0);
    if n == DVec3::ZERO {
        // Zero area: never hit.
        return None;
    }
    let nd = n.dot(d);
    if nd == 0.0 {
        return None;
    }
    let mut t = n.dot(q0 - o) / nd;
    // The plane equation cancels badly when the vertices' magnitudes differ
    // wildly (a vertex at 1e30 swallows the other edges' small components
    // in `n`), and can then put the hit far from the triangle: a hit must
    // be reported only where the triangle is, or structures that offer it
    // only there disagree with brute force. So the hit point must lie in the
    // triangle's box, up to a per-axis margin of 2^-30 of the point's own
    // terms |o| + |d t| (its rounding error when `t` is accurate, far below
    // f32 precision; the box corners are exact in f64). Otherwise `t` is
    // recomputed as the barycentric combination of the vertices' distances
    // along the dominant axis, which puts the point on the triangle by
    // construction (vertex weights 0, 1, 0 give that vertex exactly). Only
    // hits pay for the check, and a false alarm merely picks the other,
    // equally valid formula.
    let point = o + d * t;
    let lo = q0.min(q1).min(q2);
    let hi = q0.max(q1).max(q2);
    let margin = (o.abs() + (d * t).abs()) * f64::from(2.0f32.powi(-30));
    let mut known = None;
    if !(point.cmpge(lo - margin).all() && point.cmple(hi + margin).all()) {
        let (u, v, w) = weights();
        known = Some((u, v, w));
        let (k, oz) = (s.kz, o[s.kz]);
        t = (u * (q0[k] - oz) + v * (q1[k] - oz) + w * (q2[k] - oz)) / d[k];
    }
    let t = t as f32;
    if !(t >= ray.tmin && t <= ray.tmax) {
        return None;
    }
    // The distance is accurate to a tiny fraction of the vertices' scale,
    // not of `t` itself: a ray starting within that distance of the plane
    // (a subnormal offset from an edge, say) can get `t = 0` for a plane it
    // meets just behind its origin, at a point outside the triangle's box.
    // Every structure offers a triangle only where the conservative slab
    // test (the one its nodes use) finds the triangle's box on the ray, so a
    // hit is kept only where that test passes for the triangle's own box:
    // the test never rejects a true hit, and a box that contains the
    // triangle's passes whenever this one does. As in the structures'
    // culling, `tmax` is widened by the slab rounding bound: the box of a
    // triangle hit exactly at the current closest hit (a shared vertex, a
    // tie) may be entered a rounding later, and must still pass, whichever
    // of the two a traversal meets first.
    let (enter, _) = Aabb::from_points([p0, p1, p2]).intersect_widened(ray, ray.inv_dir())?;
    // A hit is never reported before the box's entry allows: where `t`
    // fell short of it (beyond the widening), as in a ray starting a
    // subnormal distance from a triangle next to a vertex at 1e30, where
    // `t` came out as 0 for an entry at 4e-40, the entry is the distance.
    // Otherwise the answer would depend on the order of the tests: with
    // `tmax` already shrunk to `t` by another triangle, the box check fails
    // and the hit vanishes, while tested first it stands (brute force and
    // `bvh-sah` disagreed on such a tie). With it, the answer depends on
    // `tmax` only through `t <= tmax`, and a structure's culling at
    // `widen_up(tmax)` never drops a reportable hit.
    let t = if enter > widen_up(t) { enter } else { t };
    if t > ray.tmax {
        return None;
    }
    let (_, v, w) = known.unwrap_or_else(weights);
    Some(TriangleHit {
        t,
        u: v as f32,
        v: w as f32,
    })
}

/// The normalised edge functions (barycentric weights of p0, p1, p2)
/// computed in `f64` from the `f32` inputs, or `None` on a miss. Used when
/// `f32` cannot decide the signs (so the only place an edge function can be
/// exactly zero, where `OWNED` applies the ownership rule).
#[cold]
fn edge_functions_f64<const OWNED: bool>(
    ray: &Ray,
    s: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<(f64, f64, f64)> {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let (sx, sy) = (d[s.kx] / d[s.kz], d[s.ky] / d[s.kz]);
    let shear = |p: Vec3| {
        let q = p.as_dvec3() - o;
        (q[s.kx] - sx * q[s.kz], q[s.ky] - sy * q[s.kz])
    };
    let (ax, ay) = shear(p0);
    let (bx, by) = shear(p1);
    let (cx, cy) = shear(p2);
    // Same formulas as in f32, so shared edges stay exactly antisymmetric.
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    if OWNED && (u == 0.0 || v == 0.0 || w == 0.0) {
        // Each edge function's sign at the pushed point: its own where
        // nonzero, else the edge's (edges b->c, c->a, a->b, as u, v, w).
        let signs = [
            pushed_sign(u, (cx - bx, cy - by)),
            pushed_sign(v, (ax - cx, ay - cy)),
            pushed_sign(w, (bx - ax, by - ay)),
        ];
        if !(signs == [1; 3] || signs == [-1; 3]) {
            return None;
        }
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    Some((u / det, v / det, w / det))
}

/// The sign of an edge function `e` at the test point pushed by
/// `epsilon (delta_x, delta_y) = epsilon (tiny, 1)`: `e` itself when nonzero,
/// else the first-order term `cross(delta, edge)`, with `edge` the directed
/// edge `q - p` in the sheared plane (the edge function at point `x` is
/// `cross(q - x, p - x) = e + cross(x, q - p)`). `0` for an edge of zero
/// length, which owns nothing. Both triangles of a shared edge see the edge
/// reversed, exactly (`fl(a - b) = -fl(b - a)`), so they get opposite signs.
#[inline(always)]
fn pushed_sign(e: f64, (ex, ey): (f64, f64)) -> i8 {
    let first_order = if ex != 0.0 { -ex } else { ey };
    let x = if e != 0.0 { e } else { first_order };
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// Whether the triangle has zero area (coincident or collinear vertices), as
/// decided by an `f64` cross product of its edges.
pub fn is_degenerate(p0: Vec3, p1: Vec3, p2: Vec3) -> bool {
    let (p0, p1, p2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
    (p1 - p0).cross(p2 - p0) == DVec3::ZERO
}

/// The case of the test `an_underflowing_bound_leaves_the_signs_to_f64`:
/// a ray from the origin, a triangle within about 1e-22 of it that the ray
/// passes just outside edge `bc` of, and the neighbour across that edge
/// (its apex mirrored through the edge's midpoint), which the ray crosses.
#[cfg(test)]
pub(crate) fn underflow_case() -> (Ray, [Vec3; 3], [Vec3; 3]) {
    let v = |b: [u32; 3]| Vec3::from_array(b.map(f32::from_bits));
    let a = v([0x1a78_3dd3, 0x1b4d_c987, 0x1a6c_8f1f]);
    let b = v([0x1aad_fc63, 0x9ad4_c7e1, 0x1b3e_89bb]);
    let c = v([0x9b61_983c, 0x9a19_d5a4, 0x1aae_3043]);
    let dir = Vec3::new(
        f32::from_bits(0xbe64_fc4c),
        f32::from_bits(0xbf08_4478),
        1.0,
    );
    let ray = Ray::new(Vec3::ZERO, dir, 0.0, f32::INFINITY);
    (ray, [a, b, c], [c, b, b + c - a])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: Vec3, d: Vec3) -> Ray {
        Ray::new(o, d, 0.0, f32::INFINITY)
    }

    const P0: Vec3 = Vec3::new(0.0, 0.0, 0.0);
    const P1: Vec3 = Vec3::new(1.0, 0.0, 0.0);
    const P2: Vec3 = Vec3::new(0.0, 1.0, 0.0);

    /// The behind-the-origin filter fires only where the plane really lies
    /// behind the origin, down to origins a hair (1e-9) off the plane, and
    /// it does fire for rays leaving a surface by the usual offsets.
    #[test]
    fn behind_filter_is_sound_and_useful() {
        let mut rnd = crate::util::unit_sequence(0x2545_f491_4f6c_dd1d);
        let (mut fired, mut sure_behind) = (0, 0);
        for i in 0..200_000 {
            let mut v = || Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0;
            let p = [v(), v(), v()];
            let d = v();
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.length() < 1e-3 {
                continue;
            }
            let (b1, b2) = (rnd() * 0.5, rnd() * 0.5);
            let on = p[0] + (p[1] - p[0]) * b1 + (p[2] - p[0]) * b2;
            let offset = 10f32.powi(-3 - (i % 7)) * if i % 2 == 0 { 1.0 } else { -1.0 };
            let origin = on + n.normalize() * offset;
            let r = ray(origin, d);
            let s = RayShear::new(&r);
            // The scalar test's edge stage.
            let rel = p.map(|q| q - r.origin);
            let sh = rel.map(|q| (q[s.kx] - s.sx * q[s.kz], q[s.ky] - s.sy * q[s.kz]));
            let (u, vv, w) = (
                sh[2].0 * sh[1].1 - sh[2].1 * sh[1].0,
                sh[0].0 * sh[2].1 - sh[0].1 * sh[2].0,
                sh[1].0 * sh[0].1 - sh[1].1 * sh[0].0,
            );
            let scale = rel
                .iter()
                .map(|q| q.abs().element_sum())
                .fold(0.0, f32::max);
            let m = sh
                .iter()
                .flat_map(|&(x, y)| [x.abs(), y.abs()])
                .fold(0.0, f32::max);
            let bound = m * scale * (1.0 / 262_144.0);
            let decided = u.abs().min(vv.abs()).min(w.abs()) > bound;
            let same = (u > 0.0 && vv > 0.0 && w > 0.0) || (u < 0.0 && vv < 0.0 && w < 0.0);
            if !(decided && same) {
                continue;
            }
            // The plane distance in f64 (inputs exact): its sign is certain
            // well beyond 1e-12 of the scene's scale.
            let (o, dd) = (r.origin.as_dvec3(), r.dir.as_dvec3());
            let q = p.map(|q| q.as_dvec3());
            let nn = (q[1] - q[0]).cross(q[2] - q[0]);
            let t = nn.dot(q[0] - o) / nn.dot(dd);
            let behind = certainly_behind(&r, &s, p, [u, vv, w], scale);
            if t.abs() > 1e-12 {
                assert!(!behind || t < 0.0, "{p:?} {r:?}: filtered at t = {t}");
                if t < -1e-4 {
                    sure_behind += 1;
                    fired += usize::from(behind);
                }
            }
        }
        assert!(
            fired > sure_behind * 9 / 10,
            "fired {fired} of {sure_behind}"
        );
        assert!(sure_behind > 10_000, "only {sure_behind} cases behind");
    }

    #[test]
    fn hit_reports_t_and_barycentrics() {
        let h = intersect_triangle(&ray(Vec3::new(0.25, 0.5, 2.0), -Vec3::Z), P0, P1, P2).unwrap();
        assert_eq!(h.t, 2.0);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
        // Two-sided: from below as well.
        let h = intersect_triangle(&ray(Vec3::new(0.25, 0.5, -3.0), Vec3::Z), P0, P1, P2).unwrap();
        assert_eq!(h.t, 3.0);
    }

    #[test]
    fn miss_and_interval() {
        assert!(intersect_triangle(&ray(Vec3::new(0.8, 0.8, 1.0), -Vec3::Z), P0, P1, P2).is_none());
        let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 0.0, 0.5);
        assert!(intersect_triangle(&r, P0, P1, P2).is_none());
        let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 1.0, 1.0);
        assert!(intersect_triangle(&r, P0, P1, P2).is_some());
        let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 1.5, 9.0);
        assert!(intersect_triangle(&r, P0, P1, P2).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays aimed
        // at the diagonal hit at least one. (Not at the square's corners,
        // where a ray rounded off the exact corner may rightly miss.)
        let q = Vec3::new(1.0, 1.0, 0.0);
        for i in 1..100 {
            let s = i as f32 / 100.0;
            let target = Vec3::new(s, 1.0 - s, 0.0);
            let o = Vec3::new(0.3, -0.7, 1.3);
            let r = ray(o, target - o);
            let a = intersect_triangle(&r, P1, P2, P0).is_some();
            let b = intersect_triangle(&r, P2, P1, q).is_some();
            assert!(a || b, "escaped at {s}");
        }
    }

    #[test]
    fn degenerate_never_hits() {
        let r = ray(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
        assert!(intersect_triangle(&r, P0, P1, Vec3::new(2.0, 0.0, 0.0)).is_none());
        assert!(intersect_triangle(&r, P0, P0, P0).is_none());
        let zero = Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::ZERO, 0.0, 1.0);
        assert!(intersect_triangle(&zero, P0, P1, P2).is_none());
    }

    /// Rays whose direction has a huge component (1e20 to 1e35) meeting a
    /// small triangle just ahead of their origin, at `t` between about
    /// 1e-40 and 1e-25: every one is a hit near the triangle's centre.
    /// A triangle within about 1e-22 of the ray's origin, where the edge
    /// functions' bound `2^-18 m s` underflows to zero: the ray passes
    /// outside edge `bc` by far less than the sheared coordinates' rounding
    /// (the exact edge function is -3.9e-52, in exact arithmetic on the
    /// `f32` inputs and shear), while the `f32` one came out as +1.4e-45
    /// (found by a search with exact rational arithmetic). A zero bound once
    /// counted as certain, and the test reported a hit just off the
    /// triangle; the neighbour across `bc`, which the ray really crosses,
    /// was missed. Both go to the `f64` stage now.
    #[test]
    fn an_underflowing_bound_leaves_the_signs_to_f64() {
        let (r, [a, b, c], neighbour) = underflow_case();
        let s = RayShear::new(&r);
        assert_eq!((s.kx, s.ky, s.kz), (0, 1, 2));
        // The `f32` edge function of `bc` and the bound, as the test computes
        // them: nonzero, and a bound of zero.
        let sheared = |p: Vec3| (p.x - s.sx * p.z, p.y - s.sy * p.z);
        let ((ax, ay), (bx, by), (cx, cy)) = (sheared(a), sheared(b), sheared(c));
        assert_eq!(cx * by - cy * bx, f32::from_bits(1));
        let m = [ax, ay, bx, by, cx, cy]
            .map(f32::abs)
            .into_iter()
            .fold(0.0, f32::max);
        let scale = [a, b, c]
            .map(|p| p.abs().element_sum())
            .into_iter()
            .fold(0.0, f32::max);
        assert_eq!(m * scale * (1.0 / 262_144.0), 0.0);
        assert_eq!(intersect_triangle(&r, a, b, c), None);
        let [p0, p1, p2] = neighbour;
        assert!(intersect_triangle(&r, p0, p1, p2).is_some());
    }

    /// `certainly_behind` once declared such triangles behind the origin:
    /// the distance's terms were subnormal, their rounding errors absolute,
    /// and its relative bound too small (7,723 of 1.4 million hits lost).
    #[test]
    fn hits_at_tiny_distances_are_not_declared_behind() {
        let mut next = crate::util::unit_sequence(7);
        let mut checked = 0;
        for _ in 0..300_000 {
            let pick = |x: f32, of: [f32; 4]| of[(x * 4.0) as usize % 4];
            let dir = Vec3::new(
                pick(next(), [1e20, 1e25, 1e30, 1e35]),
                next() * 2.0 - 1.0,
                next() * 2.0 - 1.0,
            );
            let size = pick(next(), [1e-2, 1e-3, 1e-4, 3e-4]);
            let c = Vec3::new(next(), next(), next());
            let tri =
                [0, 1, 2].map(|_| c + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size);
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            // Planes nearly parallel to the dominant axis put the hit
            // anywhere; skip them.
            if n.x.abs() < 0.3 * n.length() {
                continue;
            }
            let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
            // Many ulps of the coordinates (about 6e-8 here), so that the
            // origin really lies in front of the plane.
            let back = pick(next(), [1e-5, 3e-6, 1e-6, 3e-5]);
            let origin = centre - Vec3::new(back, 0.0, 0.0);
            let ray = Ray::new(origin, dir, 0.0, f32::INFINITY);
            let hit = intersect_triangle(&ray, tri[0], tri[1], tri[2]);
            assert!(hit.is_some(), "{ray:?} {tri:?}: lost");
            checked += 1;
        }
        assert!(checked > 100_000, "only {checked}");
    }
}
