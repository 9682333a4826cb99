//! Any bytes as an STL file (ASCII or binary, told apart by content): an
//! indexed mesh whose every index is in range and whose positions are finite
//! and distinct, or an error; never a panic.
#![no_main]

use std::collections::BTreeSet;
use std::path::Path;

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    if let Ok(mesh) = arbor::load::stl::parse(data, Path::new("fuzz.stl")) {
        let n = mesh.positions.len();
        assert!(!mesh.triangles.is_empty(), "a mesh without triangles");
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        assert!(mesh.positions.iter().all(|p| p.is_finite()));
        assert!(mesh.normals.is_none() && mesh.uvs.is_none());
        // Identical corners are merged (0.0 and -0.0 are one point).
        let distinct: BTreeSet<[u32; 3]> = mesh
            .positions
            .iter()
            .map(|p| (*p + glam::Vec3::ZERO).to_array().map(f32::to_bits))
            .collect();
        assert_eq!(distinct.len(), n, "corners not merged");
        assert!(n <= 3 * mesh.triangles.len());
    }
});
