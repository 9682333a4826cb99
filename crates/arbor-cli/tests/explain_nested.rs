//! `arbor explain --instancing nested` (issue 42 points 2 and 4): a ray's
//! way through the nested levels agrees with the nested tracer (the hit's
//! `t` is the flat explain's, bit for bit; the placements entered are what
//! `--stats` counts for that ray); the deep field at L = 9 gets a small
//! page quickly; a bad `--instancing` is a usage error.

use std::fs;
use std::path::Path;
use std::time::Instant;

use serde_json::Value;

mod support;
use support::arbor_in;

/// A folder holding `s.xml` (`scene`) and `m.msh` (a fan of 12 triangles).
fn case(scene: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("s.xml"), scene).unwrap();
    fs::write(dir.path().join("m.msh"), support::fan_msh(12)).unwrap();
    dir
}

/// Runs arbor in `dir`, asserting success.
fn ok(dir: &Path, args: &[&str]) {
    let o = arbor_in(dir, args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap()
}

/// The data document embedded in a page.
fn page_data(path: &Path) -> Value {
    let html = fs::read_to_string(path).unwrap();
    let start_tag = "<script id=\"arbor-data\" type=\"application/json\">";
    let start = html.find(start_tag).expect("data element") + start_tag.len();
    let end = start + html[start..].find("</script>").expect("end of data");
    serde_json::from_str(&html[start..end].replace("<\\/", "</")).unwrap()
}

/// `explain s.xml --ray X,Y --json FILE` with `extra`, read back.
fn ray(dir: &Path, (x, y): (u32, u32), extra: &[&str]) -> Value {
    let pixel = format!("{x},{y}");
    let args = [
        &[
            "explain", "s.xml", "--quiet", "--ray", &pixel, "--json", "r.json",
        ],
        extra,
    ]
    .concat();
    ok(dir, &args);
    read_json(&dir.join("r.json"))
}

/// `explain s.xml --instancing nested -o p.html` with `extra`: the page's
/// document.
fn nested_page(dir: &Path, extra: &[&str]) -> Value {
    let args = [
        "explain",
        "s.xml",
        "--quiet",
        "--instancing",
        "nested",
        "-o",
        "p.html",
    ];
    ok(dir, &[&args[..], extra].concat());
    page_data(&dir.join("p.html"))
}

/// Checks one nested ray's path against itself and the flat explain of
/// the same pixel; whether it hit.
fn check_pixel(dir: &Path, pixel: (u32, u32), accel: &str, extra: &[&str]) -> bool {
    let with = |mode| [&["--instancing", mode, "--accel", accel][..], extra].concat();
    let nested = ray(dir, pixel, &with("nested"));
    let flat = ray(dir, pixel, &with("flat"));
    let n = &nested["nested"];
    assert_eq!(nested["structures"], serde_json::json!([]));
    assert_eq!(n["accel"], accel);
    assert_eq!(n["left_out"], 0, "{pixel:?}");
    let levels = n["levels"].as_array().unwrap();
    // The world is reached first, at depth 0.
    assert_eq!(levels[0]["depth"], 0);
    assert_eq!(levels[0]["path"], serde_json::json!([]));
    // Every child placement reached was entered once: `--stats`' count.
    let children = levels.iter().filter(|l| !l["child"].is_null()).count();
    assert_eq!(n["entered"].as_u64(), Some(children as u64), "{pixel:?}");
    for l in levels {
        assert_eq!(
            l["depth"].as_u64(),
            Some(l["path"].as_array().unwrap().len() as u64)
        );
        assert_eq!(l["culled"].as_bool(), Some(l["t"].is_null()));
    }
    let flat_hit = &flat["structures"][0]["hit"];
    let hit = &n["hit"];
    assert_eq!(hit.is_null(), flat_hit.is_null(), "{pixel:?}");
    if hit.is_null() {
        assert!(levels.iter().all(|l| l["on_hit_path"] == false));
        return false;
    }
    let t = hit["t"].as_f64().unwrap();
    assert_eq!(
        t.to_bits(),
        flat_hit["t"].as_f64().unwrap().to_bits(),
        "{pixel:?}"
    );
    // The path to the hit: one marked level reached at each depth, entered
    // before the hit, through the items of the hit's path, ending in the
    // geometry hit.
    let path = hit["path"].as_array().unwrap();
    assert_eq!(hit["definitions"].as_array().unwrap().len(), path.len());
    for depth in 0..=path.len() {
        let marked: Vec<&Value> = levels
            .iter()
            .filter(|l| l["on_hit_path"] == true && l["depth"].as_u64() == Some(depth as u64))
            .collect();
        assert!(
            !marked.is_empty(),
            "{pixel:?}: nothing marked at depth {depth}"
        );
        for l in marked {
            assert_eq!(l["path"].as_array().unwrap()[..], path[..depth]);
            assert!(l["t"].as_f64().is_some_and(|e| e <= t), "{pixel:?}: {l}");
        }
    }
    let last = levels.iter().rfind(|l| l["on_hit_path"] == true).unwrap();
    assert_eq!(last["geometry"], true);
    assert!(hit["graph_nodes"]
        .as_array()
        .unwrap()
        .iter()
        .all(|g| g.is_u64()));
    true
}

#[test]
fn a_rays_levels_and_hit_agree_with_the_tracer_through_rotations_and_scales() {
    let dir = case(&support::transformed_scene());
    // Pixels the page's picks say hit (and one that misses), spread out.
    let size = ["--size", "160x120"];
    let d = nested_page(dir.path(), &size);
    let rays = d["picks"]["rays"].as_array().unwrap();
    let pixel = |r: &Value| {
        (
            r["pixel"][0].as_u64().unwrap() as u32,
            r["pixel"][1].as_u64().unwrap() as u32,
        )
    };
    let hitting: Vec<(u32, u32)> = rays
        .iter()
        .filter(|r| !r["nested"]["hit"].is_null())
        .map(pixel)
        .collect();
    let missing = rays
        .iter()
        .find(|r| r["nested"]["hit"].is_null())
        .map(pixel);
    assert!(hitting.len() >= 6, "{} picks hit", hitting.len());
    let step = hitting.len() / 6;
    let chosen = hitting.iter().step_by(step).take(6).copied().chain(missing);
    let mut hits = 0;
    for (k, pixel) in chosen.enumerate() {
        let accel = ["bvh-sah", "bvh-center", "kdtree"][k % 3];
        hits += usize::from(check_pixel(dir.path(), pixel, accel, &size));
    }
    assert_eq!(hits, 6);
}

#[test]
fn the_placements_entered_are_what_stats_counts_for_that_ray() {
    let dir = case(&support::transformed_scene());
    for (x, y) in [(20, 24), (40, 20)] {
        let n = ray(
            dir.path(),
            (x, y),
            &["--instancing", "nested", "--accel", "bvh-sah"],
        );
        let crop = format!("{x},{y},{},{}", x + 1, y + 1);
        let stats = support::camera_levels_per_ray(
            dir.path(),
            &[
                "--instancing",
                "nested",
                "--accel",
                "bvh-sah",
                "--crop",
                &crop,
            ],
        );
        assert_eq!(n["nested"]["entered"].as_f64(), Some(stats), "({x}, {y})");
        assert!(stats > 1.0, "({x}, {y}): {stats}");
    }
}

#[test]
fn a_page_shows_the_levels_the_graph_with_exact_counts_and_each_picks_path() {
    let dir = case(&support::transformed_scene());
    let d = nested_page(dir.path(), &[]);
    assert_eq!(d["instancing"], "nested");
    assert_eq!(d["structures"], serde_json::json!([]));
    assert!(d.get("primitives").is_none());
    let counts = &d["scene_graph"]["counts"];
    // l1 = 3 meshes of 12 + a ball = 37, l2 = 4 l1 = 148, l3 = 3 l2 + a
    // ball = 445; placed twice beside a sphere: 891.
    assert_eq!(counts["primitives"], "891", "{counts}");
    let levels = d["nested"]["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 5, "the world, l3, l2, l1 and l0");
    let world = d["nested"]["root"].as_u64().unwrap() as usize;
    assert_eq!(levels[world]["world"], true);
    let nodes = d["scene_graph"]["nodes"].as_array().unwrap();
    for l in levels {
        let node = l["graph_node"].as_u64().expect("every level named") as usize;
        let kind = &nodes[node]["kind"];
        assert!(kind == "definition" || node == 0, "{l}");
    }
    let picks = d["picks"]["rays"].as_array().unwrap();
    assert!(!picks.is_empty());
    assert!(picks.iter().any(|r| !r["nested"]["hit"].is_null()));
    assert!(d["notes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|n| n.as_str().unwrap().starts_with("nested instancing")));
}

#[test]
fn the_deep_field_at_nine_levels_gets_a_small_page_quickly() {
    let defs = support::deep_defs(9, 100, |k, i| {
        let spacing = 2.0 * 10f64.powi(k as i32 - 1);
        (
            (i % 10) as f64 * spacing - 4.5 * spacing,
            (i / 10) as f64 * spacing - 4.5 * spacing,
        )
    });
    let scene = format!(
        r#"<scene><camera><viewPoint>-9 3 -9</viewPoint><viewDir>1 -0.25 1</viewDir><projDistance>1</projDistance></camera>
<image>640 480</image><light><position>3 40 -30</position><intensity>1 1 1</intensity></light>
<defs>{defs}</defs><surface ref="level9"/></scene>
"#
    );
    let dir = case(&scene);
    let start = Instant::now();
    ok(
        dir.path(),
        &[
            "explain", "s.xml", "--quiet", "--size", "320x240", "-o", "p.html",
        ],
    );
    let took = start.elapsed();
    let bytes = fs::metadata(dir.path().join("p.html")).unwrap().len();
    assert!(took.as_secs_f64() < 30.0, "{took:?}");
    assert!(bytes < 6_000_000, "{bytes} bytes");
    let d = page_data(&dir.path().join("p.html"));
    assert_eq!(d["instancing"], "nested", "auto nests 10^18 copies");
    let counts = &d["scene_graph"]["counts"];
    assert_eq!(counts["placements"], "1000000000000000000");
    assert_eq!(counts["primitives"], "12000000000000000000");
    // The world and levels 9 to 2: auto's budget flattens each level 1
    // (100 meshes) into the level 2 that places it 100 times.
    assert_eq!(d["nested"]["levels"].as_array().unwrap().len(), 9);
    eprintln!("deep field L = 9 at 320x240: {took:?}, {bytes} bytes");
}

#[test]
fn an_unknown_instancing_names_the_expected_values() {
    let dir = case(&support::transformed_scene());
    let o = arbor_in(dir.path(), &["explain", "s.xml", "--instancing", "bogus"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("expected flat, nested or auto"), "{err}");
    assert!(!dir.path().join("explain.html").exists());
}
