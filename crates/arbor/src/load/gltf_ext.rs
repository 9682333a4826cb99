//! The glTF extensions arbor reads, taken from the file's JSON (the `gltf`
//! crate is built without its extension support): per material
//! `KHR_materials_emissive_strength`, `KHR_texture_transform` on the base
//! colour and emissive textures, `KHR_materials_transmission`,
//! `KHR_materials_ior` and `KHR_materials_volume`; per file
//! `KHR_lights_punctual`'s lights and the nodes that place them. A value of
//! the wrong type or out of its range reads as the extension's default.

use gltf::json::Value;

use glam::{DMat4, DVec3};

use crate::light::Light;
use crate::texture::UvTransform;

/// The extensions whose effect arbor implements (others, when the file
/// uses them, are named in a warning).
pub(super) const READ: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
];

/// A texture's `KHR_texture_transform`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TextureTransform {
    /// The map of texture coordinates, in arbor's coordinates.
    pub transform: UvTransform,
    /// The texture coordinate set it overrides the texture's own with.
    pub tex_coord: Option<u32>,
}

/// What one material's extensions say.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct MaterialExt {
    /// `emissiveStrength` (1 without the extension).
    pub emissive_strength: f64,
    /// The base colour texture's transform.
    pub base_color_transform: Option<TextureTransform>,
    /// The emissive texture's transform.
    pub emissive_transform: Option<TextureTransform>,
    /// `transmissionFactor` (0 without the extension).
    pub transmission: f64,
    /// `ior` (1.5 without the extension).
    pub ior: f64,
    /// `KHR_materials_volume`'s `thicknessFactor`: 0 (also without the
    /// extension) is a thin-walled surface, which does not bend light.
    pub thickness: f64,
}

impl Default for MaterialExt {
    fn default() -> Self {
        MaterialExt {
            emissive_strength: 1.0,
            base_color_transform: None,
            emissive_transform: None,
            transmission: 0.0,
            ior: 1.5,
            thickness: 0.0,
        }
    }
}

/// The kind of a punctual light, with a spot's cone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum PunctualKind {
    /// Light from a point, in candela.
    Point,
    /// Parallel light along the node's -z, in lux.
    Directional,
    /// A point light within a cone around the node's -z (angles in radians
    /// from its axis), in candela.
    Spot {
        /// Full strength inside this angle.
        inner: f64,
        /// None beyond this angle.
        outer: f64,
    },
}

/// One light of `KHR_lights_punctual`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Punctual {
    /// Point, directional or spot.
    pub kind: PunctualKind,
    /// Linear colour (white without one).
    pub color: [f64; 3],
    /// Candela (point, spot) or lux (directional); 1 without one.
    pub intensity: f64,
}

impl Punctual {
    /// The light placed by a node whose world matrix is `world` (glTF
    /// lights shine along their node's -z), in arbor's units: arbor's
    /// diffuse term has no `1/π`, so a glTF intensity (candela or lux)
    /// becomes `intensity / π` times the colour, and a white diffuse
    /// surface under `E` lux shows the radiance `E / π` a physical one
    /// would. `None` when the matrix leaves no position or direction.
    pub fn placed(&self, world: DMat4) -> Option<Light> {
        let intensity = DVec3::from_array(self.color) * (self.intensity / std::f64::consts::PI);
        let position = world.transform_point3(DVec3::ZERO);
        let along = world.transform_vector3(DVec3::NEG_Z).try_normalize()?;
        if !(position.is_finite() && intensity.is_finite()) {
            return None;
        }
        Some(match self.kind {
            PunctualKind::Point => Light::Point {
                position,
                intensity,
            },
            PunctualKind::Directional => Light::Directional {
                direction: -along,
                intensity,
            },
            PunctualKind::Spot { inner, outer } => Light::Spot {
                position,
                direction: along,
                intensity,
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            },
        })
    }
}

/// The extensions of a whole file.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct FileExt {
    /// One per material, by index.
    pub materials: Vec<MaterialExt>,
    /// The file's lights, by index (`None`: not a light arbor can read).
    pub lights: Vec<Option<Punctual>>,
    /// The light each node places, by node index.
    pub node_lights: Vec<Option<usize>>,
    /// `extensionsUsed` that arbor does not implement, for a warning.
    pub ignored: Vec<String>,
}

impl FileExt {
    /// Reads them from the JSON text (or a GLB's JSON chunk); JSON that does
    /// not parse has none (the crate then says what is wrong).
    pub fn read(json: &[u8]) -> FileExt {
        match gltf::json::deserialize::from_slice::<Value>(json) {
            Ok(root) => Self::from_root(&root),
            Err(_) => FileExt::default(),
        }
    }

