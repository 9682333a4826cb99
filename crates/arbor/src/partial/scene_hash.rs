//! The scene hash: what identifies the scene and settings a part was
//! rendered from, so that `arbor merge` and a resumed farm render refuse a
//! part of another picture.
//!
//! The hash is SHA-256 over an explicit byte encoding of the loaded
//! [`Scene`], never over its `Debug` text (which Rust does not promise to
//! keep stable). [`ENCODING_VERSION`] names the encoding; any change to it
//! must bump the version (a test pins the hash of a fixed scene).
//!
//! The encoding is documented at [`scene_hash`].

use std::fmt::Write as _;
use std::sync::Arc;

use glam::{DMat4, DVec3, Vec2, Vec3};
use sha2::{Digest, Sha256};

use crate::camera::{Camera, CameraKind};
use crate::hash_map::HashMap;
use crate::light::Light;
use crate::scene::{Scene, Variant};
use crate::shader::{Fresnel, Shader};
use crate::surface::MeshData;
use crate::surface::{BoxSurface, Cylinder, Group, MeshSurface, Sphere, Surface};
use crate::texture::{CubeMap, Texture, Wrap};

/// The version of the scene encoding [`scene_hash`] hashes.
pub const ENCODING_VERSION: u32 = 3;

/// SHA-256 of everything that decides a render's pixels: the encoding
/// version, the version of this crate and the loaded [`Scene`], in the
/// encoding below.
///
/// # The encoding (version 3)
///
/// Integers are little-endian; an `f64` or `f32` is its IEEE bits
/// (`to_bits`, so `-0.0` and `0.0` differ); a vector is its components in
/// `x, y, z` order; a matrix its 16 entries column by column; a list is its
/// length as `u64` then its items; an optional value is a byte `0` (absent)
/// or `1` followed by the value; an enum is a one-byte tag (in the order
/// below, from 0) then its fields in the order listed.
///
/// 1. The bytes `arbor-scene`, [`ENCODING_VERSION`] as `u32`, the arbor
///    version as a list of bytes (a part of another arbor version is
///    foreign: the renderer may have changed).
/// 2. Variant (`Cornell2010`, `Cornell2015`); camera: kind
///    (`Perspective2010`, `Perspective2015`, `Parallel2015`), view point,
///    view direction, up, projection normal, projection distance, view
///    width, view height; image width, height and samples per side (`u32`).
/// 3. Lights (list of `Point { position, intensity }`,
///    `Directional { direction, intensity }` or `Spot { position,
///    direction, intensity, cos_inner, cos_outer }`), background, exposure, cube
///    map (optional: block and width as `u64`, scale, texels as a list).
/// 4. Surfaces (list), each one of `Sphere { center, radius, shader }`,
///    `Box { min, max, shader }`, `Cylinder { center, radius, height,
///    shader }`, `Mesh { two_sided (byte), soft_terminator (byte), shader,
///    mesh }`,
///    `Group { transform, children (list) }`, `Instance { surface }`.
///
/// A shader is one of `Lambertian { diffuse, texture }`, `Phong { diffuse,
/// specular, exponent, texture }`, `Glazed { refractive_index, substrate,
/// fresnel (Schlick, Exact) }`, `Glass { refractive_index }`,
/// `Emissive { emission, texture, surface }`, `RgbNormals`,
/// `CookTorrance { diffuse, specular, roughness, refractive_index,
/// texture }`, `Reflective { reflectance, substrate }` (textures optional).
///
/// Three things stand in the encoding as the 32-byte SHA-256 of their own
/// encoding, computed once per shared object: a mesh (positions `f32`;
/// optional normals, texture coordinates and colours; triangles as three
/// `u32` each), a texture (wrap `Clamp`/`Repeat`, width and height `u32`,
/// texels as a list, the optional texture-coordinate transform as its six
/// numbers row by row) and an instanced surface. So hashing costs the size of
/// the scene, not of its expansion, and the hash does not depend on which
/// equal objects the loader happened to share.
///
/// Not hashed, because they do not change a single pixel: the acceleration
/// structure, the thread count and the instance limit. Because the loaded
/// data is hashed rather than the files, two scene files that load to the
/// same scene have the same hash, and an edited mesh or texture changes it.
pub fn scene_hash(scene: &Scene) -> [u8; 32] {
    scene_hash_as(scene, env!("CARGO_PKG_VERSION"))
}

/// [`scene_hash`] as arbor version `arbor_version` computes it (so a test
/// can pin the hash without changing at every release).
fn scene_hash_as(scene: &Scene, arbor_version: &str) -> [u8; 32] {
    let mut digests = Digests::default();
    let mut e = Encoder::new(&mut digests);
    e.bytes(b"arbor-scene");
    e.u32(ENCODING_VERSION);
    e.list(arbor_version.as_bytes(), |e, b| e.u8(*b));
    e.scene(scene);
    e.finish()
}

