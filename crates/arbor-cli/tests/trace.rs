//! `arbor trace` end to end: the built binary on small generated meshes and
//! ray files, checked record by record against answers worked out by hand.

use std::path::{Path, PathBuf};
use std::process::Output;

use arbor_accel::AccelKind;

mod support;
use support::{arbor, s, trace_args};

/// Two shapes along -z from above: triangle 0 is a small right triangle at
/// z = 0; triangles 1 and 2 are the fan of a large quad at z = -1.
const SCENE_OBJ: &str = "# test scene\n\
    v 0 0 0\nv 1 0 0\nv 0 1 0\n\
    v -10 -10 -1\nv 10 -10 -1\nv 10 10 -1\nv -10 10 -1\n\
    f 1 2 3\n\
    f 4/1/1 5/1/1 6/1/1 7/1/1\n";

/// A ray record: origin, tnear, direction, tfar.
fn ray(o: [f32; 3], tnear: f32, d: [f32; 3], tfar: f32) -> Vec<u8> {
    [o[0], o[1], o[2], tnear, d[0], d[1], d[2], tfar]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect()
}

/// One decoded hit record.
#[derive(Debug, PartialEq)]
struct Hit {
    t: f32,
    prim: u32,
    u: f32,
    v: f32,
}

fn read_hits(path: &Path) -> Vec<Hit> {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(bytes.len() % 16, 0);
    bytes
        .chunks_exact(16)
        .map(|r| {
            let w = |i: usize| [r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]];
            Hit {
                t: f32::from_le_bytes(w(0)),
                prim: u32::from_le_bytes(w(1)),
                u: f32::from_le_bytes(w(2)),
                v: f32::from_le_bytes(w(3)),
            }
        })
        .collect()
}

