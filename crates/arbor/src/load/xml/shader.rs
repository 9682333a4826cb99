//! `<shader>` elements: the children every shader type may have are read
//! into one [`Params`] in document order, then one function per shader type
//! builds it, dispatched by [`Loader::shader`].

use std::sync::Arc;

use glam::DVec3;
use roxmltree::Node;

use super::{elements, key, tag, Loader, Named, Result};
use crate::shader::{Fresnel, Shader};
use crate::texture::Texture;

/// The values a shader's child elements gave, with the defaults of absent ones.
struct Params {
    diffuse: DVec3,
    specular: DVec3,
    exponent: f64,
    refractive_index: Option<f64>,
    substrate: Option<Arc<Shader>>,
    fresnel: Option<Fresnel>,
    roughness: f64,
    texture: Option<Arc<Texture>>,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            diffuse: DVec3::ONE,
            specular: DVec3::ONE,
            exponent: 1.0,
            refractive_index: None,
            substrate: None,
            fresnel: None,
            roughness: 1.0,
            texture: None,
        }
    }
}

impl<'a, 'input> Loader<'a, 'input> {
    /// A `<shader>` (or a reference to one).
    pub(super) fn shader(&mut self, node: Node) -> Result<Arc<Shader>> {
        self.check_attributes(node);
        if let Some(Named::Shader(s)) = self.referenced_kind(node, "shader")? {
            return Ok(s);
        }
        let ty = self.shader_type(node)?;
        let p = self.shader_params(node, ty)?;
        let shader = match ty {
            "Lambertian" => lambertian(p),
            "Phong" => phong(p),
            "Glazed" => self.glazed(node, p)?,
            "Glass" => self.glass(node, p)?,
            "RGBNormals" => Shader::RgbNormals,
            _ => cook_torrance(p),
        };
        let shader = Arc::new(shader);
        self.remember(node, Named::Shader(shader.clone()));
        Ok(shader)
    }

    /// The element's `type`, one of the shader types of the scene's variant.
    fn shader_type<'n>(&self, node: Node<'n, '_>) -> Result<&'n str> {
        let mut types = vec!["Lambertian", "Phong", "Glazed", "Glass"];
        if self.is2015() {
            types.extend(["RGBNormals", "CookTorrance"]);
        }
        let Some(ty) = node.attribute("type") else {
            return Err(self.error(
                node,
                format!(
                    "<{}> needs a type attribute; expected one of {}",
                    tag(node),
                    types.join(", ")
                ),
            ));
        };
        if !types.contains(&ty) {
            return Err(self.error(
                node,
                format!(
                    "unknown shader type '{ty}'; expected one of {}",
                    types.join(", ")
                ),
            ));
        }
        Ok(ty)
    }

    /// The child elements a shader of type `ty` accepts.
    fn shader_children(&self, ty: &str) -> Vec<&'static str> {
        let mut expected: Vec<&str> = match ty {
            "Lambertian" => vec!["diffuseColor"],
            "Phong" => vec!["diffuseColor", "specularColor", "exponent"],
            "Glazed" => vec!["refractiveIndex", "substrate", "fresnel"],
            "Glass" => vec!["refractiveIndex"],
            "CookTorrance" => vec![
                "diffuseColor",
                "specularColor",
                "roughness",
                "refractiveIndex",
            ],
            _ => vec![],
        };
        // 2010 files give dielectrics an exponent they do not use.
        if !self.is2015() && matches!(ty, "Glazed" | "Glass") {
            expected.push("exponent");
        }
        if self.is2015() {
            expected.push("texture");
        }
        expected
    }

    /// Reads the child elements of a shader of type `ty`, in document order.
    fn shader_params(&mut self, node: Node, ty: &str) -> Result<Params> {
        let expected = self.shader_children(ty);
        let mut p = Params::default();
        for child in elements(node) {
            let k = key(child);
            if !expected.iter().any(|e| e.eq_ignore_ascii_case(&k)) {
                let shown = if expected.is_empty() {
                    vec!["no child elements"]
                } else {
                    expected.clone()
                };
                return Err(self.unknown_element(
                    child,
                    &format!("<{} type=\"{ty}\">", tag(node)),
                    &shown,
                ));
            }
            match k.as_str() {
                "diffusecolor" => p.diffuse = self.vector(child)?,
                "specularcolor" => p.specular = self.vector(child)?,
                "exponent" => p.exponent = self.number(child)?,
                "refractiveindex" => p.refractive_index = Some(self.positive(child)?),
                "roughness" => p.roughness = self.positive(child)?,
                "substrate" => p.substrate = Some(self.shader(child)?),
                "texture" => p.texture = Some(self.texture(child)?),
                "fresnel" => p.fresnel = Some(self.fresnel(child)?),
                _ => unreachable!("filtered by the expected list"),
            }
        }
        Ok(p)
    }

    fn fresnel(&mut self, child: Node) -> Result<Fresnel> {
        let text = self.text(child)?;
        match text.trim() {
            "schlick" => Ok(Fresnel::Schlick),
            "exact" => Ok(Fresnel::Exact),
            other => Err(self.error(
                child,
                format!("<fresnel> must be 'schlick' or 'exact', found '{other}'"),
            )),
        }
    }

    /// The refractive index a dielectric of type `ty` must have.
    fn need_index(&self, node: Node, ty: &str, p: &Params) -> Result<f64> {
        p.refractive_index
            .ok_or_else(|| self.error(node, format!("a {ty} shader needs a <refractiveIndex>")))
    }

    fn glazed(&self, node: Node, p: Params) -> Result<Shader> {
        let refractive_index = self.need_index(node, "Glazed", &p)?;
        let substrate = p
            .substrate
            .ok_or_else(|| self.error(node, "a Glazed shader needs a <substrate> shader"))?;
        // Each edition's framework has its own default.
        let fresnel = p.fresnel.unwrap_or(if self.is2015() {
            Fresnel::Exact
        } else {
            Fresnel::Schlick
        });
        Ok(Shader::Glazed {
            refractive_index,
            substrate,
            fresnel,
        })
    }

    fn glass(&self, node: Node, p: Params) -> Result<Shader> {
        Ok(Shader::Glass {
            refractive_index: self.need_index(node, "Glass", &p)?,
        })
    }
}

fn lambertian(p: Params) -> Shader {
    Shader::Lambertian {
        diffuse: p.diffuse,
        texture: p.texture,
    }
}

fn phong(p: Params) -> Shader {
    Shader::Phong {
        diffuse: p.diffuse,
        specular: p.specular,
        exponent: p.exponent,
        texture: p.texture,
    }
}

fn cook_torrance(p: Params) -> Shader {
    Shader::CookTorrance {
        diffuse: p.diffuse,
        specular: p.specular,
        roughness: p.roughness,
        refractive_index: p.refractive_index.unwrap_or(0.0),
        texture: p.texture,
    }
}
