//! PLY import: ASCII, binary little-endian and binary big-endian.
//!
//! Read by our own code rather than `ply-rs` (0.1.3, unmaintained since
//! 2020): it reads ASCII data one record per line and rejects header lines
//! it does not know, so real files such as Blender's `Wuson.ply` (a stray
//! "Created by" line, records wrapped over two lines) do not load; it
//! panics on an element count that does not fit a machine word; and its
//! maintained fork needs a newer Rust than ours. Here ASCII data is a
//! stream of tokens (line numbers kept for errors), unknown header lines
//! are skipped like comments, and every count (element counts from the
//! header, list lengths from the data) is checked against the bytes left
//! before anything is allocated for it. Faces with more than 3 corners are
//! triangulated by ear clipping.

use std::path::Path;

use glam::Vec3;

use super::shorten;
use super::triangulate::triangulate;
use crate::load::{LoadError, MeshData};
use crate::texture::srgb_to_linear;

/// Reads the PLY file at `path`.
pub fn load(path: &Path) -> Result<MeshData, LoadError> {
    let bytes = super::read_bytes(path)?;
    parse(&bytes, path)
}

/// A scalar type of the format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(name: &str) -> Option<Ty> {
        Some(match name {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

/// A property: a scalar, or a list with its count and item types.
#[derive(Clone, Debug)]
struct Prop {
    name: String,
    ty: Ty,
    list_count: Option<Ty>,
}

/// One element as the header declares it.
#[derive(Debug)]
struct ElementHeader {
    name: String,
    count: u64,
    props: Vec<Prop>,
    /// The 1-based header line that declared it.
    line: usize,
}

impl ElementHeader {
    /// Fewest bytes one record can take (ASCII: a digit and a separator
    /// per value; binary: the scalars and the list counts).
    fn min_record(&self, ascii: bool) -> u64 {
        self.props
            .iter()
            .map(|p| {
                if ascii {
                    2
                } else {
                    p.list_count.unwrap_or(p.ty).size() as u64
                }
            })
            .sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// What the header says.
#[derive(Debug)]
struct Header {
    format: Format,
    elements: Vec<ElementHeader>,
    /// Lines the header takes.
    lines: usize,
    /// Byte offset of the data.
    data_start: usize,
}

/// Reads the header: the format, and the elements with their properties.
fn read_header(bytes: &[u8], path: &Path) -> Result<Header, LoadError> {
    if bytes.is_empty() {
        return Err(LoadError::file(path, "the file is empty"));
    }
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<ElementHeader> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(LoadError::file(path, "the header has no 'end_header' line"));
        };
        let line = String::from_utf8_lossy(&bytes[pos..pos + len]);
        pos += len + 1;
        line_no += 1;
        let mut tokens = line.split_whitespace();
        let keyword = tokens.next().unwrap_or("");
        if line_no == 1 {
            if keyword != "ply" {
                return Err(LoadError::at(
                    path,
                    1,
                    "not a PLY file (it must start with 'ply')",
                ));
            }
            continue;
        }
        let bad = |m: String| LoadError::at(path, line_no, m);
        match keyword {
            "format" => format = Some(header_format(tokens.next()).map_err(bad)?),
            "element" => elements.push(header_element(tokens, line_no).map_err(bad)?),
            "property" => {
                let Some(e) = elements.last_mut() else {
                    return Err(bad("'property' before any 'element'".into()));
                };
                e.props.push(header_property(tokens).map_err(bad)?);
            }
            "end_header" => break,
            // Comments, obj_info, and stray text some exporters write.
            _ => {}
        }
    }
    let Some(format) = format else {
        return Err(LoadError::file(path, "the header has no 'format' line"));
    };
    Ok(Header {
        format,
        elements,
        lines: line_no,
        data_start: pos,
    })
}

/// The encoding a `format` line names; the message when it is none.
fn header_format(name: Option<&str>) -> Result<Format, String> {
    Ok(match name {
        Some("ascii") => Format::Ascii,
        Some("binary_little_endian") => Format::Little,
        Some("binary_big_endian") => Format::Big,
        other => {
            return Err(format!(
                "unknown PLY format '{}'",
                shorten(other.unwrap_or(""))
            ))
        }
    })
}

/// The element an `element NAME COUNT` line (header line `line`) declares,
/// without its properties yet.
fn header_element<'t>(
    mut tokens: impl Iterator<Item = &'t str>,
    line: usize,
) -> Result<ElementHeader, String> {
    let name = tokens.next().unwrap_or("").to_string();
    let count = tokens
        .next()
        .and_then(|c| c.parse::<u64>().ok())
        .ok_or_else(|| "'element' expects a name and a count".to_string())?;
    Ok(ElementHeader {
        name,
        count,
        props: Vec::new(),
        line,
    })
}

/// The property a `property TYPE NAME` or `property list COUNT ITEM NAME`
/// line declares (a list's count must be an integer type).
fn header_property<'t>(mut tokens: impl Iterator<Item = &'t str>) -> Result<Prop, String> {
    let ty = tokens.next().unwrap_or("");
    if ty != "list" {
        return Ok(Prop {
            ty: Ty::parse(ty).ok_or_else(|| format!("unknown property type '{}'", shorten(ty)))?,
            name: tokens.next().unwrap_or("").to_string(),
            list_count: None,
        });
    }
    let count_ty = tokens.next().unwrap_or("");
    let item_ty = tokens.next().unwrap_or("");
    match (Ty::parse(count_ty), Ty::parse(item_ty)) {
        (Some(c), Some(t)) if !matches!(c, Ty::F32 | Ty::F64) => Ok(Prop {
            name: tokens.next().unwrap_or("").to_string(),
            ty: t,
            list_count: Some(c),
        }),
        _ => Err(format!(
            "unknown list types '{} {}'",
            shorten(count_ty),
            shorten(item_ty)
        )),
    }
}

