//! `arbor trace --query all|count`, `arbor inside` and `arbor nearest` end
//! to end on a unit cube, record by record, and their error paths.

use std::path::{Path, PathBuf};

mod support;
use support::{arbor, s, trace_args};

/// The cube [0, 1]^3, six outward-facing quads (split into fans).
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
    v 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
    f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

fn f32s(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn words(bytes: &[u8]) -> Vec<[u8; 4]> {
    bytes
        .chunks_exact(4)
        .map(|w| [w[0], w[1], w[2], w[3]])
        .collect()
}

/// `arbor CMD --mesh MESH --points POINTS --out OUT EXTRA...` (`inside`,
/// `nearest`).
fn points_args<'a>(
    cmd: &'a str,
    mesh: &'a Path,
    points: &'a Path,
    out: &'a Path,
    extra: &[&'a str],
) -> Vec<&'a str> {
    [
        &[
            cmd,
            "--mesh",
            s(mesh),
            "--points",
            s(points),
            "--out",
            s(out),
        ],
        extra,
    ]
    .concat()
}

struct Fixture {
    dir: tempfile::TempDir,
    mesh: PathBuf,
}

impl Fixture {
    fn new(obj: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let mesh = dir.path().join("cube.obj");
        std::fs::write(&mesh, obj).unwrap();
        Fixture { dir, mesh }
    }

    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn out(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Runs `arbor ARGS`, expecting success; returns stdout and stderr.
    fn ok(&self, args: &[&str]) -> (String, String) {
        let out = arbor(args);
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{args:?}: {stderr}");
        (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
    }

    /// Runs `arbor ARGS` writing to `output`, expecting exit 2 with `expect`
    /// in the message and no output file left behind.
    fn fails(&self, args: &[&str], output: &Path, expect: &str) {
        let out = arbor(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expect), "expected '{expect}' in: {stderr}");
        assert!(!output.exists(), "{args:?} left {}", output.display());
        let leftovers: Vec<_> = std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }
}

fn ray(o: [f32; 3], d: [f32; 3]) -> Vec<u8> {
    f32s(&[o[0], o[1], o[2], 0.0, d[0], d[1], d[2], f32::INFINITY])
}

fn summary(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.trim()).unwrap()
}

/// Rays: straight through the middle; through the bottom face's diagonal
/// (shared by its two triangles) and out through the top's; through two
/// opposite vertices; along a silhouette edge only; a miss.
fn cube_rays() -> Vec<u8> {
    [
        ray([0.5, 0.5, -1.0], [0.0, 0.0, 1.0]),
        ray([0.25, 0.25, -1.0], [0.0, 0.0, 1.0]),
        ray([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]),
        ray([-1.0, 1.0, 0.5], [1.0, -1.0, 0.0]),
        ray([3.0, 3.0, -1.0], [0.0, 0.0, 1.0]),
    ]
    .concat()
}

#[test]
fn every_hit_and_counts_cross_the_cube_once_per_face() {
    let f = Fixture::new(CUBE_OBJ);
    let rays = f.file("cube.rays", &cube_rays());
    let all = f.out("all.hits");
    let (stdout, _) = f.ok(&trace_args(&f.mesh, &rays, &all, &["--query", "all"]));
    let json = summary(&stdout);
    assert_eq!(json["query"], "all");
    let bytes = std::fs::read(&all).unwrap();
    let w = words(&bytes);
    let mut at = 0;
    let mut counts = Vec::new();
    let mut ts = Vec::new();
    for _ in 0..5 {
        let n = u32::from_le_bytes(w[at]) as usize;
        at += 1;
        let mine: Vec<f32> = (0..n).map(|k| f32::from_le_bytes(w[at + 4 * k])).collect();
        for k in 0..n {
            assert!(u32::from_le_bytes(w[at + 4 * k + 1]) < 12);
        }
        at += 4 * n;
        counts.push(n);
        ts.push(mine);
    }
    assert_eq!(at, w.len(), "no bytes after the last ray");
    // The touching ray may report both faces' triangles at the edge or none.
    assert!(counts[3] == 0 || counts[3] == 2, "{counts:?}");
    assert_eq!([counts[0], counts[1], counts[2], counts[4]], [2, 2, 2, 0]);
    assert_eq!(ts[0], [1.0, 2.0]);
    assert_eq!(ts[1], [1.0, 2.0]);
    assert_eq!(ts[2], [1.0, 2.0]);
    assert_eq!(json["hits"], (counts.iter().sum::<usize>()) as u64);

    let count = f.out("count.bin");
    f.ok(&trace_args(&f.mesh, &rays, &count, &["--query", "count"]));
    let got: Vec<u32> = words(&std::fs::read(&count).unwrap())
        .into_iter()
        .map(u32::from_le_bytes)
        .collect();
    assert_eq!(got, counts.iter().map(|&n| n as u32).collect::<Vec<_>>());

    // The old spelling and the new one answer alike.
    let (a, b) = (f.out("a.occ"), f.out("b.occ"));
    f.ok(&trace_args(&f.mesh, &rays, &a, &["--occluded"]));
    f.ok(&trace_args(&f.mesh, &rays, &b, &["--query", "occluded"]));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(std::fs::read(&a).unwrap()[..3], [1, 1, 1]);
}

