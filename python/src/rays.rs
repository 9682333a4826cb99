//! The ray arguments of the queries (`(k, 3)` origins and directions and
//! their `tmin`/`tmax`), and hits spread into the columns Python gets.

use arbor_accel::{MeshAccel, MeshHit, Ray};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::arrays::{ScalarView, Scalars, Vec3Array, Vec3View};

/// The four ray arguments of a query, checked to agree in length.
pub struct RayArgs<'py> {
    origins: Vec3Array<'py>,
    directions: Vec3Array<'py>,
    tmin: Scalars<'py>,
    tmax: Scalars<'py>,
}

impl<'py> RayArgs<'py> {
    /// Reads the arguments; `tmin` defaults to 0 and `tmax` to infinity.
    pub fn extract(
        origins: &Bound<'py, PyAny>,
        directions: &Bound<'py, PyAny>,
        tmin: Option<&Bound<'py, PyAny>>,
        tmax: Option<&Bound<'py, PyAny>>,
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
        let scalars = |obj: Option<&Bound<'py, PyAny>>, what, default| match obj {
            Some(obj) => Scalars::extract(obj, what, k),
            None => Ok(Scalars::Same(default)),
        };
        Ok(RayArgs {
            origins,
            directions,
            tmin: scalars(tmin, "tmin", 0.0)?,
            tmax: scalars(tmax, "tmax", f32::INFINITY)?,
        })
    }

    /// Views of the arguments that can cross into code running without
    /// the GIL.
    pub fn views(&self) -> RayViews<'_> {
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
pub struct RayViews<'a> {
    origins: Vec3View<'a>,
    directions: Vec3View<'a>,
    tmin: ScalarView<'a>,
    tmax: ScalarView<'a>,
}

impl RayViews<'_> {
    /// How many rays there are.
    pub fn len(&self) -> usize {
        self.origins.len()
    }

    /// Ray `i`.
    #[inline]
    fn ray(&self, i: usize) -> Ray {
        Ray::new(
            self.origins.get(i),
            self.directions.get(i),
            self.tmin.get(i),
            self.tmax.get(i),
        )
    }

    /// Answers every ray into `out` (one slot per ray), in parallel: each
    /// task builds its chunk of rays where it uses them (no array of every
    /// ray, and the chunk stays in cache) and hands them to `answer` with
    /// its slots.
    pub fn answer_into<T: Send>(self, out: &mut [T], answer: impl Fn(&[Ray], &mut [T]) + Sync) {
        assert_eq!(out.len(), self.len(), "one answer slot per ray");
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each_init(Vec::new, |rays, (c, slots)| {
                self.chunk(c, rays);
                answer(rays, slots);
            });
    }

    /// Chunk `c` of the rays (`CHUNK` of them, fewer at the end), in `rays`.
    fn chunk(&self, c: usize, rays: &mut Vec<Ray>) {
        let end = ((c + 1) * CHUNK).min(self.len());
        rays.clear();
        rays.extend((c * CHUNK..end).map(|i| self.ray(i)));
    }

    /// Every ray, in one array (for the queries whose answers are not one
    /// per ray).
    pub fn rays(self) -> Vec<Ray> {
        (0..self.len())
            .into_par_iter()
            .map(|i| self.ray(i))
            .collect()
    }
}

/// Rays per parallel task: enough to amortise the task, few enough to stay
/// in cache with their answers (and whole packets of eight).
const CHUNK: usize = 1024;

/// A `(k, 3)` float32 array from rows.
pub fn rows3<'py>(py: Python<'py>, rows: Vec<[f32; 3]>) -> Bound<'py, PyArray2<f32>> {
    let k = rows.len();
    // The same memory, seen as 3k values: no copy.
    Array2::from_shape_vec((k, 3), rows.into_flattened())
        .expect("3 values per row")
        .into_pyarray(py)
}

/// Hits as the columns Python gets: `t`, `triangle`, `u`, `v`, `point`,
/// `normal`, one entry per hit or miss.
#[derive(Default)]
pub struct HitColumns {
    t: Vec<f32>,
    triangle: Vec<i64>,
    u: Vec<f32>,
    v: Vec<f32>,
    point: Vec<[f32; 3]>,
    normal: Vec<[f32; 3]>,
}

