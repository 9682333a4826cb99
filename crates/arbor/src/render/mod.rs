//! The renderer: camera rays for every pixel sample, shaded by the
//! [`Integrator`], averaged into a [`Film`]. Work is split into tiles that
//! run on all cores; every pixel depends only on its own samples, so the
//! image is the same bit for bit for any thread count.

use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::camera::PreparedCamera;
use crate::film::Film;
use crate::ray::Ray;
use crate::scene::{Scene, Variant};
use crate::stats::{NoStats, RayStats};
use crate::tracer::Tracer;

mod file;
mod shade;

pub use file::{
    apply_samples_and_size, build_tracer, flatten, load, render_file, valid_pixels, valid_samples,
    valid_side, RenderFileError, RenderOptions, RenderedFile,
};
pub use shade::Integrator;

/// Side of the square tiles the image is cut into for parallel rendering.
pub const TILE_SIZE: u32 = 32;

/// A rectangle of pixels, `x0..x1` by `y0..y1`, row 0 at the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// Number of pixels.
    pub fn area(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}

/// The render was cancelled before it finished; `partial` holds the tiles
/// that were done (the rest is black).
#[derive(Clone, Debug, PartialEq)]
pub struct Cancelled {
    /// What was rendered before the cancellation.
    pub partial: Film,
}

/// The tiles covering a `width` x `height` image, row by row.
pub fn tiles(width: u32, height: u32) -> Vec<Region> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(TILE_SIZE as usize) {
        for x0 in (0..width).step_by(TILE_SIZE as usize) {
            out.push(Region {
                x0,
                y0,
                x1: (x0 + TILE_SIZE).min(width),
                y1: (y0 + TILE_SIZE).min(height),
            });
        }
    }
    out
}

/// The image-plane coordinates `(u, v)` of sample `(a, b)` of pixel
/// `(column, row)` (row 0 at the top), in the variant's convention; shared by
/// the renderer and the cost heatmap so both see the same camera rays.
pub fn sample_uv(scene: &Scene, column: u32, row: u32, a: u32, b: u32) -> (f64, f64) {
    let s = scene.samples_per_side;
    let (w, h) = (scene.width, scene.height);
    match scene.variant {
        Variant::Cornell2010 => {
            let x = (column * s + a) as f64;
            let y = ((h - 1 - row) * s + b) as f64;
            (
                (x + 0.5) / (w * s) as f64 - 0.5,
                (y + 0.5) / (h * s) as f64 - 0.5,
            )
        }
        Variant::Cornell2015 => {
            let i = column as f64;
            let j = (h - 1 - row) as f64;
            let inv = 1.0 / s as f64;
            let u0 = (i + (a as f64 + 0.5) * inv) / w as f64;
            let v0 = (j + (b as f64 + 0.5) * inv) / h as f64;
            (2.0 * u0 - 1.0, 2.0 * v0 - 1.0)
        }
    }
}

/// The `tmin` of camera rays: 2010 camera rays start at 0, 2015 ones at
/// the integrator's epsilon.
pub fn camera_tmin(variant: Variant) -> f64 {
    match variant {
        Variant::Cornell2010 => 0.0,
        Variant::Cornell2015 => shade::T_EPSILON,
    }
}

/// The camera ray of sample `(a, b)` of pixel `(column, row)` (row 0 at
/// the top), as the renderer casts it: shared with the cost heatmap and
/// `arbor explain` so all see the same rays.
pub fn camera_ray(
    scene: &Scene,
    camera: &PreparedCamera,
    column: u32,
    row: u32,
    a: u32,
    b: u32,
) -> Ray {
    let (u, v) = sample_uv(scene, column, row, a, b);
    let (origin, direction) = camera.ray(u, v);
    Ray::unbounded(origin, direction, camera_tmin(scene.variant))
}

/// The linear radiance of pixel `(column, row)` (row 0 at the top): the
/// average of its `s`x`s` samples, times the exposure.
pub fn render_pixel(
    scene: &Scene,
    integrator: &Integrator,
    camera: &PreparedCamera,
    column: u32,
    row: u32,
) -> DVec3 {
    render_pixel_with(scene, integrator, camera, column, row, &mut NoStats)
}

