//! The flattened primitives as the tracer and the shader meet them: the
//! shapes, the meshes they index, their bounds, and the exact `f64`
//! intersection and hit record of each (the compile step that makes them is
//! [`super`]).

use std::sync::Arc;

use arbor_accel::numerics::{f32_at_or_above, f32_at_or_below};
use arbor_accel::{Aabb, Vec3};
use glam::{DVec2, DVec3};

use crate::ray::Ray;
use crate::shader::Shader;
use crate::surface::{box_, cylinder, sphere, triangle, Candidate, Transform};
use crate::terminator;
use crate::variant::Variant;

/// The transform index of a primitive without a transform.
pub(super) const NO_TRANSFORM: u32 = u32::MAX;

/// One shape the accelerators index.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// Analytic sphere (object space).
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// 2010 analytic box (object space).
    Box {
        /// Lower corner.
        min: DVec3,
        /// Upper corner.
        max: DVec3,
    },
    /// Capped cylinder (object space).
    Cylinder {
        /// Axis centre.
        center: DVec3,
        /// Radius.
        radius: f64,
        /// Length along z.
        height: f64,
    },
    /// Triangle `index` of mesh `mesh`.
    Triangle {
        /// Index into the flattened meshes.
        mesh: u32,
        /// Triangle index within the mesh.
        index: u32,
    },
}

/// A flattened primitive: its shape, its transform (an index, or none) and
/// its shader.
#[derive(Clone, Copy, Debug)]
pub struct Primitive {
    /// The geometry.
    pub shape: Shape,
    pub(super) transform: u32,
    pub(super) shader: u32,
}

/// A mesh after flattening: positions in world space (2010) or object space
/// with a transform (2015), normals ready for interpolation.
#[derive(Clone, Debug)]
pub struct FlatMesh {
    /// Vertex positions (the `f32` values, widened).
    pub positions: Vec<DVec3>,
    /// Per-vertex normals (2010: transformed and normalised; 2015: as in the file).
    pub normals: Option<Vec<DVec3>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<DVec2>>,
    /// Per-vertex linear colours.
    pub colors: Option<Vec<DVec3>>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Back faces shaded like front faces ([`crate::surface::MeshSurface::two_sided`]).
    pub two_sided: bool,
    /// Shadow rays lifted off ([`crate::surface::MeshSurface::soft_terminator`]).
    pub soft_terminator: bool,
    pub(super) transform: u32,
    pub(super) shader: u32,
}

/// Everything needed to shade a hit point.
#[derive(Clone, Copy, Debug)]
pub struct Hit<'a> {
    /// Ray parameter.
    pub t: f64,
    /// World-space position.
    pub point: DVec3,
    /// World-space normal (unit length, except the 2015 transformed sphere,
    /// spec §5.1).
    pub normal: DVec3,
    /// Texture coordinates when the surface has them.
    pub uv: Option<DVec2>,
    /// The interpolated vertex colour when the mesh has vertex colours.
    pub color: Option<DVec3>,
    /// Added to `point` where shadow rays start: zero, except on meshes
    /// with [`crate::surface::MeshSurface::soft_terminator`].
    pub shadow_offset: DVec3,
    /// The surface's shader.
    pub shader: &'a Shader,
}

/// Flattened geometry in one space: primitives (each with its shader and
/// transform, if any), the meshes they index and their bounds. A
/// [`FlattenedScene`] holds one for the world and one per shared geometry
/// (in that geometry's own space); [`FlatGeometry::new`] makes the whole
/// scene one, every instance copied.
#[derive(Clone, Debug)]
pub struct FlatGeometry {
    pub(super) variant: Variant,
    pub(super) primitives: Vec<Primitive>,
    pub(super) meshes: Vec<FlatMesh>,
    pub(super) transforms: Vec<Transform>,
    pub(super) shaders: Vec<Arc<Shader>>,
    /// World-space `f64` bounds of each primitive.
    pub(super) bounds: Vec<(DVec3, DVec3)>,
    /// Per primitive, its corners if it is a triangle without a transform:
    /// the exact test reads them in one place instead of through the mesh's
    /// index and position arrays (the renderer's commonest test).
    pub(super) plain_triangles: Vec<Option<[DVec3; 3]>>,
    /// Primitives dropped for non-finite coordinates.
    pub(super) dropped: usize,
}

