//! The `.part` file: one rectangle of a render with its header, written
//! and read back exactly.

use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use sha2::{Digest, Sha256};

use super::tile::tile_region;
use crate::film::{atomic_write, Film, WriteError};
use crate::render::Region;
use crate::variant::Variant;

/// The first eight bytes of every part file.
pub const MAGIC: [u8; 8] = *b"ARBORPRT";
/// The version of the part format this build reads and writes.
pub const VERSION: u32 = 1;
/// Bytes before the pixels.
pub const HEADER_LEN: usize = 80;
/// Tile index stored for a part that is an arbitrary region.
const NO_TILE: u32 = u32::MAX;

/// What a part says about itself: where it belongs and what it belongs to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartHeader {
    /// Width of the full image.
    pub width: u32,
    /// Height of the full image.
    pub height: u32,
    /// The pixels this part holds.
    pub region: Region,
    /// `(K, N)` when the part is tile `K` of `N` ([`tile_region`]).
    pub tile: Option<(u32, u32)>,
    /// The scene's conventions (needed to convert to 8 bits).
    pub variant: Variant,
    /// [`scene_hash`](super::scene_hash()) of the scene and settings it was rendered from.
    pub scene_hash: [u8; 32],
}

impl PartHeader {
    /// Bytes of a whole part file with this header.
    pub fn file_len(&self) -> u64 {
        HEADER_LEN as u64 + self.region.area() * 24 + 32
    }

    fn encode(&self) -> [u8; HEADER_LEN] {
        let mut h = [0u8; HEADER_LEN];
        h[0..8].copy_from_slice(&MAGIC);
        let (k, n) = self.tile.unwrap_or((NO_TILE, 0));
        let words = [
            VERSION,
            self.width,
            self.height,
            self.region.x0,
            self.region.y0,
            self.region.x1,
            self.region.y1,
            k,
            n,
        ];
        for (i, w) in words.iter().enumerate() {
            h[8 + 4 * i..12 + 4 * i].copy_from_slice(&w.to_le_bytes());
        }
        h[44] = match self.variant {
            Variant::Cornell2010 => 0,
            Variant::Cornell2015 => 1,
        };
        h[48..80].copy_from_slice(&self.scene_hash);
        h
    }

    /// Parses and checks a header (not the pixels): magic, version, a
    /// non-empty region inside the image, a tile index consistent with it.
    pub fn decode(bytes: &[u8]) -> Result<PartHeader, String> {
        if bytes.len() < 8 || bytes[0..8] != MAGIC {
            return Err("not an arbor part file (bad magic number)".into());
        }
        if bytes.len() < HEADER_LEN {
            return Err("truncated part file (incomplete header)".into());
        }
        let word = |i: usize| u32::from_le_bytes(bytes[8 + 4 * i..12 + 4 * i].try_into().unwrap());
        let version = word(0);
        if version != VERSION {
            return Err(format!(
                "part format version {version}; this arbor reads version {VERSION}"
            ));
        }
        let (width, height) = (word(1), word(2));
        let region = Region {
            x0: word(3),
            y0: word(4),
            x1: word(5),
            y1: word(6),
        };
        if !(region.x0 < region.x1
            && region.y0 < region.y1
            && region.x1 <= width
            && region.y1 <= height)
        {
            return Err(format!(
                "region {},{},{},{} is empty or outside the {width}x{height} image",
                region.x0, region.y0, region.x1, region.y1
            ));
        }
        let (k, n) = (word(7), word(8));
        let tile = if k == NO_TILE && n == 0 {
            None
        } else if tile_region(width, height, k, n) == Some(region) {
            Some((k, n))
        } else {
            return Err(format!("says it is tile {k}/{n} but holds another region"));
        };
        let variant = match bytes[44] {
            0 => Variant::Cornell2010,
            1 => Variant::Cornell2015,
            v => return Err(format!("unknown conventions code {v}")),
        };
        if bytes[45..48] != [0; 3] {
            return Err("damaged part header (bytes 45..48 are not zero)".into());
        }
        let mut scene_hash = [0u8; 32];
        scene_hash.copy_from_slice(&bytes[48..80]);
        Ok(PartHeader {
            width,
            height,
            region,
            tile,
            variant,
            scene_hash,
        })
    }

