//! Any bytes as a PLY file (ASCII or binary, either endianness): a mesh
//! whose every index is in range, with finite positions and usable normals,
//! or an error; never a panic or an allocation the file cannot back.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    if let Ok(mesh) = arbor::load::ply::parse(data, Path::new("fuzz.ply")) {
        let n = mesh.positions.len();
        assert!(!mesh.triangles.is_empty(), "a mesh without triangles");
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        assert!(mesh.positions.iter().all(|p| p.is_finite()));
        if let Some(ns) = &mesh.normals {
            assert_eq!(ns.len(), n);
            assert!(ns.iter().all(|v| v.is_finite() && v.length_squared() > 0.0));
        }
        if let Some(uvs) = &mesh.uvs {
            assert_eq!(uvs.len(), n);
        }
        // A record takes at least one byte: the file bounds what was built.
        assert!(n <= data.len() && mesh.triangles.len() <= data.len() * 3);
    }
});
