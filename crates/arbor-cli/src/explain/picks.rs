//! The `picks` section: the traversals of the pixels on a grid, for the
//! page's pixel picker; the grid's step is chosen so the section stays
//! within a budget.

use std::collections::HashSet;

use arbor::scene::Scene;
use serde_json::Value;

use super::structures::View;
use super::traversal::{pixel_traversal, InnerLayouts};

/// Most picks before the size budget is considered.
const MAX_PICKS: u64 = 1024;

/// Bytes of JSON the picks may take.
const PICKS_BUDGET_BYTES: usize = 2_500_000;

/// The picked pixels' traversals and the grid step between them.
pub struct Picks {
    /// Step between picked pixels, in both directions (pixels `(i * stride,
    /// j * stride)`).
    pub stride: u32,
    /// One traversal per pixel, row by row, without boxes.
    pub rays: Vec<Value>,
}

/// The picks of `scene` through `views`; notes the stride.
pub fn picks(
    scene: &Scene,
    views: &[View],
    inner: &mut InnerLayouts,
    notes: &mut Vec<String>,
) -> Picks {
    let (w, h) = (scene.width, scene.height);
    let area = u64::from(w) * u64::from(h);
    let mut stride = ((area as f64 / MAX_PICKS as f64).sqrt().ceil() as u32).max(1);
    let mut rays: Vec<(u32, u32, Value, usize)> = Vec::new();
    for y in (0..h).step_by(stride as usize) {
        for x in (0..w).step_by(stride as usize) {
            let t = pixel_traversal(scene, views, inner, (x, y), false);
            let size = t.to_string().len();
            rays.push((x, y, t, size));
        }
    }
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

/// The page numbers of the nodes the picks visit in structure `index`
/// (top level).
pub fn named_nodes(rays: &[Value], index: usize) -> HashSet<u32> {
    rays.iter()
        .filter_map(|r| r["structures"][index]["visits"].as_array())
        .flatten()
        .filter_map(|v| v["node"].as_u64())
        .map(|n| n as u32)
        .collect()
}
