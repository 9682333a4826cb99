//! `<surface>` elements: one function per surface type, dispatched by
//! [`Loader::surface`].

use std::sync::Arc;

use glam::{DMat4, DVec3};
use roxmltree::Node;

use super::{elements, key, tag, Loader, Named, Result};
use crate::limits::MAX_NESTING;
use crate::shader::Shader;
use crate::surface::transformed::{rotation_degrees, scaling, translation};
use crate::surface::{BoxSurface, Cylinder, Group, MeshSurface, Sphere, Surface};
use crate::variant::Variant;

impl<'a, 'input> Loader<'a, 'input> {
    /// A `<surface>` (or a reference to one); a named surface comes back as
    /// an instance, so that every placement of it is shared.
    pub(super) fn surface(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        self.check_attributes(node);
        if let Some(name) = node.attribute("ref") {
            if let Some(def) = self.pending.get(name).copied() {
                self.resolve(name, def)?;
            }
        }
        if let Some(Named::Surface(shared)) = self.referenced_kind(node, "surface")? {
            return Ok(Surface::Instance(shared));
        }
        let mut types = vec!["Sphere", "Box", "Mesh", "Group"];
        if self.is2015() {
            types.push("Cylinder");
        }
        let ty = self.surface_type(node, &types)?;
        let surface = match ty {
            "Sphere" => self.sphere(node)?,
            "Box" => self.box_surface(node)?,
            "Mesh" => self.mesh_surface(node)?,
            "Cylinder" => self.cylinder(node)?,
            _ => self.group(node)?,
        };
        // A named surface may be placed again by `ref`: share it from the start,
        // so that every placement (this one included) is an instance of it.
        if node.has_attribute("name") {
            let shared = Arc::new(surface);
            self.remember(node, Named::Surface(shared.clone()));
            return Ok(Surface::Instance(shared));
        }
        Ok(surface)
    }

    /// The element's `type`, one of `types`.
    fn surface_type<'n>(&self, node: Node<'n, '_>, types: &[&str]) -> Result<&'n str> {
        match node.attribute("type") {
            Some(t) if types.contains(&t) => Ok(t),
            Some(t) => Err(self.error(
                node,
                format!(
                    "unknown surface type '{t}'; expected one of {}",
                    types.join(", ")
                ),
            )),
            None => Err(self.error(
                node,
                format!(
                    "<{}> needs a type attribute; expected one of {}",
                    tag(node),
                    types.join(", ")
                ),
            )),
        }
    }

    /// Hands each child element of the surface `node` (of type `ty`) to
    /// `each` with its folded name, in document order, after checking it is
    /// one of `expected`.
    fn surface_children(
        &mut self,
        node: Node<'a, 'input>,
        expected: &[&str],
        mut each: impl FnMut(&mut Self, Node<'a, 'input>, &str) -> Result<()>,
    ) -> Result<()> {
        let ty = node.attribute("type").unwrap_or_default();
        for child in elements(node) {
            let k = key(child);
            if !expected.iter().any(|e| e.eq_ignore_ascii_case(&k)) {
                return Err(self.unknown_element(
                    child,
                    &format!("<{} type=\"{ty}\">", tag(node)),
                    expected,
                ));
            }
            each(self, child, &k)?;
        }
        Ok(())
    }

    // Not inlined (nor the other element kinds): group nesting recurses
    // through `surface`, whose frame must stay small enough for the nesting
    // limit to be reached before the stack's end.
    #[inline(never)]
    fn sphere(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        let (mut center, mut radius, mut shader) = (DVec3::ZERO, 1.0, None);
        self.surface_children(node, &["center", "radius", "shader"], |this, child, k| {
            match k {
                "center" => center = this.vector(child)?,
                "radius" => radius = this.positive(child)?,
                _ => shader = Some(this.shader(child)?),
            }
            Ok(())
        })?;
        Ok(Surface::Sphere(Sphere {
            center,
            radius,
            shader: or_default(shader),
        }))
    }

