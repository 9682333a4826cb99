//! Partial images: one rectangle of a render, saved with what it takes to
//! put the whole picture back together and to refuse a piece of another
//! picture. A render farm renders the tiles of [`tile_region`] as separate
//! processes, each writing a [`Partial`]; [`Assembly`] checks that a set of
//! parts covers the image exactly once and builds the [`Film`](crate::film::Film).
//!
//! Pixels are independent (see [`crate::render`]), and a part keeps the
//! exact `f64` radiance, so an assembled film equals the film of a full
//! render bit for bit, and so do its PNG and EXR files.
//!
//! The layout of a `.part` file is documented in `docs/cluster.md` (the
//! one place; a test checks it against [`PartHeader`]'s encoding), the
//! encoding the scene hash hashes at [`scene_hash()`].
//!
//! | file | what |
//! | --- | --- |
//! | `tile.rs` | the cut of an image into bands |
//! | `part_file.rs` | the `.part` file: header, pixels, checksum |
//! | `assembly.rs` | checks that parts make one picture, and places them |
//! | `scene_hash.rs` | what identifies the scene a part was rendered from |

mod assembly;
mod part_file;
mod scene_hash;
mod tile;

pub use assembly::Assembly;
pub use part_file::{read_header, PartError, PartHeader, Partial, HEADER_LEN, MAGIC, VERSION};
pub use scene_hash::{hash_hex, scene_hash, ENCODING_VERSION};
pub use tile::tile_region;
