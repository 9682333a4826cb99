//! Helpers every CLI test file uses: running the built `arbor` binary.
// Each test file is its own crate and uses only some of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the built `arbor` with `args` in the current directory.
pub fn arbor(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_arbor"))
        .args(args)
        .output()
        .expect("run arbor")
}

/// Runs the built `arbor` with `args` in `dir`.
pub fn arbor_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_arbor"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run arbor")
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("test paths are UTF-8")
}

/// `arbor trace --mesh MESH --rays RAYS --hits HITS EXTRA...`.
pub fn trace_args<'a>(
    mesh: &'a Path,
    rays: &'a Path,
    hits: &'a Path,
    extra: &[&'a str],
) -> Vec<&'a str> {
    [
        &[
            "trace",
            "--mesh",
            s(mesh),
            "--rays",
            s(rays),
            "--hits",
            s(hits),
        ],
        extra,
    ]
    .concat()
}

/// The files in `dir` whose extension is one of `extensions`.
pub fn files_ending(dir: &Path, extensions: &[&str]) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| extensions.iter().any(|x| e == *x))
        })
        .collect()
}

/// A temporary folder holding one file, `name`, with `contents`.
pub fn folder_with(name: &str, contents: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), contents).unwrap();
    dir
}

/// The `<defs>` of a deep instancing scene: mesh `m.msh` as `level0`, then
/// `levels` levels, each `per_level` references to the level below,
/// translated by `offset(k, i)` (x and z of reference `i` in level `k`).
pub fn deep_defs(
    levels: usize,
    per_level: usize,
    offset: fn(usize, usize) -> (f64, f64),
) -> String {
    let mut defs =
        String::from(r#"<surface type="Mesh" name="level0"><data>m.msh</data></surface>"#);
    for k in 1..=levels {
        defs += &format!(r#"<surface type="Group" name="level{k}">"#);
        for i in 0..per_level {
            let (x, z) = offset(k, i);
            defs += &format!(
                r#"<surface type="Group"><translate>{x} 0 {z}</translate><surface ref="level{}"/></surface>"#,
                k - 1
            );
        }
        defs += "</surface>\n";
    }
    defs
}
