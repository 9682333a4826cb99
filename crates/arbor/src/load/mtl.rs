//! MTL material libraries, read by us before `tobj` parses them, so that a
//! library in any byte encoding loads ([`super::text`]), a material without
//! a name is skipped rather than losing the whole library, and every
//! warning names the library file and its line.

use std::io::Cursor;
use std::path::Path;

use std::collections::HashMap;

/// The materials of the library at `path` (as `tobj` gives them), or none
/// when it cannot be used; every problem is a warning naming the library.
pub(super) fn load_library(path: &Path, warnings: &mut Vec<String>) -> Vec<tobj::Material> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) => {
            warnings.push(format!(
                "{}: warning: cannot read the material library ({e}); using the default material",
                path.display()
            ));
            return Vec::new();
        }
    };
    let text = match super::decode_text(&bytes, path) {
        Ok(text) => text,
        Err(e) => {
            warnings.push(format!(
                "{e}; warning: the material library is not used, faces get the default material"
            ));
            return Vec::new();
        }
    };
    let clean = clean(&text, path, warnings);
    match tobj::load_mtl_buf(&mut Cursor::new(clean.as_bytes())) {
        Ok((materials, _)) => materials,
        Err(e) => {
            warnings.push(format!(
                "{}: warning: cannot read the material library ({e}); using the default material",
                path.display()
            ));
            Vec::new()
        }
    }
}

/// The library's text as `tobj` can read it: the lines of a nameless
/// `newmtl` block blanked (with a warning at its line), and colours given
/// as one number (`Ks 0`, which the MTL format allows for grey) written as
/// three. Line numbers are kept.
fn clean(text: &str, path: &Path, warnings: &mut Vec<String>) -> String {
    let mut out = String::with_capacity(text.len());
    let mut skipping = false;
    for (i, raw) in text.split('\n').enumerate() {
        let line = raw.strip_suffix('\r').unwrap_or(raw);
        let body = line.split_once('#').map_or(line, |(b, _)| b);
        let tokens: Vec<&str> = body.split_whitespace().collect();
        match tokens.as_slice() {
            ["newmtl"] => {
                warnings.push(format!(
                    "{}:{}: warning: a material with no name ('newmtl' alone) is skipped",
                    path.display(),
                    i + 1
                ));
                skipping = true;
            }
            ["newmtl", ..] => {
                skipping = false;
                out.push_str(line);
            }
            _ if skipping => {}
            [key @ ("Ka" | "Kd" | "Ks" | "Ke" | "Tf"), grey] => {
                out.push_str(&format!("{key} {grey} {grey} {grey}"));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The material names to indices, as `tobj` wants them back from a loader.
pub(super) fn index(materials: &[tobj::Material]) -> HashMap<String, usize> {
    materials
        .iter()
        .enumerate()
        .map(|(i, m)| (m.name.clone(), i))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nameless_materials_are_skipped_with_their_line() {
        let mut w = Vec::new();
        let text = "newmtl \nKd 1 0 0\nnewmtl blue\nKd 0 0 1\nKs 0\n";
        let out = clean(text, Path::new("lib.mtl"), &mut w);
        assert_eq!(out, "\n\nnewmtl blue\nKd 0 0 1\nKs 0 0 0\n\n");
        assert_eq!(
            w,
            ["lib.mtl:1: warning: a material with no name ('newmtl' alone) is skipped"]
        );
    }
}
