//! Flattening: the compile step between the scene graph and the
//! accelerators. Transforms are composed down the hierarchy and pushed to the
//! leaves; every leaf becomes one or more [`Primitive`]s that an acceleration
//! structure can index by bounding box.
//!
//! Policy:
//!
//! * Geometry placed once is baked into world space: in the 2010 variant a
//!   mesh's vertices become `f32(M v)` exactly as the course's references
//!   require (spec §5.3); 2015 meshes keep object space and their transform.
//!   Analytic shapes (sphere, box, cylinder) stay analytic with their composed
//!   transform, so a transformed sphere is still an exact ellipsoid.
//! * A surface placed more than once (an [`Surface::Instance`] reached along
//!   more than one path) stays shared: its own geometry is flattened once, in
//!   its own space, and each placement is one transform referring to it.
//!   Instances of instances are composed down to single placements of the
//!   geometry they hold, so the renderer sees exactly two levels (see
//!   [`FlattenedScene`]). Memory follows the unique geometry plus one small
//!   record per placement.

use crate::hash_map::HashMap;
use std::sync::Arc;

use arbor_accel::numerics::{f32_at_or_above, f32_at_or_below};
use arbor_accel::{Aabb, Vec3};
use glam::{DMat4, DVec2, DVec3};
use rayon::prelude::*;

use crate::ray::Ray;
use crate::scene::{Scene, Variant};
use crate::shader::Shader;
use crate::surface::{box_, cylinder, sphere, triangle, Candidate, Surface, Transform};
use crate::terminator;

/// Index meaning "no transform" (the primitive is in world space).
const NO_TRANSFORM: u32 = u32::MAX;

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
    transform: u32,
    shader: u32,
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
    transform: u32,
    shader: u32,
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
    variant: Variant,
    primitives: Vec<Primitive>,
    meshes: Vec<FlatMesh>,
    transforms: Vec<Transform>,
    shaders: Vec<Arc<Shader>>,
    /// World-space `f64` bounds of each primitive.
    bounds: Vec<(DVec3, DVec3)>,
    /// Per primitive, its corners if it is a triangle without a transform:
    /// the exact test reads them in one place instead of through the mesh's
    /// index and position arrays (the renderer's commonest test).
    plain_triangles: Vec<Option<[DVec3; 3]>>,
    /// Primitives dropped for non-finite coordinates.
    dropped: usize,
}

/// A leaf whose transform cannot be inverted (a zero scale).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SingularTransform;

impl FlatGeometry {
    /// Flattens `scene`'s surface hierarchy completely: every instance is
    /// expanded into its own copy of the geometry, baked like any other leaf.
    /// The reference for [`FlattenedScene`], which keeps instances shared.
    pub fn new(scene: &Scene) -> Result<FlatGeometry, SingularTransform> {
        let mut flat = FlatGeometry::empty(scene.variant);
        let mut result = Ok(());
        for surface in &scene.surfaces {
            surface.for_each_leaf(DMat4::IDENTITY, &mut |leaf, m| {
                if result.is_ok() {
                    result = flat.add_leaf(leaf, m);
                }
            });
        }
        result?;
        flat.finish();
        Ok(flat)
    }

    fn empty(variant: Variant) -> FlatGeometry {
        FlatGeometry {
            variant,
            primitives: Vec::new(),
            meshes: Vec::new(),
            transforms: Vec::new(),
            shaders: Vec::new(),
            bounds: Vec::new(),
            plain_triangles: Vec::new(),
            dropped: 0,
        }
    }

    /// Computes the primitives' bounds once all leaves are in, dropping
    /// primitives whose bounds are not finite (NaN or infinite vertices,
    /// overflowing transforms): no exact test could hit them reliably and
    /// they would poison every box above them.
    fn finish(&mut self) {
        let bounds: Vec<_> = (0..self.primitives.len())
            .into_par_iter()
            .map(|i| self.primitive_bounds(i))
            .collect();
        let finite = |b: &(DVec3, DVec3)| b.0.is_finite() && b.1.is_finite();
        let before = self.primitives.len();
        let mut keep = bounds.iter().map(finite);
        self.primitives.retain(|_| keep.next().unwrap_or(false));
        self.bounds = bounds.into_iter().filter(finite).collect();
        self.dropped = before - self.primitives.len();
        self.plain_triangles = self
            .primitives
            .par_iter()
            .map(|prim| match prim.shape {
                Shape::Triangle { mesh, index } if prim.transform == NO_TRANSFORM => {
                    Some(self.triangle(mesh, index).1)
                }
                _ => None,
            })
            .collect();
    }

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

