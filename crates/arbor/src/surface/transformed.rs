//! A transformation and what intersecting a transformed surface needs of it:
//! the ray goes into object space by the inverse, hit points come back by the
//! matrix, normals by the inverse transpose.

use glam::{DMat3, DMat4, DVec3};

/// An affine transformation with its inverse and normal matrix precomputed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Object to world.
    pub matrix: DMat4,
    /// World to object.
    pub inverse: DMat4,
    /// `inverse` transposed (upper 3x3): maps object normals to world normals.
    pub normal_matrix: DMat3,
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform {
        matrix: DMat4::IDENTITY,
        inverse: DMat4::IDENTITY,
        normal_matrix: DMat3::IDENTITY,
    };

    /// Wraps `matrix`; `None` when it cannot be inverted (e.g. a zero scale).
    pub fn new(matrix: DMat4) -> Option<Transform> {
        let det = matrix.determinant();
        if !det.is_finite() || det == 0.0 {
            return None;
        }
        let inverse = matrix.inverse();
        Some(Transform {
            matrix,
            inverse,
            normal_matrix: DMat3::from_mat4(inverse).transpose(),
        })
    }

    /// Whether this is exactly the identity (lets callers skip the work).
    pub fn is_identity(&self) -> bool {
        self.matrix == DMat4::IDENTITY
    }

    /// A world point in object space.
    pub fn point_to_object(&self, p: DVec3) -> DVec3 {
        self.inverse.transform_point3(p)
    }

    /// A world direction in object space (not renormalised: `t` stays shared
    /// between the two spaces).
    pub fn vector_to_object(&self, v: DVec3) -> DVec3 {
        self.inverse.transform_vector3(v)
    }

    /// An object point in world space.
    pub fn point_to_world(&self, p: DVec3) -> DVec3 {
        self.matrix.transform_point3(p)
    }

    /// An object normal in world space (by the inverse transpose; not normalised).
    pub fn normal_to_world(&self, n: DVec3) -> DVec3 {
        self.normal_matrix * n
    }

    /// The box (as min, max) enclosing the 8 transformed corners of an object box.
    pub fn bounds_to_world(&self, min: DVec3, max: DVec3) -> (DVec3, DVec3) {
        corner_bounds(min, max, |c| self.point_to_world(c))
    }
}

/// `<translate>`: the matrix moving points by `t`.
pub fn translation(t: DVec3) -> DMat4 {
    DMat4::from_translation(t)
}

/// `<scale>`: the diagonal matrix `diag(s)`.
pub fn scaling(s: DVec3) -> DMat4 {
    DMat4::from_scale(s)
}

/// `<rotate>rx ry rz</rotate>` in degrees: `Rz(rz) * Ry(ry) * Rx(rx)`, so the
/// x rotation applies first (spec §5.5), each right-handed. The matrices are
/// written out rather than taken from a quaternion so every entry is exactly
/// one `sin` or `cos`, as in the course's framework.
pub fn rotation_degrees(r: DVec3) -> DMat4 {
    let rx = axis_rotation(r.x, 0);
    let ry = axis_rotation(r.y, 1);
    let rz = axis_rotation(r.z, 2);
    rz * ry * rx
}

fn axis_rotation(degrees: f64, axis: usize) -> DMat4 {
    let (s, c) = degrees.to_radians().sin_cos();
    // Columns of the 3x3 rotation (glam is column-major).
    let m = match axis {
        0 => DMat3::from_cols(
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, c, s),
            DVec3::new(0.0, -s, c),
        ),
        1 => DMat3::from_cols(
            DVec3::new(c, 0.0, -s),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(s, 0.0, c),
        ),
        _ => DMat3::from_cols(
            DVec3::new(c, s, 0.0),
            DVec3::new(-s, c, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
        ),
    };
    DMat4::from_mat3(m)
}

/// The box (as min, max) of the 8 corners of the box `lo`..`hi` mapped by
/// `to_world`: a box that holds the mapped box for any affine map.
pub(crate) fn corner_bounds(
    lo: DVec3,
    hi: DVec3,
    to_world: impl Fn(DVec3) -> DVec3,
) -> (DVec3, DVec3) {
    let mut a = DVec3::splat(f64::INFINITY);
    let mut b = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let w = to_world(c);
        a = a.min(w);
        b = b.max(w);
    }
    (a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn rotations_are_right_handed_and_x_first() {
        // 90 degrees about z takes x to y.
        let m = rotation_degrees(DVec3::new(0.0, 0.0, 90.0));
        assert!(close(m.transform_vector3(DVec3::X), DVec3::Y));
        // 90 about x takes y to z; then 90 about z takes z to z.
        let m = rotation_degrees(DVec3::new(90.0, 0.0, 90.0));
        assert!(close(m.transform_vector3(DVec3::Y), DVec3::Z));
        // x first: (90 about x) then (90 about y) maps y -> z -> x.
        let m = rotation_degrees(DVec3::new(90.0, 90.0, 0.0));
        assert!(close(m.transform_vector3(DVec3::Y), DVec3::X));
    }

    #[test]
    fn normals_use_inverse_transpose() {
        // Squash y by 0.5: a 45-degree plane's normal tilts toward y.
        let t = Transform::new(scaling(DVec3::new(1.0, 0.5, 1.0))).unwrap();
        let n = t.normal_to_world(DVec3::new(1.0, 1.0, 0.0)).normalize();
        let tangent = t.matrix.transform_vector3(DVec3::new(1.0, -1.0, 0.0));
        assert!(n.dot(tangent).abs() < 1e-12);
    }

    #[test]
    fn singular_matrix_is_rejected() {
        assert!(Transform::new(scaling(DVec3::new(1.0, 0.0, 1.0))).is_none());
    }

    #[test]
    fn rotated_bounds_contain_corners() {
        let t = Transform::new(rotation_degrees(DVec3::new(30.0, 40.0, 50.0))).unwrap();
        let (lo, hi) = t.bounds_to_world(DVec3::splat(-1.0), DVec3::splat(1.0));
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            let w = t.point_to_world(c);
            assert!(w.cmpge(lo).all() && w.cmple(hi).all());
        }
    }
}
