//! `arbor bench` and `arbor render --heatmap/--stats` through the real
//! binary: the JSON document on a small generated mesh, the plots, bad input
//! (exit status 2, nothing written), and heatmaps for every accelerator.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;
use std::process::Output;

use serde_json::Value;

mod support;
use support::arbor_in as arbor;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A closed, bumpy UV sphere as OBJ: `rings` x `segments` quads split into
/// triangles (about 2 * rings * segments triangles).
/// A temporary folder holding `ball.obj` (`sphere_obj(rings, segments)`)
/// and, given an image size, `s.xml` (`scene(width, height)`).
fn ball_folder(rings: u32, segments: u32, image: Option<(u32, u32)>) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("ball.obj"), sphere_obj(rings, segments)).unwrap();
    if let Some((width, height)) = image {
        fs::write(dir.path().join("s.xml"), scene(width, height)).unwrap();
    }
    dir
}

/// Runs `arbor` in `dir` with the space-separated words of `command`.
fn run(dir: &Path, command: &str) -> Output {
    let args: Vec<&str> = command.split_whitespace().collect();
    arbor(dir, &args)
}

fn sphere_obj(rings: u32, segments: u32) -> String {
    let mut s = String::new();
    for i in 0..=rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / segments as f64;
            let r = 1.0 + 0.1 * (5.0 * phi).sin() * (3.0 * theta).sin();
            let _ = writeln!(
                s,
                "v {} {} {}",
                r * theta.sin() * phi.cos(),
                r * theta.cos(),
                r * theta.sin() * phi.sin()
            );
        }
    }
    let idx = |i: u32, j: u32| i * segments + (j % segments) + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1));
            if i > 0 {
                let _ = writeln!(s, "f {a} {b} {c}");
            }
            if i + 1 < rings {
                let _ = writeln!(s, "f {b} {d} {c}");
            }
        }
    }
    s
}

/// What `--accel all` means: every structure but brute force, in the
/// library's order.
fn accels() -> Vec<&'static str> {
    arbor_accel::AccelKind::ALL
        .iter()
        .filter(|k| **k != arbor_accel::AccelKind::List)
        .map(|k| k.name())
        .collect()
}

#[test]
fn json_has_every_field_with_sane_values() {
    let dir = ball_folder(16, 24, None);
    let out = run(
        dir.path(),
        "bench ball.obj --accel all --json b.json --size 48 --repeat 1 --threads 2",
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("| accel |"), "{table}");
    let doc: Value = serde_json::from_str(&fs::read_to_string(dir.path().join("b.json")).unwrap())
        .expect("valid JSON");
    assert_eq!(doc["input"], "ball.obj");
    let prims = doc["primitives"].as_u64().unwrap();
    assert_eq!(prims, 2 * 16 * 24 - 2 * 24);
    assert_eq!(doc["threads"], 2);
    let results = doc["results"].as_array().unwrap();
    let names: Vec<&str> = results
        .iter()
        .map(|r| r["accel"].as_str().unwrap())
        .collect();
    assert_eq!(names, accels());
    for r in results {
        let name = r["accel"].as_str().unwrap();
        assert!(r["build_ms"].as_f64().unwrap() >= 0.0, "{name}");
        let memory = r["memory_bytes"].as_u64().unwrap();
        // Every structure references every triangle at least once.
        assert!(memory >= 4 * prims, "{name}: {memory} bytes");
        let nodes = r["nodes"].as_u64().unwrap();
        let leaves = r["leaves"].as_u64().unwrap();
        // In the wide BVH, leaves are child slots of the 4-wide nodes that
        // `nodes` counts, so a node can hold up to four of them.
        let slots = if name == "bvh-wide" { 4 * nodes } else { nodes };
        assert!(
            leaves >= 1 && leaves <= slots,
            "{name}: {leaves} leaves, {nodes} nodes"
        );
        let depth = r["max_depth"].as_u64().unwrap();
        if name == "grid" {
            // A flat structure: cells, not a tree.
            assert!(r["sah_cost"].is_null() || r["sah_cost"].is_number());
        } else {
            assert!(depth >= 1, "{name}");
            assert!(r["sah_cost"].as_f64().unwrap() > 0.0, "{name}");
        }
        let rays = r["rays"].as_object().unwrap();
        assert_eq!(
            rays.keys().map(String::as_str).collect::<Vec<_>>().len(),
            3,
            "{name}"
        );
        let primary = &rays["primary"];
        assert_eq!(primary["rays"], 48 * 48);
        for kind in ["primary", "shadow", "diffuse"] {
            let k = &rays[kind];
            let n = k["rays"].as_u64().unwrap();
            assert!(n > 0, "{name} {kind}");
            assert!(k["mrays_per_s"].as_f64().unwrap() > 0.0, "{name} {kind}");
            // Every ray that enters the scene visits at least the root.
            let nodes = k["nodes_per_ray"].as_f64().unwrap();
            assert!(
                nodes > 0.5 && nodes < nodes_bound(prims),
                "{name} {kind}: {nodes}"
            );
            let tests = k["tests_per_ray"].as_f64().unwrap();
            assert!(
                tests > 0.0 && tests < prims as f64,
                "{name} {kind}: {tests}"
            );
        }
        // The camera sees the ball: hits make the secondary rays.
        assert_eq!(rays["shadow"]["rays"], rays["diffuse"]["rays"]);
        assert!(rays["shadow"]["rays"].as_u64().unwrap() < 48 * 48);
    }
    // Every structure traces the same rays.
    let first = &results[0]["rays"];
    for r in results {
        for kind in ["primary", "shadow", "diffuse"] {
            assert_eq!(r["rays"][kind]["rays"], first[kind]["rays"]);
        }
    }
}

