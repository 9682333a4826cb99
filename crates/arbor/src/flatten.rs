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

use arbor_accel::Vec3;
use glam::{DMat4, DVec2, DVec3};
use rayon::prelude::*;

use crate::scene::{Scene, Variant};
use crate::shader::Shader;
use crate::surface::{box_, BoxSurface, MeshData, MeshSurface, Surface, Transform};

/// Index meaning "no transform" (the primitive is in world space).
mod primitive;

use primitive::NO_TRANSFORM;
pub use primitive::{to_f32_box, FlatGeometry, FlatMesh, Hit, Primitive, Shape};

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

    pub(crate) fn empty(variant: Variant) -> FlatGeometry {
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
    pub(crate) fn finish(&mut self) {
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

    pub(crate) fn add_leaf(&mut self, leaf: &Surface, m: DMat4) -> Result<(), SingularTransform> {
        match leaf {
            Surface::Sphere(s) => {
                let shape = Shape::Sphere {
                    center: s.center,
                    radius: s.radius,
                };
                self.push_primitive(shape, m, &s.shader)?;
            }
            Surface::Box(b) => self.add_box(b, m)?,
            Surface::Cylinder(c) => {
                let shape = Shape::Cylinder {
                    center: c.center,
                    radius: c.radius,
                    height: c.height,
                };
                self.push_primitive(shape, m, &c.shader)?;
            }
            Surface::Mesh(mesh) => {
                let flat = match self.variant {
                    Variant::Cornell2010 => self.baked_mesh(mesh, m)?,
                    Variant::Cornell2015 => self.object_space_mesh(mesh, m)?,
                };
                self.push_mesh(flat);
            }
            Surface::Group(_) | Surface::Instance(_) => {
                unreachable!("only leaves are added")
            }
        }
        Ok(())
    }

    /// Adds an analytic primitive of `shape` under `m` with `shader`.
    fn push_primitive(
        &mut self,
        shape: Shape,
        m: DMat4,
        shader: &Arc<Shader>,
    ) -> Result<(), SingularTransform> {
        let (transform, shader) = (self.transform_index(m)?, self.shader_index(shader));
        self.primitives.push(Primitive {
            shape,
            transform,
            shader,
        });
        Ok(())
    }

    /// A box: analytic in 2010, twelve triangles in 2015 (spec §5.2).
    fn add_box(&mut self, b: &BoxSurface, m: DMat4) -> Result<(), SingularTransform> {
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
        Ok(())
    }

    /// A 2010 mesh baked to world space: each vertex rounded to `f32` as the
    /// references require; normals by the inverse transpose, normalised per
    /// vertex.
    fn baked_mesh(&mut self, mesh: &MeshSurface, m: DMat4) -> Result<FlatMesh, SingularTransform> {
        let shader = self.shader_index(&mesh.shader);
        let data = &mesh.data;
        let (uvs, colors) = (widened_uvs(data), widened_colors(data));
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
        Ok(FlatMesh {
            positions,
            normals,
            uvs,
            colors,
            triangles: data.triangles.clone(),
            two_sided: mesh.two_sided,
            soft_terminator: mesh.soft_terminator,
            transform: NO_TRANSFORM,
            shader,
        })
    }

    /// A 2015 mesh as in the file, with its transform.
    fn object_space_mesh(
        &mut self,
        mesh: &MeshSurface,
        m: DMat4,
    ) -> Result<FlatMesh, SingularTransform> {
        let shader = self.shader_index(&mesh.shader);
        let data = &mesh.data;
        let (uvs, colors) = (widened_uvs(data), widened_colors(data));
        Ok(FlatMesh {
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
        })
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
}

/// An `f32` vector widened to `f64`.
fn widen(v: &Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// A mesh's texture coordinates widened to `f64`.
fn widened_uvs(data: &MeshData) -> Option<Vec<DVec2>> {
    let uvs = data.uvs.as_ref()?;
    Some(
        uvs.iter()
            .map(|t| DVec2::new(t.x as f64, t.y as f64))
            .collect(),
    )
}

/// A mesh's vertex colours widened to `f64`.
fn widened_colors(data: &MeshData) -> Option<Vec<DVec3>> {
    Some(data.colors.as_ref()?.iter().map(widen).collect())
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

pub(crate) fn key(shared: &Arc<Surface>) -> usize {
    Arc::as_ptr(shared) as usize
}

/// Whether `s` holds leaves of its own (outside nested instances).
pub(crate) fn has_direct_geometry(s: &Surface) -> bool {
    match s {
        Surface::Group(g) => g.children.iter().any(has_direct_geometry),
        Surface::Instance(_) => false,
        _ => true,
    }
}

/// The instances directly inside `s` (not inside nested instances).
pub(crate) fn direct_instances<'s>(s: &'s Surface, out: &mut Vec<&'s Arc<Surface>>) {
    match s {
        Surface::Group(g) => g.children.iter().for_each(|c| direct_instances(c, out)),
        Surface::Instance(shared) => out.push(shared),
        _ => {}
    }
}

/// How many times each shared surface is placed in all (the number of paths
/// from the roots to it), saturating.
pub(crate) fn placement_counts(roots: &[Surface]) -> HashMap<usize, (u64, Arc<Surface>)> {
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
            Surface::Group(g) => g.try_for_each_child(m, |c, m| self.walk(c, m)),
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
            Surface::Group(g) => g.try_for_each_child(m, |c, m| self.place_nested(c, m)),
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

pub(crate) fn add_direct_leaves(
    flat: &mut FlatGeometry,
    s: &Surface,
    m: DMat4,
) -> Result<(), SingularTransform> {
    match s {
        Surface::Group(g) => g.try_for_each_child(m, |c, m| add_direct_leaves(flat, c, m)),
        Surface::Instance(_) => Ok(()),
        leaf => flat.add_leaf(leaf, m),
    }
}
