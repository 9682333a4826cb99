//! The film: linear radiance per pixel, and its conversion to the bytes and
//! files people look at. Files are written to a temporary name beside the
//! target and renamed, so a failure never leaves a partial picture.

use std::fs;
use std::io::{self, Seek, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use rayon::prelude::*;

pub use crate::byte_table::to_byte;
use crate::byte_table::ByteTable;
use crate::variant::Variant;

/// A width x height grid of linear RGB radiance, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    /// As arrays rather than `DVec3`s: a zero array is all zero bytes, so
    /// a new film is allocated zeroed (its pages are touched where tiles
    /// land, in parallel) instead of written pixel by pixel up front.
    pixels: Vec<[f64; 3]>,
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The radiance at `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> DVec3 {
        DVec3::from_array(self.pixels[(y * self.width + x) as usize])
    }

    /// Sets the radiance at `(x, y)`.
    pub fn set(&mut self, x: u32, y: u32, value: DVec3) {
        self.pixels[(y * self.width + x) as usize] = value.to_array();
    }

    /// Sets the radiance of `values.len()` pixels of row `y` from column `x` on.
    pub fn set_row(&mut self, x: u32, y: u32, values: &[DVec3]) {
        let start = (y * self.width + x) as usize;
        for (p, v) in self.pixels[start..start + values.len()]
            .iter_mut()
            .zip(values)
        {
            *p = v.to_array();
        }
    }

    /// 8-bit RGB bytes, row 0 at the top, by the variant's conversion.
    pub fn to_rgb8(&self, variant: Variant) -> Vec<u8> {
        // In parallel, and by table: three `powf` per pixel were a visible
        // part of a quick render's whole time.
        let table = ByteTable::of(variant);
        let mut bytes = vec![0u8; self.pixels.len() * 3];
        bytes
            .par_chunks_mut(3 * 4096)
            .zip(self.pixels.par_chunks(4096))
            .for_each(|(out, pixels)| {
                for (o, p) in out.chunks_exact_mut(3).zip(pixels) {
                    o.copy_from_slice(&p.map(|c| table.byte(c)));
                }
            });
        bytes
    }

    /// Writes the film to `path`: 8-bit PNG for `.png`, linear float OpenEXR
    /// for `.exr` (any case).
    pub fn write(&self, path: &Path, variant: Variant) -> Result<(), WriteError> {
        let format = ImageFormat::from_path(path)?;
        atomic_write(path, |file| self.encode(format, variant, file))
    }

    /// Encodes the film as a `format` file into `out` (the bytes
    /// [`Film::write`] puts in a file; for callers with their own writer).
    pub fn encode(
        &self,
        format: ImageFormat,
        variant: Variant,
        out: &mut (impl Write + Seek),
    ) -> io::Result<()> {
        match format {
            ImageFormat::Png => encode_png(out, self.width, self.height, &self.to_rgb8(variant)),
            ImageFormat::Exr => self.encode_exr(out),
        }
    }

    fn encode_exr(&self, out: &mut (impl Write + Seek)) -> io::Result<()> {
        use exr::prelude::*;
        let (w, h) = (self.width as usize, self.height as usize);
        let pixels = &self.pixels;
        let image = Image::from_channels(
            (w, h),
            SpecificChannels::rgb(|p: Vec2<usize>| {
                let [r, g, b] = pixels[p.y() * w + p.x()];
                (r as f32, g as f32, b as f32)
            }),
        );
        image
            .write()
            .to_buffered(out)
            .map_err(|e| io::Error::other(e.to_string()))
    }
}

/// Output image formats, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit RGB PNG.
    Png,
    /// Linear float OpenEXR.
    Exr,
}

impl ImageFormat {
    /// The format for `path`'s extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<ImageFormat, WriteError> {
        match lowercase_extension(path).as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(WriteError::UnknownFormat(path.to_path_buf())),
        }
    }
}

/// `path`'s extension in lower case, for choosing a file format whatever
/// the case of its name.
pub fn lowercase_extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The extension names no format we write.
    #[error("{}: unknown image format; expected a .png or .exr file name", .0.display())]
    UnknownFormat(PathBuf),
    /// The file system refused.
    #[error("{}: cannot write: {source}", path.display())]
    Io {
        /// The target file.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
}

/// Writes 8-bit RGB `bytes` as a PNG (colour type 2, no alpha, no gamma chunk).
pub fn write_png(path: &Path, width: u32, height: u32, bytes: &[u8]) -> Result<(), WriteError> {
    atomic_write(path, |file| encode_png(file, width, height, bytes))
}

/// Encodes 8-bit RGB `bytes` as the PNG [`write_png`] writes, into `out`.
pub fn encode_png(out: &mut impl Write, width: u32, height: u32, bytes: &[u8]) -> io::Result<()> {
    let encoder = image::codecs::png::PngEncoder::new(out);
    image::ImageEncoder::write_image(
        encoder,
        bytes,
        width,
        height,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| io::Error::other(e.to_string()))
}

/// Writes through `fill` into a temporary file beside `path`, then renames it
/// over `path`; on any failure the temporary file is removed.
pub fn atomic_write(
    path: &Path,
    fill: impl FnOnce(&mut io::BufWriter<fs::File>) -> io::Result<()>,
) -> Result<(), WriteError> {
    let err = |source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let file = fs::File::create(&tmp)?;
        let mut writer = io::BufWriter::new(file);
        fill(&mut writer)?;
        writer.flush()?;
        writer.get_ref().sync_all()?;
        drop(writer);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_conversion() {
        assert_eq!(to_byte(0.0, Variant::Cornell2010), 0);
        assert_eq!(to_byte(1.0, Variant::Cornell2010), 255);
        assert_eq!(to_byte(7.0, Variant::Cornell2015), 255);
        assert_eq!(to_byte(-1.0, Variant::Cornell2015), 0);
        assert_eq!(to_byte(f64::NAN, Variant::Cornell2015), 0);
        // 0.5^(1/2.2) = 0.7297 -> 186.07
        assert_eq!(to_byte(0.5, Variant::Cornell2010), 186);
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        let r = atomic_write(&path, |_| Err(io::Error::other("boom")));
        assert!(r.is_err());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn png_and_exr_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut film = Film::new(3, 2);
        film.set(2, 1, DVec3::new(1.0, 0.5, 0.0));
        let png = dir.path().join("a.PNG");
        film.write(&png, Variant::Cornell2010).unwrap();
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.get_pixel(2, 1).0, [255, 186, 0]);
        let exr = dir.path().join("a.exr");
        film.write(&exr, Variant::Cornell2010).unwrap();
        assert!(fs::metadata(&exr).unwrap().len() > 0);
        assert!(film
            .write(&dir.path().join("a.jpg"), Variant::Cornell2010)
            .is_err());
    }
}
