//! Wavefront OBJ meshes, read under one of two exact numbering rules
//! ([`ObjRule`]) with line-accurate errors.
//!
//! General OBJ import (materials, groups) is not the point here: these readers
//! exist because the Cornell 2015 scenes and the ray/hit file interface each
//! fix precisely which triangles a file yields and in what order, and a
//! mistake there silently changes pictures or breaks comparisons.
//!
//! In both rules a `#` starts a comment that runs to the end of the line, and
//! CRLF line endings are tolerated.

use crate::hash_map::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::shorten;
use super::{LoadError, LoadedMesh, MeshData};

/// Which triangles an OBJ file yields, and how they are numbered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ObjRule {
    /// The Cornell 2015 framework's reader (scene format §5.4): `v`/`vn` need
    /// exactly 4 tokens and `vt` exactly 3; an `f` line with exactly 3
    /// corners is a triangle, one with more is skipped (and counted in
    /// [`LoadedMesh::skipped_polygons`]); corners are `p`, `p/t`, `p/t/n` or
    /// `p//n`, 1-based, never negative; vertices are deduplicated by their
    /// (p, t, n) triple in order of first use; the mesh has normals (UVs) when
    /// any `vn` (`vt`) line is present. A corner without a normal (UV) in such
    /// a mesh gets the zero vector.
    Cornell2015,
    /// The ray/hit file interface (`FORMAT.md`), as `embree_trace` reads it:
    /// only `v` and `f` lines matter; an `f` polygon with n corners becomes
    /// the fan `(0, k, k+1)` for k = 1..n-2; corners may be `p`, `p/t`,
    /// `p/t/n` or `p//n` (only `p` is used) and negative indices count back
    /// from the last vertex defined so far; triangle i is the i-th triangle in
    /// file order. Positions are kept exactly as listed (no deduplication),
    /// and the mesh carries no normals or UVs.
    Fan,
}

/// Reads an OBJ file under `rule`. Every error names the file and, where one
/// applies, the 1-based line.
pub fn load_obj(path: &Path, rule: ObjRule) -> Result<LoadedMesh, LoadError> {
    let text = super::read_text(path)?;
    parse_obj(&text, path, rule)
}

/// Parses OBJ text under `rule`; `path` is only used in error messages.
pub fn parse_obj(text: &str, path: &Path, rule: ObjRule) -> Result<LoadedMesh, LoadError> {
    let mut reader = Reader::new(path, rule);
    for (i, line) in text.split('\n').enumerate() {
        let line = line.strip_suffix('\r').unwrap_or(line);
        let line = line.split_once('#').map_or(line, |(before, _)| before);
        reader.line(i + 1, line)?;
    }
    reader.finish()
}

/// Which array an index refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Position,
    Uv,
    Normal,
}

impl Target {
    fn noun(self) -> &'static str {
        match self {
            Target::Position => "vertex",
            Target::Uv => "texture coordinate",
            Target::Normal => "normal",
        }
    }

    fn keyword(self) -> &'static str {
        match self {
            Target::Position => "v",
            Target::Uv => "vt",
            Target::Normal => "vn",
        }
    }
}

/// An index that refers past what was defined when its line was read. OBJ
/// files normally define before use, but nothing forbids forward references,
/// so they are checked once the whole file is read, still against their line.
struct Pending {
    line: usize,
    target: Target,
    /// The 1-based index as written.
    index: u64,
}

/// "No texture coordinate / normal" in a Cornell (p, t, n) key.
const NONE: u32 = u32::MAX;

struct Reader<'p> {
    path: &'p Path,
    rule: ObjRule,
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    any_vt: bool,
    any_vn: bool,
    /// Cornell rule: the unique (p, t, n) keys (0-based, `NONE` when absent)
    /// in order of first use, and their output index.
    keys: Vec<(u32, u32, u32)>,
    key_index: HashMap<(u32, u32, u32), u32>,
    triangles: Vec<[u32; 3]>,
    skipped: usize,
    pending: Vec<Pending>,
}

