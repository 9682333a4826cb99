//! `arbor.render`: a scene or model file rendered by the library's
//! [`arbor::render::render_file`], `arbor render`'s pipeline and defaults,
//! returned as an array of linear radiance.

use std::ffi::CString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use arbor::nested::Instancing;
use arbor::render::{render_file, RenderFileError, RenderOptions, RenderedFile};
use arbor_accel::AccelKind;
use numpy::PyArray3;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;

use crate::mesh::accel_kind;

/// How often a render looks for Ctrl-C (Python's signal handlers run only
/// on the main thread, holding the GIL).
const SIGNAL_POLL: Duration = Duration::from_millis(20);

/// Renders a Cornell XML scene or a model (``.obj``, ``.ply``, ``.stl``,
/// ``.gltf``, ``.glb``, framed as ``arbor render`` frames it) and returns
/// the image: a ``(h, w, 3)`` float32 array of linear radiance, row 0 at
/// the top (:func:`write_image` writes it).
///
/// The pipeline and defaults are ``arbor render``'s: ``width`` and
/// ``height`` are its ``--size`` (the horizontal view kept; with one of
/// them given, the other follows the file's aspect ratio), ``samples`` its
/// ``--spp`` (rounded to a square grid), ``accel`` its ``--accel``,
/// ``instancing`` its ``--instancing`` (``"flat"``, ``"nested"``, ``"auto"``), so the
/// array holds exactly the values ``arbor render -o image.exr`` writes.
/// Runs on all cores with the GIL released; Ctrl-C stops it
/// (KeyboardInterrupt). The loader's warnings become UserWarnings.
///
/// Raises OSError naming the file when it is missing or broken, and
/// ValueError for an option out of range.
#[pyfunction]
#[pyo3(signature = (scene_or_model_path, width = None, height = None, samples = None, accel = None, instancing = None))]
pub fn render<'py>(
    py: Python<'py>,
    scene_or_model_path: PathBuf,
    width: Option<i64>,
    height: Option<i64>,
    samples: Option<i64>,
    accel: Option<&str>,
    instancing: Option<&str>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let instancing = instancing
        .map_or(Ok(Instancing::Auto), str::parse)
        .map_err(|e: String| PyValueError::new_err(format!("instancing: {e}")))?;
    let options = RenderOptions {
        width: whole(width, "width")?,
        height: whole(height, "height")?,
        samples: whole(samples, "samples")?,
        accel: accel.map_or(Ok(AccelKind::DEFAULT), accel_kind)?,
        instancing,
        ..RenderOptions::default()
    };
    let rendered = run_interruptibly(py, &scene_or_model_path, &options)?;
    for w in &rendered.warnings {
        let text = CString::new(w.replace('\0', " ")).expect("no NUL left");
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
    }
    Ok(crate::image::film_array(py, &rendered.film))
}

/// An optional count as the library takes it; a negative one or one past
/// `u32` is a ValueError naming `what`.
fn whole(n: Option<i64>, what: &str) -> PyResult<Option<u32>> {
    n.map(|n| {
        u32::try_from(n).map_err(|_| {
            PyValueError::new_err(format!("{what}: expected a whole number above 0, got {n}"))
        })
    })
    .transpose()
}

/// Renders on a thread of its own while this one, between short waits
/// without the GIL, lets Python's signal handlers run: Ctrl-C cancels the
/// render and raises.
fn run_interruptibly(
    py: Python<'_>,
    path: &std::path::Path,
    options: &RenderOptions,
) -> PyResult<RenderedFile> {
    let cancel = AtomicBool::new(false);
    let result = std::thread::scope(|scope| {
        let worker = scope.spawn(|| render_file(path, options, &cancel));
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(SIGNAL_POLL));
            if let Err(interrupt) = py.check_signals() {
                cancel.store(true, Ordering::Relaxed);
                let _ = py.detach(|| worker.join());
                return Err(interrupt);
            }
        }
        worker
            .join()
            .map_err(|_| PyRuntimeError::new_err("arbor.render: the renderer panicked"))
    })?;
    result.map_err(|e| match e {
        RenderFileError::Option(_) => PyValueError::new_err(e.to_string()),
        RenderFileError::Load(_)
        | RenderFileError::Flatten { .. }
        | RenderFileError::Nest { .. } => PyOSError::new_err(e.to_string()),
        RenderFileError::Cancelled => PyRuntimeError::new_err(e.to_string()),
    })
}
