//! The Cornell `.msh` mesh format (2010 scenes), read exactly as the scene
//! format document's §5.4 describes it:
//!
//! * line 1 holds the vertex count, line 2 the triangle count;
//! * then the sections `vertices`, `triangles`, `normals` and `texcoords`, in
//!   any order, each keyword alone on its line and followed by one number per
//!   line (3 per vertex, 3 per triangle, 3 per vertex, 2 per vertex);
//! * `vertices` and `triangles` are required, other lines are skipped;
//! * floats are parsed as `f32` (parsing as `f64` and rounding later changes
//!   pixels), exponent forms such as `8.0E-6` are accepted, and CRLF line
//!   endings are tolerated.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::{shorten, LoadError, MeshData};

/// Reads a `.msh` file. Every error names the file and, where one applies,
/// the 1-based line.
pub fn load_msh(path: &Path) -> Result<MeshData, LoadError> {
    let text = super::read_text(path)?;
    parse_msh(&text, path)
}

/// Parses the text of a `.msh` file; `path` is only used in error messages.
pub fn parse_msh(text: &str, path: &Path) -> Result<MeshData, LoadError> {
    let mut lines = Lines::new(text);
    let n_points = header_count(&mut lines, path, 1, "vertex count")?;
    let n_triangles = header_count(&mut lines, path, 2, "triangle count")?;
    check_counts(text.len(), n_points, n_triangles, path)?;

    let mut sections = Sections::default();
    while let Some((line_no, line)) = lines.next() {
        let Some(kind) = Section::from_keyword(line.trim()) else {
            // The format skips anything that is not a section keyword.
            continue;
        };
        if let Some(first) = sections.seen(kind) {
            return Err(LoadError::at(
                path,
                line_no,
                format!(
                    "section '{}' appears a second time (first at line {first})",
                    kind.keyword()
                ),
            ));
        }
        let section = SectionReader {
            path,
            kind,
            start: line_no,
            total: kind.numbers(n_points, n_triangles),
        };
        match kind {
            Section::Vertices => {
                let mut out = Vec::with_capacity(n_points);
                section.read_floats(&mut lines, |i, v| push_component3(&mut out, i, v))?;
                sections.vertices = Some((line_no, out));
            }
            Section::Normals => {
                let mut out = Vec::with_capacity(n_points);
                section.read_floats(&mut lines, |i, v| push_component3(&mut out, i, v))?;
                sections.normals = Some((line_no, out));
            }
            Section::Texcoords => {
                let mut out: Vec<Vec2> = Vec::with_capacity(n_points);
                section.read_floats(&mut lines, |i, v| {
                    if i % 2 == 0 {
                        out.push(Vec2::new(v, 0.0));
                    } else if let Some(last) = out.last_mut() {
                        last.y = v;
                    }
                })?;
                sections.texcoords = Some((line_no, out));
            }
            Section::Triangles => {
                let mut out: Vec<[u32; 3]> = Vec::with_capacity(n_triangles);
                section.read_indices(&mut lines, n_points, |i, v| {
                    if i % 3 == 0 {
                        out.push([v, 0, 0]);
                    } else if let Some(last) = out.last_mut() {
                        last[i % 3] = v;
                    }
                })?;
                sections.triangles = Some((line_no, out));
            }
        }
    }

    let end_line = lines.last_line();
    let missing = |what: &str| {
        LoadError::at(
            path,
            end_line,
            format!("the file ends without the required '{what}' section"),
        )
    };
    let (_, positions) = sections.vertices.ok_or_else(|| missing("vertices"))?;
    let (_, triangles) = sections.triangles.ok_or_else(|| missing("triangles"))?;
    Ok(MeshData {
        positions,
        normals: sections.normals.map(|(_, n)| n),
        uvs: sections.texcoords.map(|(_, t)| t),
        colors: None,
        triangles,
    })
}

/// Appends component `i % 3` of a run of 3-vectors.
fn push_component3(out: &mut Vec<Vec3>, i: usize, v: f32) {
    if i.is_multiple_of(3) {
        out.push(Vec3::new(v, 0.0, 0.0));
    } else if let Some(last) = out.last_mut() {
        last[i % 3] = v;
    }
}