    /// `tile K/N` or `region x0,y0,x1,y1`, for messages.
    pub fn describe(&self) -> String {
        match self.tile {
            Some((k, n)) => format!("tile {k}/{n}"),
            None => {
                let r = self.region;
                format!("region {},{},{},{}", r.x0, r.y0, r.x1, r.y1)
            }
        }
    }
}

/// A part: its header and the radiance of its region.
#[derive(Clone, Debug, PartialEq)]
pub struct Partial {
    /// Where it belongs.
    pub header: PartHeader,
    /// The region's pixels (`film.width()` = region width).
    pub film: Film,
}

impl Partial {
    /// Writes the part to `path` (through a temporary file and a rename, so
    /// a part on disk is always whole: a farm treats its presence as done).
    pub fn write(&self, path: &Path) -> Result<(), WriteError> {
        atomic_write(path, |file| self.encode(file))
    }

    /// Encodes the part file [`Partial::write`] writes into `out` (for
    /// callers with their own writer); fails when the film is not the size
    /// of the header's region.
    pub fn encode(&self, out: &mut impl Write) -> io::Result<()> {
        let r = self.header.region;
        if self.film.width() != r.x1 - r.x0 || self.film.height() != r.y1 - r.y0 {
            return Err(io::Error::other("film size differs from the part's region"));
        }
        let mut sha = Sha256::new();
        let header = self.header.encode();
        sha.update(header);
        out.write_all(&header)?;
        let mut row = Vec::with_capacity(self.film.width() as usize * 24);
        for y in 0..self.film.height() {
            row.clear();
            for x in 0..self.film.width() {
                let p = self.film.get(x, y);
                for c in [p.x, p.y, p.z] {
                    row.extend_from_slice(&c.to_le_bytes());
                }
            }
            sha.update(&row);
            out.write_all(&row)?;
        }
        out.write_all(&sha.finalize())
    }

    /// Reads and checks a whole part file (header, length, checksum).
    pub fn read(path: &Path) -> Result<Partial, PartError> {
        let err = |message: String| PartError {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| {
            err(if e.kind() == io::ErrorKind::NotFound {
                "missing part (no such file)".into()
            } else {
                format!("cannot read: {e}")
            })
        })?;
        Partial::parse(&bytes).map_err(err)
    }

    /// Parses part file bytes.
    pub fn parse(bytes: &[u8]) -> Result<Partial, String> {
        let header = PartHeader::decode(bytes)?;
        if bytes.len() as u64 != header.file_len() {
            return Err(format!(
                "damaged part file: {} bytes, expected {} for {}",
                bytes.len(),
                header.file_len(),
                header.describe()
            ));
        }
        let (body, sum) = bytes.split_at(bytes.len() - 32);
        let mut sha = Sha256::new();
        sha.update(body);
        if sha.finalize().as_slice() != sum {
            return Err("damaged part file (checksum mismatch)".into());
        }
        let r = header.region;
        let mut film = Film::new(r.x1 - r.x0, r.y1 - r.y0);
        let mut values = body[HEADER_LEN..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()));
        for y in 0..film.height() {
            for x in 0..film.width() {
                let mut next = || values.next().unwrap_or(0.0);
                let p = DVec3::new(next(), next(), next());
                film.set(x, y, p);
            }
        }
        Ok(Partial { header, film })
    }
}

/// Reads only the header of a part file and checks the file's length (not
/// its checksum): enough to tell a finished part from a stale one cheaply.
pub fn read_header(path: &Path) -> Result<PartHeader, PartError> {
    use std::io::Read;
    let err = |message: String| PartError {
        path: path.to_path_buf(),
        message,
    };
    let mut file = std::fs::File::open(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let mut bytes = Vec::with_capacity(HEADER_LEN);
    std::io::Read::by_ref(&mut file)
        .take(HEADER_LEN as u64)
        .read_to_end(&mut bytes)
        .map_err(|e| err(format!("cannot read: {e}")))?;
    let header = PartHeader::decode(&bytes).map_err(err)?;
    let len = file
        .metadata()
        .map_err(|e| err(format!("cannot read: {e}")))?
        .len();
    if len != header.file_len() {
        return Err(err(format!(
            "damaged part file: {len} bytes, expected {}",
            header.file_len()
        )));
    }
    Ok(header)
}

/// A part file that cannot be used, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartError {
    /// The part file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub message: String,
}

