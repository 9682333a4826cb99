//! Any bytes as glTF 2.0 (`.glb` binary or `.gltf` JSON, embedded buffers
//! only): a model whose meshes all have triangles with every index in range,
//! finite positions, usable normals and finite node matrices, whose counts
//! agree with what it holds, and which frames, flattens and renders (at 4x4)
//! without panicking; or an error.
#![no_main]

use std::path::Path;
use std::sync::atomic::AtomicBool;

use arbor::surface::Surface;
use glam::DMat4;
use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

/// Checks every node matrix below `s` (each group's own, not the product,
/// which may overflow legitimately).
fn check_groups(s: &Surface) {
    match s {
        Surface::Group(g) => {
            assert!(g.transform.is_finite(), "node matrix not finite");
            g.children.iter().for_each(check_groups);
        }
        Surface::Instance(shared) => check_groups(shared),
        _ => {}
    }
}

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    // No base folder: external buffers are refused, never read from disk.
    let Ok(model) = arbor::load::gltf::parse(data, Path::new("fuzz.gltf"), None) else {
        return;
    };
    let stats = model.stats;
    assert!(stats.instanced_triangles > 0);
    assert!(stats.placements <= arbor::flatten::DEFAULT_MAX_PLACEMENTS);
    if stats.placements > 10_000 {
        return; // legitimate but slow to walk
    }
    let mut placed = 0u64;
    for s in &model.surfaces {
        check_groups(s);
        s.for_each_leaf(DMat4::IDENTITY, &mut |leaf, _| {
            let Surface::Mesh(m) = leaf else {
                panic!("a glTF model holds only meshes");
            };
            let d = &m.data;
            let n = d.positions.len();
            assert!(!d.triangles.is_empty(), "an empty mesh was kept");
            assert!(d.triangles.iter().flatten().all(|&i| (i as usize) < n));
            assert!(d.positions.iter().all(|p| p.is_finite()));
            if let Some(ns) = &d.normals {
                assert_eq!(ns.len(), n);
                assert!(ns.iter().all(|v| v.is_finite() && v.length_squared() > 0.0));
            }
            if let Some(uvs) = &d.uvs {
                assert_eq!(uvs.len(), n, "texture coordinates one per vertex");
            }
            placed += d.triangles.len() as u64;
        });
    }
    assert_eq!(placed, stats.instanced_triangles, "triangle count");
    assert!(stats.unique_triangles <= stats.instanced_triangles);
    let Some(mut scene) = arbor::load::frame::scene_for(&model) else {
        return;
    };
    scene.width = scene.width.min(4);
    scene.height = scene.height.min(4);
    scene.samples_per_side = scene.samples_per_side.min(2);
    let Ok(flat) = arbor::flatten::FlattenedScene::new(&scene, 10_000) else {
        return;
    };
    let tracer = arbor::tracer::Tracer::build(flat, &arbor::tracer::TracerOptions::default());
    let _ = arbor::render::render(&scene, &tracer, &|_| {}, &AtomicBool::new(false));
});