    fn shader_index(&mut self, shader: &Arc<Shader>) -> u32 {
        // Shaders are few; a linear search by pointer keeps them shared.
        if let Some(i) = self.shaders.iter().position(|s| Arc::ptr_eq(s, shader)) {
            return i as u32;
        }
        self.shaders.push(shader.clone());
        (self.shaders.len() - 1) as u32
    }

    fn transform_index(&mut self, m: DMat4) -> Result<u32, SingularTransform> {
        if m == DMat4::IDENTITY {
            return Ok(NO_TRANSFORM);
        }
        let t = Transform::new(m).ok_or(SingularTransform)?;
        self.transforms.push(t);
        Ok((self.transforms.len() - 1) as u32)
    }

    fn add_leaf(&mut self, leaf: &Surface, m: DMat4) -> Result<(), SingularTransform> {
        match leaf {
            Surface::Sphere(s) => {
                let (transform, shader) = (self.transform_index(m)?, self.shader_index(&s.shader));
                self.primitives.push(Primitive {
                    shape: Shape::Sphere {
                        center: s.center,
                        radius: s.radius,
                    },
                    transform,
                    shader,
                });
            }
            Surface::Box(b) => {
                let shader = self.shader_index(&b.shader);
                match self.variant {
                    Variant::Cornell2010 => {
                        let transform = self.transform_index(m)?;
                        self.primitives.push(Primitive {
                            shape: Shape::Box {
                                min: b.min,
                                max: b.max,
                            },
                            transform,
                            shader,
                        });
                    }
                    Variant::Cornell2015 => {
                        let (corners, tris) = box_::triangles_2015(b.min, b.max);
                        let transform = self.transform_index(m)?;
                        self.push_mesh(FlatMesh {
                            positions: corners.to_vec(),
                            normals: None,
                            uvs: None,
                            colors: None,
                            triangles: tris.to_vec(),
                            two_sided: false,
                            soft_terminator: false,
                            transform,
                            shader,
                        });
                    }
                }
            }
            Surface::Cylinder(c) => {
                let (transform, shader) = (self.transform_index(m)?, self.shader_index(&c.shader));
                self.primitives.push(Primitive {
                    shape: Shape::Cylinder {
                        center: c.center,
                        radius: c.radius,
                        height: c.height,
                    },
                    transform,
                    shader,
                });
            }
            Surface::Mesh(mesh) => {
                let shader = self.shader_index(&mesh.shader);
                let data = &mesh.data;
                let widen = |v: &Vec3| DVec3::new(v.x as f64, v.y as f64, v.z as f64);
                let uvs = data.uvs.as_ref().map(|uv| {
                    uv.iter()
                        .map(|t| DVec2::new(t.x as f64, t.y as f64))
                        .collect()
                });
                let colors: Option<Vec<DVec3>> = data
                    .colors
                    .as_ref()
                    .map(|cs| cs.iter().map(widen).collect());
                let flat = match self.variant {
                    Variant::Cornell2010 => {
                        // Bake to world space, rounding each vertex to f32 as the
                        // references require; normals by the inverse transpose,
                        // normalised per vertex.
                        let t = Transform::new(m).ok_or(SingularTransform)?;
                        let positions = data
                            .positions
                            .iter()
                            .map(|v| {
                                let w = t.point_to_world(widen(v));
                                DVec3::new(w.x as f32 as f64, w.y as f32 as f64, w.z as f32 as f64)
                            })
                            .collect();
                        let normals = data.normals.as_ref().map(|ns| {
                            ns.iter()
                                .map(|n| t.normal_to_world(widen(n)).normalize())
                                .collect()
                        });
                        FlatMesh {
                            positions,
                            normals,
                            uvs,
                            colors,
                            triangles: data.triangles.clone(),
                            two_sided: mesh.two_sided,
                            soft_terminator: mesh.soft_terminator,
                            transform: NO_TRANSFORM,
                            shader,
                        }
                    }
                    Variant::Cornell2015 => FlatMesh {
                        positions: data.positions.iter().map(widen).collect(),
                        normals: data
                            .normals
                            .as_ref()
                            .map(|ns| ns.iter().map(widen).collect()),
                        uvs,
                        colors,
                        triangles: data.triangles.clone(),
                        two_sided: mesh.two_sided,
                        soft_terminator: mesh.soft_terminator,
                        transform: self.transform_index(m)?,
                        shader,
                    },
                };
                self.push_mesh(flat);
            }
            Surface::Group(_) | Surface::Instance(_) => {
                unreachable!("only leaves are added")
            }
        }
        Ok(())
    }

