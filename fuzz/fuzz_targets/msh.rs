//! Any text as a Cornell `.msh` mesh: a mesh with every index in range, or a
//! located error; never a panic or a huge allocation.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(mesh) = arbor::load::msh::parse_msh(&text, Path::new("fuzz.msh")) {
        let n = mesh.positions.len() as u32;
        assert!(mesh.triangles.iter().flatten().all(|&i| i < n));
    }
});