/// A generous bound on nodes per ray: far below visiting every node of a
/// tree over `prims` primitives, so a traversal that degenerates fails.
fn nodes_bound(prims: u64) -> f64 {
    prims as f64
}

#[test]
fn ray_kinds_and_plots() {
    let dir = ball_folder(8, 12, None);
    let out = run(dir.path(), "bench ball.obj --accel grid,bvh-sah --rays shadow --json s.json --plot p.svg --size 16 --repeat 1");
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("s.json")).unwrap()).unwrap();
    let results = doc["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    assert_eq!(results[0]["accel"], "grid");
    let rays = results[0]["rays"].as_object().unwrap();
    assert_eq!(rays.keys().collect::<Vec<_>>(), ["shadow"]);
    let svg = fs::read_to_string(dir.path().join("p.svg")).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);
    assert!(svg.contains("bvh-sah") && svg.contains("Mrays/s"));

    let out = arbor(
        dir.path(),
        &[
            "bench", "ball.obj", "--accel", "kdtree", "--plot", "p.png", "--size", "16",
            "--repeat", "1",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let png = image::open(dir.path().join("p.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (1100, 480));
    // Not blank: bars and text are drawn.
    let non_white = png.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    assert!(non_white > 5000, "{non_white}");
}

/// `--quality high` builds the two kinds that have spatial splits (all
/// that `all` then means) and says so; the rays, and so the traversal
/// counts' meaning, stay those of the fast builds.
#[test]
fn high_quality_bench_builds_the_kinds_that_have_it() {
    let dir = ball_folder(24, 32, None);
    let cmd = "bench ball.obj --rays diffuse --size 32 --repeat 1 --json h.json --quality high";
    let out = run(dir.path(), cmd);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("high builds"));
    let doc: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("h.json")).unwrap()).unwrap();
    assert_eq!(doc["quality"], "high");
    let names: Vec<&str> = doc["results"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["accel"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["bvh-sah", "bvh-wide"]);
    let out = run(
        dir.path(),
        "bench ball.obj --accel bvh-sah --rays diffuse --size 32 --repeat 1 --json f.json",
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let fast: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(fast["quality"], "fast");
    assert_eq!(
        fast["results"][0]["rays"]["diffuse"]["rays"],
        doc["results"][0]["rays"]["diffuse"]["rays"]
    );
}

#[test]
fn bad_input_exits_2_and_writes_nothing() {
    let dir = ball_folder(4, 6, Some((8, 6)));
    fs::write(dir.path().join("bad.obj"), "v 0 0 0\nf 1 2 oops\n").unwrap();
    let cases: &[&[&str]] = &[
        &["bench", "ball.obj", "--accel", "octree", "--json", "o.json"],
        &["bench", "ball.obj", "--accel", "grid,", "--json", "o.json"],
        &["bench", "missing.obj", "--json", "o.json"],
        &["bench", "missing.xml", "--json", "o.json"],
        &["bench", "bad.obj", "--json", "o.json"],
        &["bench", "ball.obj", "--rays", "camera", "--json", "o.json"],
        &["bench", "ball.obj", "--rays", "", "--json", "o.json"],
        &["bench", "ball.obj", "--plot", "o.gif", "--json", "o.json"],
        &["bench", "ball.obj", "--threads", "0", "--json", "o.json"],
        &["bench", "ball.obj", "--size", "0", "--json", "o.json"],
        &["bench", "ball.txt", "--json", "o.json"],
        &["bench", "ball.obj", "--quality", "best", "--json", "o.json"],
        &[
            "bench",
            "ball.obj",
            "--quality",
            "high",
            "--accel",
            "grid",
            "--json",
            "o.json",
        ],
        &[
            "bench",
            "ball.obj",
            "--quality",
            "high",
            "--accel",
            "all,kdtree",
            "--json",
            "o.json",
        ],
        &["bench", "s.xml", "--quality", "high", "--json", "o.json"],
    ];
    for args in cases {
        let out = arbor(dir.path(), args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).contains("panicked"), "{args:?}");
        assert!(!dir.path().join("o.json").exists(), "{args:?}");
    }
}

/// A small scene with a mesh, a sphere and a glass ball (so the ray
/// statistics see every kind of ray).
fn scene(width: u32, height: u32) -> String {
    format!(
        r#"<?xml version="1.0"?>
<scene>
  <camera>
    <viewPoint>0 0.5 4</viewPoint>
    <viewDir>0 -0.1 -1</viewDir>
    <projDistance>2</projDistance>
  </camera>
  <image>{width} {height}</image>
  <shader name="grey" type="Lambertian"><diffuseColor>0.7 0.7 0.7</diffuseColor></shader>
  <surface type="Mesh"><shader ref="grey"/><data>ball.obj</data></surface>
  <surface type="Sphere">
    <shader type="Glass"><refractiveIndex>1.5</refractiveIndex></shader>
    <center>0.5 0.3 1.5</center><radius>0.3</radius>
  </surface>
  <surface type="Box"><shader ref="grey"/><minPt>-3 -1.5 -3</minPt><maxPt>3 -1.2 3</maxPt></surface>
  <light><position>3 4 5</position></light>
</scene>
"#
    )
}

#[test]
fn heatmap_for_every_accelerator() {
    let dir = ball_folder(10, 16, Some((64, 48)));
    let mut plain = None;
    for accel in accels().iter().chain(&["list"]) {
        let heat = format!("heat-{accel}.png");
        let out = arbor(
            dir.path(),
            &[
                "render",
                "s.xml",
                "-o",
                "img.png",
                "--accel",
                accel,
                "--heatmap",
                &heat,
                "--quiet",
            ],
        );
        assert!(out.status.success(), "{accel}: {}", stderr(&out));
        let img = image::open(dir.path().join("img.png")).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (64, 48));
        // -o still gets the normal image, the same for every structure.
        match &plain {
            None => plain = Some(img),
            Some(p) => assert!(p == &img, "{accel}: the image changed"),
        }
        let h = image::open(dir.path().join(&heat)).unwrap().to_rgb8();
        // The picture plus the colour bar panel; short pictures are padded
        // to fit the bar's labels.
        assert_eq!(h.dimensions(), (64 + 90, 120), "{accel}");
        // The bar runs from viridis yellow at the top to purple at the bottom.
        let bar_x = 64 + 10 + 4;
        let top = h.get_pixel(bar_x, 17).0;
        let bottom = h.get_pixel(bar_x, 120 - 18).0;
        assert!(top[1] > 200 && top[2] < 90, "{accel}: top of bar {top:?}");
        assert!(
            bottom[0] < 90 && bottom[2] > 70,
            "{accel}: bottom {bottom:?}"
        );
        // Labels: white pixels right of the bar.
        let white = (bar_x + 14..h.width())
            .flat_map(|x| (0..h.height()).map(move |y| (x, y)))
            .filter(|&(x, y)| h.get_pixel(x, y).0 == [255, 255, 255])
            .count();
        assert!(white > 40, "{accel}: {white} label pixels");
        // The map is not uniform: the mesh costs more than empty sky (brute
        // force costs the same everywhere, by design).
        if *accel == "list" {
            continue;
        }
        let mut colours: Vec<[u8; 3]> = (0..48)
            .flat_map(|y| (0..64).map(move |x| (x, y)))
            .map(|(x, y)| h.get_pixel(x, y).0)
            .collect();
        colours.sort();
        colours.dedup();
        assert!(colours.len() > 3, "{accel}: {} colours", colours.len());
    }
}

