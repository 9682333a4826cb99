//! Any text as a Cornell XML scene: parsing must return a scene or a located
//! error, never panic; a scene that parses must flatten and trace a few
//! rays (on a tiny image) without panicking.
#![no_main]

use std::path::Path;
use std::sync::atomic::AtomicBool;

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // A folder that does not exist, so relative mesh names resolve to nothing.
    let Ok(loaded) = arbor::load::xml::parse_scene(text, Path::new("/nonexistent-fuzz/scene.xml")) else {
        return;
    };
    let mut scene = loaded.scene;
    scene.width = scene.width.min(4);
    scene.height = scene.height.min(4);
    scene.samples_per_side = scene.samples_per_side.min(2);
    let Ok(flat) = arbor::flatten::FlattenedScene::new(&scene, 10_000) else {
        return;
    };
    let tracer = arbor::tracer::Tracer::build(flat, &arbor::tracer::TracerOptions::default());
    let _ = arbor::render::render(&scene, &tracer, &|_| {}, &AtomicBool::new(false));
});