fn point(p: [f32; 3], max: f32) -> Vec<u8> {
    f32s(&[p[0], p[1], p[2], max])
}

#[test]
fn inside_and_nearest_on_the_cube() {
    let f = Fixture::new(CUBE_OBJ);
    let inf = f32::INFINITY;
    let points = f.file(
        "cube.points",
        &[
            point([0.5, 0.5, 0.5], inf),
            point([0.9, 0.2, 0.7], inf),
            point([2.0, 0.5, 0.5], inf),
            point([-1.0, -1.0, -1.0], inf),
            point([2.0, 0.5, 0.5], 0.5),
        ]
        .concat(),
    );
    let inside = f.out("inside.bin");
    let (stdout, stderr) = f.ok(&points_args("inside", &f.mesh, &points, &inside, &[]));
    assert!(!stderr.contains("warning"), "{stderr}");
    assert_eq!(std::fs::read(&inside).unwrap(), [1, 1, 0, 0, 0]);
    assert_eq!(summary(&stdout)["found"], 2);

    let near = f.out("near.bin");
    f.ok(&points_args(
        "nearest",
        &f.mesh,
        &points,
        &near,
        &["--signed"],
    ));
    let bytes = std::fs::read(&near).unwrap();
    assert_eq!(bytes.len(), 5 * 32);
    let rec = |i: usize| {
        let w = words(&bytes[32 * i..32 * i + 32]);
        let f = |k: usize| f32::from_le_bytes(w[k]);
        ([f(0), f(1), f(2)], u32::from_le_bytes(w[3]), f(6), w[7])
    };
    let (p, _, d, pad) = rec(0);
    assert_eq!(d, -0.5);
    assert_eq!(pad, [0; 4]);
    assert!((p[0] - 0.5).abs() < 1e-6 || (p[1] - 0.5).abs() < 1e-6 || (p[2] - 0.5).abs() < 1e-6);
    assert_eq!(rec(1).2, -(1.0f32 - 0.9), "0.1 from the x = 1 face");
    let (p, prim, d, _) = rec(2);
    assert_eq!((p, d), ([1.0, 0.5, 0.5], 1.0));
    assert!(
        prim >= 10,
        "on the x = 1 face (triangles 10, 11), got {prim}"
    );
    assert_eq!(rec(3).2, 3f32.sqrt());
    let (_, prim, d, _) = rec(4);
    assert_eq!((prim, d), (u32::MAX, f32::INFINITY), "nothing within 0.5");
}

#[test]
fn open_meshes_are_warned_about() {
    let open = CUBE_OBJ.replace("f 2 4 8 6\n", "");
    let f = Fixture::new(&open);
    let points = f.file("p.points", &point([0.5, 0.5, 0.5], f32::INFINITY));
    let out = f.out("inside.bin");
    let (_, stderr) = f.ok(&points_args("inside", &f.mesh, &points, &out, &[]));
    assert!(
        stderr.contains("warning: ")
            && stderr.contains("4 edges are not shared by exactly two triangles"),
        "{stderr}"
    );
    let (_, stderr) = f.ok(&["nearest", "--mesh", s(&f.mesh), "--points", s(&points)]);
    assert!(
        !stderr.contains("warning"),
        "unsigned distances need no closed mesh: {stderr}"
    );
}

