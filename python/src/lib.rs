//! The `arbor` Python package's native module, `arbor._arbor`: a thin layer
//! over `arbor-accel`'s mesh queries and `arbor`'s mesh loader, renderer
//! and image writer. It has no ray logic of its own: it reads NumPy arrays,
//! calls the library's batch queries without the GIL, and returns NumPy
//! arrays.

mod arrays;
mod column;
mod image;
mod mesh;
mod points;
mod rays;
mod render;

use pyo3::prelude::*;

/// Exact, watertight ray casting against triangle meshes.
#[pymodule]
fn _arbor(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<mesh::Mesh>()?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(image::write_image, m)?)?;
    Ok(())
}
