//! Automatic framing: what a model file leaves out (a camera, lights, a
//! floor) chosen from the model's bounds so that a first render looks good.
//!
//! Conventions: y is up and the model's front faces +z (as in OBJ and
//! glTF). The camera looks from the front-right and above at the centre of
//! the bounding sphere, far enough back that the whole sphere is in view; a
//! large thin box just under the model is the floor; three point lights
//! (key, fill and rim) sit at a few radii, with intensities scaled by the
//! square of their distance because 2015 lights fall off as `1/r²`.

use std::sync::Arc;

use glam::{DMat4, DVec3};

use super::Model;
use crate::camera::{Camera, CameraKind};
use crate::light::Light;
use crate::scene::{Scene, Variant};
use crate::shader::Shader;
use crate::surface::{BoxSurface, Surface};

/// Vertical field of view of the automatic camera, in degrees.
pub const FIELD_OF_VIEW_DEGREES: f64 = 35.0;
/// Default image width in pixels (the height follows the aspect ratio).
pub const IMAGE_WIDTH: u32 = 800;
/// Default aspect ratio (width / height) without a camera in the file.
pub const ASPECT: f64 = 4.0 / 3.0;

/// World-space bounds of every triangle corner of `surfaces`, every
/// placement counted, or `None` when there is no finite triangle.
pub fn bounds(surfaces: &[Surface]) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for s in surfaces {
        s.for_each_leaf(DMat4::IDENTITY, &mut |leaf, m| {
            if let Surface::Mesh(mesh) = leaf {
                for p in mesh.data.used_positions() {
                    let w = m.transform_point3(p);
                    if w.is_finite() {
                        lo = lo.min(w);
                        hi = hi.max(w);
                    }
                }
            }
        });
    }
    (lo.cmple(hi).all()).then_some((lo, hi))
}

/// The camera that frames the bounding sphere (`center`, `radius`) from the
/// front-right and above, for an image of the given aspect ratio.
pub fn framing_camera(center: DVec3, radius: f64, aspect: f64) -> Camera {
    let vfov = FIELD_OF_VIEW_DEGREES.to_radians();
    let view_height = 2.0 * (vfov / 2.0).tan();
    let view_width = view_height * aspect;
    // The narrower of the two angles decides how far back the sphere fits.
    let half = (view_width.min(view_height) / 2.0).atan();
    let distance = radius / half.sin() * 1.05;
    let (azimuth, elevation) = (35f64.to_radians(), 25f64.to_radians());
    let to_eye = DVec3::new(
        azimuth.sin() * elevation.cos(),
        elevation.sin(),
        azimuth.cos() * elevation.cos(),
    );
    Camera {
        kind: CameraKind::Perspective2015,
        view_point: center + distance * to_eye,
        view_dir: -to_eye,
        view_up: DVec3::Y,
        proj_normal: DVec3::ZERO,
        proj_distance: 1.0,
        view_width,
        view_height,
    }
}

/// Key, fill and rim point lights around the bounding sphere.
pub fn default_lights(center: DVec3, radius: f64) -> Vec<Light> {
    let at = |dir: DVec3, distance: f64, strength: DVec3| {
        let d = distance * radius;
        Light::Point {
            position: center + d * dir.normalize(),
            // Irradiance `strength` at the model's centre despite the 1/r² falloff.
            intensity: strength * d * d,
        }
    };
    vec![
        at(
            DVec3::new(-1.0, 1.8, 1.3),
            5.0,
            DVec3::new(0.85, 0.82, 0.76),
        ),
        at(DVec3::new(1.6, 0.5, 0.9), 5.0, DVec3::new(0.3, 0.32, 0.36)),
        at(DVec3::new(0.4, 1.2, -1.5), 5.0, DVec3::new(0.3, 0.3, 0.3)),
    ]
}

/// A large thin box whose top lies just under `lo.y`, centred under the model.
pub fn ground(lo: DVec3, center: DVec3, radius: f64) -> Surface {
    let half = 40.0 * radius;
    // A small gap keeps the floor from cutting through faces resting on it.
    let top = lo.y - 1e-3 * radius;
    Surface::Box(BoxSurface {
        min: DVec3::new(center.x - half, top - 0.05 * radius, center.z - half),
        max: DVec3::new(center.x + half, top, center.z + half),
        shader: Arc::new(Shader::Lambertian {
            diffuse: DVec3::new(0.55, 0.53, 0.5),
            texture: None,
        }),
    })
}

/// The scene for `model` (2015 conventions): its surfaces on a floor, its
/// own camera or the framing camera, its own lights or the default ones.
/// `None` when the model has no finite triangle to frame.
pub fn scene_for(model: &Model) -> Option<Scene> {
    let (lo, hi) = bounds(&model.surfaces)?;
    let center = (lo + hi) / 2.0;
    // A flat or point-like model still needs a positive size to scale by.
    let radius = match (hi - lo).length() / 2.0 {
        r if r > 0.0 && r.is_finite() => r,
        _ => 1.0,
    };
    let aspect = model
        .aspect
        .filter(|a| a.is_finite() && *a > 0.05 && *a < 20.0)
        .unwrap_or(ASPECT);
    let camera = model
        .camera
        .clone()
        .unwrap_or_else(|| framing_camera(center, radius, aspect));
    let lights = if model.lights.is_empty() {
        default_lights(center, radius)
    } else {
        model.lights.clone()
    };
    let mut surfaces = model.surfaces.clone();
    surfaces.push(ground(lo, center, radius));
    let height = ((IMAGE_WIDTH as f64 / aspect).round() as u32).clamp(16, 4 * IMAGE_WIDTH);
    Some(Scene {
        variant: Variant::Cornell2015,
        camera,
        width: IMAGE_WIDTH,
        height,
        samples_per_side: 2,
        lights,
        surfaces,
        background: DVec3::new(0.62, 0.72, 0.85),
        exposure: 1.0,
        cubemap: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bounding_sphere_is_in_view() {
        let (c, r) = (DVec3::new(3.0, -2.0, 7.0), 2.5);
        let cam = framing_camera(c, r, 4.0 / 3.0);
        let d = cam.view_point - c;
        // The sphere's angular radius fits in the narrower half-angle.
        let angular = (r / d.length()).asin();
        let half_v = (cam.view_height / 2.0).atan();
        assert!(angular < half_v, "{angular} vs {half_v}");
        // From the front (+z), the right (+x) and above (+y).
        assert!(d.x > 0.0 && d.y > 0.0 && d.z > 0.0);
        let (_, dir) = cam.prepare().ray(0.0, 0.0);
        assert!((dir + d.normalize()).length() < 1e-12);
    }
}
