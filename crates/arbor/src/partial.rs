//! Partial images: one rectangle of a render, saved with what it takes to
//! put the whole picture back together and to refuse a piece of another
//! picture. A render farm renders the tiles of [`tile_region`] as separate
//! processes, each writing a [`Partial`]; [`Assembly`] checks that a set of
//! parts covers the image exactly once and builds the [`Film`].
//!
//! Pixels are independent (see [`crate::render`]), and a part keeps the
//! exact `f64` radiance, so an assembled film equals the film of a full
//! render bit for bit, and so do its PNG and EXR files.
//!
//! # The `.part` file format (version 1)
//!
//! All integers little-endian.
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `ARBORPRT` |
//! | 8 | 4 | format version, `1` |
//! | 12 | 8 | full image width, height (`u32` each) |
//! | 20 | 16 | region `x0, y0, x1, y1` (`u32` each; `x0..x1` by `y0..y1`, row 0 at the top) |
//! | 36 | 8 | tile index `K` and tile count `N` (`u32` each); `0xFFFFFFFF, 0` for a region that is no tile |
//! | 44 | 1 | conventions: 0 = Cornell 2010, 1 = Cornell 2015 (they convert to 8 bits differently) |
//! | 45 | 3 | zero |
//! | 48 | 32 | scene hash ([`scene_hash`], SHA-256) |
//! | 80 | 24 per pixel | linear radiance `R, G, B` as `f64`, row by row |
//! | end − 32 | 32 | SHA-256 of every byte before it (detects a damaged file) |

use crate::hash_map::HashMap;
use std::fmt::{self, Write as _};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use crate::film::{atomic_write, Film, WriteError};
use crate::render::Region;
use crate::scene::{Scene, Variant};
use crate::surface::Surface;

/// The first eight bytes of every part file.
pub const MAGIC: [u8; 8] = *b"ARBORPRT";
/// The version of the part format this build reads and writes.
pub const VERSION: u32 = 1;
/// Bytes before the pixels.
pub const HEADER_LEN: usize = 80;
/// Tile index stored for a part that is an arbitrary region.
const NO_TILE: u32 = u32::MAX;