/// Reads one header count from the next line, which must be line `expected`.
fn header_count(
    lines: &mut Lines<'_>,
    path: &Path,
    expected: usize,
    what: &str,
) -> Result<usize, LoadError> {
    let Some((line_no, line)) = lines.next() else {
        return Err(LoadError::at(
            path,
            expected,
            format!("expected the {what} on line {expected}, but the file ends"),
        ));
    };
    let token = line.trim();
    token.parse::<usize>().map_err(|_| {
        LoadError::at(
            path,
            line_no,
            format!(
                "expected the {what} (a non-negative integer) on line {expected}, found '{}'",
                shorten(token)
            ),
        )
    })
}

/// Rejects header counts the file cannot possibly hold, before anything is
/// allocated from them: every number takes at least one character plus a line
/// break, so a file of `len` bytes holds at most `len / 2 + 1` numbers. This
/// makes a corrupt header (say 2 billion vertices in a 100-byte file) fail at
/// once instead of reserving gigabytes.
fn check_counts(
    len: usize,
    n_points: usize,
    n_triangles: usize,
    path: &Path,
) -> Result<(), LoadError> {
    if n_points > u32::MAX as usize {
        return Err(LoadError::at(
            path,
            1,
            format!(
                "vertex count {n_points} exceeds the 2^32 vertices triangle indices can address"
            ),
        ));
    }
    let capacity = len / 2 + 1;
    let needed = n_points
        .checked_add(n_triangles)
        .and_then(|n| n.checked_mul(3));
    match needed {
        Some(needed) if needed <= capacity => Ok(()),
        _ => Err(LoadError::at(
            path,
            2,
            format!(
                "header counts ({n_points} vertices, {n_triangles} triangles) need 3 x ({n_points} + \
                 {n_triangles}) numbers, more than a {len}-byte file can hold; the file is truncated \
                 or its header is wrong"
            ),
        )),
    }
}

/// The four section kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Section {
    Vertices,
    Triangles,
    Normals,
    Texcoords,
}

impl Section {
    fn from_keyword(word: &str) -> Option<Section> {
        match word {
            "vertices" => Some(Section::Vertices),
            "triangles" => Some(Section::Triangles),
            "normals" => Some(Section::Normals),
            "texcoords" => Some(Section::Texcoords),
            _ => None,
        }
    }

    fn keyword(self) -> &'static str {
        match self {
            Section::Vertices => "vertices",
            Section::Triangles => "triangles",
            Section::Normals => "normals",
            Section::Texcoords => "texcoords",
        }
    }

    /// How many numbers follow the keyword. Cannot overflow: `check_counts`
    /// has bounded both counts by the file length.
    fn numbers(self, n_points: usize, n_triangles: usize) -> usize {
        match self {
            Section::Vertices | Section::Normals => 3 * n_points,
            Section::Triangles => 3 * n_triangles,
            Section::Texcoords => 2 * n_points,
        }
    }

    /// What one number of this section is, for error messages.
    fn item(self) -> &'static str {
        match self {
            Section::Vertices => "a vertex coordinate",
            Section::Triangles => "a vertex index",
            Section::Normals => "a normal component",
            Section::Texcoords => "a texture coordinate",
        }
    }
}

/// The sections read so far, each with its keyword's line.
#[derive(Default)]
struct Sections {
    vertices: Option<(usize, Vec<Vec3>)>,
    triangles: Option<(usize, Vec<[u32; 3]>)>,
    normals: Option<(usize, Vec<Vec3>)>,
    texcoords: Option<(usize, Vec<Vec2>)>,
}

impl Sections {
    /// The keyword line of `kind` when that section was already read.
    fn seen(&self, kind: Section) -> Option<usize> {
        match kind {
            Section::Vertices => self.vertices.as_ref().map(|s| s.0),
            Section::Triangles => self.triangles.as_ref().map(|s| s.0),
            Section::Normals => self.normals.as_ref().map(|s| s.0),
            Section::Texcoords => self.texcoords.as_ref().map(|s| s.0),
        }
    }
}

