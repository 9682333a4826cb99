//! The point arguments of the point queries (`(k, 3)` points and a
//! maximum distance), and closest points spread into columns.

use std::borrow::Cow;

use arbor_accel::{ClosestPoint, MeshAccel, Vec3};
use numpy::{PyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{Scalars, Vec3Array};
use crate::rays::{rows3, unit_normal};

/// `(k, 3)` query points (named `points` in errors).
pub struct Points<'py>(Vec3Array<'py>);

impl<'py> Points<'py> {
    /// Reads `obj`.
    pub fn extract(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        Ok(Points(Vec3Array::extract(obj, "points")?))
    }

    /// How many points there are.
    pub fn len(&self) -> usize {
        self.0.view().len()
    }

    /// The points as the library takes them: the array's own memory when
    /// it is C-contiguous float32, a float32 copy otherwise.
    pub fn slice(&self) -> Cow<'_, [Vec3]> {
        if let Vec3Array::F32(a) = &self.0 {
            // `as_slice` also accepts Fortran order, whose memory is not rows.
            let rows = a.is_c_contiguous().then(|| a.as_slice().ok()).flatten();
            if let Some(flat) = rows {
                // SAFETY: `Vec3` is `#[repr(C)]` of three `f32` with the
                // alignment of `f32`, and a C-contiguous (k, 3) float32
                // array is 3k consecutive `f32`, so its memory is k `Vec3`s;
                // the read-only borrow keeps it alive and unchanged.
                let points = unsafe {
                    std::slice::from_raw_parts(flat.as_ptr().cast::<Vec3>(), flat.len() / 3)
                };
                return Cow::Borrowed(points);
            }
        }
        Cow::Owned(self.0.view().to_vec())
    }
}

/// One answer per point of `obj` as a `(k,)` array: `answer` runs on the
/// points without the GIL (the library's parallel batch form).
pub fn per_point<'py, T: numpy::Element + Send>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    answer: impl FnOnce(&[Vec3]) -> Vec<T> + Send,
) -> PyResult<Bound<'py, PyArray1<T>>> {
    let points = Points::extract(obj)?;
    let points = points.slice();
    let answers = py.detach(|| answer(&points));
    Ok(PyArray1::from_vec(py, answers))
}

/// The per-point maximum distances (default: none).
pub fn max_distances(obj: Option<&Bound<'_, PyAny>>, k: usize) -> PyResult<Vec<f32>> {
    let limits = match obj {
        Some(obj) => Scalars::extract(obj, "max_distance", k)?,
        None => Scalars::Same(f32::INFINITY),
    };
    let view = limits.view();
    Ok((0..k).map(|i| view.get(i)).collect())
}

/// Closest points as columns `point`, `triangle`, `u`, `v`, `distance`,
/// `normal` (the triangle's unit geometric normal):
/// for a point with nothing within its maximum distance, `triangle` -1,
/// `distance` inf and the rest NaN.
pub fn closest_columns<'py>(
    py: Python<'py>,
    mesh: &MeshAccel,
    found: &[Option<ClosestPoint>],
) -> PyResult<Bound<'py, PyDict>> {
    let mut point = Vec::with_capacity(found.len());
    let mut triangle = Vec::with_capacity(found.len());
    let mut u = Vec::with_capacity(found.len());
    let mut v = Vec::with_capacity(found.len());
    let mut distance = Vec::with_capacity(found.len());
    let mut normal = Vec::with_capacity(found.len());
    for c in found {
        match c {
            Some(c) => {
                point.push(c.point.to_array());
                triangle.push(i64::from(c.prim));
                u.push(c.u);
                v.push(c.v);
                distance.push(c.distance);
                normal.push(unit_normal(mesh, c.prim));
            }
            None => {
                point.push([f32::NAN; 3]);
                triangle.push(-1);
                u.push(f32::NAN);
                v.push(f32::NAN);
                distance.push(f32::INFINITY);
                normal.push([f32::NAN; 3]);
            }
        }
    }
    let out = PyDict::new(py);
    out.set_item("point", rows3(py, point))?;
    out.set_item("triangle", PyArray1::from_vec(py, triangle))?;
    out.set_item("u", PyArray1::from_vec(py, u))?;
    out.set_item("v", PyArray1::from_vec(py, v))?;
    out.set_item("distance", PyArray1::from_vec(py, distance))?;
    out.set_item("normal", rows3(py, normal))?;
    Ok(out)
}
