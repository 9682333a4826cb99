//! glTF materials (metallic-roughness, transmission, index of refraction,
//! volume) mapped to arbor's Whitted shaders, and the material features
//! that mapping leaves out, for a warning.
//!
//! | glTF | shader |
//! | --- | --- |
//! | `transmissionFactor` ≥ 0.5 and `thicknessFactor` > 0 (a volume) | Glass, index `ior` (1.5 by default) |
//! | `transmissionFactor` ≥ 0.5, no volume (thin-walled by the spec) | Glazed (index `ior`) over Glass of index 1: reflects by Fresnel, lets the rest through unbent |
//! | `roughnessFactor` ≥ 0.9 | Lambertian, the base colour |
//! | otherwise | Phong: the base colour (darkened for metals), a highlight `lerp(0.04, base, metallic) · (1 - roughness)` whose exponent grows as the roughness falls |
//! | `roughnessFactor` < 0.5, on top | Reflective: a mirror reflection of reflectance `lerp(0.04, base, metallic) · (1 - 2 roughness)` (tinted by the base colour for metals) over the shader above |
//!
//! The base colour is `baseColorFactor` times `baseColorTexture` (both
//! linear, as the specification defines them) and times `COLOR_0`; the
//! reflection's tint and the glass ignore the texture and the colour
//! (Whitted glass is clear).

use std::sync::Arc;

use glam::{DVec3, DVec4};

use super::gltf_ext::MaterialExt;
use crate::shader::{Fresnel, Shader};
use crate::texture::Texture;

/// Transmission at or above this is glass; below it the surface is opaque.
const GLASS_TRANSMISSION: f64 = 0.5;

/// The shader for glTF material `m` whose extensions are `ext`, with its
/// base colour texture when one was read (see the module's table).
pub(super) fn shader_for(
    m: &gltf::Material,
    ext: &MaterialExt,
    texture: Option<Arc<Texture>>,
) -> Arc<Shader> {
    if ext.transmission >= GLASS_TRANSMISSION {
        let glass = Shader::Glass {
            refractive_index: ext.ior,
        };
        if ext.thickness > 0.0 {
            return Arc::new(glass);
        }
        return Arc::new(Shader::Glazed {
            refractive_index: ext.ior,
            substrate: Arc::new(Shader::Glass {
                refractive_index: 1.0,
            }),
            fresnel: Fresnel::Exact,
        });
    }
    let pbr = m.pbr_metallic_roughness();
    let c = pbr.base_color_factor();
    let base = DVec4::from_array(c.map(f64::from))
        .truncate()
        .clamp(DVec3::ZERO, DVec3::ONE);
    let texture = texture.map(|t| {
        if base == DVec3::ONE {
            t
        } else {
            Arc::new(t.tinted(base))
        }
    });
    let rough = (pbr.roughness_factor() as f64).clamp(0.0, 1.0);
    let metal = (pbr.metallic_factor() as f64).clamp(0.0, 1.0);
    let f0 = DVec3::splat(0.04).lerp(base, metal);
    let diffuse = if rough >= 0.9 {
        Shader::Lambertian {
            diffuse: base,
            texture,
        }
    } else {
        // Blinn-Phong exponent for a GGX-like roughness (alpha = r²).
        let alpha = (rough * rough).max(1e-3);
        let exponent = (2.0 / (alpha * alpha) - 2.0).clamp(2.0, 2000.0);
        Shader::Phong {
            diffuse: base * (1.0 - metal * 0.7),
            specular: f0 * (1.0 - rough),
            exponent,
            texture,
        }
    };
    // Whitted rays cannot blur a reflection: it fades out as the surface
    // roughens, gone at roughness 0.5.
    let mirror = 1.0 - 2.0 * rough;
    if mirror <= 0.0 {
        return Arc::new(diffuse);
    }
    Arc::new(Shader::Reflective {
        reflectance: f0 * mirror,
        substrate: Arc::new(diffuse),
    })
}