/// Reads the numbers of one section, with errors that say which section,
/// which number and where.
struct SectionReader<'p> {
    path: &'p Path,
    kind: Section,
    /// Line of the keyword.
    start: usize,
    /// Numbers the section must hold.
    total: usize,
}

impl SectionReader<'_> {
    /// The next number's line and text. Blank lines inside a section are
    /// skipped; a keyword or the end of the file before `total` numbers means
    /// the section is truncated.
    fn next_token<'t>(
        &self,
        lines: &mut Lines<'t>,
        index: usize,
    ) -> Result<(usize, &'t str), LoadError> {
        loop {
            let Some((line_no, line)) = lines.next() else {
                return Err(LoadError::at(
                    self.path,
                    lines.last_line(),
                    format!(
                        "the file ends inside section '{}' (line {}): expected {} numbers, found {index}; \
                         the file is truncated",
                        self.kind.keyword(),
                        self.start,
                        self.total
                    ),
                ));
            };
            let token = trim(line);
            if token.is_empty() {
                continue;
            }
            let keyword = if may_be_keyword(token) {
                Section::from_keyword(token)
            } else {
                None
            };
            if let Some(next) = keyword {
                return Err(LoadError::at(
                    self.path,
                    line_no,
                    format!(
                        "section '{}' (line {}) ends after {index} of its {} numbers; section '{}' \
                         starts here",
                        self.kind.keyword(),
                        self.start,
                        self.total,
                        next.keyword()
                    ),
                ));
            }
            return Ok((line_no, token));
        }
    }

    fn not_a_number(&self, line_no: usize, token: &str, expected: &str) -> LoadError {
        LoadError::at(
            self.path,
            line_no,
            format!(
                "expected {} ({expected}) in section '{}', found '{}'",
                self.kind.item(),
                self.kind.keyword(),
                shorten(token)
            ),
        )
    }

    fn read_floats(
        &self,
        lines: &mut Lines<'_>,
        mut sink: impl FnMut(usize, f32),
    ) -> Result<(), LoadError> {
        for i in 0..self.total {
            let (line_no, token) = self.next_token(lines, i)?;
            match token.parse::<f32>() {
                Ok(v) if v.is_finite() => sink(i, v),
                _ => return Err(self.not_a_number(line_no, token, "a finite number")),
            }
        }
        Ok(())
    }

    fn read_indices(
        &self,
        lines: &mut Lines<'_>,
        n_points: usize,
        mut sink: impl FnMut(usize, u32),
    ) -> Result<(), LoadError> {
        for i in 0..self.total {
            let (line_no, token) = self.next_token(lines, i)?;
            let Ok(index) = token.parse::<i64>() else {
                return Err(self.not_a_number(line_no, token, "an integer"));
            };
            if index < 0 || index as u64 >= n_points as u64 {
                return Err(LoadError::at(
                    self.path,
                    line_no,
                    format!(
                        "vertex index {index} is out of range: the mesh has {n_points} vertices, so \
                         indices run from 0 to {}",
                        n_points as i64 - 1
                    ),
                ));
            }
            // In range of a count that `check_counts` bounded by u32::MAX.
            sink(i, index as u32);
        }
        Ok(())
    }
}

/// Lines with their 1-based numbers, `\r` stripped: the pieces of the
/// text between `\n`s, as `str::split('\n')` gives them (an empty last
/// piece after a final `\n` included). Scanned byte by byte: lines here hold
/// one short number each, and the general splitter's set-up per line was
/// the largest cost of reading a mesh.
struct Lines<'t> {
    rest: Option<&'t str>,
    last: usize,
}

impl<'t> Lines<'t> {
    fn new(text: &'t str) -> Self {
        Lines {
            rest: Some(text),
            last: 0,
        }
    }

    /// The number of the last line handed out (at least 1), for errors at the
    /// end of the file.
    fn last_line(&self) -> usize {
        self.last.max(1)
    }
}

