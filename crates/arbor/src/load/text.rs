//! Reading files and quoting their contents in messages, shared by every
//! reader.

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
    fn shorten_cuts_long_tokens_only() {
        assert_eq!(shorten("1.5"), "1.5");
        let long = "x".repeat(100);
        assert_eq!(shorten(&long), format!("{}...", "x".repeat(40)));
    }
}