    fn push_mesh(&mut self, mesh: FlatMesh) {
        let index = self.meshes.len() as u32;
        self.primitives
            .extend((0..mesh.triangles.len() as u32).map(|i| Primitive {
                shape: Shape::Triangle {
                    mesh: index,
                    index: i,
                },
                transform: mesh.transform,
                shader: mesh.shader,
            }));
        self.meshes.push(mesh);
    }

    fn transform(&self, index: u32) -> Option<&Transform> {
        (index != NO_TRANSFORM).then(|| &self.transforms[index as usize])
    }

    fn triangle(&self, mesh: u32, index: u32) -> (&FlatMesh, [DVec3; 3]) {
        let m = &self.meshes[mesh as usize];
        let [a, b, c] = m.triangles[index as usize];
        let p = |i: u32| m.positions[i as usize];
        (m, [p(a), p(b), p(c)])
    }

    fn primitive_bounds(&self, i: usize) -> (DVec3, DVec3) {
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

/// One placement of shared geometry: which geometry, and the inverse of its
/// composed world matrix (the ray goes into the geometry's space; normals
/// come back by the inverse transpose, points by the world ray).
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    /// World to the geometry's space.
    pub inverse: glam::DAffine3,
    /// Index into [`FlattenedScene::shared`].
    pub geometry: u32,
}

impl Placement {
    /// The world-space normal for a normal in the geometry's space (normalised).
    pub fn normal_to_world(&self, n: DVec3) -> DVec3 {
        (self.inverse.matrix3.transpose() * n).normalize()
    }
}

/// Why a scene could not be flattened.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FlattenError {
    /// A transform cannot be inverted (a zero scale).
    SingularTransform,
    /// More placements than the limit allows (checked before allocating them).
    TooManyPlacements {
        /// Placements the scene asks for.
        count: u64,
        /// The limit in force.
        limit: u64,
    },
}

impl std::fmt::Display for FlattenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FlattenError::SingularTransform => {
                f.write_str("the scene has a transform that cannot be inverted (a zero scale)")
            }
            FlattenError::TooManyPlacements { count, limit } => write!(
                f,
                "the scene places shared surfaces {count} times; the limit is {limit}"
            ),
        }
    }
}

impl std::error::Error for FlattenError {}

impl From<SingularTransform> for FlattenError {
    fn from(_: SingularTransform) -> Self {
        FlattenError::SingularTransform
    }
}

pub use crate::limits::DEFAULT_MAX_PLACEMENTS;

/// The scene after flattening with instancing kept: world-space geometry for
/// what is placed once, shared geometry for what is placed more often, and
/// the placements.
#[derive(Clone, Debug)]
pub struct FlattenedScene {
    /// Geometry placed once, in world space.
    pub world: FlatGeometry,
    /// Geometry placed more than once, each in its own space.
    pub shared: Vec<FlatGeometry>,
    /// Every placement of shared geometry.
    pub placements: Vec<Placement>,
    /// With [`FlattenedScene::bounded`]: the placements that are whole top-level
    /// objects (the lecture's bounded surfaces), by index into `placements`.
    pub objects: Vec<u32>,
}

