//! Deeply nested instancing (issue 42): `arbor info` counts placements and
//! primitives as placed over the scene DAG, exactly past 64 bits, without
//! enumerating them; scenes it cannot count are input errors (exit 2, one
//! located message, nothing printed or written).

use std::fs;
use std::path::Path;
use std::process::Output;
use std::time::Instant;

mod support;
use support::arbor_in as arbor;
use support::run_scene_script;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A mesh of `n` triangles (all sharing the first two corners).
fn msh(n: usize) -> String {
    let mut v = vec!["0".to_string(); 3 * (n + 2)];
    v[3] = "1".into();
    for k in 0..n {
        v[3 * (k + 2) + 1] = format!("{}", k + 1);
    }
    let t: Vec<String> = (0..n)
        .flat_map(|k| [0, 1, k + 2])
        .map(|i| i.to_string())
        .collect();
    format!(
        "{}\n{n}\nvertices\n{}\ntriangles\n{}\n",
        n + 2,
        v.join("\n"),
        t.join("\n")
    )
}

/// A 2015 scene whose `<defs>` hold mesh `m.msh` as `level0` and `levels`
/// levels, each `per_level` translated references to the one below; the top
/// level is placed once.
fn deep_scene(levels: usize, per_level: usize) -> String {
    let defs = support::deep_defs(levels, per_level, |_, i| ((i * 2) as f64, 0.0));
    format!(
        r#"<scene><camera type="PerspectiveCamera"><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>1</projDistance></camera>
<image>16 12</image><light type="PointLight"><position>3 4 5</position></light>
<defs>{defs}</defs><surface ref="level{levels}"/></scene>
"#
    )
}

/// A temporary folder holding `s.xml` (the scene) and `m.msh` (`triangles` triangles).
fn case(scene: &str, triangles: usize) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("s.xml"), scene).unwrap();
    fs::write(dir.path().join("m.msh"), msh(triangles)).unwrap();
    dir
}

/// Runs `arbor info s.xml --json s.json` and checks it fails as an input
/// error naming the file and `message`, printing and writing nothing.
fn assert_info_refuses(dir: &Path, message: &str) {
    let out = arbor(dir, &["info", "s.xml", "--json", "s.json"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("s.xml") && err.contains(message), "{err}");
    assert!(stdout(&out).is_empty(), "{}", stdout(&out));
    assert!(!dir.join("s.json").exists());
}

#[test]
fn nine_levels_of_a_hundred_are_counted_exactly_and_quickly() {
    let dir = case(&deep_scene(9, 100), 10_000);
    let start = Instant::now();
    let out = arbor(
        dir.path(),
        &["info", "s.xml", "--json", "s.json", "--depth", "4"],
    );
    let seconds = start.elapsed().as_secs_f64();
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    for line in [
        "primitives  10000 unique",
        "placements  1000000000000000000 of shared geometry",
        "as placed   10000000000000000000000 primitives",
    ] {
        assert!(text.contains(line), "missing {line:?} in:\n{text}");
    }
    // The hierarchy stays bounded: each definition is written out once, and
    // only --depth levels of it.
    assert!(text.lines().count() < 400, "{} lines", text.lines().count());
    // Enumerating 10^18 placements would never finish; counting is instant
    // (generous bound for a loaded debug build).
    assert!(seconds < 20.0, "{seconds} s");
    let json: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("s.json")).unwrap()).unwrap();
    assert_eq!(json["placements"], "1000000000000000000");
    assert_eq!(json["primitives_as_placed"], "10000000000000000000000");
    assert_eq!(json["unique_primitives"], "10000");
}

#[test]
fn counts_at_the_edge_of_128_bits_are_exact() {
    // 2^127 placements of a one-triangle mesh: the largest power of two a
    // u128 holds, where any floating-point or 64-bit count would be off.
    let dir = case(&deep_scene(127, 2), 1);
    let out = arbor(dir.path(), &["info", "s.xml", "--depth", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let exact = (1u128 << 127).to_string();
    assert!(stdout(&out).contains(&format!("placements  {exact} of shared")));
    assert!(stdout(&out).contains(&format!("as placed   {exact} primitives")));
}

#[test]
fn primitives_beyond_128_bits_are_an_input_error() {
    // 2^127 placements fit; two triangles each make 2^128, which does not.
    let dir = case(&deep_scene(127, 2), 2);
    assert_info_refuses(
        dir.path(),
        "the number of primitives as placed exceeds 2^128 - 1",
    );
}

#[test]
fn placements_beyond_128_bits_are_an_input_error_naming_the_element() {
    let dir = case(&deep_scene(128, 2), 1);
    // The mesh is reached through the top level's reference and the
    // first child of each level: the message says where.
    assert_info_refuses(dir.path(), "the number of placements exceeds 2^128 - 1");
    let err = stderr(&arbor(dir.path(), &["info", "s.xml"]));
    assert!(
        err.contains("s.xml: top-level surface 1 (ref) > surface 1 > surface 1 (ref) > surface 1"),
        "{err}"
    );
    // The 257-step path is shortened in the middle.
    assert!(err.contains(" > (245 more) > "), "{err}");
}

#[test]
fn nesting_deeper_than_the_limit_is_an_input_error() {
    // A chain of definitions, each a group holding one reference to the
    // previous: two levels of nesting per definition.
    // The mesh is 3L + 2 deep (the top reference, then per level the
    // definition's group, the translating group and the reference).
    let dir = case(&deep_scene(667, 1), 1);
    assert_info_refuses(dir.path(), "nested more than 2000 deep");
    // At the limit it is counted.
    let dir = case(&deep_scene(666, 1), 1);
    let out = arbor(dir.path(), &["info", "s.xml", "--depth", "3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stdout(&out).contains("as placed   1 primitive\n"),
        "{}",
        stdout(&out)
    );
}

#[test]
fn a_reference_cycle_is_an_input_error() {
    let dir = case(
        &deep_scene(2, 2).replace(r#"<surface ref="level0"/>"#, r#"<surface ref="level2"/>"#),
        1,
    );
    assert_info_refuses(dir.path(), "definitions form a cycle");
}

/// The committed generator writes the issue's scene: L levels of 10x10
/// references to the bunny, 100^L bunnies of 10,000 triangles.
#[test]
fn deep_field_generator_writes_the_nested_field() {
    let dir = tempfile::tempdir().unwrap();
    if !run_scene_script("deep_field.py", &["9", "-o", "deep.xml"], dir.path()) {
        return;
    }
    let out = arbor(dir.path(), &["info", "deep.xml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.contains("placements  1000000000000000000 of shared"),
        "{text}"
    );
    assert!(
        text.contains("as placed   10000000000000000000000 primitives"),
        "{text}"
    );
    assert!(text.contains("image       640x480"), "{text}");
}
