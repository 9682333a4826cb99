//! The ray arguments of the queries (`(k, 3)` origins and directions and
//! their `tmin`/`tmax`), and hits spread into the columns Python gets.

use arbor_accel::{MeshAccel, MeshHit, Ray, Vec3};
use std::mem::MaybeUninit;

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray, PyArray2, PyArrayMethods, PyReadwriteArray, PyReadwriteArray1,
    PyReadwriteArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;

use crate::arrays::{f32_row, f64_row, Flat, ScalarView, Scalars, Vec3Array, Vec3View};
use crate::column::Column;

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
        let range = c * CHUNK..((c + 1) * CHUNK).min(self.len());
        rays.clear();
        // Contiguous arrays (NumPy's default) are read as flat slices in
        // one pass: element by element through the views, building the
        // rays cost more than testing them against the root box.
        match (self.origins.flat(), self.directions.flat()) {
            (Some(Flat::F32(o)), Some(Flat::F32(d))) => {
                self.extend(rays, range, o, d, f32_row, f32_row)
            }
            (Some(Flat::F32(o)), Some(Flat::F64(d))) => {
                self.extend(rays, range, o, d, f32_row, f64_row)
            }
            (Some(Flat::F64(o)), Some(Flat::F32(d))) => {
                self.extend(rays, range, o, d, f64_row, f32_row)
            }
            (Some(Flat::F64(o)), Some(Flat::F64(d))) => {
                self.extend(rays, range, o, d, f64_row, f64_row)
            }
            _ => rays.extend(range.map(|i| self.ray(i))),
        }
    }

    /// Appends the rays `range` from flat origin and direction values.
    #[inline]
    fn extend<O, D>(
        &self,
        rays: &mut Vec<Ray>,
        range: std::ops::Range<usize>,
        origins: &[O],
        directions: &[D],
        origin: impl Fn(&[O]) -> Vec3,
        direction: impl Fn(&[D]) -> Vec3,
    ) {
        let flat = 3 * range.start..3 * range.end;
        let rows = origins[flat.clone()]
            .chunks_exact(3)
            .zip(directions[flat].chunks_exact(3));
        // The usual call gives one `tmin` and one `tmax` for every ray: a
        // loop of its own, without the per-ray look at which kind they are.
        if let (ScalarView::Same(tmin), ScalarView::Same(tmax)) = (self.tmin, self.tmax) {
            rays.extend(rows.map(|(o, d)| Ray::new(origin(o), direction(d), tmin, tmax)));
            return;
        }
        rays.extend(rows.zip(range).map(|((o, d), i)| {
            Ray::new(origin(o), direction(d), self.tmin.get(i), self.tmax.get(i))
        }));
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
/// in cache with their answers (and whole packets of eight or sixteen).
const CHUNK: usize = 1024;

/// A `(k, 3)` float32 array from rows.
pub fn rows3<'py>(py: Python<'py>, rows: Vec<[f32; 3]>) -> Bound<'py, PyArray2<f32>> {
    let k = rows.len();
    // The same memory, seen as 3k values: no copy.
    Array2::from_shape_vec((k, 3), rows.into_flattened())
        .expect("3 values per row")
        .into_pyarray(py)
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

/// [`unit_normal`] of every triangle, in triangle order (in parallel): the
/// hit columns read a hit's normal here, one load, where computing it took
/// the triangle's indices, then its three vertices, from wherever the mesh
/// keeps them.
pub fn unit_normals(mesh: &MeshAccel) -> Vec<[f32; 3]> {
    (0..mesh.triangles().len() as u32)
        .into_par_iter()
        .map(|prim| unit_normal(mesh, prim))
        .collect()
}

/// Hits as the columns Python gets (`t`, `triangle`, `u`, `v`, `point`,
/// `normal`), in recycled memory (see `column.rs`); made only by
/// [`closest`] and [`all`], which write every entry.
pub struct HitColumns {
    t: Column<f32>,
    triangle: Column<i64>,
    u: Column<f32>,
    v: Column<f32>,
    point: Column<[f32; 3]>,
    normal: Column<[f32; 3]>,
}

impl HitColumns {
    /// Room for `n` entries, not yet written.
    fn uninit(n: usize) -> Self {
        HitColumns {
            t: Column::uninit(n),
            triangle: Column::uninit(n),
            u: Column::uninit(n),
            v: Column::uninit(n),
            point: Column::uninit(n),
            normal: Column::uninit(n),
        }
    }