    fn from_root(root: &Value) -> FileExt {
        let list = |key: &str| -> Vec<Value> {
            root.get(key)
                .and_then(Value::as_array)
                .cloned()
                .unwrap_or_default()
        };
        let materials = list("materials").iter().map(material).collect();
        let lights = root
            .pointer("/extensions/KHR_lights_punctual/lights")
            .and_then(Value::as_array)
            .map(|ls| ls.iter().map(punctual).collect())
            .unwrap_or_default();
        let node_lights = list("nodes")
            .iter()
            .map(|n| {
                n.pointer("/extensions/KHR_lights_punctual/light")
                    .and_then(Value::as_u64)
                    .map(|i| i as usize)
            })
            .collect();
        let ignored = list("extensionsUsed")
            .iter()
            .filter_map(Value::as_str)
            .filter(|n| !READ.contains(n))
            .map(str::to_string)
            .collect();
        FileExt {
            materials,
            lights,
            node_lights,
            ignored,
        }
    }

    /// The extensions of material `index` (`None`: the default material).
    pub fn material(&self, index: Option<usize>) -> MaterialExt {
        index
            .and_then(|i| self.materials.get(i).copied())
            .unwrap_or_default()
    }
}

/// A finite number at `pointer` under `v` within `range`, or `default`.
fn number(v: &Value, pointer: &str, range: std::ops::RangeInclusive<f64>, default: f64) -> f64 {
    v.pointer(pointer)
        .and_then(Value::as_f64)
        .filter(|x| range.contains(x))
        .unwrap_or(default)
}

/// Two finite numbers at `pointer` under `v`, or `default`.
fn pair(v: &Value, pointer: &str, default: [f64; 2]) -> [f64; 2] {
    match v
        .pointer(pointer)
        .and_then(Value::as_array)
        .map(Vec::as_slice)
    {
        Some([x, y]) => match (x.as_f64(), y.as_f64()) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => [x, y],
            _ => default,
        },
        _ => default,
    }
}

fn material(m: &Value) -> MaterialExt {
    let ext = |name: &str| m.pointer(&format!("/extensions/{name}"));
    let d = MaterialExt::default();
    MaterialExt {
        emissive_strength: ext("KHR_materials_emissive_strength")
            .map_or(1.0, |e| number(e, "/emissiveStrength", 0.0..=f64::MAX, 1.0)),
        base_color_transform: m
            .pointer("/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform")
            .map(texture_transform),
        emissive_transform: m
            .pointer("/emissiveTexture/extensions/KHR_texture_transform")
            .map(texture_transform),
        transmission: ext("KHR_materials_transmission")
            .map_or(0.0, |e| number(e, "/transmissionFactor", 0.0..=1.0, 0.0)),
        ior: ext("KHR_materials_ior").map_or(d.ior, |e| {
            // The extension allows 0 (a metal's "no refraction") or >= 1.
            number(e, "/ior", 1.0..=f64::MAX, d.ior)
        }),
        thickness: ext("KHR_materials_volume")
            .map_or(0.0, |e| number(e, "/thicknessFactor", 0.0..=f64::MAX, 0.0)),
    }
}

fn texture_transform(t: &Value) -> TextureTransform {
    TextureTransform {
        transform: UvTransform::gltf(
            pair(t, "/offset", [0.0, 0.0]),
            number(t, "/rotation", f64::MIN..=f64::MAX, 0.0),
            pair(t, "/scale", [1.0, 1.0]),
        ),
        tex_coord: t
            .get("texCoord")
            .and_then(Value::as_u64)
            .and_then(|c| u32::try_from(c).ok()),
    }
}

