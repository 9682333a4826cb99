//! The renderer: camera rays for every pixel sample, shaded by the
//! [`Integrator`], averaged into a [`Film`]. Work is split into tiles that
//! run on all cores; every pixel depends only on its own samples, so the
//! image is the same bit for bit for any thread count.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

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
    apply_samples_and_size, build_nested, build_tracer, flatten, load, plan, render_file,
    valid_pixels, valid_samples, valid_side, RenderFileError, RenderOptions, RenderedFile,
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

/// [`render_region_with`], also calling `on_tile(tile, film)` as each tile
/// finishes, with `film` the region's pixels so far (black where no tile is
/// done yet) and no other tile added meanwhile: a caller can copy the
/// picture so far. The image never depends on it.
pub fn render_region_observed<S: RayStats>(
    scene: &Scene,
    tracer: &Tracer,
    region: Region,
    progress: &(dyn Fn(u64) + Sync),
    on_tile: &(dyn Fn(Region, &Film) + Sync),
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
    // Tiles go into the one film as they finish: no second copy of the
    // picture, and nothing left to assemble once the last tile is done.
    let film = Mutex::new(Film::new(region.x1 - region.x0, region.y1 - region.y0));
    let done: Vec<Option<S>> = mine
        .par_iter()
        .map(|&tile| {
            let width = (tile.x1 - tile.x0) as usize;
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
            let mut film = film.lock().unwrap_or_else(|e| e.into_inner());
            for (row, values) in (tile.y0..tile.y1).zip(pixels.chunks_exact(width)) {
                film.set_row(tile.x0 - region.x0, row - region.y0, values);
            }
            on_tile(tile, &film);
            drop(film);
            progress(tile.area());
            Some(stats)
        })
        .collect();
    let film = film.into_inner().unwrap_or_else(|e| e.into_inner());
    let complete = done.iter().all(Option::is_some);
    let mut total = S::default();
    for stats in done.into_iter().flatten() {
        total.merge(stats);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flatten::{FlatGeometry, FlattenedScene};
    use crate::tracer::TracerOptions;

    /// Each tile the observer is handed is already in the film it sees,
    /// equal to the finished picture there, and no tile it has not been
    /// handed yet is (black); the tiles tile the region once each.
    #[test]
    fn the_observer_sees_each_finished_tile_in_the_film_so_far() {
        let scene = crate::default_scene::classroom();
        let tracer = Tracer::build(
            FlattenedScene::from_world(FlatGeometry::new(&scene).unwrap()),
            &TracerOptions::default(),
        );
        let region = Region {
            x0: 3,
            y0: 5,
            x1: scene.width.min(70),
            y1: scene.height.min(50),
        };
        let seen = Mutex::new(Vec::new());
        let cancel = AtomicBool::new(false);
        let (final_film, _) = render_region_observed::<NoStats>(
            &scene,
            &tracer,
            region,
            &|_| {},
            &|tile, film| seen.lock().unwrap().push((tile, film.clone())),
            &cancel,
        )
        .unwrap();
        let seen = seen.into_inner().unwrap();
        let area: u64 = seen.iter().map(|(t, _)| t.area()).sum();
        assert_eq!(area, region.area());
        let lit = |film: &Film, t: &Region| {
            (t.y0..t.y1).all(|y| {
                (t.x0..t.x1).all(|x| {
                    let (fx, fy) = (x - region.x0, y - region.y0);
                    film.get(fx, fy) == final_film.get(fx, fy)
                })
            })
        };
        for (k, (tile, film)) in seen.iter().enumerate() {
            for (earlier, _) in &seen[..=k] {
                assert!(
                    lit(film, earlier),
                    "{earlier:?} missing when {tile:?} finished"
                );
            }
            for (later, _) in &seen[k + 1..] {
                let black = (later.y0..later.y1).all(|y| {
                    (later.x0..later.x1)
                        .all(|x| film.get(x - region.x0, y - region.y0) == DVec3::ZERO)
                });
                assert!(black, "{later:?} present before it finished");
            }
        }
        assert!((0..final_film.height())
            .any(|y| (0..final_film.width()).any(|x| final_film.get(x, y) != DVec3::ZERO)));
    }
}