impl<'p> Reader<'p> {
    fn new(path: &'p Path, rule: ObjRule) -> Self {
        Reader {
            path,
            rule,
            positions: Vec::new(),
            uvs: Vec::new(),
            normals: Vec::new(),
            any_vt: false,
            any_vn: false,
            keys: Vec::new(),
            key_index: HashMap::default(),
            triangles: Vec::new(),
            skipped: 0,
            pending: Vec::new(),
        }
    }

    fn err(&self, line: usize, message: impl Into<String>) -> LoadError {
        LoadError::at(self.path, line, message)
    }

    fn line(&mut self, line_no: usize, line: &str) -> Result<(), LoadError> {
        let mut tokens = line.split_whitespace();
        let Some(kind) = tokens.next() else {
            return Ok(());
        };
        let rest: Vec<&str> = tokens.collect();
        match (self.rule, kind) {
            (ObjRule::Cornell2015, "v") => {
                let p = self.floats::<3>(line_no, "v", &rest, true)?;
                self.positions.push(Vec3::from_array(p));
            }
            (ObjRule::Cornell2015, "vn") => {
                let n = self.floats::<3>(line_no, "vn", &rest, true)?;
                self.normals.push(Vec3::from_array(n));
                self.any_vn = true;
            }
            (ObjRule::Cornell2015, "vt") => {
                let t = self.floats::<2>(line_no, "vt", &rest, true)?;
                self.uvs.push(Vec2::from_array(t));
                self.any_vt = true;
            }
            (ObjRule::Cornell2015, "f") => self.cornell_face(line_no, &rest)?,
            (ObjRule::Fan, "v") => {
                // Only x y z matter; an optional w or vertex colour may follow.
                let p = self.floats::<3>(line_no, "v", &rest, false)?;
                self.positions.push(Vec3::from_array(p));
            }
            (ObjRule::Fan, "f") => self.fan_face(line_no, &rest)?,
            _ => {}
        }
        Ok(())
    }

    /// The `N` numbers of a `v`/`vn`/`vt` line; with `exact`, no more may follow.
    fn floats<const N: usize>(
        &self,
        line_no: usize,
        kind: &str,
        rest: &[&str],
        exact: bool,
    ) -> Result<[f32; N], LoadError> {
        if rest.len() < N || (exact && rest.len() > N) {
            let need = if exact { "exactly" } else { "at least" };
            return Err(self.err(
                line_no,
                format!(
                    "a '{kind}' line needs {need} {N} numbers, found {} token(s)",
                    rest.len()
                ),
            ));
        }
        let mut out = [0.0; N];
        for (slot, token) in out.iter_mut().zip(rest) {
            match token.parse::<f32>() {
                Ok(v) if v.is_finite() => *slot = v,
                _ => {
                    return Err(self.err(
                        line_no,
                        format!(
                            "expected a finite number in a '{kind}' line, found '{}'",
                            shorten(token)
                        ),
                    ))
                }
            }
        }
        Ok(out)
    }

    /// Number of elements defined so far for `target`.
    fn defined(&self, target: Target) -> usize {
        match target {
            Target::Position => self.positions.len(),
            Target::Uv => self.uvs.len(),
            Target::Normal => self.normals.len(),
        }
    }