impl FlattenedScene {
    /// Flattens like [`FlattenedScene::new`], but keeps every top-level surface
    /// together as one object: its geometry becomes its own shared geometry,
    /// placed once (identity) and listed in [`FlattenedScene::objects`], so that
    /// the tracer can wrap it in a bounding volume (the lecture's bounded
    /// surface: skip the whole object when the ray misses its volume).
    pub fn bounded(scene: &Scene, max_placements: u64) -> Result<FlattenedScene, FlattenError> {
        let mut out = FlattenedScene::of_surfaces(&[], scene.variant, max_placements)?;
        for surface in &scene.surfaces {
            // One surface at a time, borrowed: copying the scene for each
            // (as this once did) made `--bvol` quadratic in the surfaces.
            let part = FlattenedScene::of_surfaces(
                std::slice::from_ref(surface),
                scene.variant,
                max_placements,
            )?;
            let offset = out.shared.len() as u32;
            out.placements
                .extend(part.placements.into_iter().map(|p| Placement {
                    geometry: p.geometry + offset,
                    ..p
                }));
            out.shared.extend(part.shared);
            if !part.world.is_empty() {
                out.objects.push(out.placements.len() as u32);
                out.placements.push(Placement {
                    inverse: glam::DAffine3::IDENTITY,
                    geometry: out.shared.len() as u32,
                });
                out.shared.push(part.world);
            }
        }
        Ok(out)
    }

    /// Flattens `scene`, keeping multiply-placed surfaces shared; fails
    /// before allocating when more than `max_placements` placements would
    /// result.
    pub fn new(scene: &Scene, max_placements: u64) -> Result<FlattenedScene, FlattenError> {
        FlattenedScene::of_surfaces(&scene.surfaces, scene.variant, max_placements)
    }

    /// A completely flattened scene ([`FlatGeometry::new`]): everything in
    /// world space, no shared geometry.
    pub fn from_world(world: FlatGeometry) -> FlattenedScene {
        FlattenedScene {
            world,
            shared: Vec::new(),
            placements: Vec::new(),
            objects: Vec::new(),
        }
    }

    /// [`FlattenedScene::new`] of the top-level `surfaces` of a scene of
    /// `variant` (all that flattening reads of a scene).
    fn of_surfaces(
        surfaces: &[Surface],
        variant: Variant,
        max_placements: u64,
    ) -> Result<FlattenedScene, FlattenError> {
        let uses = placement_counts(surfaces);
        // Placements are made for each shared definition holding geometry,
        // once per path that reaches it.
        let total: u64 = uses
            .values()
            .filter(|(n, s)| *n > 1 && has_direct_geometry(s))
            .fold(0u64, |a, (n, _)| a.saturating_add(*n));
        if total > max_placements {
            return Err(FlattenError::TooManyPlacements {
                count: total,
                limit: max_placements,
            });
        }
        let mut builder = Builder {
            uses,
            shared_index: HashMap::default(),
            out: FlattenedScene {
                world: FlatGeometry::empty(variant),
                shared: Vec::new(),
                placements: Vec::with_capacity(total as usize),
                objects: Vec::new(),
            },
        };
        for surface in surfaces {
            builder.walk(surface, DMat4::IDENTITY)?;
        }
        builder.out.world.finish();
        Ok(builder.out)
    }

    /// Unique primitives (world plus one copy of each shared geometry).
    pub fn unique_primitives(&self) -> u64 {
        self.world.len() as u64 + self.shared.iter().map(|s| s.len() as u64).sum::<u64>()
    }

    /// Primitives dropped for non-finite coordinates (world and shared).
    pub fn dropped_primitives(&self) -> usize {
        self.world.dropped() + self.shared.iter().map(FlatGeometry::dropped).sum::<usize>()
    }

    /// Primitives as placed (world plus each placement's geometry).
    pub fn instanced_primitives(&self) -> u64 {
        self.world.len() as u64
            + self
                .placements
                .iter()
                .map(|p| self.shared[p.geometry as usize].len() as u64)
                .sum::<u64>()
    }
}

fn key(shared: &Arc<Surface>) -> usize {
    Arc::as_ptr(shared) as usize
}

/// Whether `s` holds leaves of its own (outside nested instances).
fn has_direct_geometry(s: &Surface) -> bool {
    match s {
        Surface::Group(g) => g.children.iter().any(has_direct_geometry),
        Surface::Instance(_) => false,
        _ => true,
    }
}

/// The instances directly inside `s` (not inside nested instances).
fn direct_instances<'s>(s: &'s Surface, out: &mut Vec<&'s Arc<Surface>>) {
    match s {
        Surface::Group(g) => g.children.iter().for_each(|c| direct_instances(c, out)),
        Surface::Instance(shared) => out.push(shared),
        _ => {}
    }
}