/// The region of tile `k` of `n`: the image cut into `n` horizontal bands
/// of whole rows, band `k` being rows `floor(k·h/n) .. floor((k+1)·h/n)`
/// (so band heights differ by at most one row). `None` unless
/// `k < n <= height` (every band must hold at least one row).
pub fn tile_region(width: u32, height: u32, k: u32, n: u32) -> Option<Region> {
    if n == 0 || k >= n || n > height || width == 0 {
        return None;
    }
    let row = |i: u32| (i as u64 * height as u64 / n as u64) as u32;
    Some(Region {
        x0: 0,
        y0: row(k),
        x1: width,
        y1: row(k + 1),
    })
}

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
    /// [`scene_hash`] of the scene and settings it was rendered from.
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
        sha.update(&header);
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
        out.write_all(&sha.finish())
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
        if sha.finish() != sum {
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

/// Checks a set of part headers and tells where each goes: they must come
/// from one scene and settings, and cover the image exactly once.
#[derive(Clone, Debug)]
pub struct Assembly {
    /// Width of the full image.
    pub width: u32,
    /// Height of the full image.
    pub height: u32,
    /// The conventions of the scene.
    pub variant: Variant,
}

impl Assembly {
    /// Checks `parts` (named by their paths): the same scene hash, image
    /// size and conventions (a part differing from the majority is foreign),
    /// no two parts with the same region (duplicate) or overlapping regions,
    /// and every pixel covered. The first problem is the error, naming the
    /// part(s) concerned.
    pub fn check(parts: &[(PathBuf, PartHeader)]) -> Result<Assembly, PartError> {
        let Some(first) = parts.first() else {
            return Err(PartError {
                path: PathBuf::new(),
                message: "no parts to merge".into(),
            });
        };
        // The majority defines what the picture is; on a tie, the first part.
        let key = |h: &PartHeader| (h.scene_hash, h.width, h.height, h.variant as u8);
        let mut counts: HashMap<_, usize> = HashMap::default();
        for (_, h) in parts {
            *counts.entry(key(h)).or_default() += 1;
        }
        let mut reference = &first.1;
        for (_, h) in parts {
            if counts[&key(h)] > counts[&key(reference)] {
                reference = h;
            }
        }
        for (path, h) in parts {
            let why = if (h.width, h.height) != (reference.width, reference.height) {
                Some(format!(
                    "foreign part: image size {}x{}, the others {}x{}",
                    h.width, h.height, reference.width, reference.height
                ))
            } else if h.scene_hash != reference.scene_hash {
                Some(format!(
                    "foreign part: rendered from another scene or settings (scene hash {}, the others {})",
                    hex(&h.scene_hash[..8]),
                    hex(&reference.scene_hash[..8])
                ))
            } else if h.variant != reference.variant {
                Some("foreign part: other scene conventions".into())
            } else {
                None
            };
            if let Some(message) = why {
                return Err(PartError {
                    path: path.clone(),
                    message,
                });
            }
        }
        // Pairwise: parts are few (one per task), so quadratic is fine.
        for (i, (pa, a)) in parts.iter().enumerate() {
            for (pb, b) in &parts[i + 1..] {
                let r = (a.region, b.region);
                let overlap =
                    r.0.x0 < r.1.x1 && r.1.x0 < r.0.x1 && r.0.y0 < r.1.y1 && r.1.y0 < r.0.y1;
                if !overlap {
                    continue;
                }
                let what = if a.region == b.region {
                    "duplicate part"
                } else {
                    "overlapping part"
                };
                return Err(PartError {
                    path: pb.clone(),
                    message: format!(
                        "{what}: its {} overlaps {} of {}",
                        b.describe(),
                        a.describe(),
                        pa.display()
                    ),
                });
            }
        }
        let total: u64 = parts.iter().map(|(_, h)| h.region.area()).sum();
        let full = reference.width as u64 * reference.height as u64;
        if total != full {
            // Disjoint and inside the image, so less area means a gap.
            return Err(PartError {
                path: PathBuf::new(),
                message: missing_message(parts, reference, full - total),
            });
        }
        Ok(Assembly {
            width: reference.width,
            height: reference.height,
            variant: reference.variant,
        })
    }

    /// Copies `part` into its place in `film` (a film of the full size).
    pub fn place(film: &mut Film, part: &Partial) {
        let r = part.header.region;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                film.set(x, y, part.film.get(x - r.x0, y - r.y0));
            }
        }
    }
}

/// Says which pixels no part covers: the missing tile numbers when the
/// parts are tiles of one cut, else the rows that are not fully covered.
fn missing_message(parts: &[(PathBuf, PartHeader)], reference: &PartHeader, pixels: u64) -> String {
    let counts: Vec<u32> = parts
        .iter()
        .filter_map(|(_, h)| h.tile.map(|t| t.1))
        .collect();
    if counts.len() == parts.len() && counts.iter().all(|&n| n == counts[0]) {
        let n = counts[0];
        let have: crate::hash_map::HashSet<u32> = parts
            .iter()
            .filter_map(|(_, h)| h.tile.map(|t| t.0))
            .collect();
        let missing: Vec<String> = (0..n)
            .filter(|k| !have.contains(k))
            .map(|k| k.to_string())
            .collect();
        return format!(
            "incomplete: missing tile{} {} of {n} ({pixels} pixels)",
            if missing.len() == 1 { "" } else { "s" },
            missing.join(", ")
        );
    }
    // Row by row: how many pixels of each row the parts cover.
    let mut covered = vec![0u64; reference.height as usize];
    for (_, h) in parts {
        for row in &mut covered[h.region.y0 as usize..h.region.y1 as usize] {
            *row += (h.region.x1 - h.region.x0) as u64;
        }
    }
    let mut ranges = Vec::new();
    let mut y = 0;
    while y < covered.len() {
        if covered[y] < reference.width as u64 {
            let start = y;
            while y < covered.len() && covered[y] < reference.width as u64 {
                y += 1;
            }
            ranges.push(format!("{start}..{y}"));
        } else {
            y += 1;
        }
    }
    format!(
        "incomplete: {pixels} pixels covered by no part, in rows {}",
        ranges.join(", ")
    )
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// The scene hash as 64 hexadecimal digits.
pub fn hash_hex(hash: &[u8; 32]) -> String {
    hex(hash)
}

/// SHA-256 of everything that decides a render's pixels: the version of
/// this crate, and the loaded [`Scene`] (camera, image size, samples,
/// lights, background, exposure, cube map, and every surface with its
/// transforms, shaders, textures and mesh data), written out through its
/// `Debug` form, which prints every float exactly (shortest round-trip
/// form). A shared (instanced) surface is written once and then named by
/// its number, so hashing costs the size of the scene, not of its expansion.
///
/// Not hashed, because they do not change a single pixel: the acceleration
/// structure, the thread count and the instance limit. Because the loaded
/// data is hashed rather than the files, two scene files that load to the
/// same scene have the same hash, and an edited mesh or texture changes it.
pub fn scene_hash(scene: &Scene) -> [u8; 32] {
    let mut w = HashWriter(Sha256::new());
    let _ = writeln!(w, "arbor scene hash 1, arbor {}", env!("CARGO_PKG_VERSION"));
    let rest = Scene {
        surfaces: Vec::new(),
        ..scene.clone()
    };
    let _ = writeln!(w, "{rest:?}");
    let mut shared = HashMap::default();
    for s in &scene.surfaces {
        hash_surface(s, &mut w, &mut shared);
    }
    w.0.finish()
}

fn hash_surface(s: &Surface, w: &mut HashWriter, shared: &mut HashMap<*const Surface, usize>) {
    match s {
        Surface::Group(g) => {
            let _ = writeln!(w, "group {:?} {}", g.transform, g.children.len());
            for child in &g.children {
                hash_surface(child, w, shared);
            }
        }
        Surface::Instance(inner) => {
            let key = Arc::as_ptr(inner);
            if let Some(id) = shared.get(&key) {
                let _ = writeln!(w, "instance of {id}");
            } else {
                let id = shared.len();
                shared.insert(key, id);
                let _ = writeln!(w, "instance {id}");
                hash_surface(inner, w, shared);
            }
        }
        leaf => {
            let _ = writeln!(w, "{leaf:?}");
        }
    }
}

/// Streams formatted text into the hash, so a large scene is never held as
/// one string.
struct HashWriter(Sha256);

impl fmt::Write for HashWriter {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0.update(s.as_bytes());
        Ok(())
    }
}

