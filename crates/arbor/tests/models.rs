//! Model import against the files people have: Debian's `assimp-testmodels`
//! (under `/usr/share/assimp/models`), plus small files written here for
//! the error paths. Without the package the tests that need it report
//! themselves skipped, unless `ARBOR_REQUIRE_TEST_DATA=1`.

use std::path::{Path, PathBuf};

use arbor::flatten::{FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use arbor::light::Light;
use arbor::load::{frame, load_model, load_model_scene};
use arbor::load::{LoadError, Model};
use arbor::shader::Shader;
use arbor::surface::Surface;
use arbor_test_data::assimp_models as models;
use glam::DVec3;

/// The shaders of every mesh as placed (each placement once), with whether
/// the mesh has texture coordinates.
fn mesh_shaders(surfaces: &[Surface]) -> Vec<(std::sync::Arc<Shader>, bool)> {
    let mut out = Vec::new();
    for s in surfaces {
        s.for_each_leaf(glam::DMat4::IDENTITY, &mut |leaf, _| {
            if let Surface::Mesh(m) = leaf {
                out.push((m.shader.clone(), m.data.uvs.is_some()));
            }
        });
    }
    out
}

/// The diffuse texture of a Lambertian or Phong shader.
fn texture_of(shader: &Shader) -> Option<std::sync::Arc<arbor::texture::Texture>> {
    match shader {
        Shader::Lambertian { texture, .. } | Shader::Phong { texture, .. } => texture.clone(),
        other => panic!("unexpected shader {other:?}"),
    }
}

fn triangles(surfaces: &[Surface]) -> usize {
    let mut n = 0;
    for s in surfaces {
        s.for_each_leaf(glam::DMat4::IDENTITY, &mut |leaf, _| {
            if let Surface::Mesh(m) = leaf {
                n += m.data.triangles.len();
            }
        });
    }
    n
}

#[test]
fn the_good_files_load_and_frame() {
    let Some(dir) = models() else { return };
    // (file, fewest triangles expected): counts from the files' own faces.
    let files = [
        ("OBJ/spider.obj", 1368),
        ("OBJ/WusonOBJ.obj", 3732),
        ("OBJ/regr01.obj", 2710),
        ("OBJ/concave_polygon.obj", 64),
        ("OBJ/cube_usemtl.obj", 12),
        ("OBJ/number_formats.obj", 1),
        ("OBJ/box_mat_with_spaces.obj", 12),
        ("PLY/Wuson.ply", 3732),
        ("PLY/cube.ply", 12),
        ("PLY/cube_binary.ply", 12),
        ("PLY/cube_uv.ply", 12),
        ("STL/Spider_ascii.stl", 1000),
        ("STL/Spider_binary.stl", 1000),
        ("STL/Wuson.stl", 1000),
        ("STL/sphereWithHole.stl", 10),
        ("STL/triangle.stl", 1),
        ("STL/triangle_with_two_solids.stl", 2),
        ("STL/triangle_with_empty_solid.stl", 1),
        ("STL/3DSMaxExport.STL", 12),
        ("STL/formatDetection", 0),
    ];
    for (file, min) in files {
        let path = dir.join(file);
        if min == 0 {
            // No model extension: not ours to read.
            assert!(load_model(&path).is_err());
            continue;
        }
        let (scene, model) = load_model_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        let n = triangles(&model.surfaces);
        assert!(n >= min, "{file}: {n} triangles, expected at least {min}");
        assert_eq!(model.stats.unique_triangles as usize, n, "{file}");
        // The model, the floor under it, the default lights.
        assert_eq!(scene.surfaces.len(), model.surfaces.len() + 1, "{file}");
        assert_eq!(scene.lights.len(), 3, "{file}");
        let (lo, hi) = frame::bounds(&model.surfaces).unwrap();
        let Surface::Box(floor) = scene.surfaces.last().unwrap() else {
            panic!("{file}: no floor")
        };
        assert!(
            floor.max.y < lo.y && floor.max.y > lo.y - (hi - lo).length(),
            "{file}"
        );
        FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS).unwrap();
    }
}

#[test]
fn spider_and_wuson_agree_across_formats() {
    let Some(dir) = models() else { return };
    let a = load_model(&dir.join("STL/Spider_ascii.stl")).unwrap();
    let b = load_model(&dir.join("STL/Spider_binary.stl")).unwrap();
    assert_eq!(triangles(&a.surfaces), triangles(&b.surfaces));
    // The same bull as OBJ and PLY.
    let obj = load_model(&dir.join("OBJ/WusonOBJ.obj")).unwrap();
    let ply = load_model(&dir.join("PLY/Wuson.ply")).unwrap();
    assert_eq!(triangles(&obj.surfaces), triangles(&ply.surfaces));
    // PLY normals are read.
    let Surface::Mesh(m) = &ply.surfaces[0] else {
        panic!()
    };
    assert!(m.data.normals.is_some());
}