fn punctual(l: &Value) -> Option<Punctual> {
    let kind = match l.get("type")?.as_str()? {
        "point" => PunctualKind::Point,
        "directional" => PunctualKind::Directional,
        "spot" => {
            let quarter = std::f64::consts::FRAC_PI_4;
            let outer = number(
                l,
                "/spot/outerConeAngle",
                0.0..=std::f64::consts::FRAC_PI_2,
                quarter,
            );
            let inner = number(l, "/spot/innerConeAngle", 0.0..=outer, 0.0);
            PunctualKind::Spot { inner, outer }
        }
        _ => return None,
    };
    let color = l
        .get("color")
        .and_then(Value::as_array)
        .and_then(|c| {
            let c: Vec<f64> = c.iter().filter_map(Value::as_f64).collect();
            <[f64; 3]>::try_from(c).ok()
        })
        .filter(|c| c.iter().all(|x| x.is_finite() && *x >= 0.0))
        .unwrap_or([1.0; 3]);
    Some(Punctual {
        kind,
        color,
        intensity: number(l, "/intensity", 0.0..=f64::MAX, 1.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_extensions_are_read_with_their_defaults() {
        let json = br#"{"materials":[{},
            {"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":5.5},
                "KHR_materials_transmission":{"transmissionFactor":1},
                "KHR_materials_ior":{"ior":1.33},
                "KHR_materials_volume":{"thicknessFactor":0.2}},
             "pbrMetallicRoughness":{"baseColorTexture":{"index":0,
                "extensions":{"KHR_texture_transform":{"offset":[0.5,0],"texCoord":1}}}}},
            {"extensions":{"KHR_materials_ior":{"ior":0.5},"KHR_materials_transmission":{"transmissionFactor":"x"}}}]}"#;
        let ext = FileExt::read(json);
        assert_eq!(ext.materials[0], MaterialExt::default());
        let m = ext.material(Some(1));
        assert_eq!(
            (m.emissive_strength, m.transmission, m.ior, m.thickness),
            (5.5, 1.0, 1.33, 0.2)
        );
        let t = m.base_color_transform.unwrap();
        assert_eq!(t.tex_coord, Some(1));
        assert_eq!(t.transform.apply(0.0, 0.0), (0.5, 0.0));
        assert_eq!(m.emissive_transform, None);
        // Out of range or mistyped: the defaults.
        let m = ext.material(Some(2));
        assert_eq!((m.transmission, m.ior), (0.0, 1.5));
        assert_eq!(ext.material(None), MaterialExt::default());
        assert_eq!(ext.material(Some(9)), MaterialExt::default());
        assert_eq!(FileExt::read(b"not json"), FileExt::default());
    }

    #[test]
    fn lights_and_the_nodes_placing_them_are_read() {
        let json = br#"{"extensions":{"KHR_lights_punctual":{"lights":[
            {"type":"point","intensity":20,"color":[1,0.5,0]},
            {"type":"directional"},
            {"type":"spot","spot":{"innerConeAngle":0.2,"outerConeAngle":0.5}},
            {"type":"area"}]}},
            "nodes":[{},{"extensions":{"KHR_lights_punctual":{"light":2}}}]}"#;
        let ext = FileExt::read(json);
        assert_eq!(
            ext.lights[0],
            Some(Punctual {
                kind: PunctualKind::Point,
                color: [1.0, 0.5, 0.0],
                intensity: 20.0
            })
        );
        assert_eq!(ext.lights[1].unwrap().kind, PunctualKind::Directional);
        assert_eq!(ext.lights[1].unwrap().intensity, 1.0);
        assert_eq!(
            ext.lights[2].unwrap().kind,
            PunctualKind::Spot {
                inner: 0.2,
                outer: 0.5
            }
        );
        assert_eq!(ext.lights[3], None);
        assert_eq!(ext.node_lights, [None, Some(2)]);
    }

    #[test]
    fn lights_are_placed_by_their_node_in_arbor_units() {
        let pi = std::f64::consts::PI;
        let spot = Punctual {
            kind: PunctualKind::Spot {
                inner: 0.0,
                outer: 0.5,
            },
            color: [1.0, 0.5, 0.0],
            intensity: pi,
        };
        // A node at (1, 2, 3) turned a quarter about y: -z becomes -x.
        let world = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
            * DMat4::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let Some(Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        }) = spot.placed(world)
        else {
            panic!("a spot");
        };
        assert!((position - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!((direction - DVec3::NEG_X).length() < 1e-12);
        assert!((intensity - DVec3::new(1.0, 0.5, 0.0)).length() < 1e-12);
        assert_eq!((cos_inner, cos_outer), (1.0, 0.5f64.cos()));
        // A directional light gives the direction toward it: +x here.
        let sun = Punctual {
            kind: PunctualKind::Directional,
            ..spot
        };
        let Some(Light::Directional { direction, .. }) = sun.placed(world) else {
            panic!("directional");
        };
        assert!((direction - DVec3::X).length() < 1e-12);
        // A zero scale leaves no direction.
        assert_eq!(sun.placed(DMat4::ZERO), None);
    }

    #[test]
    fn ignored_extensions_are_named() {
        let json = br#"{"extensionsUsed":["KHR_texture_transform","KHR_materials_sheen","KHR_lights_punctual","KHR_materials_clearcoat"]}"#;
        assert_eq!(
            FileExt::read(json).ignored,
            ["KHR_materials_sheen", "KHR_materials_clearcoat"]
        );
        assert!(FileExt::read(br#"{"extensionsUsed":[]}"#)
            .ignored
            .is_empty());
    }
}
