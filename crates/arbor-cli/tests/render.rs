//! `arbor render` and `arbor compare` through the real binary: outputs,
//! determinism, and every bad-input path (exit status 2, one located error
//! line, no output file, never a panic).

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

mod support;
use support::arbor_in as arbor;
use support::files_ending;
use support::run_scene_script;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small valid 2010 scene with a box, a sphere and a mesh; `body` is
/// spliced into the scene element.
fn scene_2010(body: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<scene>
  <camera>
    <viewPoint>0 0 5</viewPoint>
    <viewDir>0 0 -1</viewDir>
    <projDistance>2</projDistance>
  </camera>
  <image>16 12</image>
  <shader name="red" type="Lambertian"><diffuseColor>1 0 0</diffuseColor></shader>
  <surface type="Sphere"><shader ref="red"/><radius>0.5</radius></surface>
  <light><position>3 4 5</position></light>
{body}
</scene>
"#
    )
}

const TRIANGLE_MSH: &str = "3\r\n1\r\nvertices\r\n0\r\n0\r\n0\r\n1\r\n0\r\n0\r\n0\r\n1\r\n0\r\ntriangles\r\n0\r\n1\r\n2\r\n";

struct Case {
    dir: tempfile::TempDir,
}

impl Case {
    fn new(xml: &str) -> Case {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("s.xml"), xml).unwrap();
        fs::write(dir.path().join("tri.msh"), TRIANGLE_MSH).unwrap();
        Case { dir }
    }

    fn path(&self) -> &Path {
        self.dir.path()
    }

    fn render(&self, extra: &[&str]) -> Output {
        let mut args = vec!["render", "s.xml", "-q"];
        args.extend_from_slice(extra);
        arbor(self.path(), &args)
    }

    /// The render fails with exit status 2, a single error line that starts
    /// with `location` and contains `needle`, and writes no image.
    fn expect_error(&self, location: &str, needle: &str) {
        let out = self.render(&[]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "stderr: {err}");
        assert!(
            err.starts_with(location),
            "expected {location:?} at the start of: {err}"
        );
        assert!(err.contains(needle), "expected {needle:?} in: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
        assert!(!err.contains("panicked"), "{err}");
        let left = files_ending(self.path(), &["png", "tmp"]);
        assert!(left.is_empty(), "no output expected, found {left:?}");
    }
}

/// [`Case::expect_error`] for a 2010 scene with `body` added.
fn scene_error(body: &str, location: &str, needle: &str) {
    Case::new(&scene_2010(body)).expect_error(location, needle);
}

/// Asserts exit status 2 and `needle` in the message.
fn assert_exit_2_saying(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(out).contains(needle), "{}", stderr(out));
}