/// [`render_pixel`], recording every ray traced into `stats`.
pub fn render_pixel_with<S: RayStats>(
    scene: &Scene,
    integrator: &Integrator,
    camera: &PreparedCamera,
    column: u32,
    row: u32,
    stats: &mut S,
) -> DVec3 {
    let s = scene.samples_per_side;
    let mut sum = DVec3::ZERO;
    for a in 0..s {
        for b in 0..s {
            sum += integrator.camera_ray_with(&camera_ray(scene, camera, column, row, a, b), stats);
        }
    }
    let n = (s * s) as f64;
    match scene.variant {
        Variant::Cornell2010 => sum / n,
        Variant::Cornell2015 => scene.exposure * sum / n,
    }
}

/// Renders `region` of `scene` through `tracer`. `progress(pixels)` is
/// called as tiles finish; setting `cancel` stops the render within one tile
/// row.
pub fn render_region(
    scene: &Scene,
    tracer: &Tracer,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Result<Film, Cancelled> {
    render_region_with::<NoStats>(scene, tracer, region, progress, cancel).map(|(film, _)| film)
}

/// [`render_region`], also returning the statistics of every ray traced,
/// gathered per tile into an `S` and merged. With [`NoStats`] this is exactly
/// [`render_region`]; the image never depends on `S`.
pub fn render_region_with<S: RayStats>(
    scene: &Scene,
    tracer: &Tracer,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(Film, S), Cancelled> {
    render_region_observed(scene, tracer, region, progress, &|_, _| {}, cancel)
}

/// [`render_region_with`], also handing each finished tile and its pixels
/// (row by row, linear radiance) to `on_tile` as soon as it is done: a
/// caller can show the picture so far. The image never depends on it.
pub fn render_region_observed<S: RayStats>(
    scene: &Scene,
    tracer: &Tracer,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
    on_tile: &(dyn Fn(Region, &[DVec3]) + Sync),
    cancel: &AtomicBool,
) -> Result<(Film, S), Cancelled> {
    let camera = scene.camera.prepare();
    let integrator = Integrator::new(scene, tracer);
    let all = tiles(scene.width, scene.height);
    let mine: Vec<Region> = all
        .into_iter()
        .filter_map(|t| {
            let r = Region {
                x0: t.x0.max(region.x0),
                y0: t.y0.max(region.y0),
                x1: t.x1.min(region.x1),
                y1: t.y1.min(region.y1),
            };
            (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
        })
        .collect();
    let done: Vec<Option<(Region, Vec<DVec3>, S)>> = mine
        .par_iter()
        .map(|&tile| {
            let mut pixels = Vec::with_capacity(tile.area() as usize);
            let mut stats = S::default();
            for row in tile.y0..tile.y1 {
                if cancel.load(Ordering::Relaxed) {
                    return None;
                }
                for col in tile.x0..tile.x1 {
                    pixels.push(render_pixel_with(
                        scene,
                        &integrator,
                        &camera,
                        col,
                        row,
                        &mut stats,
                    ));
                }
            }
            on_tile(tile, &pixels);
            progress(tile.area());
            Some((tile, pixels, stats))
        })
        .collect();
    let mut film = Film::new(region.x1 - region.x0, region.y1 - region.y0);
    let complete = done.iter().all(Option::is_some);
    let mut total = S::default();
    for (tile, pixels, stats) in done.into_iter().flatten() {
        total.merge(stats);
        let mut k = 0;
        for row in tile.y0..tile.y1 {
            for col in tile.x0..tile.x1 {
                film.set(col - region.x0, row - region.y0, pixels[k]);
                k += 1;
            }
        }
    }
    if complete {
        Ok((film, total))
    } else {
        Err(Cancelled { partial: film })
    }
}

/// Renders the whole image.
pub fn render(
    scene: &Scene,
    tracer: &Tracer,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Result<Film, Cancelled> {
    let full = Region {
        x0: 0,
        y0: 0,
        x1: scene.width,
        y1: scene.height,
    };
    render_region(scene, tracer, full, progress, cancel)
}