/// What of material `m` (with extensions `ext`) the shader from
/// [`shader_for`] does not render, named for a warning.
pub(super) fn ignored_features(m: &gltf::Material, ext: &MaterialExt) -> Vec<&'static str> {
    let pbr = m.pbr_metallic_roughness();
    let mut out = Vec::new();
    if m.normal_texture().is_some() {
        out.push("normal textures");
    }
    if m.occlusion_texture().is_some() {
        out.push("occlusion textures");
    }
    if pbr.metallic_roughness_texture().is_some() {
        out.push("metallic-roughness textures");
    }
    if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
        out.push("transparency (alphaMode BLEND or MASK)");
    }
    if ext.transmission > 0.0 && ext.transmission < GLASS_TRANSMISSION {
        out.push("partial transmission (below 0.5: opaque)");
    }
    if ext.transmission >= GLASS_TRANSMISSION
        && pbr.base_color_factor()[..3].iter().any(|&c| c < 1.0)
    {
        out.push("the colour of transmitting materials (glass is clear)");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first material of a glTF document holding only `material`.
    fn with_material(material: &str, ext: MaterialExt, f: impl FnOnce(Arc<Shader>, Vec<&str>)) {
        let json = format!(r#"{{"asset":{{"version":"2.0"}},"materials":[{material}]}}"#);
        let doc = gltf::Gltf::from_slice(json.as_bytes()).unwrap();
        let m = doc.materials().next().unwrap();
        f(shader_for(&m, &ext, None), ignored_features(&m, &ext));
    }

    #[test]
    fn a_smooth_metal_reflects_its_colour() {
        let gold = r#"{"pbrMetallicRoughness":{"baseColorFactor":[1,0.8,0.3,1],"metallicFactor":1,"roughnessFactor":0}}"#;
        with_material(gold, MaterialExt::default(), |s, ignored| {
            let Shader::Reflective { reflectance, .. } = &*s else {
                panic!("{s:?}");
            };
            assert!((*reflectance - DVec3::new(1.0, 0.8, 0.3)).length() < 1e-6);
            assert!(ignored.is_empty());
        });
        // A rough one does not, and the defaults (metallic 1, roughness 1)
        // are diffuse.
        let rough = r#"{"pbrMetallicRoughness":{"metallicFactor":1,"roughnessFactor":0.6}}"#;
        with_material(rough, MaterialExt::default(), |s, _| {
            assert!(matches!(*s, Shader::Phong { .. }), "{s:?}");
        });
        with_material("{}", MaterialExt::default(), |s, _| {
            assert!(matches!(*s, Shader::Lambertian { .. }), "{s:?}");
        });
        // A smooth dielectric reflects 4% head-on.
        let plastic = r#"{"pbrMetallicRoughness":{"metallicFactor":0,"roughnessFactor":0}}"#;
        with_material(plastic, MaterialExt::default(), |s, _| {
            let Shader::Reflective { reflectance, .. } = &*s else {
                panic!("{s:?}");
            };
            assert!((*reflectance - DVec3::splat(0.04)).length() < 1e-9);
        });
    }

    #[test]
    fn transmission_is_glass_thin_or_solid() {
        let glass = MaterialExt {
            transmission: 1.0,
            ior: 1.33,
            ..MaterialExt::default()
        };
        with_material("{}", glass, |s, _| {
            let Shader::Glazed {
                refractive_index,
                substrate,
                ..
            } = &*s
            else {
                panic!("{s:?}");
            };
            assert_eq!(*refractive_index, 1.33);
            assert_eq!(
                **substrate,
                Shader::Glass {
                    refractive_index: 1.0
                }
            );
        });
        let solid = MaterialExt {
            thickness: 0.5,
            ..glass
        };
        with_material("{}", solid, |s, _| {
            assert_eq!(
                *s,
                Shader::Glass {
                    refractive_index: 1.33
                }
            );
        });
        let faint = MaterialExt {
            transmission: 0.2,
            ..MaterialExt::default()
        };
        with_material("{}", faint, |s, ignored| {
            assert!(matches!(*s, Shader::Lambertian { .. }), "{s:?}");
            assert_eq!(ignored, ["partial transmission (below 0.5: opaque)"]);
        });
    }

    #[test]
    fn ignored_features_are_named() {
        let m = r#"{"normalTexture":{"index":0},"occlusionTexture":{"index":0},"alphaMode":"BLEND",
            "pbrMetallicRoughness":{"metallicRoughnessTexture":{"index":0}}}"#;
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"images":[{{"uri":"a.png"}}],"textures":[{{"source":0}}],"materials":[{m}]}}"#
        );
        let doc = gltf::Gltf::from_slice(json.as_bytes()).unwrap();
        let m = doc.materials().next().unwrap();
        assert_eq!(
            ignored_features(&m, &MaterialExt::default()),
            [
                "normal textures",
                "occlusion textures",
                "metallic-roughness textures",
                "transparency (alphaMode BLEND or MASK)"
            ]
        );
    }
}