impl fmt::Display for PartError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.message)
    }
}

impl std::error::Error for PartError {}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The header of a part of a 10x6 image.
    pub(in crate::partial) fn header(region: Region, tile: Option<(u32, u32)>) -> PartHeader {
        PartHeader {
            width: 10,
            height: 6,
            region,
            tile,
            variant: Variant::Cornell2015,
            scene_hash: [3; 32],
        }
    }

    fn part(region: Region, tile: Option<(u32, u32)>) -> Partial {
        let mut film = Film::new(region.x1 - region.x0, region.y1 - region.y0);
        film.set(0, 0, DVec3::new(0.1, -0.0, f64::MAX));
        Partial {
            header: header(region, tile),
            film,
        }
    }

    #[test]
    fn round_trip_and_damage() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.part");
        let p = part(tile_region(10, 6, 1, 3).unwrap(), Some((1, 3)));
        p.write(&path).unwrap();
        let q = Partial::read(&path).unwrap();
        assert_eq!(q, p);
        assert_eq!(q.film.get(0, 0).y.to_bits(), (-0.0f64).to_bits());
        assert_eq!(read_header(&path).unwrap(), p.header);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[HEADER_LEN + 3] ^= 1;
        assert!(Partial::parse(&bytes).unwrap_err().contains("checksum"));
        bytes.pop();
        assert!(Partial::parse(&bytes).unwrap_err().contains("damaged"));
        assert!(Partial::parse(b"PNG").unwrap_err().contains("magic"));
        let missing = Partial::read(&dir.path().join("none.part")).unwrap_err();
        assert!(missing.message.contains("missing"));
    }

    /// docs/cluster.md is where the layout is documented: its table must
    /// say what `encode` writes.
    #[test]
    fn the_documented_layout_is_the_written_one() {
        let doc = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../docs/cluster.md"
        ))
        .unwrap();
        let rows = [
            "| 0 | 8 | magic `ARBORPRT` |",
            "| 8 | 4 | format version (`u32`, 1) |",
            "| 12 | 8 | full image width, height (`u32` each) |",
            "| 20 | 16 | region `x0, y0, x1, y1` (`u32` each) |",
            "| 36 | 8 | tile `K`, `N` (`u32` each; `0xFFFFFFFF, 0` for a free region) |",
            "| 44 | 1 | conventions (0 = Cornell 2010, 1 = 2015) |",
            "| 45 | 3 | zero |",
            "| 48 | 32 | scene hash |",
            "| 80 | 24 per pixel | linear `R, G, B` (`f64` each), row by row |",
            "| end − 32 | 32 | SHA-256 of all bytes before |",
        ];
        for row in rows {
            assert!(doc.contains(row), "docs/cluster.md lacks the row {row}");
        }
        let p = part(tile_region(10, 6, 1, 3).unwrap(), Some((1, 3)));
        let mut bytes = Vec::new();
        p.encode(&mut bytes).unwrap();
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(&bytes[0..8], b"ARBORPRT");
        assert_eq!(word(8), 1);
        assert_eq!((word(12), word(16)), (10, 6));
        assert_eq!((word(20), word(24), word(28), word(32)), (0, 2, 10, 4));
        assert_eq!((word(36), word(40)), (1, 3));
        assert_eq!(bytes[44..48], [1, 0, 0, 0]);
        assert_eq!(bytes[48..80], [3; 32]);
        assert_eq!(bytes[80..88], 0.1f64.to_le_bytes());
        assert_eq!(bytes.len(), 80 + 10 * 2 * 24 + 32);
        let sum = Sha256::digest(&bytes[..bytes.len() - 32]);
        assert_eq!(bytes[bytes.len() - 32..], sum[..]);
        // The zero bytes are checked, so they can carry meaning one day.
        bytes[46] = 1;
        assert!(PartHeader::decode(&bytes).unwrap_err().contains("45..48"));
    }
}
