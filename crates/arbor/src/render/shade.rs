//! The Whitted integrator: the colour seen along a ray, with shadows,
//! reflection and refraction, following each variant's conventions exactly
//! (spec §4 and §6).

use glam::DVec3;

use crate::flatten::Hit;
use crate::light::{spot_falloff, Light};
use crate::ray::Ray;
use crate::scene::{Scene, Variant};
use crate::shader::{fresnel_exact, fresnel_exact_2015, schlick, schlick_r0, Fresnel, Shader};
use crate::stats::{NoStats, RayKind, RayStats};
use crate::tracer::Tracer;

/// Epsilon on the ray parameter of secondary and shadow rays (spec §4), and
/// of 2015 camera rays ([`super::camera_tmin`]).
pub(crate) const T_EPSILON: f64 = 1e-6;

/// Shades rays of one scene.
pub struct Integrator<'a> {
    scene: &'a Scene,
    tracer: &'a Tracer,
}

impl<'a> Integrator<'a> {
    /// An integrator over `scene`, tracing through `tracer`.
    pub fn new(scene: &'a Scene, tracer: &'a Tracer) -> Self {
        Integrator { scene, tracer }
    }

    /// The radiance arriving along a camera ray (as [`super::camera_ray`]
    /// makes it: its `tmin` is the variant's).
    pub fn camera_ray(&self, ray: &Ray) -> DVec3 {
        self.camera_ray_with(ray, &mut NoStats)
    }

    /// [`Integrator::camera_ray`], recording every ray it traces (camera,
    /// shadow, reflection, refraction) into `stats`. Monomorphised per sink,
    /// so [`NoStats`] costs nothing.
    pub fn camera_ray_with<S: RayStats>(&self, ray: &Ray, stats: &mut S) -> DVec3 {
        self.trace(ray, 1, 1.0, RayKind::Camera, stats)
    }

