//! Partial renders and `arbor merge` through the real binary, no scheduler
//! needed: tiles and regions merged give the very bytes of a full render
//! (PNG and EXR), and every way a set of parts can be wrong is a clear
//! error naming the part (exit status 2, no output written).

use std::fs;
use std::path::Path;
use std::process::Output;

mod support;
use support::arbor_in as arbor;
use support::files_ending;

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "arbor failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small scene with antialiasing, reflection, a mesh and both a 2015
/// camera (`variant = true`) or the 2010 conventions, `height` rows.
fn scene(variant_2015: bool, height: u32) -> String {
    let camera = if variant_2015 {
        r#"<camera type="PerspectiveCamera"><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><viewUp>0 1 0</viewUp><projDistance>2</projDistance><viewWidth>2</viewWidth><viewHeight>1.5</viewHeight></camera>
  <exposure>1.3</exposure>"#
    } else {
        r#"<camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera>"#
    };
    format!(
        r#"<?xml version="1.0"?>
<scene>
  {camera}
  <image>37 {height}</image>
  <samples>4</samples>
  <shader name="p" type="Phong"><diffuseColor>.9 .3 .1</diffuseColor><specularColor>1 1 1</specularColor><exponent>40</exponent></shader>
  <surface type="Sphere"><shader ref="p"/><radius>0.7</radius><center>0.3 0.1 0</center></surface>
  <surface type="Box"><minpt>-3 -2 -2</minpt><maxpt>3 -0.8 0</maxpt><shader type="Glazed"><refractiveIndex>1.5</refractiveIndex><substrate type="Lambertian"><diffuseColor>.2 .6 .3</diffuseColor></substrate></shader></surface>
  <surface type="Mesh"><shader ref="p"/><data>tri.msh</data></surface>
  <light><position>3 4 5</position><intensity>1 1 1</intensity></light>
</scene>
"#
    )
}

const TRIANGLE_MSH: &str =
    "3\n1\nvertices\n-2\n0\n-1\n-1\n1.5\n-1\n-2\n1.5\n-1\ntriangles\n0\n1\n2\n";

struct Case {
    dir: tempfile::TempDir,
}

impl Case {
    fn new(variant_2015: bool, height: u32) -> Case {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("s.xml"), scene(variant_2015, height)).unwrap();
        fs::write(dir.path().join("tri.msh"), TRIANGLE_MSH).unwrap();
        Case { dir }
    }

    fn path(&self) -> &Path {
        self.dir.path()
    }

    fn run(&self, args: &[&str]) -> Output {
        arbor(self.path(), args)
    }

    /// Renders tile k of n to `name`.
    fn tile(&self, k: u32, n: u32, name: &str) {
        ok(self.run(&[
            "render",
            "s.xml",
            "--quiet",
            "--tile",
            &format!("{k}/{n}"),
            "-o",
            name,
        ]));
    }

    fn read(&self, name: &str) -> Vec<u8> {
        fs::read(self.path().join(name)).unwrap()
    }

    fn exists(&self, name: &str) -> bool {
        self.path().join(name).exists()
    }
}

/// Merging tiles gives the bytes of a full render, PNG and EXR, for both
/// conventions and cuts that do and do not divide the height.
#[test]
fn merged_tiles_equal_the_full_render() {
    for (variant_2015, height, n) in [
        (false, 29, 8),
        (true, 30, 5),
        (false, 30, 30),
        (true, 29, 1),
    ] {
        let c = Case::new(variant_2015, height);
        ok(c.run(&["render", "s.xml", "--quiet", "-o", "full.png"]));
        ok(c.run(&[
            "render",
            "s.xml",
            "--quiet",
            "-o",
            "full.exr",
            "--threads",
            "1",
        ]));
        let mut parts = Vec::new();
        // Reverse order: the order of the parts does not matter.
        for k in (0..n).rev() {
            let name = format!("t{k}.part");
            c.tile(k, n, &name);
            parts.push(name);
        }
        for out in ["merged.png", "merged.exr"] {
            let mut args = vec!["merge", "--quiet"];
            args.extend(parts.iter().map(String::as_str));
            args.extend(["-o", out]);
            ok(c.run(&args));
        }
        assert!(
            c.read("full.png") == c.read("merged.png"),
            "{variant_2015} {height} {n}: PNG differs"
        );
        assert!(
            c.read("full.exr") == c.read("merged.exr"),
            "{variant_2015} {height} {n}: EXR differs"
        );
    }
}

/// Free regions (any rectangles covering the image once) merge the same,
/// and the default part name says which tile it is.
#[test]
fn regions_and_default_names() {
    let c = Case::new(true, 20);
    ok(c.run(&["render", "s.xml", "--quiet", "-o", "full.png"]));
    for r in ["0,0,10,20", "10,0,37,7", "10,7,37,20"] {
        ok(c.run(&["render", "s.xml", "--quiet", "--region", r]));
    }
    ok(c.run(&[
        "merge",
        "s.region-0-0-10-20.part",
        "s.region-10-0-37-7.part",
        "s.region-10-7-37-20.part",
        "-o",
        "m.png",
    ]));
    assert!(c.read("full.png") == c.read("m.png"));
    ok(c.run(&["render", "s.xml", "--quiet", "--tile", "2/4"]));
    assert!(c.exists("s.tile-2-of-4.part"));
    // A whole image as one part.
    ok(c.run(&["render", "s.xml", "--quiet", "-o", "whole.part"]));
    ok(c.run(&["merge", "whole.part", "-o", "w.png"]));
    assert!(c.read("full.png") == c.read("w.png"));
}

