//! Any text as an OBJ file under both numbering rules: a mesh with every
//! index in range, or a located error; never a panic.
#![no_main]

use std::path::Path;

use arbor::load::obj_exact::{parse_obj, ObjRule};
use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for rule in [ObjRule::Cornell2015, ObjRule::Fan] {
        if let Ok(obj) = parse_obj(&text, Path::new("fuzz.obj"), rule) {
            let n = obj.mesh.positions.len() as u32;
            assert!(obj.mesh.triangles.iter().flatten().all(|&i| i < n));
        }
    }
});
