//! Shaders: how a surface turns light into the colour seen along a ray.
//! The evaluation itself lives in [`crate::render`], which can trace the
//! secondary rays that reflection and refraction need.

use std::sync::Arc;

use glam::DVec3;

use crate::texture::Texture;

/// Which Fresnel reflectance formula a dielectric uses (spec §6.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fresnel {
    /// Schlick's approximation (the 2010 default).
    Schlick,
    /// The exact unpolarised formula (the 2015 default).
    Exact,
}

/// A shader and its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum Shader {
    /// Ideal diffuse.
    Lambertian {
        /// Reflectance.
        diffuse: DVec3,
        /// 2015: replaces `diffuse` when present.
        texture: Option<Arc<Texture>>,
    },
    /// Diffuse plus a Blinn–Phong highlight.
    Phong {
        /// Diffuse reflectance.
        diffuse: DVec3,
        /// Specular reflectance.
        specular: DVec3,
        /// Phong exponent.
        exponent: f64,
        /// 2015: replaces `diffuse` when present.
        texture: Option<Arc<Texture>>,
    },
    /// A dielectric coat (mirror reflection weighted by Fresnel) over another shader.
    Glazed {
        /// Refractive index of the coat.
        refractive_index: f64,
        /// The shader under the coat.
        substrate: Arc<Shader>,
        /// Fresnel formula.
        fresnel: Fresnel,
    },
    /// A mirror reflection weighted by Schlick's Fresnel with a coloured
    /// reflectance at normal incidence (glTF's smooth metals, tinted by
    /// their colour, and smooth dielectrics), over another shader, which
    /// gets what is not reflected.
    Reflective {
        /// Reflectance at normal incidence, per channel.
        reflectance: DVec3,
        /// The shader of the light not reflected.
        substrate: Arc<Shader>,
    },
    /// A clear dielectric: reflection and refraction only.
    Glass {
        /// Refractive index.
        refractive_index: f64,
    },
    /// Light given off by a surface (glTF's emission), added to what the
    /// shader under it reflects.
    Emissive {
        /// Emitted radiance, linear.
        emission: DVec3,
        /// Multiplies `emission` where the surface has texture coordinates.
        texture: Option<Arc<Texture>>,
        /// The shader of the reflected light.
        surface: Arc<Shader>,
    },
    /// 2015 debugging shader: the normal as a colour, `(n + 1) / 2`.
    RgbNormals,
    /// 2015 microfacet shader (the course left it unwritten; spec §6.5's placeholder).
    CookTorrance {
        /// Diffuse reflectance.
        diffuse: DVec3,
        /// Specular reflectance.
        specular: DVec3,
        /// Beckmann roughness `m`.
        roughness: f64,
        /// Refractive index for the Fresnel term.
        refractive_index: f64,
        /// Replaces `diffuse` when present.
        texture: Option<Arc<Texture>>,
    },
}

impl Shader {
    /// The shader a surface gets when it names none: white Lambertian.
    pub fn default_lambertian() -> Shader {
        Shader::Lambertian {
            diffuse: DVec3::ONE,
            texture: None,
        }
    }
}

/// Schlick's approximation: `R0 + (1 - R0)(1 - c)^5` with `R0 = ((η-1)/(η+1))²`.
pub fn schlick(cos: f64, eta: f64) -> f64 {
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    schlick_r0(cos, r0)
}

/// Schlick's approximation with a given normal-incidence reflectance `r0`.
pub fn schlick_r0(cos: f64, r0: f64) -> f64 {
    r0 + (1.0 - r0) * (1.0 - cos).powi(5)
}

/// Exact unpolarised Fresnel reflectance for cosine `cos` on the incident
/// side and relative index `eta` (spec §6.3, 2010 form). Total internal
/// reflection gives 1.
pub fn fresnel_exact(cos: f64, eta: f64) -> f64 {
    let sin_t = (1.0 - cos * cos).sqrt() / eta;
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (cos - eta * cos_t) / (cos + eta * cos_t);
    let rp = (eta * cos - cos_t) / (eta * cos + cos_t);
    (rs * rs + rp * rp) / 2.0
}

/// The same reflectance computed the 2015 framework's way, through the
/// angles `θi = acos(c)` and `θt = asin(sin θi / η)`; kept separate because
/// the references are bit-exact to that order of operations.
pub fn fresnel_exact_2015(cos: f64, eta: f64) -> f64 {
    let theta_i = cos.acos();
    let sin_t = theta_i.sin() / eta;
    if sin_t >= 1.0 {
        return 1.0;
    }
    let theta_t = sin_t.asin();
    let (ci, ct) = (theta_i.cos(), theta_t.cos());
    let rs = (ci - eta * ct) / (ci + eta * ct);
    let rp = (eta * ci - ct) / (eta * ci + ct);
    (rs * rs + rp * rp) / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence() {
        let r0 = (0.5f64 / 2.5).powi(2);
        assert!((schlick(1.0, 1.5) - r0).abs() < 1e-15);
        assert!((fresnel_exact(1.0, 1.5) - r0).abs() < 1e-12);
        assert!((fresnel_exact_2015(1.0, 1.5) - r0).abs() < 1e-12);
    }

    #[test]
    fn fresnel_grazing_is_total() {
        assert!((schlick(0.0, 1.5) - 1.0).abs() < 1e-15);
        assert!((fresnel_exact(1e-9, 1.5) - 1.0).abs() < 1e-6);
        // Inside glass beyond the critical angle.
        assert_eq!(fresnel_exact(0.1, 1.0 / 1.5), 1.0);
    }
}