impl HitColumns {
    /// Columns for `n` entries.
    pub fn with_capacity(n: usize) -> Self {
        HitColumns {
            t: Vec::with_capacity(n),
            triangle: Vec::with_capacity(n),
            u: Vec::with_capacity(n),
            v: Vec::with_capacity(n),
            point: Vec::with_capacity(n),
            normal: Vec::with_capacity(n),
        }
    }

    /// `ray`'s hit on `mesh`: the point is the ray's at `t`, the normal the
    /// triangle's.
    pub fn push_hit(&mut self, mesh: &MeshAccel, ray: &Ray, hit: &MeshHit) {
        self.t.push(hit.hit.t);
        self.triangle.push(i64::from(hit.prim));
        self.u.push(hit.hit.u);
        self.v.push(hit.hit.v);
        self.point.push(ray.at(hit.hit.t).to_array());
        self.normal.push(unit_normal(mesh, hit.prim));
    }

    /// The columns as a dict of NumPy arrays (no copies).
    pub fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let out = PyDict::new(py);
        out.set_item("t", PyArray1::from_vec(py, self.t))?;
        out.set_item("triangle", PyArray1::from_vec(py, self.triangle))?;
        out.set_item("u", PyArray1::from_vec(py, self.u))?;
        out.set_item("v", PyArray1::from_vec(py, self.v))?;
        out.set_item("point", rows3(py, self.point))?;
        out.set_item("normal", rows3(py, self.normal))?;
        Ok(out)
    }
}

/// The unit geometric normal `(p1 - p0) x (p2 - p0)` of triangle `prim`,
/// computed in float64 (zero for a degenerate triangle).
pub fn unit_normal(mesh: &MeshAccel, prim: u32) -> [f32; 3] {
    let [a, b, c] = mesh.triangle(prim).map(|p| p.as_dvec3());
    (b - a)
        .cross(c - a)
        .normalize_or_zero()
        .as_vec3()
        .to_array()
}

/// The closest hit of every ray, as columns. Each chunk of rays is traced
/// (the library's batch query, packets for camera rays) and spread into its
/// part of the columns at once, in parallel, while its triangles are still
/// in cache.
pub fn closest(mesh: &MeshAccel, views: RayViews<'_>) -> HitColumns {
    let n = views.len();
    // Zeros come from the allocator as untouched pages (no serial fill):
    // each entry, hit or miss, is then written once by the thread that
    // traced its ray.
    let mut c = HitColumns {
        t: vec![0.0; n],
        triangle: vec![0; n],
        u: vec![0.0; n],
        v: vec![0.0; n],
        point: vec![[0.0; 3]; n],
        normal: vec![[0.0; 3]; n],
    };
    (
        c.t.par_chunks_mut(CHUNK),
        c.triangle.par_chunks_mut(CHUNK),
        c.u.par_chunks_mut(CHUNK),
        c.v.par_chunks_mut(CHUNK),
        c.point.par_chunks_mut(CHUNK),
        c.normal.par_chunks_mut(CHUNK),
    )
        .into_par_iter()
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new()),
            |(rays, hits), (k, (t, triangle, u, v, point, normal))| {
                views.chunk(k, rays);
                hits.clear();
                hits.resize(rays.len(), None);
                mesh.closest_batch_into(rays, hits);
                for (i, (ray, hit)) in rays.iter().zip(hits.iter()).enumerate() {
                    (t[i], triangle[i], u[i], v[i], point[i], normal[i]) = match hit {
                        Some(h) => (
                            h.hit.t,
                            i64::from(h.prim),
                            h.hit.u,
                            h.hit.v,
                            ray.at(h.hit.t).to_array(),
                            unit_normal(mesh, h.prim),
                        ),
                        None => (
                            f32::INFINITY,
                            -1,
                            f32::NAN,
                            f32::NAN,
                            [f32::NAN; 3],
                            [f32::NAN; 3],
                        ),
                    };
                }
            },
        );
    c
}

/// Every hit of every ray, as columns, with the index of each hit's ray.
pub fn all(mesh: &MeshAccel, rays: &[Ray]) -> (HitColumns, Vec<i64>) {
    let all = mesh.all_hits_batch(rays);
    let mut c = HitColumns::with_capacity(all.hits.len());
    let mut ray_of = Vec::with_capacity(all.hits.len());
    let mut hits = all.hits.iter();
    for (i, (ray, &n)) in rays.iter().zip(&all.counts).enumerate() {
        for hit in hits.by_ref().take(n as usize) {
            c.push_hit(mesh, ray, hit);
            ray_of.push(i as i64);
        }
    }
    (c, ray_of)
}
