//! Every output of every command is checked before the work starts: a
//! missing folder, a folder where a file is expected or a wrong extension
//! fails with exit status 2 and one message naming the path (the cause said
//! once), before the scene is even read, and leaves no file behind, the
//! secondary outputs included.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

fn arbor(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_arbor"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run arbor")
}

const SCENE: &str = r#"<?xml version="1.0"?>
<scene>
  <camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera>
  <image>16 12</image>
  <shader name="red" type="Lambertian"><diffuseColor>1 0 0</diffuseColor></shader>
  <surface type="Sphere"><shader ref="red"/><radius>0.5</radius></surface>
  <light><position>3 4 5</position></light>
</scene>
"#;

/// Every file and folder under `dir`, sorted, as relative paths.
fn listing(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(dir).unwrap().display().to_string());
            if p.is_dir() {
                stack.push(p);
            }
        }
    }
    out.sort();
    out
}

/// A folder with `s.xml` (a good scene), `bad.xml` (not a scene), a folder
/// `sub/` and a file `file`.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("s.xml"), SCENE).unwrap();
    fs::write(dir.path().join("bad.xml"), "<scene>").unwrap();
    fs::create_dir(dir.path().join("sub")).unwrap();
    fs::write(dir.path().join("file"), "x").unwrap();
    dir
}

/// `args` fails with exit status 2 and one line that names `path` and
/// contains `needle` (and no cause twice), leaving the folder as it was.
fn refused(dir: &Path, args: &[&str], path: &str, needle: &str) {
    let before = listing(dir);
    let o = arbor(dir, args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{args:?}: one line: {err}"
    );
    assert!(
        err.starts_with(path),
        "{args:?}: expected {path:?} first: {err}"
    );
    assert!(err.contains(needle), "{args:?}: expected {needle:?}: {err}");
    assert!(
        err.matches("os error").count() <= 1,
        "cause said twice: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(listing(dir), before, "{args:?} left files behind");
}

#[test]
fn render_outputs_are_checked_before_loading() {
    let d = setup();
    let d = d.path();
    // `bad.xml` does not load: the output is refused first.
    for scene in ["s.xml", "bad.xml"] {
        refused(
            d,
            &["render", scene, "-q", "-o", "nosuchdir/x.png"],
            "nosuchdir/x.png",
            "cannot write: the folder nosuchdir does not exist",
        );
        refused(
            d,
            &["render", scene, "-q", "-o", "sub"],
            "sub",
            "it is a folder; -o names a file",
        );
        refused(
            d,
            &["render", scene, "-q", "-o", "file/x.png"],
            "file/x.png",
            "file is not a folder",
        );
        refused(
            d,
            &["render", scene, "-q", "--heatmap", "nosuchdir/h.png"],
            "nosuchdir/h.png",
            "does not exist",
        );
        refused(
            d,
            &["render", scene, "-q", "--heatmap", "h.jpg"],
            "h.jpg",
            "--heatmap writes a .png file",
        );
        refused(
            d,
            &["render", scene, "-q", "-o", "x.jpg"],
            "x.jpg",
            "unknown image format",
        );
    }
    // The good scene with good outputs writes both.
    let o = arbor(
        d,
        &["render", "s.xml", "-q", "-o", "x.png", "--heatmap", "h.png"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("x.png").is_file() && d.join("h.png").is_file());
}

#[test]
fn other_commands_check_their_outputs_first() {
    let d = setup();
    let d = d.path();
    let ok = arbor(d, &["render", "s.xml", "-q", "-o", "whole.part"]);
    assert!(ok.status.success());
    let ok = arbor(d, &["render", "s.xml", "-q", "-o", "a.png"]);
    assert!(ok.status.success());
    refused(
        d,
        &["merge", "whole.part", "-o", "nosuchdir/m.png"],
        "nosuchdir/m.png",
        "does not exist",
    );
    refused(
        d,
        &["merge", "whole.part", "-o", "sub"],
        "sub",
        "it is a folder",
    );
    refused(
        d,
        &["compare", "a.png", "a.png", "--diff", "nosuchdir/d.png"],
        "nosuchdir/d.png",
        "does not exist",
    );
    refused(
        d,
        &["compare", "a.png", "a.png", "--diff", "d.txt"],
        "d.txt",
        "--diff writes a .png file",
    );
    // The farm creates missing folders, but not under a file.
    for (out, needle) in [
        ("file/new/f.png", "file is not a folder"),
        ("sub", "-o names the picture"),
    ] {
        let abs = d.join(out).display().to_string();
        let args = [
            "farm",
            "slurm",
            "bad.xml",
            "--tiles",
            "2",
            "--dry-run",
            "-o",
            out,
        ];
        refused(d, &args, &abs, needle);
    }
    let abs = d.join("file").display().to_string();
    refused(
        d,
        &[
            "farm",
            "slurm",
            "s.xml",
            "bad.xml",
            "--tiles",
            "2",
            "--dry-run",
            "-o",
            "file",
        ],
        &abs,
        "it is a file; -o names a folder",
    );
    refused(
        d,
        &["bench", "bad.xml", "--json", "nosuchdir/b.json"],
        "nosuchdir/b.json",
        "does not exist",
    );
    refused(
        d,
        &["bench", "bad.xml", "--plot", "sub"],
        "sub",
        "it is a folder",
    );
}