/// The value of `key` in the one-line JSON summary, as text (a string's
/// contents, a number as written).
fn field(json: &str, key: &str) -> String {
    let summary: serde_json::Value =
        serde_json::from_str(json.trim()).unwrap_or_else(|e| panic!("{e}: {json}"));
    match &summary[key] {
        serde_json::Value::Null => panic!("no {key} in {json}"),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

struct Fixture {
    dir: tempfile::TempDir,
    mesh: PathBuf,
    rays: PathBuf,
}

impl Fixture {
    fn new(rays: &[Vec<u8>]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let mesh = dir.path().join("scene.obj");
        std::fs::write(&mesh, SCENE_OBJ).unwrap();
        let path = dir.path().join("test.rays");
        std::fs::write(&path, rays.concat()).unwrap();
        Fixture {
            dir,
            mesh,
            rays: path,
        }
    }

    fn out(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Files in the fixture folder other than the inputs (outputs and any
    /// leftover temporary files).
    fn extra_files(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n != "scene.obj" && n != "test.rays")
            .collect();
        names.sort();
        names
    }
}

/// Runs `arbor trace --mesh mesh --rays rays --hits hits` with `extra`
/// arguments after them.
fn trace(mesh: &Path, rays: &Path, hits: &Path, extra: &[&str]) -> Output {
    arbor(&trace_args(mesh, rays, hits, extra))
}

/// Asserts that `out` is a successful run, showing its stderr otherwise.
fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn scene_rays() -> Vec<Vec<u8>> {
    let inf = f32::INFINITY;
    vec![
        // 0: hits the small triangle at t = 1, (u, v) = (0.25, 0.5).
        ray([0.25, 0.5, 1.0], 0.0, [0.0, 0.0, -1.0], inf),
        // 1: same, with a longer direction: t halves.
        ray([0.25, 0.5, 1.0], 0.0, [0.0, 0.0, -2.0], inf),
        // 2: misses everything (outside the quad too).
        ray([50.0, 50.0, 1.0], 0.0, [0.0, 0.0, -1.0], inf),
        // 3: tfar stops short of both.
        ray([0.25, 0.5, 1.0], 0.0, [0.0, 0.0, -1.0], 0.5),
        // 4: tnear skips the small triangle; the quad's first fan triangle
        //    (4, 5, 6) covers x > y, hit at t = 2.
        ray([0.5, 0.25, 1.0], 1.5, [0.0, 0.0, -1.0], inf),
        // 5: outside the small triangle, in the quad's second fan triangle
        //    (4, 6, 7), which covers y > x.
        ray([-3.0, 5.0, 1.0], 0.0, [0.0, 0.0, -1.0], inf),
        // 6: pointing away.
        ray([0.25, 0.5, 1.0], 0.0, [0.0, 0.0, 1.0], inf),
        // 7: from below, hits the back of the quad (two-sided) at t = 1.
        ray([5.0, -5.0, -2.0], 0.0, [0.0, 0.0, 1.0], inf),
    ]
}

#[test]
fn closest_hits_on_known_triangles() {
    let f = Fixture::new(&scene_rays());
    for kind in AccelKind::ALL {
        let hits = f.out(&format!("{kind}.hits"));
        let out = trace(
            &f.mesh,
            &f.rays,
            &hits,
            &["--accel", kind.name(), "--threads", "2", "--repeat", "2"],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{kind}: {stderr}");
        let h = read_hits(&hits);
        assert_eq!(h.len(), 8);
        let miss = Hit {
            t: f32::INFINITY,
            prim: u32::MAX,
            u: 0.0,
            v: 0.0,
        };
        assert_eq!(h[0].prim, 0);
        assert_eq!(h[0].t, 1.0);
        assert!(
            (h[0].u - 0.25).abs() < 1e-6 && (h[0].v - 0.5).abs() < 1e-6,
            "{:?}",
            h[0]
        );
        assert_eq!((h[1].prim, h[1].t), (0, 0.5));
        assert_eq!(h[2], miss);
        assert_eq!(h[3], miss);
        assert_eq!((h[4].prim, h[4].t), (1, 2.0));
        assert_eq!((h[5].prim, h[5].t), (2, 2.0));
        assert_eq!(h[6], miss);
        assert_eq!((h[7].prim, h[7].t), (1, 1.0));
        // The barycentrics locate the hit point: (1-u-v) p0 + u p1 + v p2.
        let [p0, p1, p2] = [[-10.0f32, -10.0], [10.0, -10.0], [10.0, 10.0]];
        let x = (1.0 - h[7].u - h[7].v) * p0[0] + h[7].u * p1[0] + h[7].v * p2[0];
        let y = (1.0 - h[7].u - h[7].v) * p0[1] + h[7].u * p1[1] + h[7].v * p2[1];
        assert!(
            (x - 5.0).abs() < 1e-4 && (y + 5.0).abs() < 1e-4,
            "({x}, {y})"
        );

        let json = String::from_utf8(out.stdout).unwrap();
        assert_eq!(json.lines().count(), 1, "{json}");
        assert_eq!(field(&json, "tracer"), "arbor");
        assert_eq!(field(&json, "triangles"), "3");
        assert_eq!(field(&json, "rays"), "8");
        assert_eq!(field(&json, "hits"), "5");
        assert_eq!(field(&json, "threads"), "2");
        assert_eq!(field(&json, "query"), "closest");
        for key in ["build_ms", "trace_ms_median", "trace_ms_min", "mrays_per_s"] {
            let v: f64 = field(&json, key).parse().unwrap();
            assert!(v.is_finite() && v >= 0.0, "{key} = {v}");
        }
    }
    // Only the outputs, no temporary files, remain.
    let expected: Vec<String> = AccelKind::ALL.iter().map(|k| format!("{k}.hits")).collect();
    let mut expected = expected;
    expected.sort();
    assert_eq!(f.extra_files(), expected);
}

#[test]
fn occlusion_answers() {
    let f = Fixture::new(&scene_rays());
    let occ = f.out("occ");
    let out = trace(&f.mesh, &f.rays, &occ, &["--occluded"]);
    assert_success(&out);
    assert_eq!(std::fs::read(&occ).unwrap(), vec![1, 1, 0, 0, 1, 1, 0, 1]);
    let json = String::from_utf8(out.stdout).unwrap();
    assert_eq!(field(&json, "query"), "occluded");
    assert_eq!(field(&json, "hits"), "5");
}

#[test]
fn msh_mesh_and_no_output_file() {
    let f = Fixture::new(&scene_rays());
    let msh = f.out("tri.msh");
    std::fs::write(
        &msh,
        "3\r\n1\r\nvertices\r\n0\r\n0\r\n0\r\n1\r\n0\r\n0\r\n0\r\n1\r\n0\r\ntriangles\r\n0\r\n1\r\n2\r\n",
    )
    .unwrap();
    let out = arbor(&["trace", "--mesh", s(&msh), "--rays", s(&f.rays)]);
    assert_success(&out);
    let json = String::from_utf8(out.stdout).unwrap();
    assert_eq!(field(&json, "triangles"), "1");
    // Rays 0, 1 hit the triangle; the rest miss without the quad.
    assert_eq!(field(&json, "hits"), "2");
    assert_eq!(f.extra_files(), vec!["tri.msh".to_string()]);
}

#[test]
fn empty_ray_file_is_fine() {
    let f = Fixture::new(&[]);
    let hits = f.out("h");
    let out = trace(&f.mesh, &f.rays, &hits, &[]);
    assert_success(&out);
    assert_eq!(std::fs::read(&hits).unwrap().len(), 0);
    let json = String::from_utf8(out.stdout).unwrap();
    assert_eq!(field(&json, "rays"), "0");
    assert_eq!(field(&json, "mrays_per_s").parse::<f64>().unwrap(), 0.0);
}

/// Runs a failing trace and checks: exit status 2, `expect` in the message,
/// and no output (or temporary) file left behind.
fn fails(f: &Fixture, mesh: &Path, rays: &Path, extra: &[&str], expect: &str) {
    let hits = f.out("out.hits");
    let args = trace_args(mesh, rays, &hits, extra);
    let out = arbor(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(expect), "expected '{expect}' in: {stderr}");
    assert!(!hits.exists(), "{args:?} left an output file");
    let leftovers: Vec<String> = f
        .extra_files()
        .into_iter()
        .filter(|n| n.contains("out.hits"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn bad_input_exits_2_without_output() {
    let f = Fixture::new(&scene_rays());
    let missing = f.out("missing.obj");
    fails(
        &f,
        &missing,
        &f.rays,
        &[],
        "missing.obj: cannot read the mesh file",
    );

    let bad_meshes = [
        (
            "bad.obj",
            "v 0 0 0\nv 1 0 0\n\nf 1 2 0\n",
            "bad.obj:4: vertex index 0 is invalid",
        ),
        (
            "bad.msh",
            "3\n1\nvertices\n0\n0\n0\n1\n0\n0\n0\n1\n0\ntriangles\n0\n1\n7\n",
            "bad.msh:16: vertex index 7 is out of range",
        ),
        (
            "huge.msh",
            "2000000000\n2000000000\nvertices\n",
            "huge.msh:2:",
        ),
    ];
    for (name, text, expect) in bad_meshes {
        let bad = f.out(name);
        std::fs::write(&bad, text).unwrap();
        fails(&f, &bad, &f.rays, &[], expect);
    }

    let odd = f.out("odd.rays");
    std::fs::write(&odd, [0u8; 33]).unwrap();
    fails(&f, &f.mesh, &odd, &[], "not a multiple of 32");

    fails(
        &f,
        &f.mesh,
        &f.out("none.rays"),
        &[],
        "cannot read the ray file",
    );
    fails(
        &f,
        &f.mesh,
        &f.rays,
        &["--accel", "octopus"],
        "unknown accelerator 'octopus'",
    );
    fails(
        &f,
        &f.mesh,
        &f.rays,
        &["--quality", "high", "--accel", "grid"],
        "--quality high builds spatial splits, which only bvh-wide and bvh-sah have, not grid",
    );
    fails(
        &f,
        &f.mesh,
        &f.rays,
        &["--quality", "best"],
        "unknown build quality \"best\" (expected fast or high)",
    );
    fails(&f, &f.mesh, &f.rays, &["--threads", "0"], "--threads");
    fails(&f, &f.mesh, &f.rays, &["--repeat", "0"], "--repeat");
}

#[test]
fn unwritable_output_exits_2() {
    let f = Fixture::new(&scene_rays());
    let hits = f.out("no/such/dir/out.hits");
    let out = trace(&f.mesh, &f.rays, &hits, &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot write: the folder"));
}

#[test]
fn failed_run_keeps_an_existing_output_intact() {
    let f = Fixture::new(&scene_rays());
    let hits = f.out("keep.hits");
    std::fs::write(&hits, b"previous").unwrap();
    let odd = f.out("odd.rays");
    std::fs::write(&odd, [0u8; 31]).unwrap();
    let out = trace(&f.mesh, &odd, &hits, &[]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(std::fs::read(&hits).unwrap(), b"previous");
}

/// Deterministic rays from a sphere around `mesh` towards points inside its
/// bounding box, some with a short `tfar`, so that hits, misses and clipped
/// rays all occur.
fn rays_around(mesh: &Path, n: usize) -> Vec<Vec<u8>> {
    let m = arbor::load::load_msh(mesh).unwrap();
    let (lo, hi) = m.positions.iter().fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        },
    );
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        // xorshift64*: cheap, deterministic, good enough to scatter rays.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    };
    let centre: Vec<f32> = (0..3).map(|k| 0.5 * (lo[k] + hi[k])).collect();
    let radius = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max) * 2.0;
    (0..n)
        .map(|i| {
            let dir: [f32; 3] = std::array::from_fn(|_| next() * 2.0 - 1.0);
            let len = dir.iter().map(|d| d * d).sum::<f32>().sqrt().max(1e-3);
            let o: [f32; 3] = std::array::from_fn(|k| centre[k] + radius * dir[k] / len);
            let target: [f32; 3] = std::array::from_fn(|k| lo[k] + next() * (hi[k] - lo[k]));
            let d: [f32; 3] = std::array::from_fn(|k| target[k] - o[k]);
            let tfar = if i % 5 == 0 { 0.9 } else { f32::INFINITY };
            ray(o, 0.0, d, tfar)
        })
        .collect()
}

/// `--quality high` (spatial splits) answers every query as the default
/// build does: the same closest distances, occlusion bytes, counts and
/// every-hit records, for both kinds that have it.
#[test]
fn high_quality_builds_answer_like_the_default() {
    let Some(mesh) = arbor_test_data::test_b("bunny1k.msh") else {
        return;
    };
    let f = Fixture::new(&rays_around(&mesh, 4000));
    let run = |kind: &str, quality: &str, query: &str| {
        let out = f.out(&format!("{kind}.{quality}.{query}"));
        let result = trace(
            &mesh,
            &f.rays,
            &out,
            &["--accel", kind, "--quality", quality, "--query", query],
        );
        assert!(
            result.status.success(),
            "{kind} {quality} {query}: {}",
            String::from_utf8_lossy(&result.stderr)
        );
        assert_eq!(
            field(&String::from_utf8_lossy(&result.stdout), "quality"),
            quality
        );
        out
    };
    for kind in ["bvh-wide", "bvh-sah"] {
        let (fast, high) = (run(kind, "fast", "closest"), run(kind, "high", "closest"));
        let (fast, high) = (read_hits(&fast), read_hits(&high));
        assert_eq!(fast.len(), high.len());
        for (i, (a, b)) in fast.iter().zip(&high).enumerate() {
            // Another triangle only where two lie at the same distance.
            assert!(
                a == b || a.t == b.t,
                "{kind}, ray {i}: fast {a:?}, high {b:?}"
            );
        }
        for query in ["occluded", "count", "all"] {
            let fast = std::fs::read(run(kind, "fast", query)).unwrap();
            let high = std::fs::read(run(kind, "high", query)).unwrap();
            assert!(fast == high, "{kind} {query}: the answers differ");
        }
    }
}

#[test]
fn every_accelerator_agrees_with_the_list_on_a_shared_mesh() {
    let Some(mesh) = arbor_test_data::test_b("bunny1k.msh") else {
        return;
    };
    let f = Fixture::new(&rays_around(&mesh, 4000));
    let run = |kind: AccelKind, occluded: bool| {
        let out = f.out(&format!("{kind}.{occluded}"));
        let query: &[&str] = if occluded { &["--occluded"] } else { &[] };
        let result = trace(
            &mesh,
            &f.rays,
            &out,
            &[&["--accel", kind.name()], query].concat(),
        );
        assert!(
            result.status.success(),
            "{kind}: {}",
            String::from_utf8_lossy(&result.stderr)
        );
        out
    };
    let reference = read_hits(&run(AccelKind::List, false));
    let reference_occ = std::fs::read(run(AccelKind::List, true)).unwrap();
    let hits = reference.iter().filter(|h| h.prim != u32::MAX).count();
    assert!(
        hits > 200 && hits < 3800,
        "the rays should both hit and miss: {hits}"
    );
    for &kind in AccelKind::ALL {
        let got = read_hits(&run(kind, false));
        for (i, (a, b)) in reference.iter().zip(&got).enumerate() {
            let same = a == b
                || (a.prim != u32::MAX
                    && b.prim != u32::MAX
                    && (a.t - b.t).abs() <= 1e-4 * a.t.abs().max(1.0));
            assert!(same, "{kind}, ray {i}: list {a:?}, {kind} {b:?}");
        }
        assert_eq!(
            std::fs::read(run(kind, true)).unwrap(),
            reference_occ,
            "{kind} occlusion"
        );
    }
}