#[test]
fn stats_report_rays_by_kind() {
    let dir = ball_folder(10, 16, Some((40, 30)));
    let out = run(dir.path(), "render s.xml -o img.png --stats --quiet");
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    let rays = |kind: &str| -> u64 {
        let line = err
            .lines()
            .find(|l| l.starts_with(&format!("rays {kind} ")))
            .unwrap_or_else(|| panic!("no {kind} line in:\n{err}"));
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    assert_eq!(rays("camera"), 40 * 30);
    for kind in ["shadow", "reflection", "refraction"] {
        assert!(rays(kind) > 0, "{kind}:\n{err}");
    }
    assert!(err.contains("time: load"), "{err}");
    assert!(err.contains("nodes/ray") && err.contains("tests/ray"));
}

#[test]
fn heatmap_bad_extension_exits_2() {
    let dir = ball_folder(4, 6, Some((8, 8)));
    let out = run(dir.path(), "render s.xml -o img.png --heatmap h.jpg");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!dir.path().join("img.png").exists());
    assert!(!dir.path().join("h.jpg").exists());
}

/// The camera rays `arbor bench` makes for a mesh bounded by `lo..hi`
/// (`size` x `size` from a pinhole framing the bounding sphere), as a ray
/// file of 32-byte records.
fn framing_ray_file(lo: [f64; 3], hi: [f64; 3], size: u32) -> Vec<u8> {
    use glam::DVec3;
    let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
    let center = (lo + hi) / 2.0;
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let half = 22.5f64.to_radians();
    let back = DVec3::new(0.45, 0.35, 1.0).normalize();
    let eye = center + back * (radius / half.sin());
    let u = DVec3::Y.cross(back).normalize();
    let v = back.cross(u);
    let (tan, n) = (half.tan(), size as f64);
    let mut bytes = Vec::new();
    for j in 0..size {
        for i in 0..size {
            let x = ((i as f64 + 0.5) / n * 2.0 - 1.0) * tan;
            let y = (1.0 - (j as f64 + 0.5) / n * 2.0) * tan;
            let d = (-back + x * u + y * v).normalize();
            let record = [eye.x, eye.y, eye.z, 0.0, d.x, d.y, d.z, f64::INFINITY];
            bytes.extend(record.iter().flat_map(|&f| (f as f32).to_le_bytes()));
        }
    }
    bytes
}

