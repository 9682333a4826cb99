//! The one error type of loading: the file, where in it, and what was
//! expected.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error while reading any file arbor loads (scene, mesh or model): the
/// file, the 1-based line and column when they apply, and what was
/// expected. Displays as `FILE:LINE:COL: message`, `FILE:LINE: message` or
/// `FILE: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line, when the error belongs to one.
    pub line: Option<usize>,
    /// 1-based column, when the reader knows it (XML scenes).
    pub column: Option<usize>,
    /// What went wrong and what was expected.
    pub message: String,
}

impl LoadError {
    /// An error at `line` (1-based) of `path`.
    pub fn at(path: &Path, line: usize, message: impl Into<String>) -> Self {
        LoadError {
            path: path.to_path_buf(),
            line: Some(line),
            column: None,
            message: message.into(),
        }
    }

    /// An error at `line` and `column` (both 1-based) of `path`.
    pub fn at_column(path: &Path, line: usize, column: usize, message: impl Into<String>) -> Self {
        LoadError {
            column: Some(column),
            ..LoadError::at(path, line, message)
        }
    }

    /// An error about the file as a whole.
    pub fn file(path: &Path, message: impl Into<String>) -> Self {
        LoadError {
            path: path.to_path_buf(),
            line: None,
            column: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = self.path.display();
        match (self.line, self.column) {
            (Some(line), Some(column)) => write!(f, "{path}:{line}:{column}: {}", self.message),
            (Some(line), None) => write!(f, "{path}:{line}: {}", self.message),
            _ => write!(f, "{path}: {}", self.message),
        }
    }
}

impl std::error::Error for LoadError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn displays_the_place_it_knows() {
        let p = Path::new("a.obj");
        assert_eq!(LoadError::file(p, "empty").to_string(), "a.obj: empty");
        assert_eq!(LoadError::at(p, 3, "bad").to_string(), "a.obj:3: bad");
        assert_eq!(
            LoadError::at_column(p, 3, 7, "bad").to_string(),
            "a.obj:3:7: bad"
        );
    }
}
