//! The `picks` section: the traversals of the pixels on a grid, for the
//! page's pixel picker; the grid's step is chosen so the section stays
//! within a budget.

use std::collections::HashSet;

use arbor::scene::Scene;
use serde_json::Value;

use super::structures::View;
use super::traversal::{first_camera_ray, pixel_traversal, top_level_nodes, InnerLayouts};

/// Most picks before the size budget is considered.
const MAX_PICKS: u64 = 1024;

/// Bytes of JSON the picks may take.
const PICKS_BUDGET_BYTES: usize = 1_500_000;

/// The picked pixels' traversals and the grid step between them.
pub struct Picks {
    /// Step between picked pixels, in both directions (pixels `(i * stride,
    /// j * stride)`).
    pub stride: u32,
    /// One traversal per pixel, row by row, without boxes.
    pub rays: Vec<Value>,
}

/// The pixels picked at first: a grid of at most [`MAX_PICKS`], and its
/// step.
pub fn pick_pixels(scene: &Scene) -> (u32, Vec<(u32, u32)>) {
    let (w, h) = (scene.width, scene.height);
    let area = u64::from(w) * u64::from(h);
    let stride = ((area as f64 / MAX_PICKS as f64).sqrt().ceil() as u32).max(1);
    let pixels = (0..h)
        .step_by(stride as usize)
        .flat_map(|y| (0..w).step_by(stride as usize).map(move |x| (x, y)))
        .collect();
    (stride, pixels)
}

/// Numbers every view's nodes so that those the picks at `pixels` visit
/// are drawn (see [`View::renumber`]).
pub fn name_visited_nodes(scene: &Scene, views: &mut [View], pixels: &[(u32, u32)]) {
    for view in views.iter_mut() {
        let named: HashSet<u32> = pixels
            .iter()
            .flat_map(|&(x, y)| top_level_nodes(view, &first_camera_ray(scene, x, y)))
            .collect();
        view.renumber(&named);
    }
}

/// The picks at `pixels` (step `stride`) through `views`, thinned by
/// doubling the step until they fit the budget; notes the stride.
pub fn picks(
    scene: &Scene,
    views: &[View],
    inner: &mut InnerLayouts,
    pixels: (u32, Vec<(u32, u32)>),
    notes: &mut Vec<String>,
) -> Picks {
    let mut trace = |pixel| pixel_traversal(scene, views, inner, pixel, false);
    traced_picks(pixels, &mut trace, notes)
}

/// The picks at `pixels` (step `stride`), each `trace(pixel)`, thinned by
/// doubling the step until they fit the budget; notes the stride.
pub fn traced_picks(
    (mut stride, pixels): (u32, Vec<(u32, u32)>),
    trace: &mut dyn FnMut((u32, u32)) -> Value,
    notes: &mut Vec<String>,
) -> Picks {
    let mut rays: Vec<(u32, u32, Value, usize)> = pixels
        .into_iter()
        .map(|(x, y)| {
            let t = trace((x, y));
            let size = t.to_string().len();
            (x, y, t, size)
        })
        .collect();
    // Doubling the step keeps a subset of the same pixels.
    while rays.iter().map(|r| r.3).sum::<usize>() > PICKS_BUDGET_BYTES && rays.len() > 1 {
        stride *= 2;
        rays.retain(|r| r.0 % stride == 0 && r.1 % stride == 0);
    }
    notes.push(format!(
        "pixel picker: traversals stored every {stride} pixels ({} rays); a pick snaps to the nearest",
        rays.len()
    ));
    Picks {
        stride,
        rays: rays.into_iter().map(|r| r.2).collect(),
    }
}