impl FlatGeometry {
    /// How many primitives were dropped for non-finite coordinates.
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// The variant whose conventions the intersection code follows.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.primitives.len()
    }

    /// Whether there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.primitives.is_empty()
    }

    /// Bounds of primitive `i` in this geometry's space.
    pub fn bounds(&self, i: usize) -> (DVec3, DVec3) {
        self.bounds[i]
    }

    /// Primitive `i`'s corners in this scene's space, if it is a triangle
    /// (for drawing it).
    pub fn triangle_corners(&self, i: usize) -> Option<[DVec3; 3]> {
        let prim = &self.primitives[i];
        let Shape::Triangle { mesh, index } = prim.shape else {
            return None;
        };
        let (_, p) = self.triangle(mesh, index);
        Some(match self.transform(prim.transform) {
            Some(t) => p.map(|q| t.point_to_world(q)),
            None => p,
        })
    }

    /// Primitive `i`'s centre and radius, if it is a sphere that no
    /// transform distorts (for drawing it).
    pub fn plain_sphere(&self, i: usize) -> Option<(DVec3, f64)> {
        let prim = &self.primitives[i];
        match prim.shape {
            Shape::Sphere { center, radius } if prim.transform == NO_TRANSFORM => {
                Some((center, radius))
            }
            _ => None,
        }
    }

    /// Transform `index`, or none for [`NO_TRANSFORM`].
    pub(super) fn transform(&self, index: u32) -> Option<&Transform> {
        (index != NO_TRANSFORM).then(|| &self.transforms[index as usize])
    }

    /// Triangle `index` of mesh `mesh`: the mesh and its corners.
    pub(super) fn triangle(&self, mesh: u32, index: u32) -> (&FlatMesh, [DVec3; 3]) {
        let m = &self.meshes[mesh as usize];
        let [a, b, c] = m.triangles[index as usize];
        let p = |i: u32| m.positions[i as usize];
        (m, [p(a), p(b), p(c)])
    }

    /// Primitive `i`'s bounds in this geometry's space, NaN when a vertex
    /// is not finite.
    pub(super) fn primitive_bounds(&self, i: usize) -> (DVec3, DVec3) {
        let prim = &self.primitives[i];
        let xf = self.transform(prim.transform);
        let object = match prim.shape {
            Shape::Sphere { center, radius } => (center - radius, center + radius),
            Shape::Box { min, max } => (min, max),
            Shape::Cylinder {
                center,
                radius,
                height,
            } => {
                let e = DVec3::new(radius, radius, height / 2.0);
                (center - e, center + e)
            }
            Shape::Triangle { mesh, index } => {
                let (_, p) = self.triangle(mesh, index);
                // Transform the vertices themselves: tighter than the corners of their box.
                let p = p.map(|v| xf.map_or(v, |t| t.point_to_world(v)));
                if !p.iter().all(|v| v.is_finite()) {
                    // min/max would quietly skip a NaN; mark the box unusable.
                    return (DVec3::NAN, DVec3::NAN);
                }
                return (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            }
        };
        match xf {
            Some(t) => t.bounds_to_world(object.0, object.1),
            None => object,
        }
    }

    /// The exact `f64` intersection of primitive `i` with `ray` (in this
    /// scene's space), `t` in the ray's `(tmin, tmax)` (closed for 2015
    /// triangles).
    pub fn intersect(&self, i: usize, ray: &Ray) -> Option<Candidate> {
        let is2015 = self.variant == Variant::Cornell2015;
        if let Some(p) = &self.plain_triangles[i] {
            return triangle_candidate(*p, ray, is2015);
        }
        let prim = &self.primitives[i];
        let object_ray = match self.transform(prim.transform) {
            Some(t) => ray.with_line(
                t.point_to_object(ray.origin),
                t.vector_to_object(ray.direction),
            ),
            None => *ray,
        };
        let ray = &object_ray;
        match prim.shape {
            Shape::Sphere { center, radius } => {
                sphere::intersect(center, radius, ray, self.variant).map(|t| Candidate {
                    t,
                    aux: DVec3::ZERO,
                })
            }
            Shape::Box { min, max } => {
                box_::intersect(min, max, ray).map(|(t, n)| Candidate { t, aux: n })
            }
            Shape::Cylinder {
                center,
                radius,
                height,
            } => cylinder::intersect(center, radius, height, ray)
                .map(|(t, n)| Candidate { t, aux: n }),
            Shape::Triangle { mesh, index } => {
                let (_, p) = self.triangle(mesh, index);
                triangle_candidate(p, ray, is2015)
            }
        }
    }

    /// The full hit record for a candidate found by [`FlatGeometry::intersect`]
    /// on the same ray.
    pub fn hit(&self, i: usize, ray: &Ray, c: Candidate) -> Hit<'_> {
        let prim = &self.primitives[i];
        let is2015 = self.variant == Variant::Cornell2015;
        let xf = self.transform(prim.transform);
        let (o, d) = (ray.origin, ray.direction);
        let (oo, od) = match xf {
            Some(t) => (t.point_to_object(o), t.vector_to_object(d)),
            None => (o, d),
        };
        let object_point = oo + c.t * od;
        // 2010 takes the world ray's point; 2015 maps the object point back.
        let point = match (is2015, xf) {
            (true, Some(t)) => t.point_to_world(object_point),
            _ => o + c.t * d,
        };
        let to_world = |n: DVec3| match xf {
            Some(t) => t.normal_to_world(n).normalize(),
            None => n.normalize(),
        };
        let mut uv = None;
        let mut color = None;
        let mut shadow_offset = DVec3::ZERO;
        let normal = match prim.shape {
            Shape::Sphere { center, .. } => {
                let n = (object_point - center).normalize();
                if is2015 {
                    uv = Some(DVec2::new(
                        (n.x.atan2(n.z) + std::f64::consts::PI) / (2.0 * std::f64::consts::PI),
                        (n.y.asin() - std::f64::consts::FRAC_PI_2) / std::f64::consts::PI,
                    ));
                    // 2015 does not renormalise after the inverse transpose.
                    xf.map_or(n, |t| t.normal_to_world(n))
                } else {
                    to_world(n)
                }
            }
            Shape::Box { .. } => to_world(c.aux),
            Shape::Cylinder { .. } => {
                let n = if c.aux.dot(od) > 0.0 { -c.aux } else { c.aux };
                to_world(n)
            }
            Shape::Triangle { mesh, index } => {
                let (m, [p0, p1, p2]) = self.triangle(mesh, index);
                let (b, g) = (c.aux.x, c.aux.y);
                let a = 1.0 - b - g;
                let [i0, i1, i2] = m.triangles[index as usize].map(|k| k as usize);
                if let Some(uvs) = &m.uvs {
                    uv = Some(a * uvs[i0] + b * uvs[i1] + g * uvs[i2]);
                }
                if let Some(cs) = &m.colors {
                    color = Some(a * cs[i0] + b * cs[i1] + g * cs[i2]);
                }
                let geometric = (p1 - p0).cross(p2 - p0);
                let n = match &m.normals {
                    Some(ns) => a * ns[i0] + b * ns[i1] + g * ns[i2],
                    None => geometric,
                };
                // Two-sided: the normal turned to the ray's side of the
                // triangle when it points to the far side. The side is
                // decided by the geometric normal (in the space of `od`;
                // the inverse transpose keeps the sign of `n . d`), not by
                // the interpolated normal, which can face away from the
                // viewer near silhouettes of the front side too. One-sided
                // meshes (every Cornell scene's) pay for none of it.
                let turn = m.two_sided
                    && !matches!(*self.shaders[prim.shader as usize], Shader::Glass { .. })
                    && geometric.dot(od) * geometric.dot(n) > 0.0;
                if let (true, Some(ns)) = (m.soft_terminator, &m.normals) {
                    let side = if turn { -1.0 } else { 1.0 };
                    let local = terminator::shadow_offset(
                        object_point,
                        [p0, p1, p2],
                        [ns[i0], ns[i1], ns[i2]].map(|n| n * side),
                        [a, b, g],
                    );
                    shadow_offset = match xf {
                        Some(t) => t.matrix.transform_vector3(local),
                        None => local,
                    };
                }
                if turn {
                    to_world(-n)
                } else {
                    to_world(n)
                }
            }
        };
        Hit {
            t: c.t,
            point,
            normal,
            uv,
            color,
            shadow_offset,
            shader: &self.shaders[prim.shader as usize],
        }
    }
}

/// The spec's triangle test as a candidate: `t`, and the barycentrics
/// `(β, γ)` kept for the hit record.
#[inline]
fn triangle_candidate(p: [DVec3; 3], ray: &Ray, closed: bool) -> Option<Candidate> {
    triangle::intersect(p, ray, closed).map(|(t, b, g)| Candidate {
        t,
        aux: DVec3::new(b, g, 0.0),
    })
}

/// Rounds an `f64` box outward to `f32` and grows it by `pad` on every side.
pub fn to_f32_box(min: DVec3, max: DVec3, pad: f64) -> Aabb {
    let down = |x: f64| f32_at_or_below(x - pad);
    let up = |x: f64| f32_at_or_above(x + pad);
    Aabb::new(
        Vec3::new(down(min.x), down(min.y), down(min.z)),
        Vec3::new(up(max.x), up(max.y), up(max.z)),
    )
}
