//! Inputs that once broke a loader, kept in `fuzz/artifacts/TARGET/`, replayed
//! through the same reader as the fuzz target `fuzz/fuzz_targets/TARGET.rs`
//! with the same checks: an error, or a mesh whose indices are in range and
//! whose positions are finite. Then what each glTF input was, and the error
//! it gets now.

use std::path::{Path, PathBuf};

use arbor::load::obj_exact::{parse_obj, ObjRule};
use arbor::load::MeshData;
use arbor::load::{gltf, ply, stl};
use arbor::surface::Surface;
use glam::DMat4;

fn artifacts(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/artifacts")
        .join(target);
    let mut files: Vec<PathBuf> = match std::fs::read_dir(&dir) {
        Ok(entries) => entries.map(|e| e.unwrap().path()).collect(),
        Err(_) => Vec::new(),
    };
    files.sort();
    files
}

fn check_mesh(mesh: &MeshData, file: &Path) {
    let n = mesh.positions.len();
    assert!(
        !mesh.triangles.is_empty(),
        "{}: no triangles",
        file.display()
    );
    assert!(
        mesh.triangles.iter().flatten().all(|&i| (i as usize) < n),
        "{}: index out of range",
        file.display()
    );
    assert!(
        mesh.positions.iter().all(|p| p.is_finite()),
        "{}: position not finite",
        file.display()
    );
    if let Some(ns) = &mesh.normals {
        assert_eq!(ns.len(), n, "{}", file.display());
    }
}

#[test]
fn every_kept_artifact_replays_cleanly() {
    for file in artifacts("ply") {
        if let Ok(m) = ply::parse(&std::fs::read(&file).unwrap(), &file) {
            check_mesh(&m, &file);
        }
    }
    for file in artifacts("stl") {
        if let Ok(m) = stl::parse(&std::fs::read(&file).unwrap(), &file) {
            check_mesh(&m, &file);
        }
    }
    for file in artifacts("msh") {
        let text = String::from_utf8_lossy(&std::fs::read(&file).unwrap()).into_owned();
        if let Ok(m) = arbor::load::msh::parse_msh(&text, &file) {
            let n = m.positions.len() as u32;
            assert!(m.triangles.iter().flatten().all(|&i| i < n));
        }
    }
    for file in artifacts("obj") {
        let text = String::from_utf8_lossy(&std::fs::read(&file).unwrap()).into_owned();
        for rule in [ObjRule::Cornell2015, ObjRule::Fan] {
            if let Ok(o) = parse_obj(&text, &file, rule) {
                let n = o.mesh.positions.len() as u32;
                assert!(o.mesh.triangles.iter().flatten().all(|&i| i < n));
            }
        }
    }
    for file in artifacts("gltf") {
        if let Ok(model) = gltf::parse(&std::fs::read(&file).unwrap(), &file, None) {
            for s in &model.surfaces {
                s.for_each_leaf(DMat4::IDENTITY, &mut |leaf, _| {
                    if let Surface::Mesh(m) = leaf {
                        check_mesh(&m.data, &file);
                    }
                });
            }
        }
    }
}

/// The error `fuzz/artifacts/gltf/crash-NAME.gltf` gets (a panic before).
fn gltf_error(name: &str) -> String {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/artifacts/gltf")
        .join(format!("crash-{name}.gltf"));
    let bytes = std::fs::read(&file).unwrap();
    match gltf::parse(&bytes, &file, None) {
        Ok(_) => panic!("{name}: loaded"),
        Err(e) => e.message,
    }
}

/// One test per kept glTF crash, named for what it was: the file's error
/// names what is wrong.
macro_rules! gltf_errors {
    ($($(#[$doc:meta])* $test:ident: $name:literal => $needle:literal,)*) => {
        $(
            $(#[$doc])*
            #[test]
            fn $test() {
                let m = gltf_error($name);
                assert!(m.contains($needle), "{m}");
            }
        )*
    };
}

gltf_errors! {
    /// A buffer URI that percent-decodes to bytes that are not UTF-8 (`%ff`):
    /// the `gltf` crate unwraps the decoding and panicked.
    gltf_buffer_uri_not_utf8: "uri-not-utf8" => "percent-encoded UTF-8",
    /// A primitive whose POSITION names a missing accessor: `gltf-json`'s
    /// validation indexed the accessors with it before checking the index.
    gltf_position_accessor_missing: "position-accessor-missing" => "POSITION names an accessor that does not exist",
    /// A buffer view stride of 4 bytes under VEC3 float positions: the crate's
    /// reader asserted that each element slice holds 12 bytes.
    gltf_stride_shorter_than_element: "stride-shorter-than-element" => "stride shorter",
    /// Float indices: the crate's index reader has `unreachable!()` for them.
    gltf_float_indices: "float-indices" => "not unsigned integer scalars",
    /// VEC2 positions: read as VEC3 (a debug assertion in the crate, garbage
    /// positions in a release build).
    gltf_vec2_positions: "vec2-positions" => "not VEC3 of floats",
    /// A POSITION accessor with count 0: the crate's reader computes
    /// `count - 1` (an overflow panic in a debug build); the primitive is
    /// empty now and skipped, and the file has nothing else to render.
    gltf_empty_position_accessor: "empty-position-accessor" => "no triangles",
}

/// An external buffer that is not a regular file (a device that never
/// ends) is refused before reading.
#[cfg(unix)]
#[test]
fn gltf_buffer_that_is_not_a_file() {
    let json =
        br#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"file:///dev/zero"}]}"#;
    let e = gltf::parse(json, Path::new("dev.gltf"), Some(Path::new("/tmp"))).unwrap_err();
    assert!(e.message.contains("not a readable file"), "{e}");
    let json = br#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"../../../../../../dev/zero"}]}"#;
    let e = gltf::parse(json, Path::new("dev.gltf"), Some(Path::new("/tmp"))).unwrap_err();
    assert!(e.message.contains("not a readable file"), "{e}");
}

/// `crash-8aa3d1d5c49ec03e2a2b6db87e8f16bff80903f1` (found by the fuzzer): a
/// GLB whose header gives a total length of 11; the crate computed
/// `length - 12`, an overflow panic in a debug build.
#[test]
fn glb_length_shorter_than_its_header() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/artifacts/gltf/crash-8aa3d1d5c49ec03e2a2b6db87e8f16bff80903f1");
    let e = gltf::parse(&std::fs::read(&file).unwrap(), &file, None).unwrap_err();
    assert!(e.message.contains("shorter than the header"), "{e}");
    let mut glb = b"glTF\x02\0\0\0\x0b\0\0\0".to_vec();
    assert!(gltf::parse(&glb, &file, None).is_err());
    glb[8] = 12;
    assert!(gltf::parse(&glb, &file, None).is_err());
}
