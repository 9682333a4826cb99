//! Cameras: where each image-plane sample's ray starts and points.
//!
//! Image coordinates `(u, v)` run over the picture with `(0, 0)` at its
//! centre; the variant decides their range (2010: `(-1/2, 1/2)`, 2015:
//! `(-1, 1)`), see [`crate::render`].

use glam::DVec3;

/// A camera as the scene file describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The projection model.
    pub kind: CameraKind,
    /// Eye position.
    pub view_point: DVec3,
    /// Viewing direction.
    pub view_dir: DVec3,
    /// Up direction (need not be perpendicular to `view_dir`).
    pub view_up: DVec3,
    /// Normal of the image plane (2010: default `(0,0,1)`; 2015 parallel: zero
    /// means `view_dir`).
    pub proj_normal: DVec3,
    /// Distance from the eye to the image plane along `view_dir`.
    pub proj_distance: f64,
    /// Width of the image rectangle.
    pub view_width: f64,
    /// Height of the image rectangle.
    pub view_height: f64,
}

/// The projection model of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraKind {
    /// 2010: perspective onto a plane of any orientation (shifted and oblique
    /// views included), spec §3.2.
    Perspective2010,
    /// 2015 `PerspectiveCamera`, spec §3.3.
    Perspective2015,
    /// 2015 `ParallelCamera` / `OrthographicCamera`, spec §3.4.
    Parallel2015,
}

impl Camera {
    /// The 2010 defaults of spec §2.6.
    pub fn default_2010() -> Camera {
        Camera {
            kind: CameraKind::Perspective2010,
            view_point: DVec3::ZERO,
            view_dir: DVec3::NEG_Z,
            view_up: DVec3::Y,
            proj_normal: DVec3::Z,
            proj_distance: 1.0,
            view_width: 1.0,
            view_height: 1.0,
        }
    }

    /// Precomputes the basis that turns image coordinates into rays.
    pub fn prepare(&self) -> PreparedCamera {
        match self.kind {
            CameraKind::Perspective2010 => {
                let d = self.view_dir.normalize();
                let up = self.view_up.normalize();
                let n = self.proj_normal.normalize();
                let v = (up - up.dot(n) * n).normalize() * self.view_height;
                let u = v.cross(n).normalize() * self.view_width;
                PreparedCamera {
                    kind: self.kind,
                    origin: self.view_point,
                    center: self.view_point + self.proj_distance * d,
                    u,
                    v,
                    dir: d,
                    half_width: 0.0,
                    half_height: 0.0,
                }
            }
            CameraKind::Perspective2015 | CameraKind::Parallel2015 => {
                let w = if self.kind == CameraKind::Parallel2015 {
                    let n0 = if self.proj_normal == DVec3::ZERO {
                        self.view_dir
                    } else {
                        self.proj_normal
                    };
                    if n0.dot(self.view_dir) > 0.0 {
                        (-n0).normalize()
                    } else {
                        n0.normalize()
                    }
                } else {
                    (-self.view_dir).normalize()
                };
                let u = self.view_up.cross(w).normalize();
                let v = w.cross(u).normalize();
                PreparedCamera {
                    kind: self.kind,
                    origin: self.view_point,
                    center: self.view_dir.normalize() * self.proj_distance,
                    u,
                    v,
                    dir: self.view_dir.normalize(),
                    half_width: self.view_width,
                    half_height: self.view_height,
                }
            }
        }
    }
}

/// A camera with its basis computed, ready to generate rays.
#[derive(Clone, Copy, Debug)]
pub struct PreparedCamera {
    kind: CameraKind,
    origin: DVec3,
    /// 2010: image-plane centre; 2015 perspective: `norm(viewDir) * projDistance`.
    center: DVec3,
    u: DVec3,
    v: DVec3,
    dir: DVec3,
    half_width: f64,
    half_height: f64,
}

impl PreparedCamera {
    /// The ray (origin, unit direction) through image coordinates `(u, v)`.
    pub fn ray(&self, u: f64, v: f64) -> (DVec3, DVec3) {
        match self.kind {
            CameraKind::Perspective2010 => {
                let p = self.center + u * self.u + v * self.v;
                (self.origin, (p - self.origin).normalize())
            }
            CameraKind::Perspective2015 => {
                let d = self.center
                    + (u * self.half_width / 2.0) * self.u
                    + (v * self.half_height / 2.0) * self.v;
                (self.origin, d.normalize())
            }
            CameraKind::Parallel2015 => {
                let o = self.origin
                    + (u * self.half_width / 2.0) * self.u
                    + (v * self.half_height / 2.0) * self.v;
                (o, self.dir)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_follows_view_dir() {
        let mut c = Camera::default_2010();
        c.view_dir = DVec3::new(-1.0, 0.0, -1.0);
        c.proj_normal = DVec3::new(1.0, 0.0, 1.0);
        let (_, d) = c.prepare().ray(0.0, 0.0);
        assert!((d - c.view_dir.normalize()).length() < 1e-15);
        c.kind = CameraKind::Perspective2015;
        let (_, d) = c.prepare().ray(0.0, 0.0);
        assert!((d - c.view_dir.normalize()).length() < 1e-15);
    }

    #[test]
    fn image_right_is_view_right() {
        // Looking down -z with y up, +u must point to +x.
        for kind in [CameraKind::Perspective2010, CameraKind::Perspective2015] {
            let mut c = Camera::default_2010();
            c.kind = kind;
            let (_, d) = c.prepare().ray(0.4, 0.0);
            assert!(d.x > 0.0, "{kind:?}");
            let (_, d) = c.prepare().ray(0.0, 0.4);
            assert!(d.y > 0.0, "{kind:?}");
        }
    }

    #[test]
    fn parallel_rays_share_direction() {
        let mut c = Camera::default_2010();
        c.kind = CameraKind::Parallel2015;
        c.proj_normal = DVec3::ZERO;
        let p = c.prepare();
        let (o1, d1) = p.ray(-1.0, -1.0);
        let (o2, d2) = p.ray(1.0, 1.0);
        assert_eq!(d1, d2);
        assert!((o2 - o1 - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-15);
    }
}
