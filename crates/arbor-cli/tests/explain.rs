//! `arbor explain` end to end: the `--ray --json` traversal against the
//! library's own statistics and hit for that pixel, for every structure;
//! the page document's sections and picks; every error path.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use arbor::flatten::FlattenedScene;
use arbor::scene::Scene;
use arbor::tracer::{Tracer, TracerOptions};
use arbor_accel::{AccelKind, NoCounters, RayCounts};
use serde_json::Value;

mod support;
use support::{arbor, s};

/// Every structure, for `--accel`.
fn all_kinds() -> String {
    let names: Vec<&str> = AccelKind::ALL.iter().map(|k| k.name()).collect();
    names.join(",")
}

/// A Cornell scene from the shared test data, or `None` (skip) when it is
/// missing, unless the data is required (`arbor_test_data`).
fn cornell() -> Option<PathBuf> {
    arbor_test_data::shared("scenes/cornell-2015/two-boxes.xml")
}

fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// Runs arbor and returns its stdout, asserting success.
fn ok(args: &[&str]) {
    let out = arbor(args);
    assert!(
        out.status.success(),
        "arbor {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `arbor explain SCENE --quiet --size SIZE EXTRA...`, asserting
/// success.
fn explain_quietly(scene: &Path, size: &str, extra: &[&str]) {
    ok(&[&["explain", s(scene), "--quiet", "--size", size], extra].concat());
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The data document embedded in a page.
fn page_data(path: &Path) -> Value {
    let html = std::fs::read_to_string(path).unwrap();
    let start_tag = "<script id=\"arbor-data\" type=\"application/json\">";
    let start = html.find(start_tag).expect("data element") + start_tag.len();
    let end = start + html[start..].find("</script>").expect("end of data");
    serde_json::from_str(&html[start..end].replace("<\\/", "</")).unwrap()
}

fn keys(v: &Value) -> BTreeSet<&str> {
    v.as_object().unwrap().keys().map(String::as_str).collect()
}

fn set<'a>(names: &[&'a str]) -> BTreeSet<&'a str> {
    names.iter().copied().collect()
}

/// The scene as explain loads it, at `w` x `h`.
fn scene(input: Option<&Path>, (w, h): (u32, u32)) -> Scene {
    let mut scene = match input {
        Some(p) => arbor::load::load_scene(p).unwrap().scene,
        None => arbor::default_scene::classroom(),
    };
    scene.width = w;
    scene.height = h;
    scene.camera.view_height = scene.camera.view_width * h as f64 / w as f64;
    scene
}

/// Runs `--ray` on pixel `px` of `input` at `size` with every structure and
/// checks each structure's traversal against the library: counts equal to
/// `RayCounts`, lengths equal to counts, the hit equal to the renderer's.
fn check_ray(input: Option<&Path>, size: (u32, u32), px: (u32, u32)) -> Value {
    let dir = temp();
    let json = dir.path().join("ray.json");
    let (size_arg, ray_arg) = (
        format!("{}x{}", size.0, size.1),
        format!("{},{}", px.0, px.1),
    );
    let mut args = vec!["explain", "--quiet", "--accel"];
    let kinds = all_kinds();
    args.push(&kinds);
    args.extend(["--size", &size_arg, "--ray", &ray_arg, "--json", s(&json)]);
    if let Some(p) = input {
        args.insert(1, s(p));
    }
    ok(&args);
    assert!(
        !dir.path().join("explain.html").exists(),
        "--json alone writes no page"
    );
    let text = std::fs::read_to_string(&json).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(keys(&v), set(&["pixel", "ray", "structures"]));
    assert_eq!(v["pixel"], serde_json::json!([px.0, px.1]));

    let scene = scene(input, size);
    let camera = scene.camera.prepare();
    let ray = arbor::render::camera_ray(&scene, &camera, px.0, px.1, 0, 0);
    assert_eq!(v["ray"]["origin"], serde_json::json!(ray.origin.to_array()));
    assert_eq!(
        v["ray"]["direction"],
        serde_json::json!(ray.direction.to_array())
    );
    let structures = v["structures"].as_array().unwrap();
    assert_eq!(structures.len(), AccelKind::ALL.len());
    for (st, &kind) in structures.iter().zip(AccelKind::ALL) {
        assert_eq!(st["accel"], kind.name());
        assert_eq!(
            keys(st),
            set(&["accel", "visits", "tests", "placements", "hit", "counts"])
        );
        let tracer = Tracer::build(
            FlattenedScene::new(&scene, 1 << 20).unwrap(),
            &TracerOptions::with_accel(kind),
        );
        let mut counts = RayCounts::default();
        tracer.closest_counted(&ray, &mut counts);
        assert_eq!(st["counts"]["nodes"], counts.nodes, "{kind}: nodes");
        assert_eq!(st["counts"]["tests"], counts.tests, "{kind}: tests");
        // Lengths: entered visits and tests of both levels.
        let levels: Vec<&Value> = std::iter::once(st)
            .chain(st["placements"].as_array().unwrap())
            .collect();
        let entered: usize = levels
            .iter()
            .flat_map(|l| l["visits"].as_array().unwrap())
            .filter(|v| {
                assert_eq!(keys(v), set(&["node", "box", "entered"]));
                v["entered"] == true
            })
            .count();
        let tests: usize = levels
            .iter()
            .map(|l| l["tests"].as_array().unwrap().len())
            .sum();
        assert_eq!(entered as u64, counts.nodes, "{kind}: entered visits");
        assert_eq!(tests as u64, counts.tests, "{kind}: tests listed");
        if kind != AccelKind::List {
            assert!(counts.nodes > 0, "{kind}: the ray visits something");
        }
        match tracer.closest_identified(&ray, &mut NoCounters) {
            Some((id, hit)) => {
                // Exactly: serde_json writes the shortest round-trip
                // digits (its default reader may round the last bit).
                let t = format!("\"t\": {}", serde_json::to_string(&hit.t).unwrap());
                assert!(text.contains(&t), "{kind}: {t} not in the output");
                assert!((st["hit"]["t"].as_f64().unwrap() - hit.t).abs() <= 1e-12 * hit.t);
                assert_eq!(st["hit"]["primitive"], id.primitive, "{kind}: primitive");
                // The renderer's own query agrees.
                let t = tracer.closest(&ray).unwrap().t;
                assert_eq!(t, hit.t);
            }
            None => assert!(st["hit"].is_null(), "{kind}: no hit"),
        }
    }
    v
}

