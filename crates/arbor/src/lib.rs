//! arbor: a Whitted-style ray tracer built around the scene structures and
//! acceleration structures of Cornell's "Ray Tracing II".
//!
//! Data flows one way: [`xml`] loads a [`scene::Scene`] (the scene graph of
//! [`surface`]s), [`flatten`] compiles it into primitives, [`tracer`] puts an
//! acceleration structure from `arbor-accel` over them, [`render`] shades
//! camera rays into a [`film::Film`], which is written as PNG or EXR.

pub mod camera;
pub mod compare;
pub mod default_scene;
pub mod film;
pub mod flatten;
mod hash_map;
pub mod heatmap;
pub mod light;
pub mod load;
pub mod partial;
pub mod render;
pub mod scene;
pub mod shader;
pub mod stats;
pub mod surface;
pub mod texture;
pub mod tracer;
pub mod xml;
