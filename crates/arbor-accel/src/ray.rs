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
    /// (infinite for zero components).
    #[inline]
    pub fn inv_dir(&self) -> Vec3 {
        self.dir.recip()
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}
