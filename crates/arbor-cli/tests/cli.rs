//! The command line across commands, through the real binary: the checks
//! of every output (here), and `arbor render`'s overrides (`overrides`).
//!
//! Every output of every command is checked before the work starts: a
//! missing folder, a folder where a file is expected or a wrong extension
//! fails with exit status 2 and one message naming the path (the cause said
//! once), before the scene is even read, and leaves no file behind, the
//! secondary outputs included.

use std::fs;
use std::path::Path;

mod support;
use support::arbor_in as arbor;

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
    let refusals = [
        (
            "-o",
            "nosuchdir/x.png",
            "cannot write: the folder nosuchdir does not exist",
        ),
        ("-o", "sub", "it is a folder; -o names a file"),
        ("-o", "file/x.png", "file is not a folder"),
        ("--heatmap", "nosuchdir/h.png", "does not exist"),
        ("--heatmap", "h.jpg", "--heatmap writes a .png file"),
        ("-o", "x.jpg", "unknown image format"),
    ];
    for scene in ["s.xml", "bad.xml"] {
        for (flag, target, expect) in refusals {
            refused(d, &["render", scene, "-q", flag, target], target, expect);
        }
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
    // Each names the refused output last.
    let refusals: [(&[&str], &str); 6] = [
        (
            &["merge", "whole.part", "-o", "nosuchdir/m.png"],
            "does not exist",
        ),
        (&["merge", "whole.part", "-o", "sub"], "it is a folder"),
        (
            &["compare", "a.png", "a.png", "--diff", "nosuchdir/d.png"],
            "does not exist",
        ),
        (
            &["compare", "a.png", "a.png", "--diff", "d.txt"],
            "--diff writes a .png file",
        ),
        (
            &["bench", "bad.xml", "--json", "nosuchdir/b.json"],
            "does not exist",
        ),
        (&["bench", "bad.xml", "--plot", "sub"], "it is a folder"),
    ];
    for (args, expect) in refusals {
        refused(d, args, args[args.len() - 1], expect);
    }
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
}

mod overrides {
    //! `arbor render`'s overrides (`--spp`, `--size`, `--quick`, `--crop`,
    //! `--define`): each gives the very bytes of the matching scene edit, and
    //! every bad value fails with exit status 2, one message and no file.

    use std::fs;

    use super::arbor;

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

        /// Runs `arbor render` on `xml` with `flags`, to `o.png` (removed
        /// first).
        fn run(&self, xml: &str, flags: &[&str]) -> std::process::Output {
            let d = self.dir.path();
            fs::write(d.join("s.xml"), xml).unwrap();
            let _ = fs::remove_file(d.join("o.png"));
            let mut args = vec!["render", "s.xml", "-q", "-o", "o.png"];
            args.extend_from_slice(flags);
            arbor(d, &args)
        }

        /// Renders `xml` with `flags` to a PNG; returns its bytes.
        fn render(&self, xml: &str, flags: &[&str]) -> Vec<u8> {
            let d = self.dir.path();
            let o = self.run(xml, flags);
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
            let o = self.run(xml, flags);
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
        // Scene-level values; exposure and backColor need a 2015 scene.
        for (typed, define, top) in [
            (false, "samples=4", "<samples>4</samples>"),
            (true, "exposure=2.5", "<exposure>2.5</exposure>"),
            (
                true,
                "backColor=0.2,0.3,0.4",
                "<backColor>0.2 0.3 0.4</backColor>",
            ),
        ] {
            c.same(
                &scene(typed, "", IMAGE),
                &["--define", define],
                &scene(typed, "", &format!("{IMAGE}{top}")),
            );
        }
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
            (
                vec!["--crop", "0,0,17,12"],
                "--crop 0,0,17,12: outside the 16x12 image",
            ),
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
}
