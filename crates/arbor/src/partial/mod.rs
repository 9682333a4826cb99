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

mod assembly;
mod part_file;
mod scene_hash;
mod sha256;
mod tile;

pub use assembly::Assembly;
pub use part_file::{read_header, PartError, PartHeader, Partial, HEADER_LEN, MAGIC, VERSION};
pub use scene_hash::{hash_hex, scene_hash};
pub use sha256::Sha256;
pub use tile::tile_region;
