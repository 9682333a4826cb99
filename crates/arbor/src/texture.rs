//! Image textures and environment cube maps (2015 variant).

use std::path::Path;

use glam::DVec3;

/// How texture lookups outside `[0,1]` behave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// `ClampTexture`: clamp to the edge texels.
    Clamp,
    /// `RepeatTexture`: wrap around.
    Repeat,
}

/// How a texture's 8-bit values become the linear colours shading uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelEncoding {
    /// Values scaled to `[0,1]` with no decoding, as the Cornell framework
    /// reads its textures (spec §6.5) and as its reference images show.
    Raw,
    /// sRGB-encoded values decoded to linear (the sRGB transfer function):
    /// glTF colour textures by its specification, MTL textures by convention.
    Srgb,
}

impl TexelEncoding {
    /// The linear value of the byte `b`.
    pub fn decode(self, b: u8) -> f64 {
        let c = b as f64 / 255.0;
        match self {
            TexelEncoding::Raw => c,
            TexelEncoding::Srgb => srgb_to_linear(c),
        }
    }
}

/// The linear value of an sRGB-encoded value `c` in `[0, 1]` (the sRGB
/// transfer function; textures and vertex colours of models).
/// Values outside `[0, 1]` are clamped to it, non-numbers read as 0.
pub fn srgb_to_linear(c: f64) -> f64 {
    let c = if c.is_finite() {
        c.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An 8-bit image used as a colour texture, its texels linear colours
/// (decoded by the [`TexelEncoding`] it was read with).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Wrap mode.
    pub wrap: Wrap,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major texels, row 0 at the top.
    pub texels: Vec<DVec3>,
    /// Applied to the texture coordinates before the lookup (glTF's
    /// `KHR_texture_transform`); `None` looks them up as given.
    pub transform: Option<UvTransform>,
}

/// An affine map of texture coordinates, `(u, v) -> (a u + b v + c, d u +
/// e v + f)`, in arbor's coordinates (v up the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// The rows `[a, b, c]` and `[d, e, f]`.
    pub rows: [[f64; 3]; 2],
}

impl UvTransform {
    /// glTF's `KHR_texture_transform` (`offset`, `rotation` in radians,
    /// `scale`), which the extension defines as translation times rotation
    /// times scale in glTF's coordinates (v down the image), written in
    /// arbor's (v up: `v_arbor = 1 - v_gltf`).
    pub fn gltf(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> UvTransform {
        let (sin, cos) = rotation.sin_cos();
        // glTF: u' = a u + b v + ox, v' = c u + d v + oy.
        let (a, b) = (cos * scale[0], sin * scale[1]);
        let (c, d) = (-sin * scale[0], cos * scale[1]);
        // Substituting v = 1 - w and w' = 1 - v'.
        UvTransform {
            rows: [[a, -b, b + offset[0]], [-c, d, 1.0 - d - offset[1]]],
        }
    }

    /// The coordinates `(u, v)` mapped.
    pub fn apply(&self, u: f64, v: f64) -> (f64, f64) {
        let [r, s] = self.rows;
        (r[0] * u + r[1] * v + r[2], s[0] * u + s[1] * v + s[2])
    }
}

impl Texture {
    /// Reads an image file (any format the `image` crate reads; its default
    /// limits bound the memory a hostile header can claim) as a texture.
    /// The error says what went wrong, without the path.
    pub fn load(path: &Path, wrap: Wrap, encoding: TexelEncoding) -> Result<Texture, String> {
        Self::from_image(
            image::open(path).map_err(|e| e.to_string())?,
            wrap,
            encoding,
        )
    }

    /// Decodes an image file's bytes (the format guessed from them) as a
    /// texture, under the same limits as [`Texture::load`].
    pub fn decode(bytes: &[u8], wrap: Wrap, encoding: TexelEncoding) -> Result<Texture, String> {
        Self::from_image(
            image::load_from_memory(bytes).map_err(|e| e.to_string())?,
            wrap,
            encoding,
        )
    }

    /// The texture with every texel multiplied by `factor` (glTF's base
    /// colour factor times its base colour texture).
    pub fn tinted(&self, factor: DVec3) -> Texture {
        Texture {
            texels: self.texels.iter().map(|t| *t * factor).collect(),
            ..self.clone()
        }
    }

