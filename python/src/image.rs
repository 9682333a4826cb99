//! Images between arbor and NumPy: a film as a `(h, w, 3)` float32 array of
//! linear radiance, and such an array written as a picture by the
//! library's own writer (the bytes `arbor render` writes).

use std::path::PathBuf;

use arbor::film::{Film, ImageFormat};
use arbor::scene::Variant;
use glam::DVec3;
use numpy::ndarray::{Array3, ArrayView3};
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

use crate::arrays::{as_ndarray, float_elements, shape};

/// `film` as a `(h, w, 3)` float32 array, row 0 at the top.
pub fn film_array<'py>(py: Python<'py>, film: &Film) -> Bound<'py, PyArray3<f32>> {
    let (w, h) = (film.width() as usize, film.height() as usize);
    Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        film.get(x as u32, y as u32)[c] as f32
    })
    .into_pyarray(py)
}

/// The pixels of a `(h, w, 3)` float array as a film.
fn array_film<T: Copy + Into<f64>>(a: ArrayView3<'_, T>) -> Film {
    let (h, w, _) = a.dim();
    let mut film = Film::new(w as u32, h as u32);
    for y in 0..h {
        for x in 0..w {
            let c = |k| a[[y, x, k]].into();
            film.set(x as u32, y as u32, DVec3::new(c(0), c(1), c(2)));
        }
    }
    film
}

/// Writes an image to ``path``, the format chosen by its extension as
/// ``arbor render -o`` chooses it: ``.png`` (8-bit; each channel ``c``
/// becomes ``round(255 * clamp(c ** (1 / 2.2), 0, 1))``, arbor's gamma for
/// models and 2015 scenes) or ``.exr`` (linear float32, exactly the
/// array's values). ``image`` is a ``(h, w, 3)`` float32 or float64 array
/// of linear radiance, row 0 at the top, as :func:`render` returns.
///
/// The file is written to a temporary name beside ``path`` and renamed
/// into place: on any failure nothing is left half-written. Raises
/// ValueError for a wrong shape or dtype, an empty image or an unknown
/// extension, and OSError naming the file when it cannot be written.
#[pyfunction]
pub fn write_image(py: Python<'_>, path: PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    // The extension first: a name that cannot be written costs no copy.
    ImageFormat::from_path(&path).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let a = as_ndarray(image, "image", true)?;
    if a.ndim() != 3 || a.shape()[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "image: expected an array of shape (h, w, 3), got shape {}",
            shape(&a)
        )));
    }
    let (h, w) = (a.shape()[0], a.shape()[1]);
    if h == 0 || w == 0 || u32::try_from(h).is_err() || u32::try_from(w).is_err() {
        return Err(PyValueError::new_err(format!(
            "image: expected at least one pixel and sides below 2^32, got shape {}",
            shape(&a)
        )));
    }
    let film = float_elements(
        &a,
        "image",
        |a: PyReadonlyArray3<'_, f32>| array_film(a.as_array()),
        |a: PyReadonlyArray3<'_, f64>| array_film(a.as_array()),
    )?;
    py.detach(|| film.write(&path, Variant::Cornell2015))
        .map_err(|e| PyOSError::new_err(e.to_string()))
}
