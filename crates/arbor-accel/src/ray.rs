use glam::{Vec3, Vec3A};

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

    /// The per-component reciprocal of `dir` for [`crate::aabb::Aabb::intersect`]
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
        // The three components side by side in one SIMD register: one
        // division and no branch per component, where the scalar form
        // (kept in the tests as the reference) paid three of each on every
        // ray; the values are the same bit for bit (IEEE division rounds
        // the same in either form).
        let d = Vec3A::from(self.dir);
        let inv = d.recip();
        let overflow = d.cmpne(Vec3A::ZERO) & inv.abs().cmpeq(Vec3A::INFINITY);
        Vec3A::select(overflow, Vec3A::NAN, inv).into()
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference: `Ray::inv_dir` written per component.
    fn inv_dir_scalar(dir: Vec3) -> Vec3 {
        let one = |d: f32| {
            let i = 1.0 / d;
            if d != 0.0 && i.is_infinite() {
                f32::NAN
            } else {
                i
            }
        };
        Vec3::new(one(dir.x), one(dir.y), one(dir.z))
    }

    /// Same bits as the per-component form on every kind of component:
    /// signed zeros, subnormals whose reciprocal overflows, the smallest
    /// normal (whose reciprocal does not), infinities, NaN, ordinary values.
    #[test]
    fn inv_dir_matches_the_scalar_form() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -3.0,
            0.1,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::MIN_POSITIVE / 8.0,
            -f32::MIN_POSITIVE / 8.0,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e-30,
        ];
        let mut nan = 0;
        for &x in &values {
            for &y in &values {
                for &z in &values {
                    let dir = Vec3::new(x, y, z);
                    let got = Ray::new(Vec3::ZERO, dir, 0.0, 1.0).inv_dir();
                    let want = inv_dir_scalar(dir);
                    for a in 0..3 {
                        if want[a].is_nan() {
                            assert!(got[a].is_nan(), "{dir:?}: {got:?} vs {want:?}");
                            nan += 1;
                        } else {
                            assert_eq!(got[a].to_bits(), want[a].to_bits(), "{dir:?}");
                        }
                    }
                }
            }
        }
        // Three of the fourteen values give NaN (the two subnormals, whose
        // reciprocal overflows, and NaN), on each axis of every combination.
        assert_eq!(nan, 3 * (3 * 14 * 14));
    }
}