/// The scene hash as 64 hexadecimal digits.
pub fn hash_hex(hash: &[u8; 32]) -> String {
    hex(hash)
}

pub(super) fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// The digests of shared objects already encoded, by address (valid while
/// the scene is borrowed).
#[derive(Default)]
struct Digests {
    meshes: HashMap<*const MeshData, [u8; 32]>,
    textures: HashMap<*const Texture, [u8; 32]>,
    instances: HashMap<*const Surface, [u8; 32]>,
}

/// Writes the encoding straight into a hash, so a large scene is never
/// held in memory twice.
struct Encoder<'d> {
    sha: Sha256,
    digests: &'d mut Digests,
}

impl<'d> Encoder<'d> {
    fn new(digests: &'d mut Digests) -> Encoder<'d> {
        Encoder {
            sha: Sha256::new(),
            digests,
        }
    }

    fn finish(self) -> [u8; 32] {
        self.sha.finalize().into()
    }

    /// Writes the digest of `object`'s encoding (what `encode` writes, in a
    /// hash of its own), encoding each shared object once: `table` picks
    /// where its digests are kept.
    fn shared<T>(
        &mut self,
        table: fn(&mut Digests) -> &mut HashMap<*const T, [u8; 32]>,
        object: &Arc<T>,
        encode: impl FnOnce(&mut Encoder, &T),
    ) {
        let key = Arc::as_ptr(object);
        let digest = match table(self.digests).get(&key) {
            Some(d) => *d,
            None => {
                let mut sub = Encoder::new(self.digests);
                encode(&mut sub, object);
                let d = sub.finish();
                table(self.digests).insert(key, d);
                d
            }
        };
        self.bytes(&digest);
    }

    fn bytes(&mut self, b: &[u8]) {
        self.sha.update(b);
    }

    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }

    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }

    fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }

    fn f64(&mut self, v: f64) {
        self.bytes(&v.to_bits().to_le_bytes());
    }

    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_bits().to_le_bytes());
    }

    fn dvec3(&mut self, v: DVec3) {
        v.to_array().into_iter().for_each(|c| self.f64(c));
    }

    fn vec3(&mut self, v: Vec3) {
        v.to_array().into_iter().for_each(|c| self.f32(c));
    }

    fn vec2(&mut self, v: Vec2) {
        v.to_array().into_iter().for_each(|c| self.f32(c));
    }

    fn dmat4(&mut self, m: &DMat4) {
        m.to_cols_array().into_iter().for_each(|c| self.f64(c));
    }

    fn list<T>(&mut self, items: &[T], mut item: impl FnMut(&mut Self, &T)) {
        self.u64(items.len() as u64);
        for t in items {
            item(self, t);
        }
    }

    fn option<T>(&mut self, value: Option<&T>, some: impl FnOnce(&mut Self, &T)) {
        match value {
            None => self.u8(0),
            Some(v) => {
                self.u8(1);
                some(self, v);
            }
        }
    }

    fn scene(&mut self, scene: &Scene) {
        // Destructured without `..`: a new field fails to compile until it
        // is encoded (or said here not to change the picture).
        let Scene {
            variant,
            camera,
            width,
            height,
            samples_per_side,
            lights,
            surfaces,
            background,
            exposure,
            cubemap,
        } = scene;
        self.u8(match variant {
            Variant::Cornell2010 => 0,
            Variant::Cornell2015 => 1,
        });
        self.camera(camera);
        self.u32(*width);
        self.u32(*height);
        self.u32(*samples_per_side);
        self.list(lights, |e, l| e.light(l));
        self.dvec3(*background);
        self.f64(*exposure);
        self.option(cubemap.as_deref(), |e, c| e.cubemap(c));
        self.list(surfaces, |e, s| e.surface(s));
    }

    fn camera(&mut self, camera: &Camera) {
        let Camera {
            kind,
            view_point,
            view_dir,
            view_up,
            proj_normal,
            proj_distance,
            view_width,
            view_height,
        } = camera;
        self.u8(match kind {
            CameraKind::Perspective2010 => 0,
            CameraKind::Perspective2015 => 1,
            CameraKind::Parallel2015 => 2,
        });
        for v in [view_point, view_dir, view_up, proj_normal] {
            self.dvec3(*v);
        }
        for v in [proj_distance, view_width, view_height] {
            self.f64(*v);
        }
    }

    fn light(&mut self, light: &Light) {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                self.u8(0);
                self.dvec3(*position);
                self.dvec3(*intensity);
            }
            Light::Directional {
                direction,
                intensity,
            } => {
                self.u8(1);
                self.dvec3(*direction);
                self.dvec3(*intensity);
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                self.u8(2);
                for v in [position, direction, intensity] {
                    self.dvec3(*v);
                }
                self.f64(*cos_inner);
                self.f64(*cos_outer);
            }
        }
    }

    fn cubemap(&mut self, c: &CubeMap) {
        let CubeMap {
            block,
            width,
            texels,
            scale,
        } = c;
        self.u64(*block as u64);
        self.u64(*width as u64);
        self.f64(*scale);
        self.list(texels, |e, t| e.dvec3(*t));
    }

    fn surface(&mut self, s: &Surface) {
        match s {
            Surface::Sphere(Sphere {
                center,
                radius,
                shader,
            }) => {
                self.u8(0);
                self.dvec3(*center);
                self.f64(*radius);
                self.shader(shader);
            }
            Surface::Box(BoxSurface { min, max, shader }) => {
                self.u8(1);
                self.dvec3(*min);
                self.dvec3(*max);
                self.shader(shader);
            }
            Surface::Cylinder(Cylinder {
                center,
                radius,
                height,
                shader,
            }) => {
                self.u8(2);
                self.dvec3(*center);
                self.f64(*radius);
                self.f64(*height);
                self.shader(shader);
            }
            Surface::Mesh(MeshSurface {
                data,
                shader,
                two_sided,
                soft_terminator,
            }) => {
                self.u8(3);
                self.u8(*two_sided as u8);
                self.u8(*soft_terminator as u8);
                self.shader(shader);
                self.mesh(data);
            }
            Surface::Group(Group {
                transform,
                children,
            }) => {
                self.u8(4);
                self.dmat4(transform);
                self.list(children, |e, c| e.surface(c));
            }
            Surface::Instance(inner) => {
                self.u8(5);
                self.shared(|d| &mut d.instances, inner, |e, s| e.surface(s));
            }
        }
    }

    fn shader(&mut self, shader: &Shader) {
        match shader {
            Shader::Lambertian { diffuse, texture } => {
                self.u8(0);
                self.dvec3(*diffuse);
                self.texture(texture);
            }
            Shader::Phong {
                diffuse,
                specular,
                exponent,
                texture,
            } => {
                self.u8(1);
                self.dvec3(*diffuse);
                self.dvec3(*specular);
                self.f64(*exponent);
                self.texture(texture);
            }
            Shader::Glazed {
                refractive_index,
                substrate,
                fresnel,
            } => {
                self.u8(2);
                self.f64(*refractive_index);
                self.shader(substrate);
                self.u8(match fresnel {
                    Fresnel::Schlick => 0,
                    Fresnel::Exact => 1,
                });
            }
            Shader::Glass { refractive_index } => {
                self.u8(3);
                self.f64(*refractive_index);
            }
            Shader::Emissive {
                emission,
                texture,
                surface,
            } => {
                self.u8(4);
                self.dvec3(*emission);
                self.texture(texture);
                self.shader(surface);
            }
            Shader::RgbNormals => self.u8(5),
            Shader::CookTorrance {
                diffuse,
                specular,
                roughness,
                refractive_index,
                texture,
            } => {
                self.u8(6);
                self.dvec3(*diffuse);
                self.dvec3(*specular);
                self.f64(*roughness);
                self.f64(*refractive_index);
                self.texture(texture);
            }
            Shader::Reflective {
                reflectance,
                substrate,
            } => {
                self.u8(7);
                self.dvec3(*reflectance);
                self.shader(substrate);
            }
        }
    }

    fn texture(&mut self, texture: &Option<Arc<Texture>>) {
        self.option(texture.as_ref(), |e, t| {
            e.shared(
                |d| &mut d.textures,
                t,
                |e, t| {
                    let Texture {
                        wrap,
                        width,
                        height,
                        texels,
                        transform,
                    } = t;
                    e.u8(match wrap {
                        Wrap::Clamp => 0,
                        Wrap::Repeat => 1,
                    });
                    e.u32(*width);
                    e.u32(*height);
                    e.list(texels, |e, t| e.dvec3(*t));
                    e.option(transform.as_ref(), |e, m| {
                        for x in m.rows.iter().flatten() {
                            e.f64(*x);
                        }
                    });
                },
            )
        });
    }

    fn mesh(&mut self, data: &Arc<MeshData>) {
        self.shared(
            |d| &mut d.meshes,
            data,
            |e, m| {
                let MeshData {
                    positions,
                    normals,
                    uvs,
                    colors,
                    triangles,
                } = m;
                e.list(positions, |e, p| e.vec3(*p));
                e.option(normals.as_ref(), |e, n| e.list(n, |e, v| e.vec3(*v)));
                e.option(uvs.as_ref(), |e, n| e.list(n, |e, v| e.vec2(*v)));
                e.option(colors.as_ref(), |e, n| e.list(n, |e, v| e.vec3(*v)));
                e.list(triangles, |e, t| t.iter().for_each(|i| e.u32(*i)));
            },
        );
    }
}

#[cfg(test)]
mod tests;
