//! Reading files and quoting their contents in messages, shared by every
//! reader.

use std::borrow::Cow;
use std::path::Path;

use super::LoadError;

/// Reads a whole text file. Bytes that are not UTF-8 become U+FFFD: they can
/// only matter where a number is expected, and there they fail with a
/// line-accurate error, while stray bytes in comments stay harmless.
pub(super) fn read_text(path: &Path) -> Result<String, LoadError> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(match String::from_utf8(bytes) {
            Ok(text) => text,
            Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
        }),
        Err(e) => Err(LoadError::file(
            path,
            format!("cannot read the mesh file: {e}"),
        )),
    }
}

/// Reads a whole file, naming it in the error.
pub(super) fn read_bytes(path: &Path) -> Result<Vec<u8>, LoadError> {
    std::fs::read(path).map_err(|e| LoadError::file(path, format!("cannot read the file: {e}")))
}

/// The text of a file's bytes, whatever their encoding: UTF-16 (either byte
/// order) when a byte-order mark says so, UTF-8 (its byte-order mark
/// dropped) when the bytes are valid UTF-8, Latin-1 otherwise, so that every
/// byte is read and names written in a legacy encoding compare equal
/// wherever they appear in files of the same encoding.
pub(super) fn decode_text<'a>(bytes: &'a [u8], path: &Path) -> Result<Cow<'a, str>, LoadError> {
    let utf16 = match bytes {
        [0xff, 0xfe, rest @ ..] => Some((rest, u16::from_le_bytes as fn([u8; 2]) -> u16)),
        [0xfe, 0xff, rest @ ..] => Some((rest, u16::from_be_bytes as fn([u8; 2]) -> u16)),
        _ => None,
    };
    if let Some((rest, unit)) = utf16 {
        let bad = || {
            LoadError::file(
                path,
                "the file starts with a UTF-16 byte-order mark but is not valid UTF-16",
            )
        };
        if rest.len() % 2 != 0 {
            return Err(bad());
        }
        let units: Vec<u16> = rest.chunks_exact(2).map(|c| unit([c[0], c[1]])).collect();
        return String::from_utf16(&units)
            .map(Cow::Owned)
            .map_err(|_| bad());
    }
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    Ok(match std::str::from_utf8(bytes) {
        Ok(text) => Cow::Borrowed(text),
        Err(_) => Cow::Owned(bytes.iter().map(|&b| b as char).collect()),
    })
}

/// A token cut to a readable length for an error message (a malformed file
/// may have a megabyte on one line).
pub(super) fn shorten(token: &str) -> String {
    const MAX: usize = 40;
    if token.chars().count() <= MAX {
        token.to_string()
    } else {
        let cut: String = token.chars().take(MAX).collect();
        format!("{cut}...")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_in_any_encoding() {
        let p = Path::new("t.obj");
        assert_eq!(decode_text(b"\xef\xbb\xbfv 1", p).unwrap(), "v 1");
        // Latin-1: every byte is the character of that number.
        assert_eq!(
            decode_text(b"newmtl caf\xe9", p).unwrap(),
            "newmtl caf\u{e9}"
        );
        let be: Vec<u8> = [0xfe, 0xff, 0, b'v', 0, b' ', 0, b'1'].to_vec();
        assert_eq!(decode_text(&be, p).unwrap(), "v 1");
        let le: Vec<u8> = [0xff, 0xfe, b'v', 0, b' ', 0, b'1', 0].to_vec();
        assert_eq!(decode_text(&le, p).unwrap(), "v 1");
        let e = decode_text(&[0xfe, 0xff, 0], p).unwrap_err();
        assert!(
            e.to_string().starts_with("t.obj: ") && e.message.contains("UTF-16"),
            "{e}"
        );
    }

    #[test]
    fn shorten_cuts_long_tokens_only() {
        assert_eq!(shorten("1.5"), "1.5");
        let long = "x".repeat(100);
        assert_eq!(shorten(&long), format!("{}...", "x".repeat(40)));
    }
}