#[test]
fn ray_json_matches_the_statistics_and_the_hit_on_a_cornell_scene() {
    let Some(scene) = cornell() else { return };
    let v = check_ray(Some(&scene), (80, 45), (40, 30));
    assert!(
        v["structures"][0]["hit"].is_object(),
        "the pixel sees a box"
    );
}

#[test]
fn ray_json_matches_the_statistics_and_the_hit_on_the_classroom() {
    // The classroom is two-level: the ray passes placed desks.
    let v = check_ray(None, (96, 60), (48, 40));
    let placed: usize = v["structures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["placements"].as_array().unwrap().len())
        .sum();
    assert!(placed > 0, "the ray enters a placement in some structure");
}

#[test]
fn pages_of_a_cornell_scene_and_the_classroom_have_every_section() {
    for input in [cornell(), None] {
        let dir = temp();
        let page = dir.path().join("p.html");
        let mut args = vec!["explain", "--quiet", "--size", "64x36", "-o", s(&page)];
        if let Some(p) = &input {
            args.insert(1, s(p));
        }
        ok(&args);
        let d = page_data(&page);
        assert_eq!(d["format"], "arbor-explain");
        assert_eq!(d["version"], 1);
        for k in [
            "input",
            "notes",
            "image",
            "camera",
            "scene_graph",
            "primitives",
            "bounding_volumes",
            "structures",
            "picks",
        ] {
            assert!(d.get(k).is_some(), "{input:?}: {k}");
        }
        assert_eq!(
            (d["image"]["width"].as_u64(), d["image"]["height"].as_u64()),
            (Some(64), Some(36))
        );
        assert!(
            d["image"]["png_base64"]
                .as_str()
                .unwrap()
                .starts_with("iVBORw0KGgo"),
            "a PNG"
        );
        let structures = d["structures"].as_array().unwrap();
        let names: Vec<&str> = structures
            .iter()
            .map(|s| s["accel"].as_str().unwrap())
            .collect();
        assert_eq!(
            names,
            [
                "bvh-center",
                "bvh-median",
                "bvh-sah",
                "bvh-wide",
                "grid",
                "kdtree"
            ]
        );
        for st in structures {
            // One element per pixel, the narrowest that holds the largest
            // count; base64: 4 characters per 3 bytes.
            let heat = &st["heatmap"];
            let largest = heat["max_nodes"].as_u64().max(heat["max_tests"].as_u64());
            let size: usize = match heat["element"].as_str().unwrap() {
                "u8" => 1,
                "u16" => 2,
                "u32" => 4,
                other => panic!("element {other}"),
            };
            assert!(largest.unwrap() < 1 << (8 * size), "{}", st["accel"]);
            if size > 1 {
                assert!(largest.unwrap() >= 1 << (4 * size), "{}", st["accel"]);
            }
            let b64 = heat["nodes_base64"].as_str().unwrap();
            assert_eq!(
                b64.len(),
                (64 * 36 * size).div_ceil(3) * 4,
                "{}",
                st["accel"]
            );
            assert!(heat["max_nodes"].as_u64().unwrap() > 0);
        }
        assert!(d["scene_graph"]["nodes"].as_array().unwrap().len() > 1);
        let prims = &d["primitives"];
        let drawn = prims["triangle_ids"].as_array().unwrap().len()
            + prims["spheres"].as_array().unwrap().len()
            + prims["other"].as_array().unwrap().len();
        assert!(drawn > 0);
        assert!(!d["picks"]["rays"].as_array().unwrap().is_empty());
    }
}

/// The picks in the page equal `--ray`'s output for the same pixels, and
/// every node they visit is drawn.
#[test]
fn picks_equal_the_ray_output_and_name_drawn_nodes() {
    let dir = temp();
    let page = dir.path().join("p.html");
    let Some(scene) = cornell() else { return };
    explain_quietly(&scene, "80x45", &["-o", s(&page)]);
    let d = page_data(&page);
    let rays = d["picks"]["rays"].as_array().unwrap();
    let stride = d["picks"]["stride"].as_u64().unwrap();
    let last = rays.last().unwrap();
    for pick in [&rays[0], &rays[rays.len() / 2], last] {
        let (x, y) = (
            pick["pixel"][0].as_u64().unwrap(),
            pick["pixel"][1].as_u64().unwrap(),
        );
        assert_eq!((x % stride, y % stride), (0, 0));
        let json = dir.path().join("ray.json");
        let ray = format!("{x},{y}");
        explain_quietly(&scene, "80x45", &["--ray", &ray, "--json", s(&json)]);
        let mut want = read_json(&json);
        // Each top-level visit's box is its node's box in the page.
        for (st, page_st) in want["structures"]
            .as_array()
            .unwrap()
            .iter()
            .zip(d["structures"].as_array().unwrap())
        {
            if page_st["family"] == "grid" {
                continue;
            }
            for v in st["visits"].as_array().unwrap() {
                let n = v["node"].as_u64().unwrap() as usize;
                assert_eq!(
                    v["box"], page_st["nodes"][n]["box"],
                    "{}: node {n}",
                    st["accel"]
                );
            }
        }
        for st in want["structures"].as_array_mut().unwrap() {
            for v in st["visits"].as_array_mut().unwrap() {
                v.as_object_mut().unwrap().remove("box");
            }
            for p in st["placements"].as_array_mut().unwrap() {
                for v in p["visits"].as_array_mut().unwrap() {
                    v.as_object_mut().unwrap().remove("box");
                }
            }
        }
        assert_eq!(pick, &want, "pick {x},{y}");
    }
    for (i, st) in d["structures"].as_array().unwrap().iter().enumerate() {
        if st["family"] == "grid" {
            continue;
        }
        let nodes = st["nodes"].as_array().unwrap();
        for pick in rays {
            for v in pick["structures"][i]["visits"].as_array().unwrap() {
                let n = v["node"].as_u64().unwrap() as usize;
                assert!(
                    nodes.get(n).is_some_and(|n| !n.is_null()),
                    "{}: node {n} visited by a pick is not drawn",
                    st["accel"]
                );
            }
        }
    }
}

/// Exit status 2 and a first line saying what is wrong.
fn fails(args: &[&str], says: &str) {
    let out = arbor(args);
    assert_eq!(out.status.code(), Some(2), "arbor {args:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    let first = err.lines().next().unwrap_or_default();
    assert!(first.contains(says), "arbor {args:?}: {err}");
}

#[test]
fn errors_exit_2_with_one_clear_line() {
    let dir = temp();
    let json = dir.path().join("r.json");
    let Some(scene) = cornell() else { return };
    let sc = s(&scene);
    let j = s(&json);
    fails(
        &["explain", sc, "--ray", "12x3", "--json", j],
        "expected a pixel X,Y",
    );
    fails(&["explain", sc, "--ray", "-1,3", "--json", j], "--ray");
    fails(
        &[
            "explain", sc, "--size", "40x20", "--ray", "40,3", "--json", j,
        ],
        "--ray 40,3: the pixel is outside the 40x20 picture",
    );
    fails(
        &[
            "explain",
            sc,
            "--ray",
            "1,1",
            "--json",
            "/no/such/folder/r.json",
        ],
        "/no/such/folder/r.json",
    );
    fails(
        &["explain", sc, "-o", "/no/such/folder/p.html"],
        "/no/such/folder/p.html",
    );
    fails(
        &["explain", sc, "--accel", "bvh-sah,octree"],
        "unknown accelerator 'octree'",
    );
    // clap's own message: its first line, then the missing option.
    fails(
        &["explain", sc, "--ray", "1,1"],
        "required arguments were not provided",
    );
    fails(
        &[
            "explain",
            "/no/such/scene.xml",
            "-o",
            s(&dir.path().join("p.html")),
        ],
        "/no/such/scene.xml",
    );
    assert!(
        !json.exists() && !dir.path().join("p.html").exists(),
        "nothing written"
    );
}

/// The points the page draws for each top-level primitive number: triangle
/// corners, a sphere's extreme points, a box's corners.
fn drawn_points(prims: &Value) -> std::collections::HashMap<u64, Vec<[f64; 3]>> {
    let f = |v: &Value| v.as_f64().unwrap();
    let mut points: std::collections::HashMap<u64, Vec<[f64; 3]>> = Default::default();
    let tris = prims["triangles"].as_array().unwrap();
    for (i, id) in prims["triangle_ids"].as_array().unwrap().iter().enumerate() {
        let corners = tris[9 * i..9 * i + 9]
            .chunks(3)
            .map(|c| [f(&c[0]), f(&c[1]), f(&c[2])]);
        points
            .entry(id.as_u64().unwrap())
            .or_default()
            .extend(corners);
    }
    for sph in prims["spheres"].as_array().unwrap() {
        let c = [f(&sph[0]), f(&sph[1]), f(&sph[2])];
        let r = f(&sph[3]);
        let entry = points.entry(sph[4].as_u64().unwrap()).or_default();
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut p = c;
                p[axis] += sign * r;
                entry.push(p);
            }
        }
    }
    for other in prims["other"].as_array().unwrap() {
        let b = &other["box"];
        let entry = points
            .entry(other["primitive"].as_u64().unwrap())
            .or_default();
        for corner in 0..8 {
            let pick = |axis: usize| f(&b[(corner >> axis) & 1][axis]);
            entry.push([pick(0), pick(1), pick(2)]);
        }
    }
    points
}

