//! `arbor.Mesh`: a triangle mesh with its acceleration structure, and the
//! ray queries over NumPy arrays. Every query reads its arrays where they
//! lie, runs without the GIL on the library's parallel batch form, and
//! hands its answers to NumPy without a copy.

use std::path::PathBuf;

use arbor_accel::{Ray, Vec3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::arrays::{ScalarView, Scalars, Vec3Array, Vec3View};
use crate::query::{AccelKind, MeshAccel};

/// A triangle mesh prepared for ray queries.
///
/// ``Mesh(vertices, faces, accel="bvh-wide")`` takes ``(n, 3)`` float32 or
/// float64 vertices and ``(m, 3)`` integer faces (vertex indices); the mesh
/// is copied, so later changes to the arrays do not affect it. Queries run
/// in float32, in parallel, with the GIL released, and give exactly the
/// answers of ``arbor trace`` on the same rays.
///
/// Raises ValueError for arrays of the wrong shape or dtype, NaN vertices,
/// or a face index out of range.
#[pyclass(frozen, module = "arbor", name = "Mesh")]
pub struct Mesh {
    accel: MeshAccel,
    kind: AccelKind,
}

/// The accelerator named `name`.
fn accel_kind(name: &str) -> PyResult<AccelKind> {
    name.parse::<AccelKind>()
        .map_err(|e| PyValueError::new_err(format!("accel: {e}")))
}

impl Mesh {
    /// Builds the structure without the GIL.
    fn build(
        py: Python<'_>,
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        kind: AccelKind,
    ) -> PyResult<Mesh> {
        let accel = py
            .detach(|| MeshAccel::build(vertices, triangles, kind))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Mesh { accel, kind })
    }
}

/// Rays from `(k, 3)` origins and directions and their intervals.
fn rays(
    origins: Vec3View<'_>,
    directions: Vec3View<'_>,
    tmin: ScalarView<'_>,
    tmax: ScalarView<'_>,
) -> Vec<Ray> {
    (0..origins.len())
        .into_par_iter()
        .map(|i| Ray::new(origins.get(i), directions.get(i), tmin.get(i), tmax.get(i)))
        .collect()
}

/// Reads the four ray arguments, checking that they agree in length.
struct RayArgs<'py> {
    origins: Vec3Array<'py>,
    directions: Vec3Array<'py>,
    tmin: Scalars<'py>,
    tmax: Scalars<'py>,
}

impl<'py> RayArgs<'py> {
    fn extract(
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: &Bound<'py, PyAny>,
        tmax: &Bound<'py, PyAny>,
    ) -> PyResult<Self> {
        let origins = Vec3Array::extract(origins, "origins")?;
        let directions = Vec3Array::extract(directions, "directions")?;
        let k = origins.view().len();
        if directions.view().len() != k {
            return Err(PyValueError::new_err(format!(
                "directions: expected {k} rows, one per origin, got {}",
                directions.view().len()
            )));
        }
        Ok(RayArgs {
            origins,
            directions,
            tmin: Scalars::extract(tmin, "tmin", k)?,
            tmax: Scalars::extract(tmax, "tmax", k)?,
        })
    }

    /// Views of the arguments that can cross into code running without
    /// the GIL.
    fn views(&self) -> RayViews<'_> {
        RayViews {
            origins: self.origins.view(),
            directions: self.directions.view(),
            tmin: self.tmin.view(),
            tmax: self.tmax.view(),
        }
    }
}

/// [`RayArgs`] as plain views.
#[derive(Clone, Copy)]
struct RayViews<'a> {
    origins: Vec3View<'a>,
    directions: Vec3View<'a>,
    tmin: ScalarView<'a>,
    tmax: ScalarView<'a>,
}

impl RayViews<'_> {
    /// The rays, in parallel.
    fn rays(&self) -> Vec<Ray> {
        rays(self.origins, self.directions, self.tmin, self.tmax)
    }
}

/// A `(k, 3)` float32 array from rows.
fn rows3<'py>(py: Python<'py>, rows: Vec<[f32; 3]>) -> Bound<'py, PyArray2<f32>> {
    let k = rows.len();
    let flat: Vec<f32> = rows.into_iter().flatten().collect();
    // The length is 3k by construction.
    Array2::from_shape_vec((k, 3), flat)
        .expect("3 values per row")
        .into_pyarray(py)
}

/// The closest hits of [`Mesh::intersect`], one entry per ray.
struct Closest {
    t: Vec<f32>,
    triangle: Vec<i64>,
    u: Vec<f32>,
    v: Vec<f32>,
    point: Vec<[f32; 3]>,
    normal: Vec<[f32; 3]>,
}

#[pymethods]
impl Mesh {
    #[new]
    #[pyo3(signature = (vertices, faces, accel = "bvh-wide"))]
    fn new(
        py: Python<'_>,
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        accel: &str,
    ) -> PyResult<Mesh> {
        let kind = accel_kind(accel)?;
        let array = Vec3Array::extract(vertices, "vertices")?;
        let view = array.view();
        if view.has_nan() {
            return Err(PyValueError::new_err("vertices: NaN coordinates"));
        }
        let triangles = crate::arrays::faces(faces)?;
        Mesh::build(py, view.to_vec(), triangles, kind)
    }