#[test]
fn renders_scene_to_stem_png_in_current_directory() {
    let case = Case::new(&scene_2010(""));
    let out = case.render(&[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let img = image::open(case.path().join("s.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (16, 12));
    // The sphere is lit red in the middle, the corners are black.
    assert!(img.get_pixel(8, 6).0[0] > 100);
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
}

#[test]
fn default_scene_renders_and_says_where() {
    let dir = tempfile::tempdir().unwrap();
    let out = arbor(dir.path(), &["render"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("arbor.png"), "{}", stderr(&out));
    let img = image::open(dir.path().join("arbor.png")).unwrap().to_rgb8();
    assert!(img.width() >= 320);
    // Not a blank picture: many distinct colours.
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort();
    colours.dedup();
    assert!(colours.len() > 1000, "{} colours", colours.len());
}

#[test]
fn exr_output_and_same_bytes_for_any_thread_count() {
    let case = Case::new(&scene_2010(
        r#"<surface type="Mesh"><data>tri.msh</data></surface>"#,
    ));
    for (threads, name) in [("1", "one.png"), ("2", "two.png"), ("3", "three.png")] {
        let out = case.render(&["--threads", threads, "-o", name]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let one = fs::read(case.path().join("one.png")).unwrap();
    assert_eq!(one, fs::read(case.path().join("two.png")).unwrap());
    assert_eq!(one, fs::read(case.path().join("three.png")).unwrap());
    let out = case.render(&["-o", "linear.EXR"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = fs::read(case.path().join("linear.EXR")).unwrap();
    assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "OpenEXR magic");
}

#[test]
fn every_accelerator_gives_the_same_image() {
    let case = Case::new(&scene_2010(
        r#"<surface type="Mesh"><data>tri.msh</data></surface>
           <surface type="Box"><minPt>-2 -2 -2</minPt><maxPt>2 -1.5 2</maxPt></surface>"#,
    ));
    let reference = {
        assert!(case
            .render(&["--accel", "list", "-o", "list.png"])
            .status
            .success());
        fs::read(case.path().join("list.png")).unwrap()
    };
    for kind in arbor_accel::AccelKind::ALL {
        let name = format!("{kind}.png");
        let out = case.render(&["--accel", kind.name(), "-o", &name]);
        assert!(out.status.success(), "{kind}: {}", stderr(&out));
        assert_eq!(
            fs::read(case.path().join(&name)).unwrap(),
            reference,
            "{kind}"
        );
    }
}

#[test]
fn unknown_attribute_is_only_a_warning() {
    let case = Case::new(&scene_2010(r#"<surface type="Sphere" colour="blue"/>"#));
    let out = arbor(case.path(), &["render", "s.xml"]);
    let warning = "s.xml:12:1: warning: ignoring unknown attribute 'colour'";
    support::assert_exit_saying(&out, None, warning);
}

#[test]
fn unknown_element_names_parent_and_expected_children() {
    Case::new(&scene_2010(
        r#"<surface type="Box"><minpts>0 0 0</minpts></surface>"#,
    ))
    .expect_error(
        "s.xml:12:21: ",
        r#"unknown element <minpts> in <surface type="Box">; expected minPt, maxPt, shader"#,
    );
}

#[test]
fn element_names_are_case_insensitive() {
    let case = Case::new(&scene_2010(
        r#"<SURFACE type="Box"><MINPT>0 0 0</MINPT><maxpt>1 1 1</maxpt></SURFACE>"#,
    ));
    assert!(case.render(&[]).status.success());
}

#[test]
fn number_that_does_not_parse() {
    scene_error(
        r#"<surface type="Sphere"><radius>1.2.3</radius></surface>"#,
        "s.xml:12:24: ",
        "<radius>: expected a number, found '1.2.3'",
    );
}

#[test]
fn vector_with_wrong_count() {
    scene_error(
        r#"<surface type="Sphere"><center>1 2</center></surface>"#,
        "s.xml:12:24: ",
        "expected 3 numbers, found 2",
    );
}

#[test]
fn ref_to_undefined_name() {
    scene_error(
        r#"<surface type="Sphere"><shader ref="blue"/></surface>"#,
        "s.xml:12:24: ",
        "no element named 'blue' is defined before this point",
    );
}

#[test]
fn reference_cycle_in_defs() {
    scene_error(
        r#"<defs><surface type="Group" name="a"><surface ref="b"/></surface>
<surface type="Group" name="b"><surface ref="a"/></surface></defs>"#,
        "s.xml:12:7: ",
        "definitions form a cycle: a -> b -> a",
    );
}

#[test]
fn too_many_instances() {
    let case = Case::new(&scene_2010(
        r#"<defs><surface type="Sphere" name="a"/></defs>
<surface ref="a"/><surface ref="a"/><surface ref="a"/>"#,
    ));
    let out = case.render(&["--max-instances", "2"]);
    assert_exit_2_saying(&out, "places shared surfaces 3 times; the limit is 2");
    // The command names its flag; the library's message does not.
    assert_exit_2_saying(&out, "(raise it with --max-instances)");
    assert!(case.render(&["--max-instances", "3"]).status.success());
}

#[test]
fn unknown_types() {
    scene_error(
        r#"<surface type="Torus"/>"#,
        "s.xml:12:1: ",
        "unknown surface type 'Torus'; expected one of Sphere, Box, Mesh, Group",
    );
    scene_error(
        r#"<shader type="Toon"/>"#,
        "s.xml:12:1: ",
        "unknown shader type 'Toon'",
    );
    scene_error(
        r#"<light type="SpotLight"/>"#,
        "s.xml:12:1: ",
        "unknown light type 'SpotLight'",
    );
    Case::new(&scene_2010("").replace("<camera>", r#"<camera type="FisheyeCamera">"#))
        .expect_error("s.xml:3:3: ", "unknown camera type 'FisheyeCamera'");
}

#[test]
fn missing_mesh_file() {
    scene_error(
        r#"<surface type="Mesh"><data>nothere.msh</data></surface>"#,
        "s.xml:12:22: ",
        "mesh file",
    );
}

#[test]
fn mesh_index_out_of_range_names_mesh_file_and_line() {
    let case = Case::new(&scene_2010(
        r#"<surface type="Mesh"><data>bad.msh</data></surface>"#,
    ));
    fs::write(
        case.path().join("bad.msh"),
        TRIANGLE_MSH.replace("triangles\r\n0\r\n1\r\n2", "triangles\r\n0\r\n1\r\n7"),
    )
    .unwrap();
    // The mesh file is named as the scene names it, relative to the scene.
    case.expect_error("bad.msh:16: ", "vertex index 7 is out of range");
}

#[test]
fn missing_and_unreadable_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = arbor(dir.path(), &["render", "none.xml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).starts_with("none.xml: cannot read scene file"),
        "{}",
        stderr(&out)
    );
    let out = arbor(dir.path(), &["render", "."]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
}

#[test]
fn truncated_xml() {
    let xml = scene_2010("");
    Case::new(&xml[..xml.len() / 2]).expect_error("s.xml:", "malformed XML");
}

#[test]
fn missing_camera_or_image() {
    let xml = scene_2010("");
    let start = xml.find("<camera>").unwrap();
    let end = xml.find("</camera>").unwrap() + "</camera>".len();
    Case::new(&format!("{}{}", &xml[..start], &xml[end..]))
        .expect_error("s.xml:2:1: ", "the scene has no <camera>");
    Case::new(&xml.replace("<image>16 12</image>", ""))
        .expect_error("s.xml:2:1: ", "the scene has no <image>");
}

#[test]
fn out_of_range_values() {
    Case::new(&scene_2010("").replace("16 12", "200000 200000"))
        .expect_error("s.xml:8:3: ", "out of range");
    Case::new(&scene_2010("").replace("16 12", "-4 12"))
        .expect_error("s.xml:8:3: ", "out of range");
    scene_error(
        "<samples>4000000000</samples>",
        "s.xml:12:1: ",
        "<samples> must be between",
    );
    scene_error(
        r#"<surface type="Sphere"><radius>-1</radius></surface>"#,
        "s.xml:12:24: ",
        "must be positive",
    );
}

#[test]
fn variant_specific_elements() {
    scene_error("<exposure>2</exposure>", "s.xml:12:1: ", "2015 variant");
    scene_error(
        r#"<surface type="Cylinder"/>"#,
        "s.xml:12:1: ",
        "unknown surface type 'Cylinder'",
    );
}

#[test]
fn glazed_needs_index_and_substrate() {
    scene_error(
        r#"<shader type="Glazed"><refractiveIndex>1.5</refractiveIndex></shader>"#,
        "s.xml:12:1: ",
        "needs a <substrate>",
    );
    scene_error(
        r#"<shader type="Glazed"><substrate type="Lambertian"/><fresnel>fast</fresnel></shader>"#,
        "s.xml:12:53: ",
        "<fresnel> must be 'schlick' or 'exact'",
    );
}

#[test]
fn unknown_output_format() {
    let case = Case::new(&scene_2010(""));
    let out = case.render(&["-o", "out.jpg"]);
    assert_exit_2_saying(&out, "unknown image format");
}

#[test]
fn unknown_accelerator_is_a_usage_error() {
    let case = Case::new(&scene_2010(""));
    let out = case.render(&["--accel", "octree"]);
    assert_exit_2_saying(&out, "unknown accelerator 'octree'");
}

#[test]
fn compare_reports_and_enforces_thresholds() {
    let case = Case::new(&scene_2010(""));
    assert!(case.render(&["-o", "a.png"]).status.success());
    let out = arbor(
        case.path(),
        &[
            "compare",
            "a.png",
            "a.png",
            "--diff",
            "d.png",
            "--min-psnr",
            "40",
        ],
    );
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("psnr inf dB"));
    assert!(case.path().join("d.png").exists());
    // A different picture fails the threshold.
    let other = Case::new(&scene_2010("").replace("1 0 0", "0 1 0"));
    assert!(other.render(&["-o", "b.png"]).status.success());
    fs::copy(other.path().join("b.png"), case.path().join("b.png")).unwrap();
    let out = arbor(
        case.path(),
        &["compare", "a.png", "b.png", "--min-psnr", "40"],
    );
    assert_eq!(out.status.code(), Some(1));
    // Different sizes and unreadable files are input errors.
    fs::write(case.path().join("junk.png"), b"not a png").unwrap();
    assert_eq!(
        arbor(case.path(), &["compare", "a.png", "junk.png"])
            .status
            .code(),
        Some(2)
    );
}

#[test]
fn info_reports_hierarchy_and_instancing() {
    let case = Case::new(&scene_2010(
        r#"<defs><surface type="Mesh" name="tri"><data>tri.msh</data></surface></defs>
<surface type="Group"><translate>1 0 0</translate><surface ref="tri"/></surface>
<surface type="Group"><translate>-1 0 0</translate><surface ref="tri"/></surface>"#,
    ));
    let out = arbor(case.path(), &["info", "s.xml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [
        "image       16x12, 1 sample per pixel",
        "primitives  2 unique",
        "placements  2 of shared geometry",
        "as placed   3 primitives",
        "instance of #1:",
        "mesh 1 triangle, 3 vertices",
        "instance of #1 (shown above)",
    ] {
        assert!(text.contains(line), "missing {line:?} in:\n{text}");
    }
    let out = arbor(case.path(), &["info", "missing.xml"]);
    assert_eq!(out.status.code(), Some(2));
}

/// The committed generator of the instancing stress scene still produces a
/// scene that arbor loads, with the placement counts it promises.
#[test]
fn bunny_field_generator_makes_a_nested_instanced_scene() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "--per-level",
        "4",
        "--width",
        "32",
        "--height",
        "24",
        "-o",
        "f.xml",
    ];
    if !run_scene_script("bunny_field.py", &args, dir.path()) {
        return;
    }
    let out = arbor(dir.path(), &["info", "f.xml", "--depth", "2"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("placements  64 of shared geometry"), "{text}");
    // 4^3 bunnies of 10,000 triangles, plus the ground (a 2015 box: 12 triangles).
    assert!(text.contains("as placed   640012 primitives"), "{text}");
    let out = arbor(dir.path(), &["render", "f.xml", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// A scene slow enough under brute force to be interrupted mid-render.
fn slow_scene() -> String {
    let mut body = String::new();
    for i in 0..6000 {
        let (x, y) = ((i % 100) as f64 * 0.03 - 1.5, (i / 100) as f64 * 0.04 - 1.2);
        body.push_str(&format!(
            r#"<surface type="Sphere"><center>{x} {y} 0</center><radius>0.03</radius></surface>"#
        ));
    }
    scene_2010(&body).replace("16 12", "600 400")
}

/// Starts `arbor render s.xml -q --accel list -o slow.png EXTRA...` in
/// `case`'s folder, its stderr captured.
fn spawn_slow_render(case: &Case, extra: &[&str]) -> std::process::Child {
    let mut args = vec!["render", "s.xml", "-q", "--accel", "list", "-o", "slow.png"];
    args.extend_from_slice(extra);
    Command::new(env!("CARGO_BIN_EXE_arbor"))
        .args(&args)
        .current_dir(case.path())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// Sends `signal` (`-INT`, `-USR1`) to `child`.
fn signal(child: &std::process::Child, signal: &str) {
    let status = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

/// Interrupts `child` and checks that it reports writing no image and
/// leaves no preview at `out`.
fn interrupt_leaves_no_preview(child: std::process::Child, out: &Path) {
    signal(&child, "-INT");
    let o = child.wait_with_output().unwrap();
    assert!(
        stderr(&o).contains("interrupted: no image written"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists(), "the preview was left behind");
}

fn interrupt_after(
    case: &Case,
    extra: &[&str],
    wait: std::time::Duration,
) -> (Output, std::time::Duration) {
    let child = spawn_slow_render(case, extra);
    std::thread::sleep(wait);
    let sent = std::time::Instant::now();
    signal(&child, "-INT");
    let out = child.wait_with_output().unwrap();
    (out, sent.elapsed())
}

#[test]
fn ctrl_c_stops_within_a_second_and_leaves_no_file() {
    let case = Case::new(&slow_scene());
    let (out, took) = interrupt_after(&case, &[], std::time::Duration::from_millis(800));
    assert!(took < std::time::Duration::from_secs(1), "took {took:?}");
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("interrupted: no image written"),
        "{}",
        stderr(&out)
    );
    let names: Vec<_> = fs::read_dir(case.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        names.iter().all(|n| !n.to_string_lossy().contains("slow")),
        "{names:?}"
    );
    // With --partial, the finished tiles are written.
    let (out, _) = interrupt_after(
        &case,
        &["--partial"],
        std::time::Duration::from_millis(1500),
    );
    assert!(stderr(&out).contains("--partial"), "{}", stderr(&out));
    let img = image::open(case.path().join("slow.png")).unwrap();
    assert_eq!((img.width(), img.height()), (600, 400));
}

/// The hostile inputs of the hardening issue: each one a clean error (exit 2,
/// located message, no output) within a second, with nothing large allocated
/// on the promise of a header.
#[test]
fn hostile_inputs_fail_fast() {
    let huge_msh = "2000000000\r\n1\r\nvertices\r\n0\r\n0\r\n0\r\ntriangles\r\n0\r\n0\r\n0\r\n";
    let cam2015 = r#"<camera type="PerspectiveCamera"><viewPoint>0 0 5</viewPoint></camera>"#;
    let cases: Vec<(String, &str, &str)> = vec![
        (
            scene_2010("").replace("16 12", "200000 200000"),
            "s.xml:8:3: ",
            "out of range",
        ),
        (
            scene_2010("<samples>4000000000</samples>"),
            "s.xml:12:1: ",
            "<samples> must be between",
        ),
        (
            scene_2010("").replace("16 12", "-16 12"),
            "s.xml:8:3: ",
            "out of range",
        ),
        (
            scene_2010(
                r#"<defs><surface type="Group" name="a"><surface ref="a"/></surface></defs>"#,
            ),
            "s.xml:12:7: ",
            "cycle: a -> a",
        ),
        (
            scene_2010(r#"<surface type="Mesh"><data>huge.msh</data></surface>"#),
            "huge.msh:",
            "header",
        ),
        (
            format!(
                r#"<scene>{cam2015}<image>8 8</image><surface type="Mesh"><data>zero.obj</data></surface></scene>"#
            ),
            "zero.obj:4: ",
            "OBJ indices start at 1",
        ),
        (
            format!(
                r#"<scene>{cam2015}<image>8 8</image><surface type="Mesh"><data>far.obj</data></surface></scene>"#
            ),
            "far.obj:4: ",
            "out of range",
        ),
    ];
    for (xml, location, needle) in cases {
        let case = Case::new(&xml);
        fs::write(case.path().join("huge.msh"), huge_msh).unwrap();
        fs::write(
            case.path().join("zero.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        )
        .unwrap();
        fs::write(
            case.path().join("far.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        )
        .unwrap();
        let start = std::time::Instant::now();
        case.expect_error(location, needle);
        assert!(
            start.elapsed() < std::time::Duration::from_secs(1),
            "{location}: {:?}",
            start.elapsed()
        );
    }
}

/// Waits until the running render `child` has written `out`, asserting
/// (with `ended`) that it is still running meanwhile; returns the picture,
/// which must be whole and valid. A deadline only so that a broken preview
/// fails instead of hanging.
fn wait_for_preview(
    child: &mut std::process::Child,
    out: &Path,
    ended: &str,
) -> image::DynamicImage {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::time::Instant::now() < deadline {
        assert!(child.try_wait().unwrap().is_none(), "{ended}");
        if out.exists() {
            return image::open(out).expect("a whole, valid PNG");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    panic!("no preview appeared");
}

/// `--preview-every`: while the render runs, the output appears as a whole,
/// valid picture of the full size; interrupted without `--partial`, it is
/// removed again. A preview with a `.part` output is refused.
#[test]
fn preview_appears_while_rendering_and_goes_on_interrupt() {
    let case = Case::new(&slow_scene());
    let out = case.path().join("slow.png");
    let mut child = spawn_slow_render(&case, &["--preview-every", "0.2"]);
    let img = wait_for_preview(&mut child, &out, "finished before any preview");
    assert_eq!((img.width(), img.height()), (600, 400));
    interrupt_leaves_no_preview(child, &out);
    let o = case.render(&["--preview-every", "1", "-o", "x.part"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--preview-every writes pictures"));
    let o = case.render(&["--preview-every", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// SIGUSR1 asks a running render for its picture so far, without
/// `--preview-every`: a whole, valid picture appears at the output while
/// the render goes on, and an interrupt removes it again.
#[cfg(target_os = "linux")]
#[test]
fn sigusr1_writes_a_preview() {
    let case = Case::new(&slow_scene());
    let out = case.path().join("slow.png");
    let mut child = spawn_slow_render(&case, &[]);
    // The handler is installed before the scene is read; give the process
    // time to get there, and check that nothing is written unasked.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "finished too soon");
    assert!(!out.exists(), "a picture appeared before it was asked for");
    signal(&child, "-USR1");
    let img = wait_for_preview(
        &mut child,
        &out,
        "ended before writing a preview (SIGUSR1 not caught?)",
    );
    assert_eq!((img.width(), img.height()), (600, 400));
    interrupt_leaves_no_preview(child, &out);
}