#[test]
fn mtl_materials_become_shaders() {
    let Some(m) = assimp_model("OBJ/cube_usemtl.obj") else {
        return;
    };
    let exponents: Vec<f64> = m
        .surfaces
        .iter()
        .filter_map(|s| match s {
            Surface::Mesh(m) => match &*m.shader {
                Shader::Phong { exponent, .. } => Some(*exponent),
                _ => None,
            },
            _ => None,
        })
        .collect();
    // cube_usemtl.mtl: Ns 200 and Ns 16, both with Ks.
    assert!(
        exponents.contains(&200.0) && exponents.contains(&16.0),
        "{exponents:?}"
    );
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

/// The textures of a material (`map_Kd`) are read, also when written with
/// Windows separators (`.\\SpiderTex.jpg` in spider.mtl), and shared by
/// the materials that name the same image.
#[test]
fn mtl_textures_are_read() {
    let Some(m) = assimp_model("OBJ/spider.obj") else {
        return;
    };
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let textures: Vec<_> = mesh_shaders(&m.surfaces)
        .iter()
        .map(|(shader, _)| texture_of(shader).expect("every spider material has a map_Kd"))
        .collect();
    assert!(textures.len() >= 5, "{}", textures.len());
    assert!(textures.iter().all(|t| t.width > 0 && t.height > 0));
}

/// A texture that is missing or unreadable is a warning naming the file,
/// the material and the texture; the model still loads, with the
/// material's colour. A texture replaces the colour where it is found.
#[test]
fn missing_or_broken_textures_are_warnings() {
    let (dir, obj) = folder_with(
        "quad.obj",
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl missing\nf 1/1 2/2 3/3\nusemtl broken\nf 1/1 3/3 4/4\n\
         usemtl good\nf 1/1 2/2 4/4\n",
    );
    std::fs::write(
        dir.path().join("quad.mtl"),
        "newmtl missing\nKd 0.5 0.5 0.5\nmap_Kd nowhere.png\n\
         newmtl broken\nKd 0.5 0.5 0.5\nmap_Kd broken.png\n\
         newmtl good\nKd 0.5 0.5 0.5\nmap_Kd -s 1 1 1 good.png\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("broken.png"), b"not a png").unwrap();
    image::RgbImage::from_pixel(2, 1, image::Rgb([255, 0, 0]))
        .save(dir.path().join("good.png"))
        .unwrap();
    let m = load_model(&obj).unwrap();
    let joined = m.warnings.join("\n");
    assert_eq!(m.warnings.len(), 2, "{joined}");
    assert!(
        joined.contains("quad.obj") && joined.contains("'missing'"),
        "{joined}"
    );
    assert!(
        joined.contains("nowhere.png") && joined.contains("not found"),
        "{joined}"
    );
    assert!(
        joined.contains("'broken'") && joined.contains("broken.png"),
        "{joined}"
    );
    let textured: Vec<bool> = mesh_shaders(&m.surfaces)
        .iter()
        .map(|(shader, _)| texture_of(shader).is_some())
        .collect();
    assert_eq!(textured, [false, false, true]);
}

#[test]
fn concave_face_is_ear_clipped() {
    let Some(dir) = models() else { return };
    // One 66-corner face: a ring written as one outline with a seam.
    let m = load_model(&dir.join("OBJ/concave_polygon.obj")).unwrap();
    let Surface::Mesh(mesh) = &m.surfaces[0] else {
        panic!()
    };
    let d = &mesh.data;
    assert_eq!(d.triangles.len(), 64);
    // The hole stays empty: no triangle covers the ring's centre.
    let (lo, hi) = frame::bounds(&m.surfaces).unwrap();
    let c = (lo + hi) / 2.0;
    let covers = d.triangles.iter().any(|t| {
        let [a, b, e] = t.map(|i| {
            let p = d.positions[i as usize].as_dvec3();
            glam::DVec2::new(p.y - c.y, p.z - c.z)
        });
        let s = |p: glam::DVec2, q: glam::DVec2| p.perp_dot(q);
        let (x, y, z) = (s(b - a, -a), s(e - b, -b), s(a - e, -e));
        (x > 0.0 && y > 0.0 && z > 0.0) || (x < 0.0 && y < 0.0 && z < 0.0)
    });
    assert!(!covers);
}

fn err(path: &Path) -> LoadError {
    match load_model_scene(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e,
    }
}

#[test]
fn broken_files_and_point_clouds_fail_cleanly() {
    let Some(dir) = models() else { return };
    for (file, line, words) in [
        ("invalid/empty.obj", None, "no vertices"),
        ("invalid/empty.ply", None, "empty"),
        ("invalid/malformed.obj", Some(23), "out of range"),
        ("OBJ/point_cloud.obj", None, "point cloud"),
        ("OBJ/testpoints.obj", None, "no faces"),
        ("PLY/points.ply", None, "point cloud"),
        ("PLY/issue623.ply", None, "point cloud"),
        ("PLY/pond.0.ply", Some(3), "promises"),
    ] {
        let e = err(&dir.join(file));
        assert_eq!(e.path, dir.join(file));
        assert_eq!(e.line, line, "{file}: {e}");
        assert!(e.message.contains(words), "{file}: {e}");
    }
    // A material the library lacks is a warning, not an error.
    let m = load_model(&dir.join("invalid/malformed2.obj"));
    assert!(m.is_ok() || m.unwrap_err().message.contains("faces"));
}

#[test]
fn written_broken_files_fail_with_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[u8], Option<usize>, &str); 8] = [
        ("a.obj", b"v 0 0 0\nv 1 0 0\nv x 1 0\nf 1 2 3\n", Some(3), "numbers"),
        ("b.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", Some(4), "out of range"),
        ("c.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", Some(4), "out of range"),
        ("d.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/a\n", Some(4), "malformed"),
        ("e.stl", b"", None, "empty"),
        ("f.STL", b"short", None, "too short"),
        ("g.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", Some(14), "ends"),
        ("h.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3000000000\nproperty float x\nend_header\n", Some(3), "promises"),
    ];
    for (name, bytes, line, words) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = err(&path);
        assert_eq!(e.line, line, "{name}: {e}");
        assert!(e.message.contains(words), "{name}: {e}");
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
    }
    // A missing material library is a warning with the default material.
    let path = dir.path().join("m.obj");
    std::fs::write(
        &path,
        "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    )
    .unwrap();
    let m = load_model(&path).unwrap();
    assert_warned(&m.warnings, "material library");
}

