//! `arbor.Mesh`: a triangle mesh with its acceleration structure, and the
//! queries over NumPy arrays. Every query reads its arrays where they lie,
//! runs the library's parallel batch form without the GIL, and hands its
//! answers to NumPy without a copy.

use std::path::PathBuf;
use std::sync::OnceLock;

use arbor_accel::{AccelKind, BuildQuality, MeshAccel, Vec3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::Vec3Array;
use crate::points::{closest_columns, max_distances, per_point, Points};
use crate::rays::{rows3, HitArrays, RayArgs};

/// A triangle mesh prepared for ray and point queries.
///
/// ``Mesh(vertices, faces, accel="bvh-wide", quality="fast")`` takes
/// ``(n, 3)`` float32 or float64 vertices and ``(m, 3)`` integer faces
/// (vertex indices); the mesh is copied, so later changes to the arrays do
/// not affect it. ``accel`` names the acceleration structure (``list``,
/// ``bvh-center``, ``bvh-median``, ``bvh-sah``, ``bvh-sweep``,
/// ``bvh-cluster``, ``bvh-wide``, ``grid``, ``kdtree``); all give the same
/// answers. ``quality="high"`` builds ``bvh-wide`` or ``bvh-sah`` with
/// spatial splits: several times the build time, a few per cent faster
/// ray queries on meshes with long or overlapping triangles. Queries
/// run in float32, in parallel, with the GIL released, and give exactly the
/// answers of ``arbor trace`` on the same rays.
///
/// Ray queries take ``(k, 3)`` origins and directions (directions need not
/// be unit length: ``t`` is in their units) and optional ``tmin`` (default
/// 0) and ``tmax`` (default inf), numbers or ``(k,)`` arrays; a hit counts
/// when ``tmin <= t <= tmax``. Point queries take ``(k, 3)`` points.
///
/// Raises ValueError for arrays of the wrong shape or dtype, NaN vertices,
/// or a face index out of range.
#[pyclass(frozen, module = "arbor", name = "Mesh")]
pub struct Mesh {
    accel: MeshAccel,
    quality: BuildQuality,
    /// Every triangle's unit normal, for the hit columns; computed by the
    /// first query that returns normals (12 bytes per triangle).
    normals: OnceLock<Vec<[f32; 3]>>,
}

/// The accelerator named `name`.
pub fn accel_kind(name: &str) -> PyResult<AccelKind> {
    name.parse::<AccelKind>()
        .map_err(|e| PyValueError::new_err(format!("accel: {e}")))
}

/// The build quality named `name`, checked against `kind`.
fn build_quality(kind: AccelKind, name: &str) -> PyResult<BuildQuality> {
    let quality: BuildQuality = name
        .parse()
        .map_err(|e| PyValueError::new_err(format!("quality: {e}")))?;
    kind.check_quality(quality)
        .map_err(|e| PyValueError::new_err(format!("quality: \"{quality}\" {e}")))?;
    Ok(quality)
}

impl Mesh {
    /// Builds the structure without the GIL.
    fn build(
        py: Python<'_>,
        vertices: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        kind: AccelKind,
        quality: &str,
    ) -> PyResult<Mesh> {
        let quality = build_quality(kind, quality)?;
        let params = MeshAccel::params(kind).with_quality(quality);
        let accel = py
            .detach(|| MeshAccel::build_with(vertices, triangles, kind, &params))
            .map_err(|e| PyValueError::new_err(format!("faces: {e}")))?;
        Ok(Mesh {
            accel,
            quality,
            normals: OnceLock::new(),
        })
    }

    /// [`crate::rays::unit_normals`] of the mesh, computed on first use
    /// (called without the GIL).
    fn normals(&self) -> &[[f32; 3]] {
        self.normals
            .get_or_init(|| crate::rays::unit_normals(&self.accel))
    }
}

#[pymethods]
impl Mesh {
    #[new]
    #[pyo3(signature = (vertices, faces, accel = "bvh-wide", quality = "fast"))]
    fn new(
        py: Python<'_>,
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        accel: &str,
        quality: &str,
    ) -> PyResult<Mesh> {
        let kind = accel_kind(accel)?;
        let array = Vec3Array::extract(vertices, "vertices")?;
        let view = array.view();
        if view.has_nan() {
            return Err(PyValueError::new_err("vertices: NaN coordinates"));
        }
        let triangles = crate::arrays::faces(faces)?;
        Mesh::build(py, view.to_vec(), triangles, kind, quality)
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
        self.accel.kind().name()
    }

    /// The build quality: ``"fast"`` or ``"high"``.
    #[getter]
    fn quality(&self) -> &'static str {
        self.quality.name()
    }

    fn __len__(&self) -> usize {
        self.accel.triangles().len()
    }

    fn __repr__(&self) -> String {
        format!(
            "arbor.Mesh({} vertices, {} triangles, accel={:?})",
            self.accel.vertices().len(),
            self.accel.triangles().len(),
            self.accel.kind().name()
        )
    }

    /// The closest hit of each ray.
    ///
    /// Returns a dict of ``(k,)`` arrays: ``t`` (float32, inf on a miss),
    /// ``triangle`` (int64, -1 on a miss), ``u`` and ``v`` (float32
    /// barycentrics: the hit is ``(1 - u - v) p0 + u p1 + v p2``), and
    /// ``(k, 3)`` float32 ``point`` (the ray's point at ``t``) and
    /// ``normal`` (the unit geometric normal ``(p1 - p0) x (p2 - p0)``);
    /// u, v, point and normal are NaN on a miss.
    ///
    /// ``out``: a dict returned by an earlier call for as many rays, whose
    /// arrays are overwritten with this call's answers and returned (the
    /// same dict): a loop over batches of rays then allocates nothing.
    /// Without ``out``, large result arrays reuse the memory of results
    /// already let go of (so the kernel need not clear fresh pages), which
    /// makes a plain loop nearly as fast.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, out = None))]
    fn intersect<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
        out: Option<Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let args = RayArgs::extract(origins, directions, tmin, tmax)?;
        let views = args.views();
        match out {
            Some(out) => {
                let mut arrays = HitArrays::extract(&out, views.len())?;
                let slots = arrays.slots();
                py.detach(|| crate::rays::closest_into(&self.accel, self.normals(), views, slots));
                Ok(out)
            }
            None => {
                let found = py.detach(|| crate::rays::closest(&self.accel, self.normals(), views));
                found.into_dict(py)
            }
        }
    }

    /// Whether anything lies on each ray: a ``(k,)`` bool array.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None))]
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let args = RayArgs::extract(origins, directions, tmin, tmax)?;
        let views = args.views();
        let mut blocked = vec![false; views.len()];
        py.detach(|| {
            views.answer_into(&mut blocked, |rays, out| {
                self.accel.occluded_batch_into(rays, out)
            })
        });
        Ok(PyArray1::from_vec(py, blocked))
    }

    /// Every crossing of the surface along each ray, each crossing once:
    /// where a ray passes exactly through an edge or vertex shared by
    /// several triangles, exactly one of them reports it, so a ray through
    /// a closed mesh has an even number of hits.
    ///
    /// Returns a dict of flat arrays, sorted by ray, then ``t``, ties by
    /// triangle: ``ray`` (int64, the index of each hit's ray) and the
    /// columns of :meth:`intersect` (``t``, ``triangle``, ``u``, ``v``,
    /// ``point``, ``normal``).
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None))]
    fn all_hits<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let args = RayArgs::extract(origins, directions, tmin, tmax)?;
        let views = args.views();
        let (found, ray) =
            py.detach(|| crate::rays::all(&self.accel, self.normals(), &views.rays()));
        let out = found.into_dict(py)?;
        out.set_item("ray", PyArray1::from_vec(py, ray))?;
        Ok(out)
    }

    /// How many times each ray crosses the surface (the hits of
    /// :meth:`all_hits`, without storing them): a ``(k,)`` uint32 array.
    #[pyo3(signature = (origins, directions, tmin = None, tmax = None))]
    fn count<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let args = RayArgs::extract(origins, directions, tmin, tmax)?;
        let views = args.views();
        let mut counts = vec![0; views.len()];
        py.detach(|| {
            views.answer_into(&mut counts, |rays, out| {
                self.accel.count_batch_into(rays, out)
            })
        });
        Ok(PyArray1::from_vec(py, counts))
    }

    /// Whether each point lies inside the mesh: a ``(k,)`` bool array.
    ///
    /// The exact parity of the crossings of one ray from the point in a
    /// fixed direction (no jittered votes). Exact for a closed mesh; for a
    /// mesh with holes (see :meth:`open_edges`) the answer is that fixed
    /// direction's parity. Points on the surface may be answered either way.
    fn contains<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        per_point(py, points, |points| self.accel.contains_batch(points))
    }

    /// The generalised winding number of the mesh at each point: a
    /// ``(k,)`` float32 array, about 1 inside a closed mesh whose triangles
    /// face outwards, 0 outside, and in between near holes, so that
    /// ``winding_number(p) >= 0.5`` is an inside test for meshes with holes
    /// and soups. Far triangles are summed by their moments: within about
    /// 1e-2 of the exact sum of solid angles.
    fn winding_number<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        per_point(py, points, |points| self.accel.winding_number_batch(points))
    }

    /// The point of the mesh closest to each point, within ``max_distance``
    /// (a number or a ``(k,)`` array; default inf).
    ///
    /// Returns a dict: ``point`` (``(k, 3)`` float32), ``triangle`` (int64;
    /// of several at the same distance the smallest index), ``u`` and ``v``
    /// (float32 barycentrics on it), ``distance`` (float32) and ``normal``
    /// (``(k, 3)`` float32, the triangle's unit geometric normal); for a point
    /// with nothing within its maximum distance ``triangle`` is -1,
    /// ``distance`` inf and the rest NaN.
    #[pyo3(signature = (points, max_distance = None))]
    fn closest_points<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        max_distance: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let points = Points::extract(points)?;
        let limits = max_distances(max_distance, points.len())?;
        let points = points.slice();
        let found = py.detach(|| self.accel.closest_point_batch(&points, &limits));
        closest_columns(py, &self.accel, &found)
    }

    /// The distance from each point to the mesh, negative inside (the sign
    /// is :meth:`contains`'s answer): a ``(k,)`` float32 array; inf for an
    /// empty mesh.
    fn signed_distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        per_point(py, points, |points| {
            self.accel.signed_distance_batch(points)
        })
    }

    /// How many edges are not shared by exactly two triangles running along
    /// them in opposite directions: 0 for a closed, consistently oriented
    /// mesh, where :meth:`contains` and :meth:`signed_distance` are exact.
    fn open_edges(&self, py: Python<'_>) -> usize {
        py.detach(|| self.accel.open_edges())
    }
}

/// Reads a mesh file with the loader of ``arbor trace``, triangles numbered
/// as it numbers them, and prepares it for queries (``accel`` and
/// ``quality`` as for :class:`Mesh`): ``.msh``, ``.obj`` (polygons split as
/// fans ``(0, k, k+1)``), ``.ply``, ``.stl`` (faces in file order,
/// coordinates as stored),
/// ``.gltf`` and ``.glb``. A glTF file becomes one mesh of every triangle
/// primitive placed by the default scene's nodes, their transforms applied:
/// nodes depth first in the scene's order (a node's mesh before its
/// children), each mesh's primitives and their triangles in file order; a
/// mesh placed twice appears twice. Raises OSError naming the file when it
/// is missing or broken.
#[pyfunction]
#[pyo3(signature = (path, accel = "bvh-wide", quality = "fast"))]
pub fn load_mesh(py: Python<'_>, path: PathBuf, accel: &str, quality: &str) -> PyResult<Mesh> {
    let kind = accel_kind(accel)?;
    let data = py
        .detach(|| arbor::load::load_ray_mesh(&path))
        .map_err(|e| PyOSError::new_err(e.to_string()))?;
    Mesh::build(py, data.positions, data.triangles, kind, quality)
}
