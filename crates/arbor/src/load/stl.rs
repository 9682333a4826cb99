//! STL import, ASCII and binary.
//!
//! The two are told apart by content, not by the word `solid` alone: many
//! exporters write binary files whose 80-byte header starts with "solid",
//! so a file whose size is exactly `84 + 50 × count` (the count at byte 80)
//! is binary whatever its header says; otherwise a file starting with
//! `solid` is ASCII. Facet normals are ignored (they are often wrong or
//! zero); the winding gives the flat normal. Identical corners are merged
//! so the mesh is indexed.

use crate::hash_map::HashMap;
use std::path::Path;

use glam::Vec3;

use super::shorten;
use crate::load::{LoadError, MeshData};

/// Size of a binary STL header plus its triangle count.
const BINARY_HEADER: usize = 84;
/// Size of one binary triangle record (normal, 3 corners, attribute word).
const BINARY_RECORD: usize = 50;

/// Reads the STL file at `path` (ASCII or binary, by content).
pub fn load(path: &Path) -> Result<MeshData, LoadError> {
    let bytes = super::read_bytes(path)?;
    parse(&bytes, path)
}

/// Parses STL bytes; `path` is only used in error messages.
pub fn parse(bytes: &[u8], path: &Path) -> Result<MeshData, LoadError> {
    if bytes.is_empty() {
        return Err(LoadError::file(path, "the file is empty"));
    }
    let binary_count = (bytes.len() >= BINARY_HEADER)
        .then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize);
    let exact_binary = binary_count.is_some_and(|n| {
        n.checked_mul(BINARY_RECORD).map(|s| s + BINARY_HEADER) == Some(bytes.len())
    });
    let looks_ascii = {
        let start = bytes
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(0);
        bytes[start..].starts_with(b"solid")
    };
    let mesh = if exact_binary || !looks_ascii {
        parse_binary(bytes, path)?
    } else {
        parse_ascii(bytes, path)?
    };
    if mesh.triangles.is_empty() {
        return Err(LoadError::file(path, "the file has no triangles"));
    }
    super::check_finite(path, &mesh.positions)?;
    Ok(mesh)
}

/// Collects corners into an indexed mesh, merging bit-identical positions.
#[derive(Default)]
struct Builder {
    mesh: MeshData,
    index: HashMap<[u32; 3], u32>,
}

impl Builder {
    fn corner(&mut self, p: Vec3) -> u32 {
        // -0.0 and 0.0 are the same point.
        let key = (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let next = self.mesh.positions.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.mesh.positions.push(p);
            next
        })
    }

    fn triangle(&mut self, c: [Vec3; 3]) {
        let t = c.map(|p| self.corner(p));
        self.mesh.triangles.push(t);
    }
}

fn parse_binary(bytes: &[u8], path: &Path) -> Result<MeshData, LoadError> {
    if bytes.len() < BINARY_HEADER {
        return Err(LoadError::file(
            path,
            format!(
                "not an ASCII STL (no 'solid') and too short for a binary one ({} bytes, the header alone is 84)",
                bytes.len()
            ),
        ));
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    let available = (bytes.len() - BINARY_HEADER) as u64 / BINARY_RECORD as u64;
    // The count is checked against the file before anything is allocated.
    if count > available {
        return Err(LoadError::file(
            path,
            format!(
                "binary STL header promises {count} triangles but the file holds only {available} ({} bytes)",
                bytes.len()
            ),
        ));
    }
    let mut b = Builder::default();
    b.mesh.triangles.reserve(count as usize);
    for rec in bytes[BINARY_HEADER..]
        .chunks_exact(BINARY_RECORD)
        .take(count as usize)
    {
        let f = |k: usize| {
            let o = 12 + 4 * k;
            f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]])
        };
        let c = [0, 1, 2].map(|v| Vec3::new(f(3 * v), f(3 * v + 1), f(3 * v + 2)));
        b.triangle(c);
    }
    Ok(b.mesh)
}