    // Not inlined, as `sphere`.
    #[inline(never)]
    fn box_surface(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        let (mut min, mut max, mut shader) = (DVec3::ZERO, DVec3::ZERO, None);
        self.surface_children(node, &["minPt", "maxPt", "shader"], |this, child, k| {
            match k {
                "minpt" => min = this.vector(child)?,
                "maxpt" => max = this.vector(child)?,
                _ => shader = Some(this.shader(child)?),
            }
            Ok(())
        })?;
        if !(min.cmple(max).all()) {
            return Err(self.error(
                node,
                format!(
                    "a Box needs minPt <= maxPt on every axis; found minPt {min} and maxPt {max}"
                ),
            ));
        }
        Ok(Surface::Box(BoxSurface {
            min,
            max,
            shader: or_default(shader),
        }))
    }

    // Not inlined, as `sphere`.
    #[inline(never)]
    fn cylinder(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        let (mut center, mut radius, mut height, mut shader) = (DVec3::ZERO, 1.0, 1.0, None);
        let expected = ["center", "radius", "height", "shader"];
        self.surface_children(node, &expected, |this, child, k| {
            match k {
                "center" => center = this.vector(child)?,
                "radius" => radius = this.positive(child)?,
                "height" => height = this.positive(child)?,
                _ => shader = Some(this.shader(child)?),
            }
            Ok(())
        })?;
        Ok(Surface::Cylinder(Cylinder {
            center,
            radius,
            height,
            shader: or_default(shader),
        }))
    }

    // Not inlined, as `sphere`.
    #[inline(never)]
    fn mesh_surface(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        let (mut data, mut shader) = (None, None);
        self.surface_children(node, &["data", "shader"], |this, child, k| {
            match k {
                "data" => data = Some((child, this.text(child)?.trim().to_string())),
                _ => shader = Some(this.shader(child)?),
            }
            Ok(())
        })?;
        let (at, file) = data.ok_or_else(|| {
            self.error(node, "a Mesh needs a <data> element naming its mesh file")
        })?;
        Ok(Surface::Mesh(MeshSurface {
            data: self.mesh(at, &file)?,
            shader: or_default(shader),
            two_sided: false,
            soft_terminator: false,
        }))
    }

    fn group(&mut self, node: Node<'a, 'input>) -> Result<Surface> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(self.error(
                node,
                format!("groups are nested more than {MAX_NESTING} deep"),
            ));
        }
        let (mut transform, mut children) = (DMat4::IDENTITY, Vec::new());
        let expected = ["translate", "rotate", "scale", "surface", "shader"];
        self.surface_children(node, &expected, |this, child, k| {
            match k {
                // A group's shader is read (and checked) but not used.
                "shader" => drop(this.shader(child)?),
                "surface" => children.push(this.surface(child)?),
                _ => {
                    let m = this.transform_step(child, k)?;
                    // Spec §5.5: 2010 applies the last element first, 2015 the first.
                    transform = match this.variant {
                        Variant::Cornell2010 => transform * m,
                        Variant::Cornell2015 => m * transform,
                    };
                }
            }
            Ok(())
        })?;
        self.depth -= 1;
        Ok(Surface::Group(Group {
            transform,
            children,
        }))
    }

    /// The matrix of one `<translate>`, `<rotate>` or `<scale>` (folded
    /// name `k`).
    fn transform_step(&mut self, child: Node, k: &str) -> Result<DMat4> {
        let v = self.vector(child)?;
        Ok(match k {
            "translate" => translation(v),
            "rotate" => rotation_degrees(v),
            _ => {
                if v.x == 0.0 || v.y == 0.0 || v.z == 0.0 {
                    return Err(self.error(child, "<scale> factors must not be zero"));
                }
                scaling(v)
            }
        })
    }
}

/// The surface's shader, or the default Lambertian when it names none.
fn or_default(shader: Option<Arc<Shader>>) -> Arc<Shader> {
    shader.unwrap_or_else(|| Arc::new(Shader::default_lambertian()))
}
