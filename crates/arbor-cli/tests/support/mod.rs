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

/// Asserts that `out` exited with `code` (`None`: any success) and that
/// its standard error says `text`.
pub fn assert_exit_saying(out: &Output, code: Option<i32>, text: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    match code {
        None => assert!(out.status.success(), "{err}"),
        Some(c) => assert_eq!(out.status.code(), Some(c), "{err}"),
    }
    assert!(err.contains(text), "expected {text:?} in: {err}");
}

/// Runs the committed scene generator `scripts/{script}` with `args` and
/// `--mesh` the TEST_B bunny, in `dir`; `false` when the shared test data is
/// absent (the caller skips), panics when the script fails.
pub fn run_scene_script(script: &str, args: &[&str], dir: &Path) -> bool {
    let Some(mesh) = arbor_test_data::test_b("bunny10k.msh") else {
        return false;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let status = Command::new("python3")
        .arg(root.join("scripts").join(script))
        .args(args)
        .arg("--mesh")
        .arg(&mesh)
        .current_dir(dir)
        .status()
        .expect("python3");
    assert!(status.success(), "scripts/{script} failed");
    true
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

/// A small mesh: a fan of `n` triangles around the origin, tilted so no
/// face is edge-on to the camera.
pub fn fan_msh(n: usize) -> String {
    let mut v = vec![0.0, 0.0, 0.0];
    for k in 0..=n {
        let a = k as f64 / n as f64 * 5.0;
        v.extend([a.cos(), a.sin(), 0.3 * a.sin()]);
    }
    let t: Vec<String> = (0..n)
        .flat_map(|k| [0, k + 1, k + 2])
        .map(|i| i.to_string())
        .collect();
    let v: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
    format!(
        "{}\n{n}\nvertices\n{}\ntriangles\n{}\n",
        n + 2,
        v.join("\n"),
        t.join("\n")
    )
}

/// Three levels of references with rotations and non-uniform scales at
/// each, geometry beside the references at the inner levels, placed twice
/// at the top beside a sphere; every level places its child 3 or 4 times.
pub fn transformed_scene() -> String {
    let place = |child: &str, i: usize, spread: f64| {
        format!(
            r#"<surface type="Group"><translate>{} {} {}</translate><rotate>{} {} {}</rotate><scale>{} {} {}</scale><surface ref="{child}"/></surface>"#,
            spread * (i as f64 - 1.5),
            0.3 * i as f64 - 0.4,
            -spread * 0.4 * i as f64,
            17 * i + 5,
            31 * i,
            -23 * i as i64 + 11,
            0.6 + 0.15 * i as f64,
            1.1 - 0.1 * i as f64,
            0.8 + 0.05 * i as f64,
        )
    };
    let level = |name: &str, child: &str, copies: usize, spread: f64, extra: &str| {
        let parts: String = (0..copies).map(|i| place(child, i, spread)).collect();
        format!(
            r#"<surface type="Group" name="{name}"><rotate>0 10 0</rotate>{parts}{extra}</surface>"#
        )
    };
    let ball = r#"<surface type="Sphere"><center>0.2 0.5 0</center><radius>0.3</radius><shader ref="red"/></surface>"#;
    let defs = [
        r#"<surface type="Mesh" name="l0"><shader ref="grey"/><data>m.msh</data></surface>"#
            .to_string(),
        level("l1", "l0", 3, 2.0, ball),
        level("l2", "l1", 4, 5.0, ""),
        level("l3", "l2", 3, 12.0, ball),
    ]
    .concat();
    format!(
        r#"<scene>
<camera><viewPoint>0 6 30</viewPoint><viewDir>0 -0.2 -1</viewDir><projDistance>1</projDistance><viewWidth>1.2</viewWidth><viewHeight>0.9</viewHeight></camera>
<image>64 48</image>
<shader name="grey" type="Phong"><diffuseColor>0.7 0.7 0.7</diffuseColor><specularColor>0.3 0.3 0.3</specularColor><exponent>30</exponent></shader>
<shader name="red" type="Lambertian"><diffuseColor>0.8 0.2 0.1</diffuseColor></shader>
<light><position>10 20 30</position><intensity>1 1 1</intensity></light>
<defs>{defs}</defs>
<surface type="Group"><rotate>0 -20 5</rotate><scale>1 1.3 0.9</scale><surface ref="l3"/></surface>
<surface type="Group"><translate>4 -3 -10</translate><rotate>10 40 0</rotate><surface ref="l3"/></surface>
<surface type="Sphere"><center>0 -1 5</center><radius>1</radius><shader ref="grey"/></surface>
</scene>
"#
    )
}

/// `--stats`' instance levels entered per camera ray, from its
/// `rays camera ... levels/ray` line.
pub fn camera_levels_per_ray(dir: &Path, extra: &[&str]) -> f64 {
    let mut args = vec!["render", "s.xml", "-o", "out.png", "--stats"];
    args.extend(extra);
    let o = arbor_in(dir, &args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("rays camera"))
        .unwrap_or_else(|| panic!("no camera line: {err}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = words.iter().position(|w| *w == "levels/ray").expect(line);
    words[at - 1].parse().expect(line)
}