/// How many times each shared surface is placed in all (the number of paths
/// from the roots to it), saturating.
fn placement_counts(roots: &[Surface]) -> HashMap<usize, (u64, Arc<Surface>)> {
    // Topological order of the DAG of shared surfaces (parents first).
    fn visit(s: &Arc<Surface>, seen: &mut HashMap<usize, ()>, order: &mut Vec<Arc<Surface>>) {
        if seen.insert(key(s), ()).is_some() {
            return;
        }
        let mut children = Vec::new();
        direct_instances(s, &mut children);
        for c in children {
            visit(c, seen, order);
        }
        order.push(s.clone());
    }
    let mut top = Vec::new();
    roots.iter().for_each(|r| direct_instances(r, &mut top));
    let mut seen = HashMap::default();
    let mut order = Vec::new();
    for s in &top {
        visit(s, &mut seen, &mut order);
    }
    let mut counts: HashMap<usize, (u64, Arc<Surface>)> =
        order.iter().map(|s| (key(s), (0, s.clone()))).collect();
    for s in &top {
        counts.get_mut(&key(s)).expect("visited").0 += 1;
    }
    for s in order.iter().rev() {
        let n = counts[&key(s)].0;
        let mut children = Vec::new();
        direct_instances(s, &mut children);
        for c in children {
            let entry = counts.get_mut(&key(c)).expect("visited");
            entry.0 = entry.0.saturating_add(n);
        }
    }
    counts
}

struct Builder {
    uses: HashMap<usize, (u64, Arc<Surface>)>,
    shared_index: HashMap<usize, Option<u32>>,
    out: FlattenedScene,
}

impl Builder {
    /// Adds `s` under world matrix `m`: leaves into the world geometry,
    /// instances placed once inline, shared ones as placements.
    fn walk(&mut self, s: &Surface, m: DMat4) -> Result<(), FlattenError> {
        match s {
            Surface::Group(g) => {
                let m = m * g.transform;
                for c in &g.children {
                    self.walk(c, m)?;
                }
                Ok(())
            }
            Surface::Instance(shared) if self.uses[&key(shared)].0 <= 1 => self.walk(shared, m),
            Surface::Instance(shared) => self.place(shared, m),
            leaf => Ok(self.out.world.add_leaf(leaf, m)?),
        }
    }

    /// Places shared surface `s` at `m`: one placement of its own geometry,
    /// and its nested instances composed with `m`.
    fn place(&mut self, s: &Arc<Surface>, m: DMat4) -> Result<(), FlattenError> {
        if let Some(geometry) = self.shared_geometry(s)? {
            let inverse = glam::DAffine3::from_mat4(m).inverse();
            if !inverse.is_finite() || m.determinant() == 0.0 {
                return Err(FlattenError::SingularTransform);
            }
            self.out.placements.push(Placement { inverse, geometry });
        }
        self.place_nested(s, m)
    }

    fn place_nested(&mut self, s: &Surface, m: DMat4) -> Result<(), FlattenError> {
        match s {
            Surface::Group(g) => {
                let m = m * g.transform;
                for c in &g.children {
                    self.place_nested(c, m)?;
                }
                Ok(())
            }
            Surface::Instance(shared) => self.place(shared, m),
            _ => Ok(()),
        }
    }

    /// The index of `s`'s own geometry in [`FlattenedScene::shared`] (flattened in
    /// its own space on first use), or `None` when it holds only instances.
    fn shared_geometry(&mut self, s: &Arc<Surface>) -> Result<Option<u32>, FlattenError> {
        if let Some(&index) = self.shared_index.get(&key(s)) {
            return Ok(index);
        }
        let index = if has_direct_geometry(s) {
            let mut flat = FlatGeometry::empty(self.out.world.variant);
            add_direct_leaves(&mut flat, s, DMat4::IDENTITY)?;
            flat.finish();
            self.out.shared.push(flat);
            Some((self.out.shared.len() - 1) as u32)
        } else {
            None
        };
        self.shared_index.insert(key(s), index);
        Ok(index)
    }
}

fn add_direct_leaves(
    flat: &mut FlatGeometry,
    s: &Surface,
    m: DMat4,
) -> Result<(), SingularTransform> {
    match s {
        Surface::Group(g) => {
            let m = m * g.transform;
            for c in &g.children {
                add_direct_leaves(flat, c, m)?;
            }
            Ok(())
        }
        Surface::Instance(_) => Ok(()),
        leaf => flat.add_leaf(leaf, m),
    }
}