/// SHA-256 (FIPS 180-4), small and dependency-free: part files are checked
/// with it and scenes identified by it.
#[derive(Clone)]
pub struct Sha256 {
    state: [u32; 8],
    block: [u8; 64],
    filled: usize,
    length: u64,
}

const K256: [u32; 64] = [
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2,
];

impl Default for Sha256 {
    fn default() -> Self {
        Sha256::new()
    }
}

impl Sha256 {
    /// A fresh hash.
    pub fn new() -> Sha256 {
        Sha256 {
            state: [
                0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab,
                0x5be0cd19,
            ],
            block: [0; 64],
            filled: 0,
            length: 0,
        }
    }

    /// Feeds `data`.
    pub fn update(&mut self, mut data: &[u8]) {
        self.length = self.length.wrapping_add(data.len() as u64);
        while !data.is_empty() {
            let n = (64 - self.filled).min(data.len());
            self.block[self.filled..self.filled + n].copy_from_slice(&data[..n]);
            self.filled += n;
            data = &data[n..];
            if self.filled == 64 {
                let block = self.block;
                self.compress(&block);
                self.filled = 0;
            }
        }
    }

    /// The digest.
    pub fn finish(mut self) -> [u8; 32] {
        let bits = self.length.wrapping_mul(8);
        self.update(&[0x80]);
        while self.filled != 56 {
            self.update(&[0]);
        }
        self.update(&bits.to_be_bytes());
        let mut out = [0u8; 32];
        for (i, s) in self.state.iter().enumerate() {
            out[4 * i..4 * i + 4].copy_from_slice(&s.to_be_bytes());
        }
        out
    }