#[test]
fn ply_and_stl_serve_as_xml_mesh_data() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("q.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("t.stl"),
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n",
    )
    .unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(
        &scene,
        r#"<scene><camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera>
<image>8 8</image>
<surface type="Mesh"><data>q.ply</data></surface>
<surface type="Mesh"><data>t.stl</data></surface>
<light><position>3 4 5</position></light></scene>"#,
    )
    .unwrap();
    let loaded = arbor::load::xml::load_scene(&scene).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(triangles(&loaded.scene.surfaces), 3);
}

/// A glTF file with one triangle mesh in a data-URI buffer, placed by the
/// given nodes (JSON), with `extra` spliced into the top level.
fn gltf_json(nodes: &str, scene_nodes: &str, extra: &str) -> String {
    // Three float positions then three u16 indices (0, 1, 2), padded.
    let mut bin: Vec<u8> = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = base64::encode(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{scene_nodes}}}],"nodes":{nodes},
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{uri}"}}]{extra}}}"#,
        bin.len()
    )
}

/// Base colour textures load from each place glTF keeps images: a file
/// beside the model, a `data:` URI, a GLB buffer view, all the same
/// picture; texture coordinates come along.
#[test]
fn gltf_base_color_textures() {
    let Some(dir) = models() else { return };
    let mut texels = Vec::new();
    for f in [
        "glTF2/BoxTextured-glTF/BoxTextured.gltf",
        "glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf",
        "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
    ] {
        let m = load_model(&dir.join(f)).unwrap_or_else(|e| panic!("{e}"));
        assert!(m.warnings.is_empty(), "{f}: {:?}", m.warnings);
        let shaders = mesh_shaders(&m.surfaces);
        assert!(!shaders.is_empty(), "{f}");
        for (shader, has_uvs) in shaders {
            assert!(has_uvs, "{f}: texture coordinates");
            let t = texture_of(&shader).unwrap_or_else(|| panic!("{f}: no texture"));
            texels.push(t.texels.clone());
        }
    }
    assert!(texels.windows(2).all(|w| w[0] == w[1]), "the same image");
}

