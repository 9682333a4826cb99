//! The built-in default scene: what `arbor render` shows with no arguments.
//!
//! A classroom built the way the lecture builds scenes: a desk-and-chair
//! assembly is made once from transformed boxes and cylinders, grouped, and
//! placed twelve times as instances (one shared assembly, twelve
//! transforms); a glass globe and a glazed ball sit on the teacher's desk.

use std::sync::Arc;

use glam::{DMat4, DVec3};

use crate::camera::{Camera, CameraKind};
use crate::light::Light;
use crate::scene::{Scene, Variant};
use crate::shader::{Fresnel, Shader};
use crate::surface::transformed::{rotation_degrees, translation};
use crate::surface::{BoxSurface, Cylinder, Group, Sphere, Surface};

fn lambert(r: f64, g: f64, b: f64) -> Arc<Shader> {
    Arc::new(Shader::Lambertian {
        diffuse: DVec3::new(r, g, b),
        texture: None,
    })
}

fn phong(r: f64, g: f64, b: f64, exponent: f64) -> Arc<Shader> {
    Arc::new(Shader::Phong {
        diffuse: DVec3::new(r, g, b),
        specular: DVec3::splat(0.35),
        exponent,
        texture: None,
    })
}

fn cuboid(min: [f64; 3], max: [f64; 3], shader: &Arc<Shader>) -> Surface {
    Surface::Box(BoxSurface {
        min: DVec3::from(min),
        max: DVec3::from(max),
        shader: shader.clone(),
    })
}

fn group(transform: DMat4, children: Vec<Surface>) -> Surface {
    Surface::Group(Group {
        transform,
        children,
    })
}

/// A vertical cylinder (the primitive runs along z; a -90 degree turn about x
/// stands it up) with its foot at `(x, 0, z)`.
fn leg(x: f64, z: f64, height: f64, radius: f64, shader: &Arc<Shader>) -> Surface {
    group(
        translation(DVec3::new(x, 0.0, z)) * rotation_degrees(DVec3::new(-90.0, 0.0, 0.0)),
        vec![Surface::Cylinder(Cylinder {
            center: DVec3::new(0.0, 0.0, height / 2.0),
            radius,
            height,
            shader: shader.clone(),
        })],
    )
}

fn four_legs(half_x: f64, half_z: f64, height: f64, shader: &Arc<Shader>) -> Vec<Surface> {
    [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
        .iter()
        .map(|(sx, sz)| leg(sx * half_x, sz * half_z, height, 0.025, shader))
        .collect()
}

/// One pupil's desk with its chair, centred on the origin, facing -z.
fn desk_and_chair(wood: &Arc<Shader>, metal: &Arc<Shader>, seat: &Arc<Shader>) -> Surface {
    let mut desk = four_legs(0.55, 0.25, 0.72, metal);
    desk.push(cuboid([-0.6, 0.72, -0.3], [0.6, 0.76, 0.3], wood));
    let mut chair = four_legs(0.2, 0.2, 0.44, metal);
    chair.push(cuboid([-0.23, 0.44, -0.23], [0.23, 0.48, 0.23], seat));
    chair.push(cuboid([-0.23, 0.48, 0.2], [0.23, 0.9, 0.24], seat));
    group(
        DMat4::IDENTITY,
        vec![
            group(DMat4::IDENTITY, desk),
            group(translation(DVec3::new(0.0, 0.0, 0.55)), chair),
        ],
    )
}

/// The classroom scene (2015 conventions: `1/r²` lights, exposure, a
/// background colour and cylinders).
pub fn classroom() -> Scene {
    let wood = phong(0.55, 0.36, 0.2, 30.0);
    let metal = phong(0.3, 0.3, 0.33, 60.0);
    let seat = lambert(0.15, 0.35, 0.6);
    let floor = lambert(0.55, 0.5, 0.45);
    let wall = lambert(0.8, 0.78, 0.7);
    let board = lambert(0.08, 0.2, 0.12);
    let teacher_wood = phong(0.4, 0.22, 0.12, 40.0);

    let mut surfaces = vec![
        cuboid([-6.0, -0.1, -5.0], [6.0, 0.0, 6.0], &floor),
        cuboid([-6.0, 0.0, -5.2], [6.0, 3.2, -5.0], &wall),
        cuboid([-2.5, 1.0, -5.0], [2.5, 2.6, -4.95], &board),
    ];
    // Rows of identical desk-and-chair assemblies, placed by transforms.
    let pupil = Arc::new(desk_and_chair(&wood, &metal, &seat));
    for row in 0..3 {
        for col in 0..4 {
            let x = -2.7 + 1.8 * col as f64;
            let z = -1.2 + 1.6 * row as f64;
            // A slight turn per desk: the same part, a different placement.
            let turn = rotation_degrees(DVec3::new(0.0, (col as f64 - 1.5) * 4.0, 0.0));
            surfaces.push(group(
                translation(DVec3::new(x, 0.0, z)) * turn,
                vec![Surface::Instance(pupil.clone())],
            ));
        }
    }
    // The teacher's desk with a glass globe and a glazed ball on it.
    let mut teacher = four_legs(0.8, 0.35, 0.74, &metal);
    teacher.push(cuboid([-0.9, 0.74, -0.42], [0.9, 0.8, 0.42], &teacher_wood));
    teacher.push(Surface::Sphere(Sphere {
        center: DVec3::new(-0.4, 1.05, 0.0),
        radius: 0.25,
        shader: Arc::new(Shader::Glass {
            refractive_index: 1.5,
        }),
    }));
    teacher.push(Surface::Sphere(Sphere {
        center: DVec3::new(0.45, 0.98, 0.05),
        radius: 0.18,
        shader: Arc::new(Shader::Glazed {
            refractive_index: 1.6,
            substrate: lambert(0.8, 0.15, 0.1),
            fresnel: Fresnel::Exact,
        }),
    }));
    surfaces.push(group(translation(DVec3::new(0.0, 0.0, -3.6)), teacher));

    Scene {
        variant: Variant::Cornell2015,
        camera: Camera {
            kind: CameraKind::Perspective2015,
            view_point: DVec3::new(4.2, 3.4, 6.2),
            view_dir: DVec3::new(-4.0, -2.6, -8.0),
            view_up: DVec3::Y,
            proj_normal: DVec3::ZERO,
            proj_distance: 1.0,
            view_width: 1.0,
            view_height: 0.625,
        },
        width: 640,
        height: 400,
        samples_per_side: 2,
        lights: vec![
            Light::Point {
                position: DVec3::new(-2.0, 3.0, 1.5),
                intensity: DVec3::new(9.0, 8.6, 8.0),
            },
            Light::Point {
                position: DVec3::new(3.0, 3.0, -2.5),
                intensity: DVec3::new(6.0, 6.2, 7.0),
            },
        ],
        surfaces,
        background: DVec3::new(0.6, 0.75, 0.9),
        exposure: 1.0,
        cubemap: None,
    }
}