/// Whether `p` lies in bounding volume `v` (to float rounding).
fn volume_contains(v: &Value, p: [f64; 3]) -> bool {
    let f = |v: &Value| v.as_f64().unwrap();
    let vec = |v: &Value| [f(&v[0]), f(&v[1]), f(&v[2])];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let eps = 1e-4 * (1.0 + dot(p, p).sqrt());
    match v["kind"].as_str().unwrap() {
        "aabb" => {
            let (lo, hi) = (vec(&v["box"][0]), vec(&v["box"][1]));
            (0..3).all(|k| lo[k] - eps <= p[k] && p[k] <= hi[k] + eps)
        }
        "sphere" => {
            let c = vec(&v["center"]);
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            dot(d, d).sqrt() <= f(&v["radius"]) + eps
        }
        "obb" => {
            let c = vec(&v["center"]);
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let half = vec(&v["half"]);
            (0..3).all(|k| dot(d, vec(&v["axes"][k])).abs() <= half[k] + eps)
        }
        other => panic!("unknown kind {other}"),
    }
}

/// With `--bvol`, the page holds the volumes the tracer tests, one per
/// object, of the kind asked for, each around everything drawn of its
/// object; without it, none.
#[test]
fn bounding_volumes_of_bvol_wrap_their_objects() {
    let dir = temp();
    let page = dir.path().join("p.html");
    let Some(scene) = cornell() else { return };
    let run = |extra: &[&str]| {
        explain_quietly(&scene, "40x30", &[extra, &["-o", s(&page)]].concat());
        page_data(&page)
    };
    assert_eq!(run(&[])["bounding_volumes"], serde_json::json!([]));
    for kind in ["sphere", "aabb", "obb"] {
        let d = run(&["--bvol", kind]);
        let volumes = d["bounding_volumes"].as_array().unwrap();
        assert!(!volumes.is_empty(), "{kind}");
        let points = drawn_points(&d["primitives"]);
        let mut checked = 0;
        for v in volumes {
            // An OBB falls back to a box when its points give no axes.
            let k = v["kind"].as_str().unwrap();
            assert!(k == kind || (kind == "obb" && k == "aabb"), "{kind}: {v}");
            let surface = v["surface"].as_u64().unwrap();
            for &p in points.get(&surface).map_or(&[][..], Vec::as_slice) {
                assert!(volume_contains(v, p), "{kind}: {p:?} outside {v}");
                checked += 1;
            }
        }
        assert!(checked > 0, "{kind}: no drawn point belongs to a volume");
    }
}