/// `arbor bench` on a mesh times what `arbor trace` times (the batch
/// queries, camera rays in packets): on the same camera rays, one thread,
/// both report Mrays/s within a factor of three of each other (a generous
/// bound: timings on a shared machine are noisy).
#[test]
fn bench_and_trace_report_the_same_speed_on_camera_rays() {
    let dir = ball_folder(120, 160, None);
    let text = fs::read_to_string(dir.path().join("ball.obj")).unwrap();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for line in text.lines().filter(|l| l.starts_with("v ")) {
        for (a, w) in line.split_whitespace().skip(1).enumerate() {
            let x: f64 = w.parse().unwrap();
            (lo[a], hi[a]) = (lo[a].min(x), hi[a].max(x));
        }
    }
    let size = 256;
    fs::write(dir.path().join("cam.rays"), framing_ray_file(lo, hi, size)).unwrap();
    let common = "--accel bvh-wide --threads 1 --repeat 5";
    let bench = run(
        dir.path(),
        &format!("bench ball.obj --rays primary --size {size} --json b.json {common}"),
    );
    assert!(bench.status.success(), "{}", stderr(&bench));
    let doc: Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("b.json")).unwrap()).unwrap();
    let primary = &doc["results"][0]["rays"]["primary"];
    assert_eq!(primary["rays"].as_u64(), Some(u64::from(size * size)));
    let benched = primary["mrays_per_s"].as_f64().unwrap();
    let trace = run(
        dir.path(),
        &format!("trace --mesh ball.obj --rays cam.rays {common}"),
    );
    assert!(trace.status.success(), "{}", stderr(&trace));
    let summary: Value = serde_json::from_slice(&trace.stdout).unwrap();
    // Fastest pass against fastest pass (bench reports its fastest).
    let rays = f64::from(size * size);
    let traced = rays / (summary["trace_ms_min"].as_f64().unwrap() * 1e3);
    assert!(
        benched > 0.0 && traced > 0.0 && benched / traced < 3.0 && traced / benched < 3.0,
        "bench {benched} Mrays/s, trace {traced} Mrays/s"
    );
}
