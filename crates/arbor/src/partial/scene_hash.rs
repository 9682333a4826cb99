//! The scene hash: what identifies the scene and settings a part was
//! rendered from.

use std::fmt::{self, Write as _};
use std::sync::Arc;

use super::sha256::Sha256;
use crate::hash_map::HashMap;
use crate::scene::Scene;
use crate::surface::Surface;

pub(super) fn hex(bytes: &[u8]) -> String {
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
