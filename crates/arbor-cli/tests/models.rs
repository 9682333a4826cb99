//! `arbor render MODEL` through the real binary: a model file becomes a
//! picture, a broken one a located error with exit status 2 and no file.

mod support;
use support::arbor_in as arbor;
use support::folder_with;

#[test]
fn a_written_model_renders_to_a_picture_with_the_model_in_it() {
    let dir = tempfile::tempdir().unwrap();
    // A red tetrahedron (OBJ with an MTL library, upper-case extension).
    std::fs::write(dir.path().join("t.mtl"), "newmtl red\nKd 0.9 0.1 0.1\n").unwrap();
    std::fs::write(
        dir.path().join("T.OBJ"),
        "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 -1\nv 0.3 1 -0.3\nusemtl red\nf 1 2 4\nf 2 3 4\nf 3 1 4\nf 1 3 2\n",
    )
    .unwrap();
    let o = arbor(dir.path(), &["render", "T.OBJ", "-o", "t.png", "--quiet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = image::open(dir.path().join("t.png")).unwrap().to_rgb8();
    // The framing puts the model in the middle of the picture: red there.
    let (w, h) = img.dimensions();
    let reddish = img
        .enumerate_pixels()
        .filter(|(x, y, p)| {
            x.abs_diff(w / 2) < w / 4
                && y.abs_diff(h / 2) < h / 4
                && p[0] as u32 > 2 * p[1] as u32
                && p[0] > 60
        })
        .count();
    assert!(reddish > 500, "{reddish} red pixels near the centre");
}

#[test]
fn broken_models_exit_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.path().join("empty.stl"), "").unwrap();
    std::fs::write(dir.path().join("cloud.ply"), "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n").unwrap();
    for (file, want) in [
        ("bad.obj", "bad.obj:3: "),
        ("empty.stl", "empty.stl: "),
        ("cloud.ply", "point cloud"),
    ] {
        let o = arbor(dir.path(), &["render", file, "-o", "out.png"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{file}: {err}");
        assert!(err.contains(want), "{file}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!dir.path().join("out.png").exists());
    }
}

#[test]
fn assimp_models_render_and_invalid_ones_fail() {
    let Some(models) = arbor_test_data::assimp_models() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let good = models.join("PLY/cube_binary.ply");
    let o = arbor(
        dir.path(),
        &["render", good.to_str().unwrap(), "-o", "c.png", "--quiet"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.path().join("c.png").is_file());
    for bad in [
        "invalid/empty.obj",
        "invalid/malformed.obj",
        "invalid/empty.ply",
        "OBJ/point_cloud.obj",
    ] {
        let path = models.join(bad);
        let o = arbor(
            dir.path(),
            &["render", path.to_str().unwrap(), "-o", "x.png"],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad}: {err}");
        assert!(err.starts_with(path.to_str().unwrap()), "{bad}: {err}");
        assert!(!dir.path().join("x.png").exists());
    }
}

#[test]
fn info_reports_the_engine_structure() {
    let glb = "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
    let Some(glb) = arbor_test_data::assimp_model(glb) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let o = arbor(dir.path(), &["info", glb.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("nodes       82\n"), "{out}");
    assert!(
        out.contains("meshes      29 (14 placed more than once)\n"),
        "{out}"
    );
    assert!(
        out.contains("triangles   75730 unique, 121496 as placed\n"),
        "{out}"
    );
}

#[test]
fn unknown_extensions_are_refused_before_parsing() {
    // A valid scene under a name arbor does not read: refused, not parsed.
    let dir = folder_with(
        "car.3ds",
        "<scene><camera/><surface type=\"Sphere\"/></scene>",
    );
    let want = "car.3ds: not a format arbor reads (.3ds); it reads .xml, .obj, .ply, .stl, .gltf, .glb, .msh";
    for args in [
        &["render", "car.3ds", "-o", "out.png"][..],
        &["info", "car.3ds"],
        &["bench", "car.3ds", "--json", "out.json"],
        &[
            "trace", "--mesh", "car.3ds", "--rays", "rays.bin", "--hits", "hits.bin",
        ],
    ] {
        let o = arbor(dir.path(), args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end(), want, "{args:?}");
        for out in ["out.png", "out.json", "hits.bin"] {
            assert!(!dir.path().join(out).exists(), "{args:?} wrote {out}");
        }
    }
}

#[test]
fn info_counts_only_faces_of_an_obj_with_polylines() {
    let Some(models) = arbor_test_data::assimp_models() else {
        return;
    };
    let o = arbor(&models, &["info", "OBJ/testmixed.obj"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("triangles   12 unique, 12 as placed"), "{out}");
}

#[test]
fn vertex_colours_show_in_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    // A green triangle by its vertex colours alone (no material).
    std::fs::write(
        dir.path().join("g.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n0 0 0 0 200 0\n1 0 0 0 200 0\n0 1 0 0 200 0\n3 0 1 2\n",
    )
    .unwrap();
    let o = arbor(dir.path(), &["render", "g.ply", "-o", "g.png", "--quiet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = image::open(dir.path().join("g.png")).unwrap().to_rgb8();
    let green = img
        .pixels()
        .filter(|p| p[1] > 60 && p[1] as u32 > 3 * (p[0] as u32 + p[2] as u32 + 1))
        .count();
    assert!(green > 500, "{green} green pixels");
}

#[test]
fn up_and_camera_flags() {
    let dir = folder_with(
        "t.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n",
    );
    let o = arbor(
        dir.path(),
        &[
            "render", "t.obj", "--up", "-z", "--camera", "auto", "-o", "t.png", "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.path().join("t.png").is_file());
    for bad in [&["--up", "w"][..], &["--camera", "front"]] {
        let mut args = vec!["render", "t.obj", "-o", "bad.png"];
        args.extend_from_slice(bad);
        let o = arbor(dir.path(), &args);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        assert!(!dir.path().join("bad.png").exists());
    }
}

/// A model's report: bounds, counts, materials with their textures, the
/// automatic camera, lights and floor said to be automatic (and the floor
/// kept out of the model's hierarchy), no Cornell conventions; the same as
/// JSON with `--json`, written only when everything succeeded.
#[test]
fn info_describes_a_model_and_writes_json() {
    let Some(spider) = arbor_test_data::assimp_model("OBJ/spider.obj") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let o = arbor(
        dir.path(),
        &["info", spider.to_str().unwrap(), "--json", "spider.json"],
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for needle in [
        "\nbounds      (",
        "\nvertices    ",
        "\nmaterials   ",
        ", texture ",
        "\ncamera      automatic (framing the model), at (",
        "lights (automatic)",
        "\nfloor       automatic: a box ",
    ] {
        assert!(out.contains(needle), "`{needle}` not in:\n{out}");
    }
    assert!(!out.contains("conventions"), "{out}");
    // The view size is rounded like every other number of the report.
    let camera = out.lines().find(|l| l.starts_with("camera")).unwrap();
    let view = camera.rsplit_once("view ").unwrap().1;
    for side in view.split(" x ") {
        let decimals = side.split_once('.').map_or(0, |(_, f)| f.len());
        assert!(decimals <= 4, "{camera}");
    }
    assert!(
        !out.contains("\n  box "),
        "the floor in the hierarchy:\n{out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("spider.json")).unwrap())
            .unwrap();
    assert_eq!(json["kind"], "model");
    assert_eq!(json["camera"]["source"], "automatic");
    assert_eq!(json["floor"]["automatic"], true);
    assert_eq!(json["bounds"]["min"].as_array().unwrap().len(), 3);
    let materials = json["materials"].as_array().unwrap();
    assert!(!materials.is_empty());
    assert!(materials
        .iter()
        .any(|m| m["texture"]["width"].as_u64() > Some(0)));
    let triangles: u64 = materials
        .iter()
        .map(|m| m["triangles"].as_u64().unwrap())
        .sum();
    assert_eq!(json["triangles"].as_u64(), Some(triangles));
    // A missing model: exit 2 and no JSON left.
    let o = arbor(dir.path(), &["info", "none.obj", "--json", "none.json"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!dir.path().join("none.json").exists());
}
