//! The scene as loaded: camera, lights, shaders and the surface hierarchy,
//! plus the rendering conventions of the format variant it came from.

use std::sync::Arc;

use glam::DVec3;

use crate::camera::Camera;
use crate::light::Light;
use crate::surface::Surface;
use crate::texture::CubeMap;

pub use crate::variant::Variant;

/// A complete scene, ready to be compiled for rendering.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The conventions to follow.
    pub variant: Variant,
    /// How rays leave the eye.
    pub camera: Camera,
    /// Image width and height in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Antialiasing: each pixel is sampled on a `samples_per_side`² grid.
    pub samples_per_side: u32,
    /// The light sources.
    pub lights: Vec<Light>,
    /// The top-level surfaces (each may be a group holding more).
    pub surfaces: Vec<Surface>,
    /// Radiance of rays that hit nothing (2015 `backColor`; black in 2010).
    pub background: DVec3,
    /// Scale applied to every pixel before gamma (2015 `exposure`).
    pub exposure: f64,
    /// Environment map seen by rays that hit nothing (2015 `cubemap`).
    pub cubemap: Option<Arc<CubeMap>>,
}

impl Scene {
    /// The grid side `s` for a `<samples>` value `n`: `round(sqrt(n))`, at least 1.
    pub fn samples_per_side_for(n: u32) -> u32 {
        ((n as f64).sqrt().round() as u32).max(1)
    }

    /// The image becomes `width` x `height` pixels, the horizontal extent
    /// of the view kept and the vertical one fitted (square pixels).
    pub fn resize(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        self.camera.view_height = self.camera.view_width * height as f64 / width as f64;
    }
}

/// A loaded scene and the warnings met on the way (unknown attributes,
/// skipped polygons, ...), each already located as `FILE:LINE:COL: ...`.
#[derive(Debug)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Non-fatal remarks for the user.
    pub warnings: Vec<String>,
}