    fn compress(&mut self, block: &[u8; 64]) {
        let mut w = [0u32; 64];
        for i in 0..16 {
            w[i] = u32::from_be_bytes(block[4 * i..4 * i + 4].try_into().unwrap());
        }
        for i in 16..64 {
            let s0 = w[i - 15].rotate_right(7) ^ w[i - 15].rotate_right(18) ^ (w[i - 15] >> 3);
            let s1 = w[i - 2].rotate_right(17) ^ w[i - 2].rotate_right(19) ^ (w[i - 2] >> 10);
            w[i] = w[i - 16]
                .wrapping_add(s0)
                .wrapping_add(w[i - 7])
                .wrapping_add(s1);
        }
        let [mut a, mut b, mut c, mut d, mut e, mut f, mut g, mut h] = self.state;
        for i in 0..64 {
            let s1 = e.rotate_right(6) ^ e.rotate_right(11) ^ e.rotate_right(25);
            let ch = (e & f) ^ (!e & g);
            let t1 = h
                .wrapping_add(s1)
                .wrapping_add(ch)
                .wrapping_add(K256[i])
                .wrapping_add(w[i]);
            let s0 = a.rotate_right(2) ^ a.rotate_right(13) ^ a.rotate_right(22);
            let maj = (a & b) ^ (a & c) ^ (b & c);
            let t2 = s0.wrapping_add(maj);
            h = g;
            g = f;
            f = e;
            e = d.wrapping_add(t1);
            d = c;
            c = b;
            b = a;
            a = t1.wrapping_add(t2);
        }
        for (s, v) in self.state.iter_mut().zip([a, b, c, d, e, f, g, h]) {
            *s = s.wrapping_add(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sha(data: &[u8]) -> String {
        let mut s = Sha256::new();
        s.update(data);
        hash_hex(&s.finish())
    }

    #[test]
    fn sha256_known_answers() {
        assert_eq!(
            sha(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            sha(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            sha(b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        // Fed in pieces crossing block boundaries: the same digest.
        let data = vec![7u8; 1000];
        let mut s = Sha256::new();
        for chunk in data.chunks(37) {
            s.update(chunk);
        }
        assert_eq!(hash_hex(&s.finish()), sha(&data));
    }

    #[test]
    fn bands_cover_every_row_once() {
        for h in 1..40 {
            for n in 1..=h {
                let mut next = 0;
                for k in 0..n {
                    let r = tile_region(7, h, k, n).unwrap();
                    assert_eq!(r.y0, next);
                    assert!(r.y1 > r.y0);
                    assert!(r.y1 - r.y0 <= h / n + 1);
                    next = r.y1;
                }
                assert_eq!(next, h);
            }
        }
        assert_eq!(tile_region(7, 5, 0, 6), None);
        assert_eq!(tile_region(7, 5, 3, 3), None);
        assert_eq!(tile_region(7, 5, 0, 0), None);
    }

    fn part(region: Region, tile: Option<(u32, u32)>) -> Partial {
        let mut film = Film::new(region.x1 - region.x0, region.y1 - region.y0);
        film.set(0, 0, DVec3::new(0.1, -0.0, f64::MAX));
        Partial {
            header: PartHeader {
                width: 10,
                height: 6,
                region,
                tile,
                variant: Variant::Cornell2015,
                scene_hash: [3; 32],
            },
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

    #[test]
    fn assembly_errors() {
        let tiles: Vec<(PathBuf, PartHeader)> = (0..3)
            .map(|k| {
                let h = part(tile_region(10, 6, k, 3).unwrap(), Some((k, 3))).header;
                (PathBuf::from(format!("t{k}")), h)
            })
            .collect();
        assert!(Assembly::check(&tiles).is_ok());
        let e = Assembly::check(&tiles[..2]).unwrap_err();
        assert!(e.message.contains("missing tile 2 of 3"), "{e}");
        let mut dup = tiles.clone();
        dup.push((PathBuf::from("again"), tiles[1].1.clone()));
        let e = Assembly::check(&dup).unwrap_err();
        assert_eq!(e.path, PathBuf::from("again"));
        assert!(e.message.contains("duplicate"), "{e}");
        let mut foreign = tiles.clone();
        foreign[2].1.scene_hash = [4; 32];
        let e = Assembly::check(&foreign).unwrap_err();
        assert_eq!(e.path, PathBuf::from("t2"));
        assert!(e.message.contains("foreign"), "{e}");
        let mut over = tiles[..2].to_vec();
        let mut h = tiles[2].1.clone();
        h.region.y0 -= 1;
        h.tile = None;
        over.push((PathBuf::from("big"), h));
        let e = Assembly::check(&over).unwrap_err();
        assert!(e.message.contains("overlapping"), "{e}");
        let mut gap = tiles[..2].to_vec();
        let mut h = tiles[2].1.clone();
        h.region.x1 = 9;
        h.tile = None;
        gap.push((PathBuf::from("narrow"), h));
        let e = Assembly::check(&gap).unwrap_err();
        assert!(e.message.contains("rows 4..6"), "{e}");
    }
}