    /// Resolves one written index to a 0-based one. Positive indices past what
    /// is defined so far are remembered and checked at the end of the file.
    fn index(
        &mut self,
        line_no: usize,
        token: &str,
        target: Target,
        allow_negative: bool,
    ) -> Result<u32, LoadError> {
        let noun = target.noun();
        let Ok(written) = token.parse::<i64>() else {
            return Err(self.err(
                line_no,
                format!(
                    "expected a {noun} index (an integer), found '{}'",
                    shorten(token)
                ),
            ));
        };
        let defined = self.defined(target);
        if written == 0 {
            return Err(self.err(
                line_no,
                format!("{noun} index 0 is invalid: OBJ indices start at 1"),
            ));
        }
        if written < 0 {
            if !allow_negative {
                return Err(self.err(
                    line_no,
                    format!(
                        "negative (relative) {noun} index {written} is not supported by the \
                         Cornell 2015 OBJ rule; expected an index from 1"
                    ),
                ));
            }
            let back = written.unsigned_abs();
            if back > defined as u64 {
                return Err(self.err(
                    line_no,
                    format!(
                        "relative {noun} index {written} is out of range: only {defined} {noun}(s) \
                         are defined before this line"
                    ),
                ));
            }
            return Ok((defined as u64 - back) as u32);
        }
        let written = written as u64;
        if written > u64::from(u32::MAX) {
            return Err(self.err(
                line_no,
                format!("{noun} index {written} is out of range: indices must fit in 32 bits"),
            ));
        }
        if written > defined as u64 {
            self.pending.push(Pending {
                line: line_no,
                target,
                index: written,
            });
        }
        Ok((written - 1) as u32)
    }

    fn cornell_face(&mut self, line_no: usize, corners: &[&str]) -> Result<(), LoadError> {
        if corners.len() > 3 {
            // The 2015 framework drops polygons; the caller may warn.
            self.skipped += 1;
            return Ok(());
        }
        if corners.len() < 3 {
            return Err(self.err(
                line_no,
                format!("an 'f' line needs 3 vertices, found {}", corners.len()),
            ));
        }
        let mut tri = [0u32; 3];
        for (slot, corner) in tri.iter_mut().zip(corners) {
            let parts: Vec<&str> = corner.split('/').collect();
            let (p, t, n) = match parts.as_slice() {
                [p] => (*p, None, None),
                [p, t] => (*p, Some(*t), None),
                [p, "", n] => (*p, None, Some(*n)),
                [p, t, n] => (*p, Some(*t), Some(*n)),
                _ => {
                    return Err(self.err(
                        line_no,
                        format!(
                            "expected a face vertex of the form p, p/t, p/t/n or p//n, found '{}'",
                            shorten(corner)
                        ),
                    ))
                }
            };
            let p = self.index(line_no, p, Target::Position, false)?;
            let t = match t {
                Some(t) => self.index(line_no, t, Target::Uv, false)?,
                None => NONE,
            };
            let n = match n {
                Some(n) => self.index(line_no, n, Target::Normal, false)?,
                None => NONE,
            };
            let key = (p, t, n);
            *slot = match self.key_index.get(&key) {
                Some(&i) => i,
                None => {
                    let i = u32::try_from(self.keys.len())
                        .map_err(|_| self.err(line_no, "more than 2^32 distinct face vertices"))?;
                    self.keys.push(key);
                    self.key_index.insert(key, i);
                    i
                }
            };
        }
        self.triangles.push(tri);
        Ok(())
    }