impl<'t> Iterator for Lines<'t> {
    type Item = (usize, &'t str);
    fn next(&mut self) -> Option<Self::Item> {
        let rest = self.rest?;
        let line = match rest.bytes().position(|b| b == b'\n') {
            Some(end) => {
                // `\n` is one byte, so both sides are on char boundaries.
                self.rest = Some(&rest[end + 1..]);
                &rest[..end]
            }
            None => {
                self.rest = None;
                rest
            }
        };
        self.last += 1;
        Some((self.last, line.strip_suffix('\r').unwrap_or(line)))
    }
}

/// `line.trim()`, by the quicker ASCII trim where that is the same: when
/// what it leaves neither starts nor ends with a byte that could begin or
/// end other Unicode white space (non-ASCII) or the vertical tab (which
/// `trim` strips and `trim_ascii` keeps).
fn trim(line: &str) -> &str {
    let t = line.trim_ascii();
    let unsure = |b: Option<&u8>| b.is_some_and(|&b| b >= 0x80 || b == 0x0B);
    if unsure(t.as_bytes().first()) || unsure(t.as_bytes().last()) {
        t.trim()
    } else {
        t
    }
}

/// Whether `token` can be a section keyword: they all start with `v`, `t`
/// or `n`, numbers never do (a number token is checked against the four
/// keywords otherwise, on every line of a section).
fn may_be_keyword(token: &str) -> bool {
    matches!(token.as_bytes().first(), Some(b'v' | b't' | b'n'))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MeshData, LoadError> {
        parse_msh(text, Path::new("m.msh"))
    }

    fn err(text: &str) -> LoadError {
        parse(text).expect_err("expected an error")
    }

    const TRI: &str = "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n2\n";

    #[test]
    fn reads_a_triangle() {
        let m = parse(TRI).unwrap();
        assert_eq!(
            m.positions,
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            "positions in file order"
        );
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert!(m.normals.is_none() && m.uvs.is_none());
    }

    #[test]
    fn sections_in_any_order_with_crlf_exponents_and_extra_lines() {
        let text = "3\r\n1\r\n# a comment line\r\ntexcoords\r\n0\r\n0\r\n1\r\n0\r\n0\r\n1\r\n\
                    triangles\r\n2\r\n1\r\n0\r\nnormals\r\n0\r\n0\r\n1\r\n0\r\n0\r\n1\r\n0\r\n0\r\n1E0\r\n\
                    vertices\r\n8.0E-6\r\n-1.5e+2\r\n0\r\n1\r\n0\r\n0\r\n0\r\n1\r\n0\r\n";
        let m = parse(text).unwrap();
        assert_eq!(m.positions[0], Vec3::new(8.0e-6, -150.0, 0.0));
        assert_eq!(m.positions[0].x, "8.0E-6".parse::<f32>().unwrap());
        assert_eq!(m.triangles, vec![[2, 1, 0]]);
        assert_eq!(m.normals.unwrap(), vec![Vec3::Z; 3]);
        assert_eq!(m.uvs.unwrap(), vec![Vec2::ZERO, Vec2::X, Vec2::Y]);
    }

    #[test]
    fn floats_are_parsed_as_f32_directly() {
        // A decimal that rounds differently via f64 -> f32 than directly would
        // catch double rounding; direct parsing is correctly rounded.
        let text = "1\n0\nvertices\n0.1\n1.0000001192092896\n3.4028235e38\ntriangles\n";
        let m = parse(text).unwrap();
        assert_eq!(m.positions[0].x, 0.1f32);
        assert_eq!(
            m.positions[0].y,
            "1.0000001192092896".parse::<f32>().unwrap()
        );
        assert_eq!(m.positions[0].z, f32::MAX);
    }

    /// Malformed files, each with the line its error names (where that is
    /// pinned) and the words its message must contain (all of them).
    #[test]
    fn malformed_files_name_the_line_and_the_problem() {
        let cases: &[(&str, Option<usize>, &[&str])] = &[
            // An empty file.
            ("", Some(1), &["vertex count"]),
            // A missing triangle count.
            ("3\n", Some(2), &["triangle count"]),
            // A bad header.
            ("three\n1\n", Some(1), &["'three'"]),
            ("3\n-1\n", Some(2), &[]),
            // Missing sections.
            (
                "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\n",
                Some(13),
                &["'triangles'"],
            ),
            ("1\n1\ntriangles\n0\n0\n0\n", None, &["'vertices'"]),
            // Not a number, not finite (rejected too), not an integer.
            (
                "3\n1\nvertices\n0\n0\nzero\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n2\n",
                Some(6),
                &["'zero'", "vertex coordinate"],
            ),
            (
                "3\n1\nvertices\n0\n0\nnan\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n2\n",
                Some(6),
                &[],
            ),
            (
                "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1.5\n2\n",
                Some(15),
                &["integer"],
            ),
            // A truncated file.
            (
                "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n",
                Some(16),
                &["truncated", "found 2"],
            ),
            // A section cut short by the next keyword.
            (
                "3\n1\nvertices\n0\n0\n0\n1\ntriangles\n0\n1\n2\n",
                Some(8),
                &["after 4 of its 9"],
            ),
            // Indices out of range.
            (
                "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n3\n2\n",
                Some(15),
                &["index 3", "3 vertices"],
            ),
            (
                "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n-1\n1\n2\n",
                None,
                &["index -1"],
            ),
            // A section given twice.
            (
                "1\n0\nvertices\n0\n0\n0\nvertices\n0\n0\n0\ntriangles\n",
                Some(7),
                &["second time"],
            ),
        ];
        for &(text, line, words) in cases {
            let e = err(text);
            if let Some(line) = line {
                assert_eq!(e.line, Some(line), "{text:?}: {e}");
            }
            for word in words {
                assert!(e.message.contains(word), "{text:?}: {e}");
            }
        }
        // The message is shown after the file's name and the line.
        let e = err("");
        assert_eq!(e.to_string(), format!("m.msh:1: {}", e.message));
    }

    #[test]
    fn huge_header_fails_fast_without_allocating() {
        // Were the counts trusted, this would reserve tens of gigabytes.
        let e = err("2000000000\n2000000000\nvertices\n0\n0\n0\ntriangles\n0\n0\n0\n");
        assert!(e.message.contains("more than"), "{e}");
        let e = err(&format!("{}\n{}\n", usize::MAX, usize::MAX));
        assert!(
            e.message.contains("exceeds") || e.message.contains("more than"),
            "{e}"
        );
        let e = err("99999999999999999999999\n1\n");
        assert_eq!(e.line, Some(1), "{e}");
    }

    #[test]
    fn missing_file_is_named() {
        let e = load_msh(Path::new("/nonexistent/dir/x.msh")).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/dir/x.msh: "), "{e}");
    }

    /// The byte scanner hands out the lines `split('\n')` does, numbered
    /// alike, and its trim is `str::trim`.
    #[test]
    fn lines_and_trim_match_the_standard_ones() {
        let texts = [
            "",
            "\n",
            "a",
            "a\n",
            "a\r\nb\r\n\r\n",
            "\n\nx\ny",
            "3\n1\nvertices\n0.5\n\u{e9}\n\u{2003}7\u{a0}\n",
        ];
        for text in texts {
            let ours: Vec<_> = Lines::new(text).collect();
            let standard: Vec<_> = text
                .split('\n')
                .enumerate()
                .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
                .collect();
            assert_eq!(ours, standard, "{text:?}");
            let mut lines = Lines::new(text);
            lines.by_ref().for_each(drop);
            assert_eq!(lines.last_line(), standard.len().max(1));
        }
        for token in [
            " 1.5 ",
            "\t-2\t",
            "\u{b}3\u{b}",
            "\u{2003}4\u{a0}",
            "\u{c}5",
            "x\u{85}",
            "",
            " ",
            "\u{3000}",
            "\u{e9}",
            "6\u{200b}",
        ] {
            assert_eq!(trim(token), token.trim(), "{token:?}");
        }
    }
}
