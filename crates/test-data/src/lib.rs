//! Where arbor's tests find data that is not in the repository: the shared
//! folder (the Cornell course scenes and meshes, the peers' files) and
//! Debian's `assimp-testmodels`.
//!
//! - The shared folder is `../shared` beside the repository, or wherever
//!   `ARBOR_SHARED` points.
//! - The assimp models are in `/usr/share/assimp/models`, or wherever
//!   `ARBOR_ASSIMP_MODELS` points.
//!
//! A test asks for what it needs and returns early on `None`: the data is
//! absent, and the helper has printed that the test is skipped. With
//! `ARBOR_REQUIRE_TEST_DATA=1` (as CI sets) absent data fails the test
//! instead, so a CI run cannot pass by skipping.

#![warn(missing_docs)]

use std::path::{Path, PathBuf};

/// The shared folder, whether or not it exists: `ARBOR_SHARED`, else
/// `../shared` beside the repository.
pub fn shared_root() -> PathBuf {
    match std::env::var_os("ARBOR_SHARED") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared"),
    }
}

/// `relative` under the shared folder (a file or a folder), or `None` after
/// printing why when it is absent (a failed test instead when
/// [`required`]).
pub fn shared(relative: &str) -> Option<PathBuf> {
    present(
        shared_root().join(relative),
        "the shared test data: ../shared beside the repository, or ARBOR_SHARED",
        required(),
    )
}

/// A mesh or scene file of the Cornell 2010 `TEST_B` set
/// (`scenes/cornell-2010/TEST_B/NAME` under the shared folder), as
/// [`shared`] finds it.
pub fn test_b(name: &str) -> Option<PathBuf> {
    shared(&format!("scenes/cornell-2010/TEST_B/{name}"))
}

/// The assimp test models folder (`ARBOR_ASSIMP_MODELS`, else
/// `/usr/share/assimp/models`), or `None` after printing why when it is
/// absent (a failed test instead when [`required`]).
pub fn assimp_models() -> Option<PathBuf> {
    let dir = std::env::var_os("ARBOR_ASSIMP_MODELS")
        .map_or_else(|| PathBuf::from("/usr/share/assimp/models"), PathBuf::from);
    present(dir, "apt-get install assimp-testmodels", required())
}

/// The assimp test model at `relative` (under [`assimp_models`]), or
/// `None` as [`assimp_models`] says.
pub fn assimp_model(relative: &str) -> Option<PathBuf> {
    assimp_models().map(|models| models.join(relative))
}

/// Whether absent test data fails the test (`ARBOR_REQUIRE_TEST_DATA=1`)
/// rather than skipping it.
pub fn required() -> bool {
    std::env::var("ARBOR_REQUIRE_TEST_DATA").as_deref() == Ok("1")
}

/// `path` if it exists; else says why the caller skips, or fails when the
/// data is `required`.
fn present(path: PathBuf, where_from: &str, required: bool) -> Option<PathBuf> {
    if path.exists() {
        return Some(path);
    }
    assert!(
        !required,
        "ARBOR_REQUIRE_TEST_DATA=1 but {} is missing ({where_from})",
        path.display()
    );
    eprintln!("skipping: {} is absent ({where_from})", path.display());
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn present_data_is_found_and_absent_data_skips() {
        let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(present(here.clone(), "", false), Some(here.clone()));
        assert_eq!(present(here.clone(), "", true), Some(here.clone()));
        assert_eq!(present(here.join("no such file"), "", false), None);
    }

    #[test]
    #[should_panic(expected = "ARBOR_REQUIRE_TEST_DATA=1 but")]
    fn absent_required_data_fails() {
        present(
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("no such file"),
            "",
            true,
        );
    }
}