    /// The nearest hit, with the traversal work recorded as a ray of `kind`.
    #[inline(always)]
    fn closest<S: RayStats>(&self, ray: &Ray, kind: RayKind, stats: &mut S) -> Option<Hit<'a>> {
        let mut counts = S::Counters::default();
        let hit = self.tracer.closest_counted(ray, &mut counts);
        stats.record(kind, counts);
        hit
    }

    /// Whether a shadow ray is blocked, recorded as a shadow ray.
    #[inline(always)]
    fn occluded<S: RayStats>(&self, ray: &Ray, stats: &mut S) -> bool {
        let mut counts = S::Counters::default();
        let blocked = self.tracer.occluded_counted(ray, &mut counts);
        stats.record(RayKind::Shadow, counts);
        blocked
    }

    /// The colour seen along `ray`, in the variant's manner. 2010: black
    /// past depth 10 or below 1% contribution, misses are black. 2015: black
    /// past depth 12 (it does not track `contrib`), misses see the cube map
    /// or the background.
    fn trace<S: RayStats>(
        &self,
        ray: &Ray,
        depth: u32,
        contrib: f64,
        kind: RayKind,
        stats: &mut S,
    ) -> DVec3 {
        let is2015 = self.scene.variant == Variant::Cornell2015;
        let too_deep = if is2015 {
            depth > 12
        } else {
            contrib < 0.01 || depth > 10
        };
        if too_deep {
            return DVec3::ZERO;
        }
        let contrib = if is2015 { 1.0 } else { contrib };
        match self.closest(ray, kind, stats) {
            Some(hit) => self.shade(&hit, hit.shader, ray, depth, contrib, stats),
            None if !is2015 => DVec3::ZERO,
            None => match &self.scene.cubemap {
                Some(map) => map.lookup(ray.direction),
                None => self.scene.background,
            },
        }
    }

    /// A secondary ray from hit point `from` along `direction` (from just
    /// past the point: spec §4's epsilon).
    fn trace_secondary<S: RayStats>(
        &self,
        from: DVec3,
        direction: DVec3,
        depth: u32,
        contrib: f64,
        kind: RayKind,
        stats: &mut S,
    ) -> DVec3 {
        let ray = Ray::unbounded(from, direction, T_EPSILON);
        self.trace(&ray, depth, contrib, kind, stats)
    }

    /// The colour of `hit` under `shader`, seen along `ray`.
    fn shade<S: RayStats>(
        &self,
        hit: &Hit,
        shader: &Shader,
        ray: &Ray,
        depth: u32,
        contrib: f64,
        stats: &mut S,
    ) -> DVec3 {
        let is2015 = self.scene.variant == Variant::Cornell2015;
        let x = hit.point;
        let n = hit.normal;
        let v = if is2015 {
            -ray.direction.normalize()
        } else {
            (ray.origin - x).normalize()
        };
        match shader {
            Shader::Lambertian { diffuse, texture } => {
                let kd = texture_or(texture, hit, *diffuse);
                self.lights(x, x + hit.shadow_offset, stats, |l, e| {
                    let nl = n.dot(l);
                    if nl > 0.0 {
                        kd * e * nl
                    } else {
                        DVec3::ZERO
                    }
                })
            }
            Shader::Phong {
                diffuse,
                specular,
                exponent,
                texture,
            } => {
                let kd = texture_or(texture, hit, *diffuse);
                self.phong(hit, v, kd, *specular, *exponent, stats)
            }
            Shader::Glazed {
                refractive_index: eta,
                substrate,
                fresnel,
            } => self.glazed(
                hit, *eta, substrate, *fresnel, ray, v, depth, contrib, stats,
            ),
            Shader::Reflective {
                reflectance,
                substrate,
            } => {
                let c = n.dot(v).clamp(0.0, 1.0);
                let f = *reflectance + (DVec3::ONE - *reflectance) * (1.0 - c).powi(5);
                let r = 2.0 * n.dot(v) * n - v;
                let reflected = self.trace_secondary(
                    x,
                    r,
                    depth + 1,
                    contrib * f.max_element(),
                    RayKind::Reflection,
                    stats,
                );
                let below = self.shade(hit, substrate, ray, depth, contrib, stats);
                (DVec3::ONE - f) * below + f * reflected
            }
            Shader::Glass {
                refractive_index: eta,
            } => {
                if is2015 {
                    self.glass_2015(hit, v, *eta, depth, stats)
                } else {
                    self.glass_2010(hit, v, *eta, depth, contrib, stats)
                }
            }
            Shader::RgbNormals => (n + DVec3::ONE) / 2.0,
            Shader::Emissive {
                emission,
                texture,
                surface,
            } => {
                let glow = match (texture, hit.uv) {
                    (Some(t), Some(uv)) => *emission * t.lookup(uv.x, uv.y),
                    _ => *emission,
                };
                glow + self.shade(hit, surface, ray, depth, contrib, stats)
            }
            Shader::CookTorrance {
                diffuse,
                specular,
                roughness,
                refractive_index,
                texture,
            } => {
                let kd = texture_or(texture, hit, *diffuse);
                self.cook_torrance(hit, v, kd, *specular, *roughness, *refractive_index, stats)
            }
        }
    }

    /// Phong (spec §6.2): the 2015 form sums both terms only for lights in
    /// front of the surface; the 2010 form adds each term where its own
    /// cosine is positive.
    fn phong<S: RayStats>(
        &self,
        hit: &Hit,
        v: DVec3,
        kd: DVec3,
        specular: DVec3,
        exponent: f64,
        stats: &mut S,
    ) -> DVec3 {
        let is2015 = self.scene.variant == Variant::Cornell2015;
        let (x, n) = (hit.point, hit.normal);
        self.lights(x, x + hit.shadow_offset, stats, |l, e| {
            let nl = n.dot(l);
            let h = (l + v).normalize();
            let nh = n.dot(h);
            if is2015 {
                if nl > 0.0 {
                    (kd * nl + specular * nh.max(0.0).powf(exponent)) * e
                } else {
                    DVec3::ZERO
                }
            } else {
                let mut c = DVec3::ZERO;
                if nl > 0.0 {
                    c += kd * e * nl;
                }
                if nh > 0.0 {
                    c += specular * e * nh.powf(exponent);
                }
                c
            }
        })
    }

    /// A glazed coat over `substrate` (spec §6.3): Fresnel-weighted mirror
    /// reflection over the substrate's colour. The 2010 form skips the
    /// reflected ray where the weight is zero, and traces it before the
    /// substrate, as the reference renderer does.
    #[allow(clippy::too_many_arguments)]
    fn glazed<S: RayStats>(
        &self,
        hit: &Hit,
        eta: f64,
        substrate: &Shader,
        fresnel: Fresnel,
        ray: &Ray,
        v: DVec3,
        depth: u32,
        contrib: f64,
        stats: &mut S,
    ) -> DVec3 {
        let (x, n) = (hit.point, hit.normal);
        if self.scene.variant == Variant::Cornell2015 {
            let f = fresnel_exact_2015(n.dot(v), eta);
            let r = 2.0 * v.dot(n) * n - v;
            let below = self.shade(hit, substrate, ray, depth, contrib, stats);
            let reflected = self.trace_secondary(x, r, depth + 1, 1.0, RayKind::Reflection, stats);
            (1.0 - f) * below + f * reflected
        } else {
            let r = (2.0 * n.dot(v) * n - v).normalize();
            let c = r.dot(n);
            let f = if c < 0.0 {
                0.0
            } else {
                match fresnel {
                    Fresnel::Schlick => schlick(c, eta),
                    Fresnel::Exact => fresnel_exact(c, eta),
                }
            };
            let reflected = if f > 0.0 {
                self.trace_secondary(x, r, depth + 1, contrib * f, RayKind::Reflection, stats)
            } else {
                DVec3::ZERO
            };
            let below = self.shade(hit, substrate, ray, depth, contrib, stats);
            (1.0 - f) * below + f * reflected
        }
    }

    /// Cook-Torrance (Beckmann distribution, the V-cavity masking term,
    /// exact Fresnel) plus a Lambertian term, for lights in front of both
    /// the surface and the viewer.
    #[allow(clippy::too_many_arguments)]
    fn cook_torrance<S: RayStats>(
        &self,
        hit: &Hit,
        v: DVec3,
        kd: DVec3,
        specular: DVec3,
        roughness: f64,
        refractive_index: f64,
        stats: &mut S,
    ) -> DVec3 {
        let (x, n) = (hit.point, hit.normal);
        let m2 = roughness * roughness;
        self.lights(x, x + hit.shadow_offset, stats, |l, e| {
            let nl = n.dot(l);
            let nv = n.dot(v);
            if nl <= 0.0 || nv <= 0.0 {
                return DVec3::ZERO;
            }
            let h = (l + v).normalize();
            let nh = n.dot(h).max(1e-12);
            let vh = v.dot(h).max(1e-12);
            let nh2 = nh * nh;
            let beckmann =
                ((nh2 - 1.0) / (m2 * nh2)).exp() / (std::f64::consts::PI * m2 * nh2 * nh2);
            let g = 1f64.min(2.0 * nh * nv / vh).min(2.0 * nh * nl / vh);
            let f = fresnel_exact(vh, refractive_index);
            let spec = f * beckmann * g / (std::f64::consts::PI * nl * nv);
            (kd + specular * spec) * e * nl
        })
    }

    /// 2010 glass (spec §6.4): Schlick with the air-side cosine; the
    /// refracted ray keeps the depth.
    fn glass_2010<S: RayStats>(
        &self,
        hit: &Hit,
        v: DVec3,
        eta: f64,
        depth: u32,
        contrib: f64,
        stats: &mut S,
    ) -> DVec3 {
        let (x, n) = (hit.point, hit.normal);
        let d = -v;
        let entering = d.dot(n) < 0.0;
        let (n1, n2, nn) = if entering {
            (1.0, eta, n)
        } else {
            (eta, 1.0, -n)
        };
        let ci = -d.dot(nn);
        let k = n1 / n2;
        let disc = 1.0 - k * k * (1.0 - ci * ci);
        let r_dir = (d + 2.0 * ci * nn).normalize();
        if disc < 0.0 {
            return self.trace_secondary(x, r_dir, depth + 1, contrib, RayKind::Reflection, stats);
        }
        let ct = disc.sqrt();
        let t_dir = (k * (d + ci * nn) - ct * nn).normalize();
        let r0 = ((n2 - n1) / (n2 + n1)).powi(2);
        let c = if entering { ci } else { ct };
        let r = schlick_r0(c, r0);
        let reflected =
            self.trace_secondary(x, r_dir, depth + 1, contrib * r, RayKind::Reflection, stats);
        let refracted = self.trace_secondary(
            x,
            t_dir,
            depth,
            contrib * (1.0 - r),
            RayKind::Refraction,
            stats,
        );
        r * reflected + (1.0 - r) * refracted
    }

    /// 2015 glass (spec §6.4), with total internal reflection as `R = 1`.
    fn glass_2015<S: RayStats>(
        &self,
        hit: &Hit,
        v: DVec3,
        eta: f64,
        depth: u32,
        stats: &mut S,
    ) -> DVec3 {
        let (x, n) = (hit.point, hit.normal);
        let cos = v.dot(n);
        let (eta, nn) = if cos >= 0.0 {
            (eta, n)
        } else {
            (1.0 / eta, -n)
        };
        let theta1 = v.dot(nn).acos();
        let r = fresnel_exact_2015(theta1.cos(), eta);
        let reflected = if theta1 == 0.0 {
            DVec3::ZERO
        } else {
            let r = 2.0 * v.dot(nn) * nn - v;
            self.trace_secondary(x, r, depth + 1, 1.0, RayKind::Reflection, stats)
        };
        if r >= 1.0 {
            return reflected;
        }
        let theta2 = (theta1.sin() / eta).asin();
        let t = (-v + nn * theta1.cos()) / eta - nn * theta2.cos();
        let refracted = self.trace_secondary(x, t, depth + 1, 1.0, RayKind::Refraction, stats);
        r * reflected + (1.0 - r) * refracted
    }

    /// Sums `f(l, E)` over the lights that reach `x` unshadowed, where `l` is
    /// the unit direction to the light and `E` its irradiance factor; the
    /// shadow rays start from `from` (`x`, or `x` lifted off a coarse
    /// smooth mesh: [`crate::terminator`]).
    fn lights<S: RayStats>(
        &self,
        x: DVec3,
        from: DVec3,
        stats: &mut S,
        mut f: impl FnMut(DVec3, DVec3) -> DVec3,
    ) -> DVec3 {
        let mut sum = DVec3::ZERO;
        for light in &self.scene.lights {
            if let Some((l, e)) = self.light_at(light, x, from, stats) {
                sum += f(l, e);
            }
        }
        sum
    }

    /// Direction to and irradiance factor of `light` at `x`, or `None` when
    /// something lies between it and `from` (spec §4 shadow rays, §6
    /// falloff).
    fn light_at<S: RayStats>(
        &self,
        light: &Light,
        x: DVec3,
        from: DVec3,
        stats: &mut S,
    ) -> Option<(DVec3, DVec3)> {
        let shadowed = |this: &Self, to: DVec3, stats: &mut S| match light {
            Light::Directional { .. } => {
                this.occluded(&Ray::new(from, to, T_EPSILON, f64::MAX), stats)
            }
            _ => {
                let d = to - from;
                let ray = match this.scene.variant {
                    Variant::Cornell2010 if matches!(light, Light::Point { .. }) => {
                        Ray::new(from, d, T_EPSILON, 1.0)
                    }
                    _ => Ray::new(from, d.normalize(), T_EPSILON, d.length()),
                };
                this.occluded(&ray, stats)
            }
        };
        match (self.scene.variant, light) {
            (
                Variant::Cornell2010,
                Light::Point {
                    position,
                    intensity,
                },
            ) => {
                let to_light = *position - x;
                (!shadowed(self, *position, stats)).then(|| (to_light.normalize(), *intensity))
            }
            (
                Variant::Cornell2015,
                Light::Point {
                    position,
                    intensity,
                },
            ) => {
                let (l, dist) = toward(*position, x);
                (!shadowed(self, *position, stats)).then(|| (l, *intensity / (dist * dist)))
            }
            (
                _,
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                },
            ) => {
                // Only models have spots: 2015's 1/r² in either variant.
                let (l, dist) = toward(*position, x);
                let falloff = spot_falloff(-l.dot(*direction), *cos_inner, *cos_outer);
                (falloff > 0.0 && !shadowed(self, *position, stats))
                    .then(|| (l, *intensity * (falloff / (dist * dist))))
            }
            (
                _,
                Light::Directional {
                    direction,
                    intensity,
                },
            ) => {
                let l = direction.normalize();
                (!shadowed(self, l, stats)).then_some((l, *intensity))
            }
        }
    }
}

/// The unit direction from `x` toward a light at `position`, and the
/// distance to it.
fn toward(position: DVec3, x: DVec3) -> (DVec3, f64) {
    let to_light = position - x;
    (to_light.normalize(), to_light.length())
}

fn texture_or(
    texture: &Option<std::sync::Arc<crate::texture::Texture>>,
    hit: &Hit,
    base: DVec3,
) -> DVec3 {
    // A texture times the mesh's vertex colours (models only; both
    // linear), else the vertex colours, else the shader's own colour.
    match (texture, hit.uv, hit.color) {
        (Some(t), Some(uv), Some(c)) => t.lookup(uv.x, uv.y) * c,
        (Some(t), Some(uv), None) => t.lookup(uv.x, uv.y),
        _ => hit.color.unwrap_or(base),
    }
}
