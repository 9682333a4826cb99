//! Reading NumPy inputs: `(k, 3)` float arrays of points or directions,
//! `(m, 3)` integer faces, and per-ray scalars given as a number or a
//! `(k,)` array. Float arrays are read where they lie (any strides, float32
//! or float64); anything that is not an array yet (a list) goes through
//! `numpy.asarray` first. Wrong shapes and dtypes are `ValueError`s that
//! name the argument.

use arbor_accel::Vec3;
use numpy::ndarray::{ArrayView1, ArrayView2, Dimension};
use numpy::{
    dtype, PyArray, PyArray2, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray,
    PyReadonlyArray1, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `obj` as a NumPy array; other array-likes are converted (as float64 when
/// `float` says so, otherwise with NumPy's own choice of dtype).
pub fn as_ndarray<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    float: bool,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return Ok(a.clone());
    }
    let py = obj.py();
    let numpy = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    if float {
        kwargs.set_item("dtype", numpy.getattr("float64")?)?;
    }
    let converted = numpy
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| PyValueError::new_err(format!("{what}: cannot be read as an array: {e}")))?;
    Ok(converted.cast_into::<PyUntypedArray>()?)
}

/// Checks that `a` has shape `(k, 3)`.
fn check_k3(a: &Bound<'_, PyUntypedArray>, what: &str) -> PyResult<()> {
    if a.ndim() != 2 || a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected an array of shape (k, 3), got shape {}",
            shape(a)
        )));
    }
    Ok(())
}

/// `a`'s shape as Python writes it: `(3, 2)`, `(5,)`.
pub fn shape(a: &Bound<'_, PyUntypedArray>) -> String {
    let dims: Vec<String> = a.shape().iter().map(usize::to_string).collect();
    match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    }
}

/// The name of `a`'s dtype, for messages.
fn dtype_name(a: &Bound<'_, PyUntypedArray>) -> String {
    a.dtype().to_string()
}

/// `a` borrowed read-only with its float32 or float64 elements, handed to
/// `f32s` or `f64s`; other dtypes are a `ValueError` naming `what`.
pub fn float_elements<'py, D: Dimension, R>(
    a: &Bound<'py, PyUntypedArray>,
    what: &str,
    f32s: impl FnOnce(PyReadonlyArray<'py, f32, D>) -> R,
    f64s: impl FnOnce(PyReadonlyArray<'py, f64, D>) -> R,
) -> PyResult<R> {
    let py = a.py();
    let dt = a.dtype();
    if dt.is_equiv_to(&dtype::<f32>(py)) {
        Ok(f32s(a.cast::<PyArray<f32, D>>()?.readonly()))
    } else if dt.is_equiv_to(&dtype::<f64>(py)) {
        Ok(f64s(a.cast::<PyArray<f64, D>>()?.readonly()))
    } else {
        Err(PyValueError::new_err(format!(
            "{what}: expected float32 or float64 values, got dtype {}",
            dtype_name(a)
        )))
    }
}

/// A `(k, 3)` float32 or float64 array, borrowed read-only.
pub enum Vec3Array<'py> {
    /// float32 elements.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64 elements.
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> Vec3Array<'py> {
    /// Reads `obj` (named `what` in errors) as `(k, 3)` floats.
    pub fn extract(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Self> {
        let a = as_ndarray(obj, what, true)?;
        check_k3(&a, what)?;
        float_elements(&a, what, Vec3Array::F32, Vec3Array::F64)
    }

    /// A view that can cross into code running without the GIL.
    pub fn view(&self) -> Vec3View<'_> {
        match self {
            Vec3Array::F32(a) => Vec3View::F32(a.as_array()),
            Vec3Array::F64(a) => Vec3View::F64(a.as_array()),
        }
    }
}

/// Rows of a `(k, 3)` float array, read as [`Vec3`] (float64 rounded to the
/// nearest float32, as the library computes in float32).
#[derive(Clone, Copy)]
pub enum Vec3View<'a> {
    /// float32 elements.
    F32(ArrayView2<'a, f32>),
    /// float64 elements.
    F64(ArrayView2<'a, f64>),
}

impl Vec3View<'_> {
    /// The number of rows.
    pub fn len(&self) -> usize {
        match self {
            Vec3View::F32(a) => a.nrows(),
            Vec3View::F64(a) => a.nrows(),
        }
    }

    /// Row `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        match self {
            Vec3View::F32(a) => Vec3::new(a[[i, 0]], a[[i, 1]], a[[i, 2]]),
            Vec3View::F64(a) => Vec3::new(a[[i, 0]] as f32, a[[i, 1]] as f32, a[[i, 2]] as f32),
        }
    }

    /// All elements as one flat slice (row after row), when the array is
    /// contiguous in NumPy's default layout.
    pub fn flat(&self) -> Option<Flat<'_>> {
        match self {
            Vec3View::F32(a) => a.as_slice().map(Flat::F32),
            Vec3View::F64(a) => a.as_slice().map(Flat::F64),
        }
    }

    /// Whether any element is NaN.
    pub fn has_nan(&self) -> bool {
        match self {
            Vec3View::F32(a) => a.iter().any(|x| x.is_nan()),
            Vec3View::F64(a) => a.iter().any(|x| x.is_nan()),
        }
    }

    /// Every row.
    pub fn to_vec(self) -> Vec<Vec3> {
        match self.flat() {
            Some(Flat::F32(v)) => v
                .chunks_exact(3)
                .map(|r| Vec3::new(r[0], r[1], r[2]))
                .collect(),
            Some(Flat::F64(v)) => v.chunks_exact(3).map(f64_row).collect(),
            None => (0..self.len()).map(|i| self.get(i)).collect(),
        }
    }
}

