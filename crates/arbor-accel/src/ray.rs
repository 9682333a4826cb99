use glam::Vec3;

/// A ray `origin + t * dir`, valid for `tmin <= t <= tmax`.
///
/// `dir` need not be unit length; its components may be zero (the slab test
/// handles the resulting infinities).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts (t = 0).
    pub origin: Vec3,
    /// The direction; not necessarily normalised.
    pub dir: Vec3,
    /// Smallest accepted parameter.
    pub tmin: f32,
    /// Largest accepted parameter (may be `f32::INFINITY`). Traversal shrinks it
    /// as closer hits are found.
    pub tmax: f32,
}

impl Ray {
    /// A ray with the given interval.
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Ray {
            origin,
            dir,
            tmin,
            tmax,
        }
    }

    /// The per-component reciprocal of `dir` for [`crate::Aabb::intersect`]
    /// and the structures' plane distances: infinite for zero components
    /// (the ray is parallel to that axis), and NaN for nonzero components so
    /// small (subnormal) that their reciprocal overflows.
    ///
    /// Why NaN there: `(plane - origin) * inf` would put every plane of that
    /// axis at infinity, yet the true distance `(plane - origin) / dir` is
    /// finite when the plane is as close to the origin as `dir` is small (a
    /// fuzzed ray with components of `MIN_POSITIVE / 8` missed a box at
    /// t = 6 this way). Every structure treats a NaN distance as "this axis
    /// does not constrain the ray", which is conservative: such rays cost
    /// more, but lose no hit.
    #[inline]
    pub fn inv_dir(&self) -> Vec3 {
        let inv = self.dir.recip();
        let overflow = |d: f32, i: f32| {
            if d != 0.0 && i.is_infinite() {
                f32::NAN
            } else {
                i
            }
        };
        Vec3::new(
            overflow(self.dir.x, inv.x),
            overflow(self.dir.y, inv.y),
            overflow(self.dir.z, inv.z),
        )
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}