/// `inside --winding` answers by the winding number: as the ray's parity
/// on the closed cube; with one face missing, the centre and a point 0.1
/// from the hole still inside (winding numbers about 0.9 and 0.6), and no
/// open-mesh warning.
#[test]
fn inside_by_winding_numbers() {
    let inf = f32::INFINITY;
    let points = [
        point([0.5, 0.5, 0.5], inf),
        point([0.9, 0.2, 0.7], inf),
        point([2.0, 0.5, 0.5], inf),
        point([-1.0, -1.0, -1.0], inf),
    ]
    .concat();
    let f = Fixture::new(CUBE_OBJ);
    let pts = f.file("cube.points", &points);
    let out = f.out("w.bin");
    let (stdout, _) = f.ok(&points_args("inside", &f.mesh, &pts, &out, &["--winding"]));
    assert_eq!(std::fs::read(&out).unwrap(), [1, 1, 0, 0]);
    assert_eq!(summary(&stdout)["query"], "inside_winding");

    let open = CUBE_OBJ.replace("f 2 4 8 6\n", "");
    let f = Fixture::new(&open);
    let pts = f.file("cube.points", &points);
    let out = f.out("w.bin");
    let (_, stderr) = f.ok(&points_args("inside", &f.mesh, &pts, &out, &["--winding"]));
    assert!(!stderr.contains("warning"), "{stderr}");
    assert_eq!(std::fs::read(&out).unwrap(), [1, 1, 0, 0]);
}

#[test]
fn bad_point_files_and_meshes_exit_2_without_output() {
    let f = Fixture::new(CUBE_OBJ);
    let out = f.out("out.bin");
    let odd = f.file("odd.points", &[0u8; 17]);
    for cmd in ["inside", "nearest"] {
        f.fails(
            &points_args(cmd, &f.mesh, &odd, &out, &[]),
            &out,
            "odd.points: a point file holds 16-byte records (x, y, z, max_distance as little-endian f32), but its length 17 is not a multiple of 16",
        );
    }
    let nan = f.file(
        "nan.points",
        &[point([0.0; 3], 1.0), point([0.0, f32::NAN, 0.0], 1.0)].concat(),
    );
    f.fails(
        &points_args("inside", &f.mesh, &nan, &out, &[]),
        &out,
        "nan.points: point 1 (bytes 16..32) has a coordinate that is not a finite number",
    );
    for (file, message) in [
        (&odd, "odd.points: a point file holds 16-byte records"),
        (
            &nan,
            "nan.points: point 1 (bytes 16..32) has a coordinate that is not a finite number",
        ),
    ] {
        f.fails(
            &points_args("inside", &f.mesh, file, &out, &["--winding"]),
            &out,
            message,
        );
    }
    let negative = f.file("neg.points", &point([0.0; 3], -1.0));
    f.fails(
        &points_args("nearest", &f.mesh, &negative, &out, &[]),
        &out,
        "neg.points: point 0 has max_distance -1; expected a number >= 0",
    );
    let empty = f.file("empty.obj", b"v 0 0 0\n");
    let good = f.file("good.points", &point([0.0; 3], 1.0));
    f.fails(
        &points_args("nearest", &empty, &good, &out, &[]),
        &out,
        "empty.obj: the mesh has no triangles",
    );
    f.fails(
        &points_args("inside", &f.mesh, &f.out("none.points"), &out, &[]),
        &out,
        "none.points: cannot read the point file",
    );
    let nowhere = f.out("no/such/dir/out.bin");
    f.fails(
        &points_args("inside", &f.mesh, &good, &nowhere, &[]),
        &nowhere,
        "cannot write: the folder",
    );
    let rays = f.file("r.rays", &cube_rays());
    f.fails(
        &trace_args(&f.mesh, &rays, &out, &["--query", "all", "--occluded"]),
        &out,
        "cannot be used with",
    );
    f.fails(
        &trace_args(&f.mesh, &rays, &out, &["--query", "every"]),
        &out,
        "invalid value 'every'",
    );
}