/// Asserts that `args` fails with exit status 2, one line mentioning every
/// one of `needles`, and leaves no `out.png`.
fn fails(c: &Case, args: &[&str], needles: &[&str]) {
    let o = c.run(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!c.exists("out.png"), "{args:?} wrote an output");
}

#[test]
fn every_merge_error_names_the_part() {
    let c = Case::new(false, 12);
    for k in 0..3 {
        c.tile(k, 3, &format!("t{k}.part"));
    }
    // Tile 1/3 of `xml` rendered in a folder of its own, to `out`.
    let tile_of = |folder: &str, xml: String, out: &str| {
        let dir = c.path().join(folder);
        fs::create_dir(&dir).unwrap();
        fs::write(dir.join("s.xml"), xml).unwrap();
        fs::write(dir.join("tri.msh"), TRIANGLE_MSH).unwrap();
        let args = ["render", "s.xml", "--quiet", "--tile", "1/3", "-o", out];
        ok(arbor(&dir, &args));
    };
    // The same scene with another light: a foreign part.
    let other_light = scene(false, 12).replace("3 4 5", "3 4 6");
    tile_of("other", other_light, "../foreign.part");
    // A bigger image of the same scene.
    tile_of("bigger", scene(false, 13), "../big.part");
    for (region, out) in [("0,3,37,6", "overlap.part"), ("0,4,36,8", "narrow.part")] {
        let args = ["render", "s.xml", "--quiet", "--region", region, "-o", out];
        ok(c.run(&args));
    }
    let mut damaged = c.read("t1.part");
    let middle = damaged.len() / 2;
    damaged[middle] ^= 0x40;
    fs::write(c.path().join("damaged.part"), &damaged).unwrap();
    fs::write(c.path().join("short.part"), &damaged[..100]).unwrap();
    fs::write(c.path().join("text.part"), "hello").unwrap();
    fs::copy(c.path().join("t1.part"), c.path().join("copy.part")).unwrap();

    let merge = |parts: &[&str]| {
        let mut a = vec!["merge"];
        a.extend(parts);
        a.extend(["-o", "out.png"]);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let check = |parts: &[&str], needles: &[&str]| {
        let a = merge(parts);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails(&c, &a, needles);
    };
    let bad_sets: [(&[&str], &[&str]); 11] = [
        (&["t0.part", "t2.part"], &["missing tile 1 of 3"]),
        (
            &["t0.part", "t1.part", "t2.part", "t3.part"],
            &["t3.part", "missing part"],
        ),
        (
            &["t0.part", "t1.part", "t2.part", "t1.part"],
            &["t1.part", "duplicate"],
        ),
        (
            &["t0.part", "t1.part", "t2.part", "copy.part"],
            &["copy.part", "duplicate", "tile 1/3"],
        ),
        (
            &["t0.part", "foreign.part", "t2.part"],
            &["foreign.part", "foreign part", "scene"],
        ),
        (
            &["t0.part", "t1.part", "big.part"],
            &["big.part", "foreign part", "37x13"],
        ),
        (
            &["t0.part", "t1.part", "t2.part", "overlap.part"],
            &["overlap.part", "overlapping", "t0.part"],
        ),
        (
            &["t0.part", "narrow.part", "t2.part"],
            &["incomplete", "rows 4..8"],
        ),
        (
            &["t0.part", "damaged.part", "t2.part"],
            &["damaged.part", "damaged"],
        ),
        (
            &["t0.part", "short.part", "t2.part"],
            &["short.part", "damaged"],
        ),
        (
            &["t0.part", "text.part", "t2.part"],
            &["text.part", "not an arbor part"],
        ),
    ];
    for (parts, needles) in bad_sets {
        check(parts, needles);
    }
    // A bad output format is refused before reading anything.
    let o = c.run(&["merge", "t0.part", "t1.part", "t2.part", "-o", "out.jpg"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // And the good set still merges.
    ok(c.run(&["merge", "t2.part", "t0.part", "t1.part", "-o", "out.png"]));
}

#[test]
fn bad_tile_and_region_flags() {
    let c = Case::new(false, 12);
    for (args, needle) in [
        (vec!["--tile", "3/3"], "between 0 and N-1"),
        (vec!["--tile", "1/13"], "at most 12"),
        (vec!["--tile", "x"], "K/N"),
        (vec!["--region", "0,0,38,12"], "outside"),
        (vec!["--region", "5,5,5,6"], "x0 < x1"),
        (vec!["--region", "1,2,3"], "four numbers"),
        (vec!["--tile", "0/2", "-o", "a.png"], ".part"),
        (
            vec!["--tile", "0/2", "--region", "0,0,1,1"],
            "cannot be used with",
        ),
    ] {
        let mut a = vec!["render", "s.xml"];
        a.extend(args.iter());
        let o = c.run(&a);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{a:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"));
    }
    let written = files_ending(c.path(), &["part", "png"]);
    assert!(written.is_empty(), "{written:?}");
}
