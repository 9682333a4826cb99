//! Assembly: checking that a set of parts makes one whole picture, and
//! putting each in its place.

use std::path::PathBuf;

use super::part_file::{PartError, PartHeader, Partial};
use super::scene_hash::hex;
use crate::film::Film;
use crate::hash_map::HashMap;
use crate::variant::Variant;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::partial::part_file::tests::header;
    use crate::partial::tile_region;

    #[test]
    fn assembly_errors() {
        let tiles: Vec<(PathBuf, PartHeader)> = (0..3)
            .map(|k| {
                let h = header(tile_region(10, 6, k, 3).unwrap(), Some((k, 3)));
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
