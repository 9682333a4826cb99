//! The shadow terminator before and after its softening
//! (`arbor::terminator`): a model framed as `arbor render` frames it,
//! rendered with shadow rays from the hit point (left) and from the lifted
//! point (right), side by side in one PNG: the middle 400 x 300 pixels of
//! an 800 x 600 picture each, so the model is seen at twice the size.
//!
//! ```sh
//! cargo run --release -p arbor --example terminator -- \
//!     /usr/share/assimp/models/OBJ/WusonOBJ.obj docs/images/terminator.png
//! ```

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use arbor::flatten::{FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use arbor::surface::Surface;
use arbor::tracer::{Tracer, TracerOptions};

/// Sets every mesh's `soft_terminator` under `surfaces`.
fn set_soft(surfaces: &mut [Surface], soft: bool) {
    for s in surfaces {
        match s {
            Surface::Mesh(m) => m.soft_terminator = soft,
            Surface::Group(g) => set_soft(&mut g.children, soft),
            Surface::Instance(shared) => {
                set_soft(std::slice::from_mut(Arc::make_mut(shared)), soft)
            }
            _ => {}
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let model = args
        .first()
        .map_or("/usr/share/assimp/models/OBJ/WusonOBJ.obj", String::as_str);
    let out = args.get(1).map_or("terminator.png", String::as_str);
    let (mut scene, _) = arbor::load::load_model_scene(Path::new(model))?;
    let (w, h) = (800, 600);
    scene.width = w;
    scene.height = h;
    scene.camera.view_height = scene.camera.view_width * h as f64 / w as f64;
    let mut halves = Vec::new();
    for soft in [false, true] {
        let mut s = scene.clone();
        set_soft(&mut s.surfaces, soft);
        let flat = FlattenedScene::new(&s, DEFAULT_MAX_PLACEMENTS)?;
        let tracer = Tracer::build(flat, &TracerOptions::default());
        let film = arbor::render::render(&s, &tracer, &|_| {}, &AtomicBool::new(false))
            .expect("not cancelled");
        halves.push(film.to_rgb8(s.variant));
    }
    let row = w as usize * 3;
    let (x0, y0) = (w as usize / 4, h as usize / 4);
    let mut both = Vec::new();
    for y in y0..y0 + h as usize / 2 {
        for half in &halves {
            both.extend_from_slice(&half[y * row + x0 * 3..y * row + (x0 + w as usize / 2) * 3]);
        }
    }
    arbor::film::write_png(Path::new(out), w, h / 2, &both)?;
    println!("{out}: {model}, before (left) and after (right)");
    Ok(())
}