    /// The texture looked up through `transform` (its texels shared in
    /// value, not in memory).
    pub fn transformed(&self, transform: UvTransform) -> Texture {
        Texture {
            transform: Some(transform),
            ..self.clone()
        }
    }

    fn from_image(
        img: image::DynamicImage,
        wrap: Wrap,
        encoding: TexelEncoding,
    ) -> Result<Texture, String> {
        let img = img.to_rgb8();
        if img.width() == 0 || img.height() == 0 {
            return Err("the image has no pixels".into());
        }
        let texels = img
            .pixels()
            .map(|p| {
                let [r, g, b] = p.0.map(|c| encoding.decode(c));
                DVec3::new(r, g, b)
            })
            .collect();
        Ok(Texture {
            wrap,
            width: img.width(),
            height: img.height(),
            texels,
            transform: None,
        })
    }

    /// The texel for texture coordinates `(u, v)` (after the texture's
    /// [`UvTransform`], if any): `x = floor(u w + 0.5)`, `y = floor((1 - v)
    /// h + 0.5)`, then clamped or wrapped.
    pub fn lookup(&self, u: f64, v: f64) -> DVec3 {
        let (u, v) = match &self.transform {
            Some(t) => t.apply(u, v),
            None => (u, v),
        };
        let (w, h) = (self.width as i64, self.height as i64);
        let x = (u * w as f64 + 0.5).floor() as i64;
        let y = ((1.0 - v) * h as f64 + 0.5).floor() as i64;
        let (x, y) = match self.wrap {
            Wrap::Clamp => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
            Wrap::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
        };
        self.texels[(y * w + x) as usize]
    }
}

/// A vertical-cross environment map (3 blocks wide, 4 tall) of linear
/// radiance, as the 2015 framework reads from PFM files (spec §6.5).
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    /// Block size in texels (`width / 3`).
    pub block: usize,
    /// Image width in texels.
    pub width: usize,
    /// Row-major texels as stored in the PFM (bottom row first).
    pub texels: Vec<DVec3>,
    /// Multiplier applied to every lookup.
    pub scale: f64,
}

impl CubeMap {
    /// The radiance seen in direction `d`.
    pub fn lookup(&self, d: DVec3) -> DVec3 {
        let (ax, ay, az) = (d.x.abs(), d.y.abs(), d.z.abs());
        // (face u, face v, block column, block row) per the framework's dirToFace/faceToIndex.
        let (u, v, bx, by) = if ax >= ay && ax >= az {
            if d.x > 0.0 {
                (d.z / d.x, d.y / ax, 2, 2)
            } else {
                (d.z / d.x, d.y / ax, 0, 2)
            }
        } else if ay >= az {
            if d.y > 0.0 {
                (d.x / ay, d.z / d.y, 1, 3)
            } else {
                (d.x / ay, d.z / d.y, 1, 1)
            }
        } else if d.z > 0.0 {
            (d.x / az, -d.y / d.z, 1, 0)
        } else {
            (d.x / az, -d.y / d.z, 1, 2)
        };
        let b = self.block as f64;
        let iu = ((b * (u + 1.0) / 2.0).floor() as usize).min(self.block - 1);
        let iv = ((b * (v + 1.0) / 2.0).floor() as usize).min(self.block - 1);
        let x = bx * self.block + iu;
        let y = by * self.block + iv;
        self.texels[y * self.width + x] * self.scale
    }
}