    fn slots(&mut self) -> HitSlots<'_> {
        HitSlots {
            t: self.t.slots(),
            triangle: self.triangle.slots(),
            u: self.u.slots(),
            v: self.v.slots(),
            point: self.point.slots(),
            normal: self.normal.slots(),
        }
    }

    /// The columns as a dict of NumPy arrays (no copies).
    pub fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let out = PyDict::new(py);
        // SAFETY: `closest` and `all` wrote every slot of every column.
        unsafe {
            out.set_item("t", self.t.into_array(py)?)?;
            out.set_item("triangle", self.triangle.into_array(py)?)?;
            out.set_item("u", self.u.into_array(py)?)?;
            out.set_item("v", self.v.into_array(py)?)?;
            out.set_item("point", self.point.into_rows(py)?)?;
            out.set_item("normal", self.normal.into_rows(py)?)?;
        }
        Ok(out)
    }
}

/// The closest hit of every ray, as columns.
pub fn closest(mesh: &MeshAccel, normals: &[[f32; 3]], views: RayViews<'_>) -> HitColumns {
    let mut c = HitColumns::uninit(views.len());
    // Not filled first: `closest_into` writes every entry.
    closest_into(mesh, normals, views, c.slots());
    c
}

/// Where [`closest_into`] writes: one slot per ray in each column, written
/// or not yet (fresh memory, or arrays the caller hands back for reuse).
pub struct HitSlots<'a> {
    /// Distances.
    pub t: &'a mut [MaybeUninit<f32>],
    /// Triangle ids, -1 on a miss.
    pub triangle: &'a mut [MaybeUninit<i64>],
    /// First barycentric.
    pub u: &'a mut [MaybeUninit<f32>],
    /// Second barycentric.
    pub v: &'a mut [MaybeUninit<f32>],
    /// Hit points.
    pub point: &'a mut [MaybeUninit<[f32; 3]>],
    /// Unit geometric normals.
    pub normal: &'a mut [MaybeUninit<[f32; 3]>],
}

impl HitSlots<'_> {
    /// Writes entry `i`: `ray`'s hit (the point the ray's at `t`, the
    /// normal its triangle's in `normals`, from [`unit_normals`]), or a miss
    /// (inf, -1 and NaN).
    fn write(&mut self, i: usize, normals: &[[f32; 3]], ray: &Ray, hit: Option<&MeshHit>) {
        let (t, triangle, u, v, point, normal) = match hit {
            Some(h) => (
                h.hit.t,
                i64::from(h.prim),
                h.hit.u,
                h.hit.v,
                ray.at(h.hit.t).to_array(),
                normals[h.prim as usize],
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
        self.t[i].write(t);
        self.triangle[i].write(triangle);
        self.u[i].write(u);
        self.v[i].write(v);
        self.point[i].write(point);
        self.normal[i].write(normal);
    }
}

/// Writes the closest hit of every ray into `slots` (each column one slot
/// per ray). Each chunk of rays is traced (the library's batch query,
/// packets for camera rays) and spread into its part of the columns at
/// once, in parallel, while its triangles are still in cache; every slot,
/// hit or miss, is written once.
///
/// # Panics
/// If a column's length differs from the number of rays.
pub fn closest_into(
    mesh: &MeshAccel,
    normals: &[[f32; 3]],
    views: RayViews<'_>,
    slots: HitSlots<'_>,
) {
    let n = views.len();
    for len in [
        slots.t.len(),
        slots.triangle.len(),
        slots.u.len(),
        slots.v.len(),
        slots.point.len(),
        slots.normal.len(),
    ] {
        assert_eq!(len, n, "one slot per ray in every column");
    }
    (
        slots.t.par_chunks_mut(CHUNK),
        slots.triangle.par_chunks_mut(CHUNK),
        slots.u.par_chunks_mut(CHUNK),
        slots.v.par_chunks_mut(CHUNK),
        slots.point.par_chunks_mut(CHUNK),
        slots.normal.par_chunks_mut(CHUNK),
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
                // Each column cut to the chunk's length, so that the writes
                // below need no bounds checks (six per ray otherwise).
                let n = rays.len();
                let mut chunk = HitSlots {
                    t: &mut t[..n],
                    triangle: &mut triangle[..n],
                    u: &mut u[..n],
                    v: &mut v[..n],
                    point: &mut point[..n],
                    normal: &mut normal[..n],
                };
                for (i, (ray, hit)) in rays.iter().zip(hits.iter()).enumerate() {
                    chunk.write(i, normals, ray, hit.as_ref());
                }
            },
        );
}

/// `values` seen as slots to overwrite.
///
/// # Safety
/// Only initialised values may be written through the result (as
/// [`closest_into`] does, with `MaybeUninit::write`), so that `values` is
/// still initialised when it is used again.
unsafe fn as_slots<T: Copy>(values: &mut [T]) -> &mut [MaybeUninit<T>] {
    // SAFETY: `MaybeUninit<T>` has `T`'s layout; the caller keeps the
    // contents initialised.
    unsafe { &mut *(values as *mut [T] as *mut [MaybeUninit<T>]) }
}

