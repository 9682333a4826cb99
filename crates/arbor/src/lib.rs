//! arbor: a Whitted-style ray tracer built around the scene structures and
//! acceleration structures of Cornell's "Ray Tracing II".
//!
//! Data flows one way: [`load`] reads a [`scene::Scene`] (the scene graph of
//! [`surface`]s), [`flatten`] compiles it into primitives, [`tracer`] puts an
//! acceleration structure from `arbor-accel` over them, [`render`] shades
//! camera rays into a [`film::Film`], which is written as PNG or EXR.
//!
//! ```
//! use std::sync::atomic::AtomicBool;
//!
//! use arbor::flatten::FlattenedScene;
//! use arbor::tracer::{Tracer, TracerOptions};
//!
//! // The built-in classroom (what `arbor render` shows without a scene),
//! // made small so the example runs quickly.
//! let mut scene = arbor::default_scene::classroom();
//! (scene.width, scene.height) = (32, 20);
//! // Flatten the scene graph (instances stay shared) and accelerate it.
//! let flat = FlattenedScene::new(&scene, arbor::flatten::DEFAULT_MAX_PLACEMENTS)?;
//! let tracer = Tracer::build(flat, &TracerOptions::default());
//! // Render every pixel, with no progress report and no way to cancel.
//! let film = arbor::render::render(&scene, &tracer, &|_| {}, &AtomicBool::new(false))
//!     .expect("not cancelled");
//! assert_eq!((film.width(), film.height()), (32, 20));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod byte_table;
pub mod camera;
pub mod census;
pub mod compare;
pub mod default_scene;
pub mod film;
pub mod flatten;
mod hash_map;
pub mod heatmap;
mod level;
pub mod light;
pub mod limits;
pub mod load;
pub mod nested;
mod option_names;
pub mod partial;
pub mod ray;
pub mod render;
pub mod scene;
pub mod shader;
pub mod stats;
pub mod surface;
pub mod terminator;
pub mod texture;
pub mod tracer;
pub mod traversal;
pub mod variant;