/// Reads the data values one at a time, in either encoding.
struct Data<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    /// 1-based line of the ASCII position.
    line: usize,
    path: &'a Path,
}

impl Data<'_> {
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn error(&self, message: impl Into<String>) -> LoadError {
        match self.format {
            Format::Ascii => LoadError::at(self.path, self.line, message),
            _ => LoadError::file(
                self.path,
                format!("at byte {}: {}", self.pos, message.into()),
            ),
        }
    }

    fn value(&mut self, ty: Ty) -> Result<f64, LoadError> {
        if self.format == Format::Ascii {
            return self.ascii_value(ty);
        }
        let n = ty.size();
        if self.remaining() < n {
            return Err(self.error("the file ends before the data the header promises"));
        }
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
        self.pos += n;
        if self.format == Format::Big {
            b[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(b),
        })
    }

    /// Moves past white space (ASCII data), counting lines.
    fn skip_space(&mut self) {
        if self.format != Format::Ascii {
            return;
        }
        while let Some(&c) = self.bytes.get(self.pos) {
            if !c.is_ascii_whitespace() {
                break;
            }
            if c == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    fn ascii_value(&mut self, ty: Ty) -> Result<f64, LoadError> {
        self.skip_space();
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|c| !c.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(self.error("the file ends before the data the header promises"));
        }
        let token = String::from_utf8_lossy(&self.bytes[start..self.pos]);
        let v: Option<f64> = match ty {
            Ty::F32 | Ty::F64 => token.parse().ok().filter(|v: &f64| v.is_finite()),
            _ => token.parse::<i64>().ok().map(|v| v as f64),
        };
        v.ok_or_else(|| {
            self.error(format!(
                "expected {}, found '{}'",
                if matches!(ty, Ty::F32 | Ty::F64) {
                    "a number"
                } else {
                    "an integer"
                },
                shorten(&token)
            ))
        })
    }
}

/// Parses PLY bytes; `path` is only used in error messages.
pub fn parse(bytes: &[u8], path: &Path) -> Result<MeshData, LoadError> {
    let header = read_header(bytes, path)?;
    check_counts(&header, bytes, path)?;
    let has = |name: &str| {
        header
            .elements
            .iter()
            .any(|e| e.name == name && e.count > 0)
    };
    if !has("vertex") || !has("face") {
        return Err(LoadError::file(
            path,
            "the file has no vertices or no faces (a point cloud?); nothing to render",
        ));
    }
    let mut data = Data {
        bytes,
        pos: header.data_start,
        format: header.format,
        line: header.lines + 1,
        path,
    };
    let mut body = Body::default();
    for e in &header.elements {
        body.element(&mut data, e)?;
    }
    body.mesh(path, header.format == Format::Ascii)
}

/// Checks every element count of the header against the data that is
/// there, before anything is read.
fn check_counts(header: &Header, bytes: &[u8], path: &Path) -> Result<(), LoadError> {
    let ascii = header.format == Format::Ascii;
    let available = (bytes.len() - header.data_start) as u64;
    let mut needed: u64 = 0;
    for e in &header.elements {
        needed = needed.saturating_add(e.count.saturating_mul(e.min_record(ascii).max(1)));
        if needed > available {
            return Err(LoadError::at(
                path,
                e.line,
                format!(
                    "the header promises {} '{}' records, more than the {available} bytes of data can hold",
                    e.count, e.name
                ),
            ));
        }
    }
    Ok(())
}

