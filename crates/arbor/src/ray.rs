//! The tracer's ray: an `f64` origin and direction with the parameter
//! interval a hit must lie in. Every exact test (primitives, the tracer's
//! queries, the integrator) takes one of these; the acceleration structures
//! of `arbor-accel` traverse with their own `f32` [`arbor_accel::Ray`],
//! derived from it conservatively (see [`crate::tracer`]).

use glam::DVec3;

/// The points `origin + t direction` with `t` in `(tmin, tmax)`; the
/// direction need not be unit length (`t` is measured in its units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts (`t = 0`).
    pub origin: DVec3,
    /// Its direction, not necessarily normalised.
    pub direction: DVec3,
    /// Hits at or before this parameter do not count.
    pub tmin: f64,
    /// Hits at or beyond this parameter do not count.
    pub tmax: f64,
}

impl Ray {
    /// The ray from `origin` along `direction`, hits in `(tmin, tmax)`.
    pub fn new(origin: DVec3, direction: DVec3, tmin: f64, tmax: f64) -> Ray {
        Ray {
            origin,
            direction,
            tmin,
            tmax,
        }
    }

    /// The ray from `origin` along `direction` with no far limit: hits in
    /// `(tmin, infinity)`.
    pub fn unbounded(origin: DVec3, direction: DVec3, tmin: f64) -> Ray {
        Ray::new(origin, direction, tmin, f64::INFINITY)
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.direction
    }

    /// The same interval along another line (the ray seen in another space:
    /// an object's, a placement's). The parameter is not rescaled, so `t`
    /// means the same point in both spaces.
    pub fn with_line(&self, origin: DVec3, direction: DVec3) -> Ray {
        Ray::new(origin, direction, self.tmin, self.tmax)
    }

    /// The same line with hits in `(tmin, tmax)` instead.
    pub fn with_interval(&self, tmin: f64, tmax: f64) -> Ray {
        Ray::new(self.origin, self.direction, tmin, tmax)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn at_walks_the_unnormalised_direction() {
        let r = Ray::new(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(0.0, 2.0, 0.0),
            0.5,
            4.0,
        );
        assert_eq!(r.at(0.0), r.origin);
        assert_eq!(r.at(1.5), DVec3::new(1.0, 5.0, 3.0));
    }

    #[test]
    fn derived_rays_keep_what_they_do_not_change() {
        let r = Ray::unbounded(DVec3::X, DVec3::Y, 1e-6);
        assert_eq!(r.tmax, f64::INFINITY);
        let moved = r.with_line(DVec3::Z, DVec3::NEG_X);
        assert_eq!((moved.tmin, moved.tmax), (1e-6, f64::INFINITY));
        assert_eq!((moved.origin, moved.direction), (DVec3::Z, DVec3::NEG_X));
        let cut = r.with_interval(0.0, 2.0);
        assert_eq!((cut.origin, cut.direction), (r.origin, r.direction));
        assert_eq!((cut.tmin, cut.tmax), (0.0, 2.0));
    }
}