/// An image that cannot be read (bad base64, bytes that are no image, a
/// missing file) is a warning naming the material and the image; the model
/// loads with the base colour.
#[test]
fn gltf_unreadable_textures_are_warnings() {
    let dir = tempfile::tempdir().unwrap();
    for (case, uri) in [
        ("bad base64", "data:image/png;base64,@@@@"),
        ("not an image", "data:image/png;base64,bm90IGFuIGltYWdl"),
        ("missing file", "missing.png"),
    ] {
        let extra = format!(
            r#","materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
"textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}]"#
        );
        let json = gltf_json(r#"[{"mesh":0}]"#, "[0]", &extra)
            .replace(r#""indices":1}"#, r#""indices":1,"material":0}"#);
        let path = dir.path().join("t.gltf");
        std::fs::write(&path, json).unwrap();
        let m = load_model(&path).unwrap_or_else(|e| panic!("{case}: {e}"));
        assert_eq!(m.warnings.len(), 1, "{case}: {:?}", m.warnings);
        let w = &m.warnings[0];
        assert!(
            w.contains("t.gltf") && w.contains("material 0") && w.contains("image 0"),
            "{case}: {w}"
        );
        let shaders = mesh_shaders(&m.surfaces);
        assert_eq!(shaders.len(), 1, "{case}");
        assert!(texture_of(&shaders[0].0).is_none(), "{case}");
    }
}

#[test]
fn gltf_instancing_cameras_and_broken_files() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // One mesh placed by three nodes (one a child with a matrix): stored once.
    let ok = write(
        "ok.gltf",
        &gltf_json(
            r#"[{"children":[1,2],"translation":[1,0,0]},{"mesh":0,"scale":[2,2,2]},{"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,5,1]},{"mesh":0},{"camera":0,"translation":[0,0,10]}]"#,
            "[0,3,4]",
            r#","cameras":[{"type":"perspective","perspective":{"yfov":0.5,"aspectRatio":2.0,"znear":0.1}}]"#,
        ),
    );
    let (scene, model) = load_model_scene(&ok).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(model.stats.nodes, 5);
    assert_eq!(model.stats.meshes, 1);
    assert_eq!(model.stats.placements, 3);
    assert_eq!(model.stats.shared_meshes, 1);
    assert_eq!(model.stats.unique_triangles, 1);
    assert_eq!(model.stats.instanced_triangles, 3);
    let flat = FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS).unwrap();
    assert_eq!(flat.placements.len(), 3);
    // The child's placement composes its parent's translation and its own scale.
    let (lo, hi) = frame::bounds(&model.surfaces).unwrap();
    assert_eq!((lo.x, hi.x, hi.y, hi.z), (0.0, 3.0, 2.0, 5.0));
    // The file's camera: at z = 10 looking down -z, yfov 0.5 at distance 1.
    assert_eq!(scene.camera.view_point, glam::DVec3::new(0.0, 0.0, 10.0));
    assert!((scene.camera.view_height - 2.0 * 0.25f64.tan()).abs() < 1e-6);
    assert_eq!(scene.width, 2 * scene.height);

    for (name, text, words) in [
        (
            "cycle.gltf",
            gltf_json(r#"[{"children":[1]},{"children":[0],"mesh":0}]"#, "[0]", ""),
            "cycle",
        ),
        (
            "index.gltf",
            gltf_json(r#"[{"mesh":0}]"#, "[0]", "")
                .replace(
                    r#""count":3,"type":"SCALAR""#,
                    r#""count":3,"type":"SCALAR","byteOffset":0"#,
                )
                .replace("AAABAAIA", "AAABAAkA"),
            "out of range",
        ),
        (
            "range.gltf",
            gltf_json(r#"[{"mesh":7}]"#, "[0]", ""),
            "glTF",
        ),
        (
            "missing.gltf",
            gltf_json(r#"[{"mesh":0}]"#, "[0]", "")
                .replace("data:application/octet-stream;base64,", "nowhere.bin#"),
            "buffer",
        ),
        (
            "short.gltf",
            gltf_json(r#"[{"mesh":0}]"#, "[0]", "")
                .replace(r#""byteLength":36}"#, r#""byteLength":360}"#),
            "beyond",
        ),
        ("empty.glb", String::new(), "empty"),
    ] {
        let p = write(name, &text);
        let e = err(&p);
        assert!(e.message.contains(words), "{name}: {e}");
        assert_eq!(e.path, p);
    }
}

#[test]
fn the_engine_keeps_its_shared_meshes() {
    let Some(dir) = models() else { return };
    let path = dir.join("glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    let (scene, model) = load_model_scene(&path).unwrap();
    let s = model.stats;
    assert_eq!((s.nodes, s.meshes, s.shared_meshes), (82, 29, 14));
    assert!(s.instanced_triangles > 120_000 && s.unique_triangles < s.instanced_triangles);
    let flat = FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS).unwrap();
    // Every placement of a shared mesh stays a placement, not a copy.
    assert_eq!(flat.instanced_primitives() - 12, s.instanced_triangles);
    assert_eq!(flat.unique_primitives() - 12, s.unique_triangles);
    for bad in [
        "RecursiveNodes/RecursiveNodes.gltf",
        "IndexOutOfRange/IndexOutOfRange.gltf",
        "MissingBin/BoxTextured.gltf",
    ] {
        let e = err(&dir.join("glTF2").join(bad));
        assert!(e.to_string().starts_with(dir.to_str().unwrap()), "{e}");
    }
}

/// Colour textures are decoded from sRGB into linear colour: an MTL
/// `map_Kd` texel (92, 135, 39) is linear (0.107, 0.242, 0.020), which the
/// output's gamma brings back near the texel it was.
#[test]
fn model_textures_are_decoded_from_srgb() {
    let (dir, obj) = folder_with(
        "t.obj",
        "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl t\nf 1/1 2/2 3/3\n",
    );
    std::fs::write(dir.path().join("t.mtl"), "newmtl t\nmap_Kd t.png\n").unwrap();
    image::RgbImage::from_pixel(1, 1, image::Rgb([92, 135, 39]))
        .save(dir.path().join("t.png"))
        .unwrap();
    let m = load_model(&obj).unwrap();
    let (shader, _) = &mesh_shaders(&m.surfaces)[0];
    let t = texture_of(shader).expect("the material has a texture");
    let want = glam::DVec3::new(0.107023, 0.242281, 0.020289);
    assert!(
        (t.texels[0] - want).abs().max_element() < 1e-5,
        "{}",
        t.texels[0]
    );
}

/// glTF's base colour factor multiplies its base colour texture
/// (`issue_3269/texcoord_crash.gltf`: one white-and-black image tinted four
/// ways by four materials).
#[test]
fn gltf_base_colour_factor_tints_the_texture() {
    let Some(m) = assimp_model("glTF2/issue_3269/texcoord_crash.gltf") else {
        return;
    };
    let mut tints = Vec::new();
    for (shader, _) in mesh_shaders(&m.surfaces) {
        if let Some(t) = texture_of(&shader) {
            // The brightest texel is the factor itself (the image is white there).
            let max = t
                .texels
                .iter()
                .copied()
                .fold(glam::DVec3::ZERO, glam::DVec3::max);
            tints.push(max);
        }
    }
    assert_eq!(tints.len(), 4, "{tints:?}");
    for want in [
        [0.0, 0.16, 0.8],
        [0.0, 0.8, 0.0],
        [0.8, 0.8, 0.0],
        [0.8, 0.08, 0.0],
    ] {
        let want = glam::DVec3::from_array(want);
        assert!(
            tints.iter().any(|t| (*t - want).abs().max_element() < 1e-6),
            "{want} not among {tints:?}"
        );
    }
}

/// OBJ `l` and `p` lines are not faces: `testmixed.obj` has 12 triangles
/// and 12 polylines.
#[test]
fn obj_lines_and_points_are_not_faces() {
    let Some(m) = assimp_model("OBJ/testmixed.obj") else {
        return;
    };
    assert_eq!(triangles(&m.surfaces), 12);
    assert_warned(&m.warnings, "'l' and 'p'");
}

/// MTL libraries load in any byte encoding (Latin-1 bytes in `regr01.mtl`
/// and `box_spaces.mtl`), a nameless `newmtl` is skipped with a warning
/// naming the library and its line (`empty_mat.mtl`), and a UTF-16 OBJ
/// with a byte-order mark is read.
#[test]
fn obj_and_mtl_in_any_encoding() {
    let Some(dir) = models() else { return };
    for file in ["OBJ/regr01.obj", "OBJ/box_mat_with_spaces.obj"] {
        let m = load_model(&dir.join(file)).unwrap();
        // regr01.mtl has a half-transparent material, which arbor names.
        assert!(
            m.warnings
                .iter()
                .all(|w| w.ends_with("are ignored: transparency (d below 1)")),
            "{file}: {:?}",
            m.warnings
        );
        let default = arbor::load::default_shader();
        assert!(
            mesh_shaders(&m.surfaces)
                .iter()
                .any(|(s, _)| **s != *default),
            "{file}: every surface has the default material"
        );
    }
    let m = load_model(&dir.join("OBJ/empty_mat.obj")).unwrap();
    assert!(triangles(&m.surfaces) > 0);
    assert_warned(
        &m.warnings,
        "empty_mat.mtl:3: warning: a material with no name",
    );
    let m = load_model(&dir.join("OBJ/box_UTF16BE.obj")).unwrap();
    assert_eq!(triangles(&m.surfaces), 12);
}

/// glTF triangle strips and fans are triangulated (the asset generator's
/// four files of two triangles each); a file of points fails with the
/// warning that says why in its one line.
#[test]
fn gltf_strips_and_fans_render_and_points_say_why() {
    let Some(dir) = models() else { return };
    let modes = dir.join("glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode");
    for n in ["04", "05", "11", "12"] {
        let m = load_model(&modes.join(format!("Mesh_PrimitiveMode_{n}.gltf")))
            .unwrap_or_else(|e| panic!("{n}: {e}"));
        assert_eq!(triangles(&m.surfaces), 2, "{n}");
    }
    let e = err(&modes.join("Mesh_PrimitiveMode_00.gltf"));
    let text = e.to_string();
    assert!(
        text.contains("no triangles to render") && text.contains("Points primitive"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 1, "{text}");
}

/// What arbor cannot read is said in one line: glTF 1.0, an extension the
/// file requires (named once), and files with no scene or no nodes fail
/// because they hold nothing, not on the optional parts they leave out.
#[test]
fn gltf_unsupported_inputs_get_one_clear_line() {
    let Some(dir) = models() else { return };
    let e = err(&dir.join("glTF/BoxTextured-glTF/BoxTextured.gltf")).to_string();
    assert!(
        e.contains("glTF 1.0") && e.contains("arbor reads glTF 2.0"),
        "{e}"
    );
    let e = err(&dir.join("glTF2/draco/2CylinderEngine.gltf")).to_string();
    assert_eq!(e.matches("KHR_draco_mesh_compression").count(), 1, "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    for f in ["NoScene.gltf", "SceneWithoutNodes.gltf"] {
        let e = err(&dir.join("glTF2/TestNoRootNode").join(f)).to_string();
        assert!(e.contains("no triangles to render"), "{f}: {e}");
    }
}

/// The colours of the mesh of a one-mesh model, if it has them.
fn vertex_colors(path: &Path) -> Option<Vec<glam::Vec3>> {
    let m = load_model(path).unwrap_or_else(|e| panic!("{e}"));
    let mut out = None;
    for s in &m.surfaces {
        s.for_each_leaf(glam::DMat4::IDENTITY, &mut |leaf, _| {
            if let Surface::Mesh(mesh) = leaf {
                out = mesh.data.colors.clone();
            }
        });
    }
    out
}

/// Vertex colours are read and decoded from sRGB: OBJ's `v x y z r g b`
/// (`cube_with_vertexcolors.obj`), PLY's `red`/`green`/`blue` as floats
/// (`float-color.ply`) and as bytes (a file written here).
#[test]
fn vertex_colours_are_read_linear() {
    let (_dir, ply) = folder_with(
        "c.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 188 0 0\n0 1 0 0 0 255\n3 0 1 2\n",
    );
    let c = vertex_colors(&ply).expect("the PLY has colours");
    assert_eq!(c[0], glam::Vec3::new(1.0, 0.0, 0.0));
    assert!(
        (c[1].x - 0.5029).abs() < 1e-3,
        "sRGB 188 is linear 0.503: {}",
        c[1]
    );
    assert_eq!(c[2], glam::Vec3::new(0.0, 0.0, 1.0));
    let Some(models) = models() else { return };
    let c = vertex_colors(&models.join("PLY/float-color.ply")).expect("float-color has colours");
    assert!(
        c.iter().all(|c| *c == glam::Vec3::new(0.0, 0.0, 1.0)),
        "{c:?}"
    );
    let c = vertex_colors(&models.join("OBJ/cube_with_vertexcolors.obj"))
        .expect("cube_with_vertexcolors has colours");
    // Its first vertex: sRGB (0.48627, 0.43137, 0.47059).
    let want = glam::Vec3::new(0.2016, 0.1559, 0.1878);
    assert!(
        c.iter().any(|c| (*c - want).abs().max_element() < 1e-3),
        "{c:?}"
    );
}

/// A model whose only face is degenerate (`number_formats.obj`) loads with a
/// warning that nothing will show; a good model has no such warning.
#[test]
fn all_degenerate_models_are_warned_about() {
    let Some(dir) = models() else { return };
    let m = load_model(&dir.join("OBJ/number_formats.obj")).unwrap();
    assert_warned(&m.warnings, "every triangle has zero area");
    let m = load_model(&dir.join("OBJ/spider.obj")).unwrap();
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

/// `up` turns a model: Wuson.stl read with y up (as its OBJ twin is) has
/// the height its z-up default gives its depth; `auto_camera` drops the
/// file's camera (2CylinderEngine.glb has one).
#[test]
fn model_options_turn_and_frame() {
    use arbor::load::{load_model_with, ModelOptions, Up};
    let Some(dir) = models() else { return };
    let stl = dir.join("STL/Wuson.stl");
    let (lo, hi) = frame::bounds(&load_model(&stl).unwrap().surfaces).unwrap();
    let y_up = ModelOptions {
        up: Some(Up::Y),
        ..ModelOptions::default()
    };
    let (lo2, hi2) = frame::bounds(&load_model_with(&stl, &y_up).unwrap().surfaces).unwrap();
    assert!(
        ((hi2.y - lo2.y) - (hi.z - lo.z)).abs() < 1e-4,
        "{lo2} {hi2} vs {lo} {hi}"
    );
    assert!(
        ((hi2.z - lo2.z) - (hi.y - lo.y)).abs() < 1e-4,
        "{lo2} {hi2} vs {lo} {hi}"
    );
    let glb = dir.join("glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    assert!(load_model(&glb).unwrap().camera.is_some());
    let auto = ModelOptions {
        auto_camera: true,
        ..ModelOptions::default()
    };
    assert!(load_model_with(&glb, &auto).unwrap().camera.is_none());
}

/// glTF emission is added to the shaded colour: ClearCoatTest's label
/// material (emissiveFactor 1 with an emissive texture) glows, the others
/// (emissiveFactor 0) do not.
#[test]
fn gltf_emission_is_kept() {
    let Some(m) = assimp_model("glTF2/ClearCoat-glTF/ClearCoatTest.gltf") else {
        return;
    };
    let shaders = mesh_shaders(&m.surfaces);
    let glowing: Vec<_> = shaders
        .iter()
        .filter_map(|(s, _)| match &**s {
            Shader::Emissive {
                emission, texture, ..
            } => Some((*emission, texture.is_some())),
            _ => None,
        })
        .collect();
    assert!(!glowing.is_empty(), "no emissive material");
    assert!(
        glowing
            .iter()
            .all(|(e, textured)| *e == glam::DVec3::ONE && *textured),
        "{glowing:?}"
    );
    assert!(glowing.len() < shaders.len(), "every material glows");
}

/// The assimp test model at `relative`, loaded, or `None` where the models
/// are not installed (the test then skips, as [`models`] says).
fn assimp_model(relative: &str) -> Option<Model> {
    Some(load_model(&arbor_test_data::assimp_model(relative)?).unwrap())
}

/// A temporary folder holding one file, `name`, with `contents`, and the
/// file's path (the folder is removed when dropped).
fn folder_with(name: &str, contents: impl AsRef<[u8]>) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, contents).unwrap();
    (dir, path)
}

/// Asserts that one of `warnings` contains `words`.
fn assert_warned(warnings: &[String], words: &str) {
    assert!(
        !warnings_with(warnings, words).is_empty(),
        "no warning says {words:?}: {warnings:?}"
    );
}

/// The warnings that contain `words`.
fn warnings_with<'a>(warnings: &'a [String], words: &str) -> Vec<&'a String> {
    warnings.iter().filter(|w| w.contains(words)).collect()
}

/// glTF extensions arbor does not implement are named in a warning, not
/// ignored without a word; the ones it implements are not.
#[test]
fn gltf_ignored_extensions_are_warned_about() {
    let (_dir, p) = folder_with(
        "ext.gltf",
        gltf_json(
            r#"[{"mesh":0}]"#,
            "[0]",
            r#","extensionsUsed":["KHR_texture_transform","KHR_materials_sheen"]"#,
        ),
    );
    let m = load_model(&p).unwrap();
    let w = warnings_with(&m.warnings, "arbor ignores");
    assert_eq!(w.len(), 1, "{:?}", m.warnings);
    assert!(
        w[0].contains("(KHR_materials_sheen)") && w[0].starts_with(&p.display().to_string()),
        "{w:?}"
    );
}

/// `KHR_texture_transform` (`TextureTransformTest.gltf`): the six squares
/// whose materials transform their texture look it up through the
/// transform the extension gives, the three without (Correct,
/// NotSupported, Error) as stored; no warning calls the extension ignored.
#[test]
fn gltf_texture_transforms_are_applied() {
    let Some(m) = assimp_model("glTF2/textureTransform/TextureTransformTest.gltf") else {
        return;
    };
    assert!(
        !m.warnings
            .iter()
            .any(|w| w.contains("KHR_texture_transform")),
        "{:?}",
        m.warnings
    );
    let transforms: Vec<_> = mesh_shaders(&m.surfaces)
        .iter()
        .map(|(s, _)| texture_of(s).expect("every square is textured").transform)
        .collect();
    // Twelve placements of nine squares: six distinct transforms.
    let mut distinct: Vec<_> = Vec::new();
    for t in transforms.iter().flatten() {
        if !distinct.contains(t) {
            distinct.push(*t);
        }
    }
    assert_eq!(distinct.len(), 6, "{transforms:?}");
    assert!(transforms.contains(&None));
    // "Offset U" moves the texture by half its width: in arbor's (v up)
    // coordinates, (u, v) -> (u + 0.5, v).
    let offset = arbor::texture::UvTransform::gltf([0.5, 0.0], 0.0, [1.0, 1.0]);
    assert!(transforms.contains(&Some(offset)), "{transforms:?}");
    assert_eq!(offset.apply(0.25, 0.75), (0.75, 0.75));
}

/// A written glTF file with a material and a light: the material (JSON),
/// the primitive's extra attributes and the top-level extra.
fn gltf_material_json(material: &str, nodes: &str, extra: &str) -> String {
    gltf_json(
        nodes,
        "[0,1]",
        &format!(r#","materials":[{material}]{extra}"#),
    )
    .replace(r#""indices":1}"#, r#""indices":1,"material":0}"#)
}

/// `KHR_lights_punctual`: the file's lights replace the automatic ones,
/// placed by their nodes, in arbor's units (intensity / π); `--up` turns
/// them with the model.
#[test]
fn gltf_punctual_lights_replace_the_automatic_ones() {
    let (dir, p) = folder_with(
        "lights.gltf",
        gltf_material_json(
            "{}",
            r#"[{"mesh":0},{"children":[2,3],"translation":[0,0,4]},
                {"extensions":{"KHR_lights_punctual":{"light":0}}},
                {"rotation":[0.7071068,0,0,0.7071068],"extensions":{"KHR_lights_punctual":{"light":1}}}]"#,
            r#","extensions":{"KHR_lights_punctual":{"lights":[
                {"type":"spot","intensity":31.4159265,"spot":{"outerConeAngle":0.5}},
                {"type":"directional","color":[1,0.5,0.25],"intensity":3.14159265}]}}"#,
        ),
    );
    let (scene, model) = load_model_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.lights, model.lights);
    let [Light::Spot {
        position,
        direction,
        intensity,
        cos_outer,
        ..
    }, Light::Directional {
        direction: sun,
        intensity: sun_intensity,
    }] = model.lights.as_slice()
    else {
        panic!("{:?}", model.lights);
    };
    assert_eq!(*position, DVec3::new(0.0, 0.0, 4.0));
    assert_eq!(*direction, DVec3::NEG_Z);
    assert!((*intensity - DVec3::splat(10.0)).length() < 1e-6);
    assert!((cos_outer - 0.5f64.cos()).abs() < 1e-12);
    // A quarter turn about x: the sun's -z shines along +y, so it is below.
    assert!((*sun - DVec3::NEG_Y).length() < 1e-6, "{sun}");
    assert!((*sun_intensity - DVec3::new(1.0, 0.5, 0.25)).length() < 1e-6);
    // Turned with the model: z up makes the file's +z arbor's +y.
    let turned = arbor::load::load_model_with(
        &p,
        &arbor::load::ModelOptions {
            up: Some(arbor::load::Up::Z),
            auto_camera: false,
        },
    )
    .unwrap();
    let Light::Spot { position, .. } = &turned.lights[0] else {
        panic!("{:?}", turned.lights);
    };
    assert!(
        (*position - DVec3::new(0.0, 4.0, 0.0)).length() < 1e-9,
        "{position}"
    );
    // Without lights in the file: the automatic three.
    let plain = dir.path().join("plain.gltf");
    std::fs::write(&plain, gltf_json(r#"[{"mesh":0}]"#, "[0]", "")).unwrap();
    let (scene, model) = load_model_scene(&plain).unwrap();
    assert!(model.lights.is_empty());
    assert_eq!(scene.lights.len(), 3);
}

/// Transmission is glass (thin-walled without a volume), a smooth metal
/// reflects, and what the shaders leave out is named in one warning.
#[test]
fn gltf_materials_map_to_glass_mirrors_and_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let shader = |name: &str, material: &str| {
        let p = dir.path().join(name);
        let images = r#","images":[{"uri":"n.png"}],"textures":[{"source":0}]"#;
        std::fs::write(
            &p,
            gltf_material_json(material, r#"[{"mesh":0},{}]"#, images),
        )
        .unwrap();
        let m = load_model(&p).unwrap_or_else(|e| panic!("{e}"));
        (mesh_shaders(&m.surfaces)[0].0.clone(), m.warnings, p)
    };
    let (s, _, _) = shader(
        "glass.gltf",
        r#"{"extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_ior":{"ior":1.4},
            "KHR_materials_volume":{"thicknessFactor":1}}}"#,
    );
    assert_eq!(
        *s,
        Shader::Glass {
            refractive_index: 1.4
        }
    );
    let (s, _, _) = shader(
        "thin.gltf",
        r#"{"extensions":{"KHR_materials_transmission":{"transmissionFactor":1}}}"#,
    );
    assert!(
        matches!(&*s, Shader::Glazed { refractive_index, .. } if *refractive_index == 1.5),
        "{s:?}"
    );
    let (s, _, _) = shader(
        "metal.gltf",
        r#"{"pbrMetallicRoughness":{"baseColorFactor":[0.9,0.6,0.2,1],"metallicFactor":1,"roughnessFactor":0.1}}"#,
    );
    let Shader::Reflective { reflectance, .. } = &*s else {
        panic!("{s:?}");
    };
    assert!((*reflectance - DVec3::new(0.9, 0.6, 0.2) * 0.8).length() < 1e-6);
    let (_, warnings, p) = shader(
        "bumpy.gltf",
        r#"{"normalTexture":{"index":0},"occlusionTexture":{"index":0}}"#,
    );
    let named = warnings_with(&warnings, "material features arbor does not render");
    assert_eq!(named.len(), 1, "{warnings:?}");
    assert!(
        named[0].starts_with(&p.display().to_string())
            && named[0].ends_with("normal textures, occlusion textures"),
        "{named:?}"
    );
}

/// glTF `COLOR_0` is read linear (floats here) and multiplied by the base
/// colour factor.
#[test]
fn gltf_vertex_colours_multiply_the_base_colour() {
    let dir = tempfile::tempdir().unwrap();
    let mut bin = Vec::new();
    for v in [1f32, 0.5, 0.25, 0.2, 0.4, 0.6, 1., 1., 1.] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let uri = base64::encode(&bin);
    let json = gltf_material_json(
        r#"{"pbrMetallicRoughness":{"baseColorFactor":[0.5,1,1,1]}}"#,
        r#"[{"mesh":0},{}]"#,
        "",
    )
    .replace(r#""attributes":{"POSITION":0}"#, r#""attributes":{"POSITION":0,"COLOR_0":2}"#)
    .replace(
        r#""type":"SCALAR"}]"#,
        r#""type":"SCALAR"},{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}]"#,
    )
    .replace(
        r#""byteLength":6}]"#,
        r#""byteLength":6},{"buffer":1,"byteOffset":0,"byteLength":36}]"#,
    )
    .replace(
        r#"}],"materials""#,
        &format!(
            r#"}},{{"byteLength":36,"uri":"data:application/octet-stream;base64,{uri}"}}],"materials""#
        ),
    );
    let p = dir.path().join("colours.gltf");
    std::fs::write(&p, json).unwrap();
    let m = load_model(&p).unwrap_or_else(|e| panic!("{e}"));
    let Surface::Group(g) = &m.surfaces[0] else {
        panic!("{:?}", m.surfaces[0]);
    };
    let Surface::Instance(mesh) = &g.children[0] else {
        panic!("{:?}", g.children[0]);
    };
    let Surface::Mesh(mesh) = &**mesh else {
        panic!("{mesh:?}");
    };
    let colors = mesh.data.colors.as_ref().expect("COLOR_0 is read");
    assert_eq!(colors[0], glam::Vec3::new(0.5, 0.5, 0.25));
    assert_eq!(colors[1], glam::Vec3::new(0.1, 0.4, 0.6));
}

/// MTL features the shaders leave out are named in one warning that names
/// the OBJ file.
#[test]
fn mtl_ignored_features_are_named_once() {
    let (dir, obj) = folder_with(
        "b.obj",
        "mtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 1 3 2\n",
    );
    std::fs::write(
        dir.path().join("b.mtl"),
        "newmtl a\nKd 1 0 0\nmap_Bump n.png\nillum 9\nnewmtl b\nKd 0 1 0\nbump n.png\nKe 1 1 1\n",
    )
    .unwrap();
    let m = load_model(&obj).unwrap();
    let named = warnings_with(&m.warnings, "material features arbor does not render");
    assert_eq!(named.len(), 1, "{:?}", m.warnings);
    assert_eq!(
        *named[0],
        format!(
            "{}: warning: material features arbor does not render are ignored: bump maps (map_Bump), illum 8 and 9 (reflection without ray tracing), emission (Ke)",
            obj.display()
        )
    );
    // A plain material: no such warning.
    std::fs::write(dir.path().join("b.mtl"), "newmtl a\nKd 1 0 0\nnewmtl b\n").unwrap();
    let m = load_model(&obj).unwrap();
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

/// glTF as a mesh for ray casting: every placement of every mesh, node
/// transforms applied, in tree order (a node's mesh before its children);
/// the engine's triangles are all there, as placed.
#[test]
fn gltf_ray_meshes_are_placed_in_tree_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("placed.gltf");
    // Scene roots 3 then 0; node 0 (translated by x + 1) places the mesh
    // itself, then its children 1 (scaled by 2) and 2 (z + 5).
    let json = gltf_json(
        r#"[{"children":[1,2],"translation":[1,0,0],"mesh":0},{"mesh":0,"scale":[2,2,2]},{"mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,5,1]},{"mesh":0,"translation":[0,-3,0]}]"#,
        "[3,0]",
        "",
    );
    std::fs::write(&path, json).unwrap();
    let mesh = arbor::load::load_ray_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
    let tris: Vec<[u32; 3]> = (0..4).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    assert_eq!(mesh.triangles, tris);
    // Each placement's corner (1, 0, 0) of the triangle (0,0,0) (1,0,0) (0,1,0).
    let corners: Vec<[f32; 3]> = (0..4)
        .map(|k| mesh.positions[3 * k + 1].to_array())
        .collect();
    assert_eq!(
        corners,
        [[1., -3., 0.], [2., 0., 0.], [3., 0., 0.], [2., 0., 5.]]
    );
    let Some(models) = models() else { return };
    let engine = models.join("glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    let mesh = arbor::load::load_ray_mesh(&engine).unwrap_or_else(|e| panic!("{e}"));
    let model = load_model(&engine).unwrap();
    assert_eq!(mesh.triangles.len() as u64, model.stats.instanced_triangles);
    // The same bounds as the model as placed.
    let (lo, hi) = frame::bounds(&model.surfaces).unwrap();
    let (mut mlo, mut mhi) = (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY);
    for p in &mesh.positions {
        (mlo, mhi) = (mlo.min(*p), mhi.max(*p));
    }
    assert!((mlo.as_dvec3() - lo).abs().max_element() < 1e-3 * (hi - lo).max_element());
    assert!((mhi.as_dvec3() - hi).abs().max_element() < 1e-3 * (hi - lo).max_element());
}