/// The six arrays of an earlier [`closest`] result handed back as `out=`,
/// borrowed for writing.
pub struct HitArrays<'py> {
    t: PyReadwriteArray1<'py, f32>,
    triangle: PyReadwriteArray1<'py, i64>,
    u: PyReadwriteArray1<'py, f32>,
    v: PyReadwriteArray1<'py, f32>,
    point: PyReadwriteArray2<'py, f32>,
    normal: PyReadwriteArray2<'py, f32>,
}

impl<'py> HitArrays<'py> {
    /// Borrows the arrays of `out` for `k` rays: every key of an
    /// `intersect` result, each a writeable C-contiguous array of its dtype
    /// and shape, none overlapping another or the inputs. Anything else is
    /// a `ValueError` that names the key.
    pub fn extract(out: &Bound<'py, PyDict>, k: usize) -> PyResult<Self> {
        fn get<'py, T: numpy::Element, D: numpy::ndarray::Dimension>(
            out: &Bound<'py, PyDict>,
            key: &str,
            dtype: &str,
            shape: &[usize],
        ) -> PyResult<PyReadwriteArray<'py, T, D>> {
            let wanted = || {
                let shape = match shape {
                    [k] => format!("({k},)"),
                    [k, m] => format!("({k}, {m})"),
                    _ => unreachable!("the columns are 1- or 2-dimensional"),
                };
                format!("out[{key:?}]: expected a writeable C-contiguous {dtype} array of shape {shape}")
            };
            let item = out.get_item(key)?.ok_or_else(|| {
                PyValueError::new_err(format!(
                    "out: missing {key:?} (pass a dict returned by intersect)"
                ))
            })?;
            let array = item
                .cast::<PyArray<T, D>>()
                .map_err(|_| PyValueError::new_err(wanted()))?;
            if array.shape() != shape || !array.is_c_contiguous() {
                return Err(PyValueError::new_err(wanted()));
            }
            array
                .try_readwrite()
                .map_err(|e| PyValueError::new_err(format!("{}: {e}", wanted())))
        }
        Ok(HitArrays {
            t: get(out, "t", "float32", &[k])?,
            triangle: get(out, "triangle", "int64", &[k])?,
            u: get(out, "u", "float32", &[k])?,
            v: get(out, "v", "float32", &[k])?,
            point: get(out, "point", "float32", &[k, 3])?,
            normal: get(out, "normal", "float32", &[k, 3])?,
        })
    }

    /// The arrays as slots for [`closest_into`].
    pub fn slots(&mut self) -> HitSlots<'_> {
        // Checked C-contiguous in `extract`, so every slice exists.
        let rows = |a: &mut PyReadwriteArray2<'py, f32>| -> &mut [[f32; 3]] {
            let flat = a.as_slice_mut().expect("C-contiguous");
            // SAFETY: `[f32; 3]` is three `f32`s with `f32`'s alignment, and
            // the array has shape (k, 3), so its 3k values are k rows.
            unsafe { std::slice::from_raw_parts_mut(flat.as_mut_ptr().cast(), flat.len() / 3) }
        };
        // SAFETY (`as_slots`): `closest_into` writes initialised values only.
        unsafe {
            HitSlots {
                t: as_slots(self.t.as_slice_mut().expect("C-contiguous")),
                triangle: as_slots(self.triangle.as_slice_mut().expect("C-contiguous")),
                u: as_slots(self.u.as_slice_mut().expect("C-contiguous")),
                v: as_slots(self.v.as_slice_mut().expect("C-contiguous")),
                point: as_slots(rows(&mut self.point)),
                normal: as_slots(rows(&mut self.normal)),
            }
        }
    }
}

/// Every hit of every ray, as columns, with the index of each hit's ray.
pub fn all(mesh: &MeshAccel, normals: &[[f32; 3]], rays: &[Ray]) -> (HitColumns, Vec<i64>) {
    let all = mesh.all_hits_batch(rays);
    let mut c = HitColumns::uninit(all.hits.len());
    let mut slots = c.slots();
    let mut ray_of = Vec::with_capacity(all.hits.len());
    let mut hits = all.hits.iter().enumerate();
    for (i, (ray, &n)) in rays.iter().zip(&all.counts).enumerate() {
        for (k, hit) in hits.by_ref().take(n as usize) {
            slots.write(k, normals, ray, Some(hit));
            ray_of.push(i as i64);
        }
    }
    (c, ray_of)
}
