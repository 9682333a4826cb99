//! `arbor render`'s overrides (`--spp`, `--size`, `--quick`, `--crop`,
//! `--define`): each gives the very bytes of the matching scene edit, and
//! every bad value fails with exit status 2, one message and no file.

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

/// A 2010 scene (`camera` holds extra camera elements, `top` extra scene
/// elements) or, with `typed`, a 2015 one.
fn scene(typed: bool, camera: &str, top: &str) -> String {
    let kind = if typed {
        r#" type="PerspectiveCamera""#
    } else {
        ""
    };
    format!(
        r#"<?xml version="1.0"?>
<scene>
  <camera{kind}><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance>{camera}</camera>
  {top}
  <shader name="p" type="Phong"><diffuseColor>.9 .3 .1</diffuseColor><specularColor>1 1 1</specularColor><exponent>40</exponent></shader>
  <surface type="Sphere"><shader ref="p"/><radius>0.7</radius></surface>
  <surface type="Box"><minpt>-3 -2 -2</minpt><maxpt>3 -0.8 0</maxpt><shader ref="p"/></surface>
  <light><position>3 4 5</position></light>
</scene>
"#
    )
}

struct Case {
    dir: tempfile::TempDir,
}

impl Case {
    fn new() -> Case {
        Case {
            dir: tempfile::tempdir().unwrap(),
        }
    }

    /// Renders `xml` with `flags` to a PNG; returns its bytes.
    fn render(&self, xml: &str, flags: &[&str]) -> Vec<u8> {
        let d = self.dir.path();
        fs::write(d.join("s.xml"), xml).unwrap();
        let _ = fs::remove_file(d.join("o.png"));
        let mut args = vec!["render", "s.xml", "-q", "-o", "o.png"];
        args.extend_from_slice(flags);
        let o = arbor(d, &args);
        assert!(
            o.status.success(),
            "{flags:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        fs::read(d.join("o.png")).unwrap()
    }

    /// The render of `xml` with `flags` equals the render of `edited`.
    fn same(&self, xml: &str, flags: &[&str], edited: &str) {
        let a = self.render(xml, flags);
        let b = self.render(edited, &[]);
        assert!(a == b, "{flags:?}: differs from the edited scene");
        // And the flag changed something: the test can fail.
        assert!(self.render(xml, &[]) != a, "{flags:?}: changed nothing");
    }

    /// `flags` fail with status 2, one line containing `needle`, no image.
    fn refused(&self, xml: &str, flags: &[&str], needle: &str) {
        let d = self.dir.path();
        fs::write(d.join("s.xml"), xml).unwrap();
        let _ = fs::remove_file(d.join("o.png"));
        let mut args = vec!["render", "s.xml", "-q", "-o", "o.png"];
        args.extend_from_slice(flags);
        let o = arbor(d, &args);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {err}");
        assert!(
            err.contains(needle),
            "{flags:?}: expected {needle:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
        assert!(!d.join("o.png").exists(), "{flags:?} wrote an image");
    }
}

const IMAGE: &str = "<image>16 12</image>";

#[test]
fn spp_size_and_quick_equal_their_scene_edits() {
    let c = Case::new();
    let base = scene(false, "", IMAGE);
    c.same(
        &base,
        &["--spp", "9"],
        &scene(false, "", &format!("{IMAGE}<samples>9</samples>")),
    );
    // The default 2010 view is 1 wide: 32x6 keeps it and is 6/32 high.
    c.same(
        &base,
        &["--size", "32x6"],
        &scene(
            false,
            "<viewHeight>0.1875</viewHeight>",
            "<image>32 6</image>",
        ),
    );
    let sampled = scene(false, "", &format!("{IMAGE}<samples>4</samples>"));
    c.same(
        &sampled,
        &["--quick"],
        &scene(false, "<viewHeight>0.75</viewHeight>", "<image>4 3</image>"),
    );
}

#[test]
fn defines_equal_their_scene_edits() {
    let c = Case::new();
    let base = scene(false, "", IMAGE);
    for (define, camera) in [
        ("viewPoint=0.5,0,5", "<viewPoint>0.5 0 5</viewPoint>"),
        ("viewDir=0.1,0,-1", "<viewDir>0.1 0 -1</viewDir>"),
        ("viewUp=0.2,1,0", "<viewUp>0.2 1 0</viewUp>"),
        ("projDistance=3", "<projDistance>3</projDistance>"),
        ("viewWidth=1.5", "<viewWidth>1.5</viewWidth>"),
        ("viewHeight=0.5", "<viewHeight>0.5</viewHeight>"),
    ] {
        c.same(&base, &["-D", define], &scene(false, camera, IMAGE));
    }
    c.same(
        &base,
        &["--define", "samples=4"],
        &scene(false, "", &format!("{IMAGE}<samples>4</samples>")),
    );
    let typed = scene(true, "", IMAGE);
    c.same(
        &typed,
        &["--define", "exposure=2.5"],
        &scene(true, "", &format!("{IMAGE}<exposure>2.5</exposure>")),
    );
    c.same(
        &typed,
        &["--define", "backColor=0.2,0.3,0.4"],
        &scene(
            true,
            "",
            &format!("{IMAGE}<backColor>0.2 0.3 0.4</backColor>"),
        ),
    );
}

#[test]
fn crop_is_the_window_of_the_full_render() {
    let c = Case::new();
    let base = scene(false, "", IMAGE);
    let full = image::load_from_memory(&c.render(&base, &[]))
        .unwrap()
        .to_rgb8();
    let crop = image::load_from_memory(&c.render(&base, &["--crop", "3,2,13,9"]))
        .unwrap()
        .to_rgb8();
    assert_eq!(crop.dimensions(), (10, 7));
    for (x, y, p) in crop.enumerate_pixels() {
        assert_eq!(p, full.get_pixel(x + 3, y + 2), "pixel {x},{y}");
    }
}

#[test]
fn bad_overrides_are_usage_errors() {
    let c = Case::new();
    let base = scene(false, "", IMAGE);
    for (flags, needle) in [
        (vec!["--spp", "0"], "from 1 to"),
        (vec!["--size", "640"], "WIDTHxHEIGHT"),
        (vec!["--size", "0x4"], "WIDTHxHEIGHT"),
        (vec!["--quick", "--spp", "4"], "cannot be used with"),
        (vec!["--crop", "0,0,17,12"], "outside the 16x12 image"),
        (
            vec!["--crop", "0,0,4,4", "--tile", "0/2"],
            "cannot be used with",
        ),
        (vec!["-D", "colour=1"], "unknown name"),
        (vec!["-D", "samples"], "NAME=VALUE"),
        (vec!["-D", "viewDir=0,0,0"], "other than 0,0,0"),
        (vec!["-D", "viewDir=0,1,0"], "parallel"),
        (vec!["-D", "projDistance=-1"], "above 0"),
        (vec!["-D", "exposure=2"], "only 2015 scenes"),
    ] {
        c.refused(&base, &flags, needle);
    }
}