/// Reads a little-endian RGB PFM (`PF`, negative scale) laid out as a
/// vertical cross, as the 2015 framework's cube maps are.
pub fn read_pfm_cubemap(path: &std::path::Path, scale: f64) -> Result<CubeMap, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    // Header: three whitespace-separated tokens after the magic, then one byte.
    let mut tokens = Vec::new();
    let mut pos = 0;
    while tokens.len() < 4 && pos < bytes.len() {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    if tokens.len() < 4 || tokens[0] != "PF" {
        return Err("not a colour PFM file (expected the PF header)".into());
    }
    let width: usize = tokens[1].parse().map_err(|_| "bad PFM width")?;
    let height: usize = tokens[2].parse().map_err(|_| "bad PFM height")?;
    let endian: f64 = tokens[3].parse().map_err(|_| "bad PFM scale")?;
    if width == 0 || !width.is_multiple_of(3) || height != width / 3 * 4 {
        return Err(format!(
            "a cube map cross must be 3 blocks wide and 4 tall; found {width} x {height}"
        ));
    }
    let needed = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(12))
        .ok_or("PFM size overflows")?;
    let data = bytes
        .get(pos..pos + needed)
        .ok_or("PFM data is shorter than its header says")?;
    let texels = data
        .chunks_exact(12)
        .map(|c| {
            let f = |i: usize| {
                let b = [c[i], c[i + 1], c[i + 2], c[i + 3]];
                (if endian < 0.0 {
                    f32::from_le_bytes(b)
                } else {
                    f32::from_be_bytes(b)
                }) as f64
            };
            DVec3::new(f(0), f(4), f(8))
        })
        .collect();
    Ok(CubeMap {
        block: width / 3,
        width,
        texels,
        scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1x1 PNG of the colour `rgb`.
    fn png(rgb: [u8; 3]) -> Vec<u8> {
        let mut bytes = Vec::new();
        image::RgbImage::from_pixel(1, 1, image::Rgb(rgb))
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .unwrap();
        bytes
    }

    #[test]
    fn srgb_texels_are_decoded_and_raw_ones_kept() {
        let bytes = png([92, 135, 39]);
        let raw = Texture::decode(&bytes, Wrap::Clamp, TexelEncoding::Raw).unwrap();
        assert_eq!(raw.texels[0], DVec3::new(92.0, 135.0, 39.0) / 255.0);
        let srgb = Texture::decode(&bytes, Wrap::Clamp, TexelEncoding::Srgb).unwrap();
        // sRGB 92, 135, 39 are linear 0.107, 0.242, 0.020.
        let want = DVec3::new(0.107023, 0.242281, 0.020289);
        assert!(
            (srgb.texels[0] - want).abs().max_element() < 1e-5,
            "{}",
            srgb.texels[0]
        );
        // The ends stay where they are.
        assert_eq!(TexelEncoding::Srgb.decode(0), 0.0);
        assert!((TexelEncoding::Srgb.decode(255) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn gltf_transforms_match_the_extension_in_gltf_coordinates() {
        // A glTF transform applied to (u, 1 - v) equals the extension's
        // matrix applied to glTF's (u, v), then flipped back.
        let (offset, rotation, scale) = ([-0.2, -0.1], 0.3, [1.5, 0.7]);
        let t = UvTransform::gltf(offset, rotation, scale);
        let (s, c) = f64::sin_cos(rotation);
        for (u, v) in [(0.0, 0.0), (0.25, 0.8), (1.3, -0.4)] {
            let (gu, gv) = (u, 1.0 - v);
            let want_u = c * scale[0] * gu + s * scale[1] * gv + offset[0];
            let want_v = -s * scale[0] * gu + c * scale[1] * gv + offset[1];
            let (au, av) = t.apply(u, v);
            assert!((au - want_u).abs() < 1e-12 && (1.0 - av - want_v).abs() < 1e-12);
        }
        // The identity is the identity.
        assert_eq!(
            UvTransform::gltf([0.0; 2], 0.0, [1.0; 2]).apply(0.3, 0.6),
            (0.3, 0.6)
        );
    }

    #[test]
    fn a_transformed_texture_looks_up_the_mapped_texel() {
        let mut t = Texture::decode(&png([0, 0, 0]), Wrap::Repeat, TexelEncoding::Raw).unwrap();
        // Two texels side by side: black at u < 0.5, white beyond.
        t.width = 2;
        t.texels = vec![DVec3::ZERO, DVec3::ONE];
        assert_eq!(t.lookup(0.1, 0.5), DVec3::ZERO);
        // An offset of half the width in u swaps them.
        let shifted = t.transformed(UvTransform::gltf([0.5, 0.0], 0.0, [1.0; 2]));
        assert_eq!(shifted.lookup(0.1, 0.5), DVec3::ONE);
    }

    #[test]
    fn tinting_multiplies_every_texel() {
        let t = Texture::decode(&png([255, 255, 255]), Wrap::Clamp, TexelEncoding::Raw).unwrap();
        let tinted = t.tinted(DVec3::new(0.0, 0.16, 0.8));
        assert_eq!(tinted.texels[0], DVec3::new(0.0, 0.16, 0.8));
    }
}