    fn fan_face(&mut self, line_no: usize, corners: &[&str]) -> Result<(), LoadError> {
        if corners.len() < 3 {
            return Err(self.err(
                line_no,
                format!(
                    "an 'f' line needs at least 3 vertices, found {}",
                    corners.len()
                ),
            ));
        }
        let mut idx = Vec::with_capacity(corners.len());
        for corner in corners {
            // Only the position index matters; texture and normal indices
            // after a '/' are ignored as embree_trace ignores them.
            let p = corner.split('/').next().unwrap_or("");
            idx.push(self.index(line_no, p, Target::Position, true)?);
        }
        for k in 1..idx.len() - 1 {
            self.triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
        Ok(())
    }

    fn finish(self) -> Result<LoadedMesh, LoadError> {
        // Forward references are in file order, so the first bad one is reported.
        for p in &self.pending {
            let defined = self.defined(p.target);
            if p.index > defined as u64 {
                let noun = p.target.noun();
                return Err(self.err(
                    p.line,
                    format!(
                        "{noun} index {} is out of range: the file defines {defined} {noun}(s) \
                         ('{}' lines)",
                        p.index,
                        p.target.keyword()
                    ),
                ));
            }
        }
        let mesh = match self.rule {
            ObjRule::Fan => MeshData {
                positions: self.positions,
                normals: None,
                uvs: None,
                colors: None,
                triangles: self.triangles,
            },
            ObjRule::Cornell2015 => {
                let positions = self
                    .keys
                    .iter()
                    .map(|&(p, _, _)| self.positions.get(p as usize).copied().unwrap_or_default())
                    .collect();
                let normals = self.any_vn.then(|| {
                    self.keys
                        .iter()
                        .map(|&(_, _, n)| {
                            self.normals.get(n as usize).copied().unwrap_or(Vec3::ZERO)
                        })
                        .collect()
                });
                let uvs = self.any_vt.then(|| {
                    self.keys
                        .iter()
                        .map(|&(_, t, _)| self.uvs.get(t as usize).copied().unwrap_or(Vec2::ZERO))
                        .collect()
                });
                MeshData {
                    positions,
                    normals,
                    uvs,
                    colors: None,
                    triangles: self.triangles,
                }
            }
        };
        Ok(LoadedMesh {
            mesh,
            skipped_polygons: self.skipped,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, rule: ObjRule) -> Result<LoadedMesh, LoadError> {
        parse_obj(text, Path::new("m.obj"), rule)
    }

    fn err(text: &str, rule: ObjRule) -> LoadError {
        parse(text, rule).expect_err("expected an error")
    }

    const BOTH: [ObjRule; 2] = [ObjRule::Cornell2015, ObjRule::Fan];

    #[test]
    fn fan_splits_polygons_in_order() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\n\
                    f 1 2 3\nf 1 2 3 4 5\no x\ng y\nvn 0 0 1\nf 2 3 4\n";
        let m = parse(text, ObjRule::Fan).unwrap();
        assert_eq!(
            m.mesh.triangles,
            vec![[0, 1, 2], [0, 1, 2], [0, 2, 3], [0, 3, 4], [1, 2, 3]]
        );
        assert_eq!(m.mesh.positions.len(), 5);
        assert_eq!(m.mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.skipped_polygons, 0);
        assert!(m.mesh.normals.is_none() && m.mesh.uvs.is_none());
    }

    #[test]
    fn fan_negative_indices_and_slashes() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3/1/1 -2//4 -1/7\nv 5 5 5\nf -4 -1 2\n";
        let m = parse(text, ObjRule::Fan).unwrap();
        assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 3, 1]]);
    }

    #[test]
    fn fan_keeps_duplicate_positions() {
        let text = "v 0 0 0\nv 0 0 0\nv 1 0 0\nf 1 2 3\n";
        let m = parse(text, ObjRule::Fan).unwrap();
        assert_eq!(m.mesh.positions.len(), 3);
    }

    #[test]
    fn fan_negative_index_out_of_range() {
        let e = err("v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", ObjRule::Fan);
        assert_eq!(e.line, Some(3));
        assert!(
            e.message.contains("-3") && e.message.contains("2 vertex"),
            "{e}"
        );
    }

    #[test]
    fn cornell_skips_quads_and_counts_them() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 2 3\nf 1 3 4\nf 1 2 3 4 1\n";
        let m = parse(text, ObjRule::Cornell2015).unwrap();
        assert_eq!(m.skipped_polygons, 2);
        assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.mesh.positions.len(), 4);
    }

    #[test]
    fn cornell_dedups_by_triple_in_first_use_order() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n\
                    f 3/1/1 2/2/1 1/1/1\nf 3/1/1 1/2/1 2//1\n";
        let m = parse(text, ObjRule::Cornell2015).unwrap().mesh;
        // Keys: (3,1,1) (2,2,1) (1,1,1) then (1,2,1) and (2,-,1) are new.
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 3, 4]]);
        assert_eq!(
            m.positions,
            vec![
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::X,
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::X
            ]
        );
        assert_eq!(m.normals.unwrap(), vec![Vec3::Z; 5]);
        let uvs = m.uvs.unwrap();
        assert_eq!(uvs[1], Vec2::X);
        assert_eq!(uvs[4], Vec2::ZERO, "a corner without t gets a zero UV");
    }

    #[test]
    fn cornell_without_vn_or_vt_has_neither() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", ObjRule::Cornell2015).unwrap();
        assert!(m.mesh.normals.is_none() && m.mesh.uvs.is_none());
    }

    #[test]
    fn cornell_token_counts_are_exact() {
        let e = err("v 0 0 0 1\n", ObjRule::Cornell2015);
        assert_eq!(e.line, Some(1));
        assert!(e.message.contains("exactly 3"), "{e}");
        let e = err("v 0 0 0\nvt 0 0 0\n", ObjRule::Cornell2015);
        assert_eq!(e.line, Some(2));
        let e = err("vn 0 0\n", ObjRule::Cornell2015);
        assert!(e.message.contains("'vn'"), "{e}");
        // The fan rule accepts a trailing w.
        assert!(parse("v 0 0 0 1\n", ObjRule::Fan).is_ok());
    }

    #[test]
    fn cornell_rejects_negative_indices() {
        let e = err(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -1 -2 -3\n",
            ObjRule::Cornell2015,
        );
        assert_eq!(e.line, Some(4));
        assert!(e.message.contains("not supported"), "{e}");
    }

    #[test]
    fn cornell_bad_corner_form() {
        let e = err("v 0 0 0\nf 1/1/1/1 1 1\n", ObjRule::Cornell2015);
        assert!(e.message.contains("p/t/n"), "{e}");
    }

    #[test]
    fn index_zero_is_an_error() {
        for rule in BOTH {
            let e = err("v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 0 1 2\n", rule);
            assert_eq!(e.line, Some(5), "{rule:?}");
            assert!(e.message.contains("index 0"), "{e}");
            assert_eq!(e.to_string(), format!("m.obj:5: {}", e.message));
        }
    }

    #[test]
    fn index_out_of_range() {
        for rule in BOTH {
            let e = err("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\nf 1 2 9\n", rule);
            assert_eq!(e.line, Some(4), "{rule:?}: {e}");
            assert!(
                e.message.contains("index 4") && e.message.contains("3 vertex"),
                "{e}"
            );
        }
        let e = err(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/2 2/1 3/1\n",
            ObjRule::Cornell2015,
        );
        assert!(e.message.contains("texture coordinate index 2"), "{e}");
    }

    #[test]
    fn forward_references_resolve() {
        for rule in BOTH {
            let m = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 1 1 0\n", rule).unwrap();
            assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
        }
    }

    #[test]
    fn non_numbers() {
        for rule in BOTH {
            let e = err("v 0 x 0\n", rule);
            assert_eq!(e.line, Some(1));
            assert!(e.message.contains("'x'"), "{e}");
            let e = err("v 0 0 0\nf 1 a 1\n", rule);
            assert_eq!(e.line, Some(2));
            assert!(e.message.contains("'a'"), "{e}");
            let e = err("v 0 0 inf\n", rule);
            assert!(e.message.contains("finite"), "{e}");
        }
    }

    #[test]
    fn too_few_corners() {
        for rule in BOTH {
            let e = err("v 0 0 0\nv 1 0 0\nf 1 2\n", rule);
            assert_eq!(e.line, Some(3));
        }
    }

    #[test]
    fn crlf_comments_exponents_and_empty() {
        let text = "# header\r\nv 8.0E-6 0 0 # trailing\r\nv 1e0 0 0\r\nv 0 1 0\r\n\r\nf 1 2 3\r\n";
        for rule in BOTH {
            let m = parse(text, rule).unwrap();
            assert_eq!(m.mesh.positions[0].x, 8.0e-6f32);
            assert_eq!(m.mesh.triangles.len(), 1);
            let empty = parse("", rule).unwrap();
            assert!(empty.mesh.triangles.is_empty());
        }
    }

    #[test]
    fn missing_file_is_named() {
        let e = load_obj(Path::new("/nonexistent/q.obj"), ObjRule::Fan).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/q.obj: "), "{e}");
    }
}