    /// The vertex positions, a ``(n, 3)`` float32 array (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        rows3(
            py,
            self.accel.vertices().iter().map(|v| v.to_array()).collect(),
        )
    }

    /// The triangles as vertex indices, a ``(m, 3)`` int64 array (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        let tris = self.accel.triangles();
        let flat: Vec<i64> = tris.iter().flatten().map(|&i| i64::from(i)).collect();
        Array2::from_shape_vec((tris.len(), 3), flat)
            .expect("3 indices per triangle")
            .into_pyarray(py)
    }

    /// The acceleration structure's name.
    #[getter]
    fn accel(&self) -> &'static str {
        self.kind.name()
    }

    fn __len__(&self) -> usize {
        self.accel.triangles().len()
    }

    fn __repr__(&self) -> String {
        format!(
            "arbor.Mesh({} vertices, {} triangles, accel={:?})",
            self.accel.vertices().len(),
            self.accel.triangles().len(),
            self.kind.name()
        )
    }

    /// The closest hit of each ray ``origins[i] + t * directions[i]`` with
    /// ``tmin <= t <= tmax``.
    ///
    /// ``origins`` and ``directions`` are ``(k, 3)`` float arrays
    /// (directions need not be unit length: ``t`` is in their units);
    /// ``tmin`` (default 0) and ``tmax`` (default inf) are numbers or
    /// ``(k,)`` arrays. Returns a dict of arrays: ``t`` (float32, inf on a
    /// miss), ``triangle`` (int64, -1 on a miss), ``u`` and ``v`` (float32
    /// barycentrics: the hit is ``(1 - u - v) p0 + u p1 + v p2``), ``point``
    /// (``(k, 3)`` float32) and ``normal`` (``(k, 3)`` float32, the unit
    /// geometric normal ``(p1 - p0) x (p2 - p0)``); u, v, point and normal
    /// are NaN on a miss.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None))]
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (tmin, tmax) = defaults(py, tmin, tmax);
        let args = RayArgs::extract(origins, directions, &tmin, &tmax)?;
        let views = args.views();
        let found = py.detach(|| {
            let rays = views.rays();
            let hits = self.accel.closest_batch(&rays);
            self.closest(&rays, &hits)
        });
        let out = PyDict::new(py);
        out.set_item("t", PyArray1::from_vec(py, found.t))?;
        out.set_item("triangle", PyArray1::from_vec(py, found.triangle))?;
        out.set_item("u", PyArray1::from_vec(py, found.u))?;
        out.set_item("v", PyArray1::from_vec(py, found.v))?;
        out.set_item("point", rows3(py, found.point))?;
        out.set_item("normal", rows3(py, found.normal))?;
        Ok(out)
    }

    /// Whether anything lies on each ray within ``[tmin, tmax]``: a
    /// ``(k,)`` bool array. Arguments as for :meth:`intersect`.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None))]
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let (tmin, tmax) = defaults(py, tmin, tmax);
        let args = RayArgs::extract(origins, directions, &tmin, &tmax)?;
        let views = args.views();
        let blocked = py.detach(|| self.accel.occluded_batch(&views.rays()));
        Ok(PyArray1::from_vec(py, blocked))
    }
}

impl Mesh {
    /// Spreads closest hits into the columns of [`Mesh::intersect`].
    fn closest(&self, rays: &[Ray], hits: &[Option<arbor_accel::MeshHit>]) -> Closest {
        let nan3 = [f32::NAN; 3];
        let mut c = Closest {
            t: Vec::with_capacity(hits.len()),
            triangle: Vec::with_capacity(hits.len()),
            u: Vec::with_capacity(hits.len()),
            v: Vec::with_capacity(hits.len()),
            point: Vec::with_capacity(hits.len()),
            normal: Vec::with_capacity(hits.len()),
        };
        for (ray, hit) in rays.iter().zip(hits) {
            match hit {
                Some(h) => {
                    c.t.push(h.hit.t);
                    c.triangle.push(i64::from(h.prim));
                    c.u.push(h.hit.u);
                    c.v.push(h.hit.v);
                    c.point.push(ray.at(h.hit.t).to_array());
                    c.normal.push(self.normal(h.prim));
                }
                None => {
                    c.t.push(f32::INFINITY);
                    c.triangle.push(-1);
                    c.u.push(f32::NAN);
                    c.v.push(f32::NAN);
                    c.point.push(nan3);
                    c.normal.push(nan3);
                }
            }
        }
        c
    }

    /// The unit geometric normal of triangle `prim`, computed in float64.
    fn normal(&self, prim: u32) -> [f32; 3] {
        let [a, b, c] = self.accel.triangles()[prim as usize]
            .map(|i| self.accel.vertices()[i as usize].as_dvec3());
        (b - a)
            .cross(c - a)
            .normalize_or_zero()
            .as_vec3()
            .to_array()
    }
}

/// `tmin` and `tmax` with their defaults, 0 and inf.
fn defaults<'py>(
    py: Python<'py>,
    tmin: Option<&Bound<'py, PyAny>>,
    tmax: Option<&Bound<'py, PyAny>>,
) -> (Bound<'py, PyAny>, Bound<'py, PyAny>) {
    let num = |x: f64| {
        x.into_pyobject(py)
            .map(|f| f.into_any())
            .expect("a float converts")
    };
    (
        tmin.cloned().unwrap_or_else(|| num(0.0)),
        tmax.cloned().unwrap_or_else(|| num(f64::INFINITY)),
    )
}

/// Reads a mesh file (``.obj`` or ``.msh``) with the loader of ``arbor
/// trace``, triangles numbered as it numbers them, and prepares it for
/// queries. Raises OSError naming the file when it is missing or broken.
#[pyfunction]
#[pyo3(signature = (path, accel = "bvh-wide"))]
pub fn load_mesh(py: Python<'_>, path: PathBuf, accel: &str) -> PyResult<Mesh> {
    let kind = accel_kind(accel)?;
    let data = py
        .detach(|| arbor::mesh::load_mesh_file(&path))
        .map_err(|e| PyOSError::new_err(e.to_string()))?;
    Mesh::build(py, data.positions, data.triangles, kind)
}