/// The elements of a contiguous [`Vec3View`], three to a row.
#[derive(Clone, Copy)]
pub enum Flat<'a> {
    /// float32 elements.
    F32(&'a [f32]),
    /// float64 elements.
    F64(&'a [f64]),
}

/// A row of float32 values.
#[inline]
pub fn f32_row(r: &[f32]) -> Vec3 {
    Vec3::new(r[0], r[1], r[2])
}

/// A row of float64 values rounded to float32.
#[inline]
pub fn f64_row(r: &[f64]) -> Vec3 {
    Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
}

/// Reads `(m, 3)` integer faces as triangles; a negative index or one past
/// `u32` is a `ValueError` (indices past the vertex count are the library's
/// to refuse).
pub fn faces(obj: &Bound<'_, PyAny>) -> PyResult<Vec<[u32; 3]>> {
    let a = as_ndarray(obj, "faces", false)?;
    // An empty list converts to float64: no face, nothing to misread.
    if a.len() == 0 && a.ndim() <= 2 {
        return Ok(Vec::new());
    }
    check_k3(&a, "faces")?;
    let kind = a.dtype().kind();
    if kind != b'i' && kind != b'u' {
        return Err(PyValueError::new_err(format!(
            "faces: expected integer vertex indices, got dtype {}",
            dtype_name(&a)
        )));
    }
    // Any integer dtype, read through int64 (uint64 beyond i64 wraps
    // negative and is refused below).
    let py = a.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("copy", false)?;
    let as_i64 = a.call_method("astype", (dtype::<i64>(py),), Some(&kwargs))?;
    let arr = as_i64.cast::<PyArray2<i64>>()?.readonly();
    let view = arr.as_array();
    let mut out = Vec::with_capacity(view.nrows());
    for (i, row) in view.rows().into_iter().enumerate() {
        let mut tri = [0u32; 3];
        for (slot, &k) in tri.iter_mut().zip(row.iter()) {
            *slot = u32::try_from(k).map_err(|_| {
                PyValueError::new_err(format!(
                    "faces: triangle {i} has vertex index {k}, out of range"
                ))
            })?;
        }
        out.push(tri);
    }
    Ok(out)
}

/// A per-ray or per-point scalar: one number for all, or a `(k,)` array.
pub enum Scalars<'py> {
    /// The same value everywhere.
    Same(f32),
    /// float32 values, one per query.
    F32(PyReadonlyArray1<'py, f32>),
    /// float64 values, one per query.
    F64(PyReadonlyArray1<'py, f64>),
}

impl<'py> Scalars<'py> {
    /// Reads `obj` (named `what` in errors) as a number or as `k` values.
    pub fn extract(obj: &Bound<'py, PyAny>, what: &str, k: usize) -> PyResult<Self> {
        if obj.cast::<PyUntypedArray>().is_err() {
            if let Ok(x) = obj.extract::<f64>() {
                return Ok(Scalars::Same(x as f32));
            }
        }
        let a = as_ndarray(obj, what, true)?;
        if a.ndim() == 0 {
            let x: f64 = a.call_method0("item")?.extract().map_err(|_| {
                PyValueError::new_err(format!("{what}: expected a number or an array of floats"))
            })?;
            return Ok(Scalars::Same(x as f32));
        }
        if a.ndim() != 1 || a.len() != k {
            return Err(PyValueError::new_err(format!(
                "{what}: expected a number or an array of shape ({k},), got shape {}",
                shape(&a)
            )));
        }
        float_elements(&a, what, Scalars::F32, Scalars::F64)
    }

    /// A view that can cross into code running without the GIL.
    pub fn view(&self) -> ScalarView<'_> {
        match self {
            Scalars::Same(x) => ScalarView::Same(*x),
            Scalars::F32(a) => ScalarView::F32(a.as_array()),
            Scalars::F64(a) => ScalarView::F64(a.as_array()),
        }
    }
}

/// The values of [`Scalars`], by query index.
#[derive(Clone, Copy)]
pub enum ScalarView<'a> {
    /// The same value everywhere.
    Same(f32),
    /// float32 values.
    F32(ArrayView1<'a, f32>),
    /// float64 values (rounded to float32).
    F64(ArrayView1<'a, f64>),
}

impl ScalarView<'_> {
    /// The value for query `i`.
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        match self {
            ScalarView::Same(x) => *x,
            ScalarView::F32(a) => a[i],
            ScalarView::F64(a) => a[i] as f32,
        }
    }
}
