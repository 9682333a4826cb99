//! The `arbor` Python package's native module, `arbor._arbor`: a thin layer
//! over `arbor-accel`'s mesh queries and `arbor`'s mesh loader. It has no
//! ray logic of its own: it reads NumPy arrays, calls the library's batch
//! queries without the GIL, and returns NumPy arrays.

mod arrays;
mod mesh;
mod points;
mod rays;

use pyo3::prelude::*;

/// Exact, watertight ray casting against triangle meshes.
#[pymodule]
fn _arbor(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<mesh::Mesh>()?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    Ok(())
}
