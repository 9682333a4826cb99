//! Helpers the `arbor` test files share.
// Each test file is its own crate and uses only some of these.
#![allow(dead_code)]

use arbor::flatten::Hit;
use arbor::ray::Ray;
use arbor::tracer::Tracer;
use glam::DVec3;

/// The closest hit of the ray from `(10, y, 0)` along -x (the test scenes
/// lie well within `x < 10`); panics on a miss.
pub fn hit_from_plus_x(tracer: &Tracer, y: f64) -> Hit<'_> {
    let ray = Ray::new(DVec3::new(10.0, y, 0.0), DVec3::NEG_X, 0.0, f64::INFINITY);
    tracer.closest(&ray).expect("the ray from +x hits")
}