/// Where the values this reader uses sit in an element's records.
struct Layout {
    xyz: [Option<usize>; 3],
    nxyz: [Option<usize>; 3],
    rgb: [Option<usize>; 3],
    /// What an integer colour is divided by to run to 1.
    colour_scale: f64,
    is_vertex: bool,
    is_face: bool,
    /// The face's corner list.
    corners_prop: Option<usize>,
}

impl Layout {
    /// The layout of element `e`; an error when a vertex element has no
    /// position or a face element no corner list.
    fn of(e: &ElementHeader, path: &Path) -> Result<Layout, LoadError> {
        let find = |n: &str| {
            e.props
                .iter()
                .position(|p| p.name == n && p.list_count.is_none())
        };
        let xyz = [find("x"), find("y"), find("z")];
        let nxyz = [find("nx"), find("ny"), find("nz")];
        let rgb = [find("red"), find("green"), find("blue")];
        // Integer colours run to their type's maximum, float ones to 1.
        let colour_scale = rgb[0].map_or(1.0, |i| match e.props[i].ty {
            Ty::U8 | Ty::I8 => 255.0,
            Ty::U16 | Ty::I16 => 65535.0,
            Ty::U32 | Ty::I32 => u32::MAX as f64,
            Ty::F32 | Ty::F64 => 1.0,
        });
        let is_vertex = e.name == "vertex";
        let is_face = e.name == "face";
        let corners_prop = e.props.iter().position(|p| {
            p.list_count.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        if is_vertex && xyz.iter().any(Option::is_none) {
            return Err(LoadError::at(
                path,
                e.line,
                "the vertex element has no x, y and z",
            ));
        }
        if is_face && corners_prop.is_none() {
            return Err(LoadError::at(
                path,
                e.line,
                "the face element has no 'vertex_indices' list",
            ));
        }
        Ok(Layout {
            xyz,
            nxyz,
            rgb,
            colour_scale,
            is_vertex,
            is_face,
            corners_prop,
        })
    }
}

/// What the data section holds so far: vertices (with their normals and
/// colours), and faces with the line they were read from, checked and
/// triangulated at the end.
#[derive(Default)]
struct Body {
    mesh: MeshData,
    normals: Vec<Vec3>,
    colors: Vec<Vec3>,
    faces: Vec<(usize, Vec<u32>)>,
    /// One record's scalar values (0 in a list's place).
    values: Vec<f64>,
    list: Vec<f64>,
}

impl Body {
    /// Reads every record of element `e`, keeping vertices and faces.
    fn element(&mut self, data: &mut Data, e: &ElementHeader) -> Result<(), LoadError> {
        let layout = Layout::of(e, data.path)?;
        for _ in 0..e.count {
            let (record_line, corners) = self.record(data, e, layout.corners_prop)?;
            if layout.is_vertex {
                self.vertex(&layout);
            } else if layout.is_face {
                self.face(record_line, &corners);
            }
        }
        Ok(())
    }

    /// Reads one record into `values`; returns the line it starts on and
    /// the values of its corner list (`corners_prop`), if it has one.
    fn record(
        &mut self,
        data: &mut Data,
        e: &ElementHeader,
        corners_prop: Option<usize>,
    ) -> Result<(usize, Vec<f64>), LoadError> {
        let ascii = data.format == Format::Ascii;
        self.values.clear();
        data.skip_space();
        let record_line = data.line;
        let mut corners = Vec::new();
        for (k, p) in e.props.iter().enumerate() {
            match p.list_count {
                None => self.values.push(data.value(p.ty)?),
                Some(count_ty) => {
                    let n = data.value(count_ty)?;
                    // A list length read from the data is checked too.
                    let min = if ascii { 2 } else { p.ty.size() };
                    if n < 0.0 || n * min as f64 > data.remaining() as f64 + 1.0 {
                        return Err(data.error(format!(
                            "a list of {n} values does not fit in the rest of the file"
                        )));
                    }
                    self.list.clear();
                    for _ in 0..n as usize {
                        self.list.push(data.value(p.ty)?);
                    }
                    if Some(k) == corners_prop {
                        corners = self.list.clone();
                    }
                    self.values.push(0.0);
                }
            }
        }
        Ok((record_line, corners))
    }

    /// Keeps the vertex just read: position, and normal and colour when
    /// the element has them.
    fn vertex(&mut self, layout: &Layout) {
        let values = &self.values;
        let get = |i: Option<usize>| i.map_or(0.0, |i| values[i]) as f32;
        let xyz = layout.xyz;
        self.mesh
            .positions
            .push(Vec3::new(get(xyz[0]), get(xyz[1]), get(xyz[2])));
        let nxyz = layout.nxyz;
        if nxyz.iter().all(Option::is_some) {
            self.normals
                .push(Vec3::new(get(nxyz[0]), get(nxyz[1]), get(nxyz[2])));
        }
        if let [Some(r), Some(g), Some(b)] = layout.rgb {
            let c = |i: usize| srgb_to_linear(values[i] / layout.colour_scale) as f32;
            self.colors.push(Vec3::new(c(r), c(g), c(b)));
        }
    }

    /// Keeps the face just read (read from line `record_line`), its
    /// corners as vertex indices (`u32::MAX` for one that is none).
    fn face(&mut self, record_line: usize, corners: &[f64]) {
        let corners = corners
            .iter()
            .map(|&c| {
                if c >= 0.0 && c <= u32::MAX as f64 {
                    c as u32
                } else {
                    u32::MAX
                }
            })
            .collect();
        self.faces.push((record_line, corners));
    }

    /// The mesh: normals and colours when every vertex has one, the faces
    /// checked against the vertex count and triangulated.
    fn mesh(self, path: &Path, ascii: bool) -> Result<MeshData, LoadError> {
        let Body {
            mut mesh,
            normals,
            colors,
            faces,
            ..
        } = self;
        if normals.len() == mesh.positions.len() {
            mesh.normals = Some(normals);
        }
        if !colors.is_empty() && colors.len() == mesh.positions.len() {
            mesh.colors = Some(colors);
        }
        // Faces may come before vertices in the file: check them at the end.
        let n = mesh.positions.len() as u64;
        for (k, (line, corners)) in faces.iter().enumerate() {
            if let Some(&bad) = corners.iter().find(|&&c| c as u64 >= n) {
                let message = format!(
                    "vertex index {bad} is out of range (the file has {n} vertices, numbered from 0)"
                );
                return Err(if ascii {
                    LoadError::at(path, *line, message)
                } else {
                    LoadError::file(path, format!("face {}: {message}", k + 1))
                });
            }
            triangulate(&mesh.positions, corners, &mut mesh.triangles);
        }
        if mesh.triangles.is_empty() {
            return Err(LoadError::file(
                path,
                "the file has no faces with 3 or more corners",
            ));
        }
        super::check_finite(path, &mesh.positions)?;
        super::sanitize_normals(&mut mesh);
        Ok(mesh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad() {
        let m = parse(ASCII.as_bytes(), Path::new("q.ply")).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles.len(), 2);
    }

    #[test]
    fn binary_both_endians_agree_with_ascii() {
        let ascii = parse(ASCII.as_bytes(), Path::new("q.ply")).unwrap();
        for (name, big) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut b = ASCII
                .split("end_header\n")
                .next()
                .unwrap()
                .replace("ascii", name)
                .into_bytes();
            b.extend_from_slice(b"end_header\n");
            let f = |x: f32| {
                if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            };
            let i = |x: i32| {
                if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            };
            for p in &ascii.positions {
                for c in p.to_array() {
                    b.extend_from_slice(&f(c));
                }
            }
            b.push(4);
            for k in 0..4 {
                b.extend_from_slice(&i(k));
            }
            let m = parse(&b, Path::new("q.ply")).unwrap();
            assert_eq!(m, ascii, "{name}");
        }
    }

    #[test]
    fn header_promising_too_much_is_refused() {
        let text = ASCII.replace("element vertex 4", "element vertex 4000000000000");
        let e = parse(text.as_bytes(), Path::new("q.ply")).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.message.contains("promises"), "{e}");
        let text = ASCII.replace("element vertex 4", "element vertex 99999999999999999999999");
        assert!(parse(text.as_bytes(), Path::new("q.ply")).is_err());
    }

    #[test]
    fn bad_index_names_its_line() {
        let text = ASCII.replace("4 0 1 2 3", "4 0 1 2 9");
        // Records may wrap over lines, as Blender writes them.
        let wrapped = ASCII.replace("0 1 0\n4", "0\n1 0\n4");
        assert_eq!(
            parse(wrapped.as_bytes(), Path::new("q.ply"))
                .unwrap()
                .triangles
                .len(),
            2
        );
        let e = parse(text.as_bytes(), Path::new("q.ply")).unwrap_err();
        assert_eq!(e.line, Some(14), "{e}");
        let text = ASCII.replace("1 1 0\n", "1 x 0\n");
        let e = parse(text.as_bytes(), Path::new("q.ply")).unwrap_err();
        assert!(e.line.is_some(), "{e}");
    }
}