fn parse_ascii(bytes: &[u8], path: &Path) -> Result<MeshData, LoadError> {
    let text = String::from_utf8_lossy(bytes);
    let mut b = Builder::default();
    let mut corners: Vec<Vec3> = Vec::with_capacity(3);
    let mut facet_line = 0;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("facet") => {
                if facet_line != 0 {
                    return Err(LoadError::at(
                        path,
                        line_no,
                        format!("'facet' before the facet of line {facet_line} ended"),
                    ));
                }
                facet_line = line_no;
                corners.clear();
            }
            Some("vertex") => {
                if facet_line == 0 {
                    return Err(LoadError::at(path, line_no, "'vertex' outside a facet"));
                }
                let mut v = [0f32; 3];
                for slot in &mut v {
                    let tok = tokens.next().unwrap_or("");
                    *slot = tok.parse().map_err(|_| {
                        LoadError::at(
                            path,
                            line_no,
                            format!("'vertex' expects 3 numbers, found '{}'", shorten(tok)),
                        )
                    })?;
                }
                if corners.len() == 3 {
                    return Err(LoadError::at(
                        path,
                        line_no,
                        "a facet has more than 3 vertices",
                    ));
                }
                corners.push(Vec3::from(v));
            }
            Some("endfacet") => {
                if corners.len() != 3 {
                    return Err(LoadError::at(
                        path,
                        line_no,
                        format!("a facet needs 3 vertices, this one has {}", corners.len()),
                    ));
                }
                b.triangle([corners[0], corners[1], corners[2]]);
                facet_line = 0;
            }
            Some("solid" | "endsolid" | "outer" | "endloop") | None => {}
            Some(other) => {
                return Err(LoadError::at(
                    path,
                    line_no,
                    format!("unexpected '{}' in an ASCII STL file", shorten(other)),
                ))
            }
        }
    }
    if facet_line != 0 {
        return Err(LoadError::at(
            path,
            facet_line,
            "the file ends inside this facet",
        ));
    }
    Ok(b.mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(header: &[u8], tris: &[[f32; 9]], count: u32) -> Vec<u8> {
        let mut v = vec![0u8; 80];
        v[..header.len()].copy_from_slice(header);
        v.extend_from_slice(&count.to_le_bytes());
        for t in tris {
            v.extend_from_slice(&[0u8; 12]);
            for x in t {
                v.extend_from_slice(&x.to_le_bytes());
            }
            v.extend_from_slice(&[0u8; 2]);
        }
        v
    }

    const TRI: [f32; 9] = [0., 0., 0., 1., 0., 0., 0., 1., 0.];
    const TRI2: [f32; 9] = [1., 0., 0., 1., 1., 0., 0., 1., 0.];

    #[test]
    fn binary_with_solid_header_is_binary() {
        let bytes = binary(b"solid but binary", &[TRI, TRI2], 2);
        let m = parse(&bytes, Path::new("x.stl")).unwrap();
        assert_eq!(m.triangles.len(), 2);
        // Shared corners are merged.
        assert_eq!(m.positions.len(), 4);
    }

    #[test]
    fn binary_count_beyond_the_file_is_an_error() {
        let bytes = binary(b"x", &[TRI], 1_000_000_000);
        let e = parse(&bytes, Path::new("x.stl")).unwrap_err();
        assert!(e.to_string().contains("promises 1000000000"), "{e}");
    }

    #[test]
    fn ascii_errors_name_the_line() {
        let text = "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 x 0\n";
        let e = parse(text.as_bytes(), Path::new("a.stl")).unwrap_err();
        assert_eq!(e.line, Some(5), "{e}");
        let text = "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n";
        let e = parse(text.as_bytes(), Path::new("a.stl")).unwrap_err();
        assert_eq!(e.line, Some(7), "{e}");
        let e = parse(b"solid empty\nendsolid empty\n", Path::new("a.stl")).unwrap_err();
        assert!(e.message.contains("no triangles"), "{e}");
    }
}
