//! `arbor render --instancing flat|nested|auto` (issue 42): the nested
//! tracer writes the very bytes of the flat one; `auto` keeps small scenes
//! flat; scenes only nesting can render do render; bad input is an input
//! error naming the file and the element, with no picture written.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

mod support;
use support::arbor_in as arbor;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A temporary folder holding `s.xml` and `m.msh`.
fn case(scene: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("s.xml"), scene).unwrap();
    fs::write(dir.path().join("m.msh"), support::fan_msh(12)).unwrap();
    dir
}

/// Renders `s.xml` in `dir` to `out` with `extra` flags; the PNG's bytes.
fn render(dir: &Path, scene: &str, out: &str, extra: &[&str]) -> Vec<u8> {
    let mut args = vec!["render", scene, "-o", out, "--quiet"];
    args.extend(extra);
    let o = arbor(dir, &args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    fs::read(dir.join(out)).unwrap()
}

/// Flat, nested and auto pictures of `scene` in `dir`, checked identical
/// and not blank.
fn assert_all_identical(dir: &Path, scene: &str, extra: &[&str]) {
    let with = |mode: &'static str| [extra, &["--instancing", mode]].concat();
    let flat = render(dir, scene, "flat.png", &with("flat"));
    let nested = render(dir, scene, "nested.png", &with("nested"));
    let auto = render(dir, scene, "auto.png", &with("auto"));
    assert!(flat == nested, "{scene}: flat and nested differ");
    assert!(flat == auto, "{scene}: flat and auto differ");
    let picture = image::load_from_memory(&flat).unwrap().to_rgb8();
    let first = picture.get_pixel(0, 0);
    assert!(picture.pixels().any(|p| p != first), "{scene}: blank");
}

#[test]
fn flat_and_nested_write_the_same_bytes_through_rotations_and_scales() {
    let dir = case(&support::transformed_scene());
    assert_all_identical(dir.path(), "s.xml", &[]);
    // Every accelerator at every level, and more samples.
    for accel in ["list", "bvh-sah", "grid", "kdtree"] {
        assert_all_identical(dir.path(), "s.xml", &["--accel", accel, "--spp", "4"]);
    }
}

/// The issue's deep field at L = 2 and 3 (10^4 and 10^6 bunnies), smaller.
#[test]
fn the_deep_field_is_the_same_flat_and_nested() {
    let Some(mesh) = arbor_test_data::test_b("bunny10k.msh") else {
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    for levels in ["2", "3"] {
        let status = Command::new("python3")
            .arg(root.join("scripts/deep_field.py"))
            .args([levels, "-o", "deep.xml", "--mesh"])
            .arg(&mesh)
            .current_dir(dir.path())
            .status()
            .expect("python3");
        assert!(status.success());
        assert_all_identical(dir.path(), "deep.xml", &["--size", "96x72"]);
    }
}

/// `deep_scene`: `levels` levels of `per_level` translated references to
/// the mesh, the top level placed once.
fn deep_scene(levels: usize, per_level: usize) -> String {
    // Reference `i` of level `k` on a 10-wide grid, spaced 2.5 * 10^(k-1).
    let defs = support::deep_defs(levels, per_level, |k, i| {
        let spacing = 2.5 * 10f64.powi(k as i32 - 1);
        ((i % 10) as f64 * spacing, (i / 10) as f64 * spacing)
    });
    format!(
        r#"<scene><camera><viewPoint>-3 2 -3</viewPoint><viewDir>1 -0.2 1</viewDir><projDistance>1</projDistance></camera>
<image>32 24</image><light><position>3 40 -30</position><intensity>1 1 1</intensity></light><light><position>3 40 30</position><intensity>1 1 1</intensity></light>
<defs>{defs}</defs><surface ref="level{levels}"/></scene>
"#
    )
}

#[test]
fn nine_levels_of_a_hundred_render_by_default_and_flat_refuses() {
    let dir = case(&deep_scene(9, 100));
    let o = arbor(
        dir.path(),
        &["render", "s.xml", "-o", "flat.png", "--instancing", "flat"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the limit is 4194304"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("flat.png").exists());
    let picture = render(dir.path(), "s.xml", "deep.png", &["--stats"]);
    let picture = image::load_from_memory(&picture).unwrap().to_rgb8();
    let first = picture.get_pixel(0, 0);
    assert!(picture.pixels().any(|p| p != first), "blank");
}

/// Runs `arbor render s.xml -o out.png` with `extra` and checks it fails as
/// an input error naming the file and `message`, writing nothing.
fn assert_render_refuses(dir: &Path, extra: &[&str], message: &str) {
    let mut args = vec!["render", "s.xml", "-o", "out.png"];
    args.extend(extra);
    let o = arbor(dir, &args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("s.xml") && err.contains(message), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.join("out.png").exists());
}

#[test]
fn nesting_deeper_than_the_limit_is_an_input_error_naming_the_element() {
    // 32 levels of two over the mesh (33 references deep): too deep for
    // nested instancing (32), too many copies for flat (2^32): auto nests,
    // and refuses.
    let dir = case(&deep_scene(32, 2));
    let message =
        "s.xml: top-level surface 1 (ref): references nest 33 deep from here; nested instancing follows at most 32";
    assert_render_refuses(dir.path(), &[], message);
    assert_render_refuses(dir.path(), &["--instancing", "nested"], message);
    // At the limit it renders.
    let dir = case(&deep_scene(31, 2));
    render(dir.path(), "s.xml", "ok.png", &["--instancing", "nested"]);
}

#[test]
fn a_reference_cycle_is_an_input_error() {
    let scene =
        deep_scene(2, 2).replace(r#"<surface ref="level0"/>"#, r#"<surface ref="level2"/>"#);
    let dir = case(&scene);
    for mode in ["flat", "nested", "auto"] {
        assert_render_refuses(
            dir.path(),
            &["--instancing", mode],
            "definitions form a cycle",
        );
    }
}

#[test]
fn an_unknown_instancing_is_a_usage_error() {
    let dir = case(&deep_scene(1, 2));
    let o = arbor(dir.path(), &["render", "s.xml", "--instancing", "deep"]);
    support::assert_exit_saying(&o, Some(2), "expected flat, nested or auto");
}

#[test]
fn stats_count_the_instance_levels_a_ray_enters() {
    let dir = case(&support::transformed_scene());
    // Three levels of references: a camera ray that meets the field goes
    // through several of them, nested; flat enters one placement at most
    // per copy it meets.
    let nested = support::camera_levels_per_ray(dir.path(), &["--instancing", "nested"]);
    let flat = support::camera_levels_per_ray(dir.path(), &["--instancing", "flat"]);
    assert!(nested > 1.0, "nested: {nested}");
    assert!(flat > 0.0 && flat < nested, "flat {flat}, nested {nested}");
    // Nothing placed by reference: no level is ever entered.
    let plain = case(
        r#"<scene><camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>1</projDistance></camera>
<image>16 12</image><light><position>3 4 5</position><intensity>1 1 1</intensity></light>
<surface type="Sphere"><center>0 0 0</center><radius>1</radius></surface></scene>"#,
    );
    assert_eq!(support::camera_levels_per_ray(plain.path(), &[]), 0.0);
}
