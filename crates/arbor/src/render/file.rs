//! Rendering a file as `arbor render` does: load a Cornell scene or a
//! framed model, set the size and samples, flatten, accelerate, render
//! every pixel. [`render_file`] runs it all (the Python package); the steps
//! are public ([`load`], [`flatten`], [`build_tracer`]) so the command line
//! runs the same sequence with its own overrides, progress and outputs in
//! between. The defaults are the command's, so the same options give the
//! same image bit for bit.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use arbor_accel::AccelKind;

use crate::film::Film;
use crate::flatten::{FlattenError, FlattenedScene, DEFAULT_MAX_PLACEMENTS};
use crate::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_SAMPLES};
use crate::load::{LoadError, ModelOptions};
use crate::nested::{Instancing, NestError, Plan};
use crate::scene::LoadedScene;
use crate::scene::{Scene, Variant};
use crate::tracer::{BoundingVolumeKind, Tracer, TracerOptions};

/// What [`render_file`] changes from the file's own settings, and how it
/// renders; [`Default`] is `arbor render` without options.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderOptions {
    /// Image width in pixels (`--size`). With only one of width and height
    /// given, the other follows the file's aspect ratio.
    pub width: Option<u32>,
    /// Image height in pixels (`--size`).
    pub height: Option<u32>,
    /// Samples per pixel (`--spp`), rounded to a square grid.
    pub samples: Option<u32>,
    /// The acceleration structure (`--accel`).
    pub accel: AccelKind,
    /// How a model is placed and viewed (`--up`, `--camera auto`).
    pub model: ModelOptions,
    /// Most placements of shared surfaces to accept (`--max-instances`).
    pub max_placements: u64,
    /// A bounding volume around each top-level object (`--bvol`).
    pub bounding_volume: Option<BoundingVolumeKind>,
    /// How references are traced (`--instancing`); `--bvol` is flat.
    pub instancing: Instancing,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: None,
            height: None,
            samples: None,
            accel: AccelKind::DEFAULT,
            model: ModelOptions::default(),
            max_placements: DEFAULT_MAX_PLACEMENTS,
            bounding_volume: None,
            instancing: Instancing::Auto,
        }
    }
}

impl RenderOptions {
    /// How the tracer is built.
    pub fn tracer(&self) -> TracerOptions {
        TracerOptions {
            accel: self.accel,
            bounding_volume: self.bounding_volume,
        }
    }
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct RenderedFile {
    /// Linear radiance per pixel.
    pub film: Film,
    /// The conventions of the scene (they decide the PNG conversion).
    pub variant: Variant,
    /// The loader's non-fatal remarks, each naming the file.
    pub warnings: Vec<String>,
}

/// Why [`render_file`] gave no image.
#[derive(Debug, thiserror::Error)]
pub enum RenderFileError {
    /// An option is out of range (the message names it).
    #[error("{0}")]
    Option(String),
    /// The file is missing or broken.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The scene cannot be flattened (a singular transform, too many
    /// placements).
    #[error("{}: {source}", path.display())]
    Flatten {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: FlattenError,
    },
    /// The scene cannot be built into nested levels (`--instancing`).
    #[error("{}: {source}", path.display())]
    Nest {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: NestError,
    },
    /// `cancel` was set before the render finished.
    #[error("the render was cancelled")]
    Cancelled,
}

/// Renders the scene or model at `path` with `options`, as `arbor render
/// PATH --size WxH --spp N --accel A` would (PNG and EXR written from the
/// film are that command's bytes). Setting `cancel` stops the render within
/// one tile row.
pub fn render_file(
    path: &Path,
    options: &RenderOptions,
    cancel: &AtomicBool,
) -> Result<RenderedFile, RenderFileError> {
    let loaded = load(path, options)?;
    let scene = loaded.scene;
    let path = path.to_path_buf();
    let tracer = match plan(&scene, options) {
        Plan::Flat => {
            let flat = flatten(&scene, options)
                .map_err(|source| RenderFileError::Flatten { path, source })?;
            build_tracer(flat, options)
        }
        Plan::Nested { flatten_budget } => build_nested(&scene, options, flatten_budget)
            .map_err(|source| RenderFileError::Nest { path, source })?,
    };
    let film =
        super::render(&scene, &tracer, &|_| {}, cancel).map_err(|_| RenderFileError::Cancelled)?;
    Ok(RenderedFile {
        film,
        variant: scene.variant,
        warnings: loaded.warnings,
    })
}

/// The first step: checks the options (before reading anything), loads the
/// scene or model at `path` and applies the options' samples and size.
pub fn load(path: &Path, options: &RenderOptions) -> Result<LoadedScene, RenderFileError> {
    check_options(options)?;
    let mut loaded = crate::load::load_scene_with(path, &options.model)?;
    apply_samples_and_size(options, &mut loaded.scene)?;
    Ok(loaded)
}

/// The second step: the scene flattened for the tracer, its top-level
/// objects kept apart when the options ask for bounding volumes. The
/// error says what the limit is, not how a caller raises it.
pub fn flatten(scene: &Scene, options: &RenderOptions) -> Result<FlattenedScene, FlattenError> {
    match options.bounding_volume {
        Some(_) => FlattenedScene::bounded(scene, options.max_placements),
        None => FlattenedScene::new(scene, options.max_placements),
    }
}

/// The third step: the tracer the options ask for over `flat`.
pub fn build_tracer(flat: FlattenedScene, options: &RenderOptions) -> Tracer {
    Tracer::build(flat, &options.tracer())
}

/// How the options' instancing traces `scene`: flat (then [`flatten`] and
/// [`build_tracer`]) or nested ([`build_nested`]); always flat with
/// bounding volumes, which wrap the flat objects.
pub fn plan(scene: &Scene, options: &RenderOptions) -> Plan {
    match options.bounding_volume {
        Some(_) => Plan::Flat,
        None => options.instancing.plan(scene),
    }
}

/// The second and third steps for a nested plan: `scene` built into
/// nested levels of the options' structure (no placement limit: memory
/// follows the definitions).
pub fn build_nested(
    scene: &Scene,
    options: &RenderOptions,
    flatten_budget: u64,
) -> Result<Tracer, NestError> {
    let nested = crate::nested::build(scene, options.accel, flatten_budget)?;
    Ok(Tracer::from_nested(nested, options.accel, scene.variant))
}

/// Whether `n` pixels is a possible image side (what the scene reader accepts).
pub fn valid_side(n: i64) -> bool {
    (1..=MAX_IMAGE_SIDE).contains(&n)
}

/// Whether `n` is a possible sample count per pixel.
pub fn valid_samples(n: i64) -> bool {
    (1..=MAX_SAMPLES).contains(&n)
}

/// Whether a `w` x `h` image is small enough to render.
pub fn valid_pixels(w: i64, h: i64) -> bool {
    w * h <= MAX_IMAGE_PIXELS
}

/// Checks the options against the scene reader's limits, before loading.
fn check_options(options: &RenderOptions) -> Result<(), RenderFileError> {
    let bad = |m: String| Err(RenderFileError::Option(m));
    for (name, side) in [("width", options.width), ("height", options.height)] {
        if let Some(n) = side {
            if !valid_side(n.into()) {
                return bad(format!(
                    "{name}: expected a whole number of pixels from 1 to {MAX_IMAGE_SIDE}, got {n}"
                ));
            }
        }
    }
    if let Some(n) = options.samples {
        if !valid_samples(n.into()) {
            return bad(format!(
                "samples: expected a whole number from 1 to {MAX_SAMPLES}, got {n}"
            ));
        }
    }
    Ok(())
}

/// Applies the options' samples, then their size, as `--spp` and `--size`
/// do, to a scene loaded without them (the built-in one, say).
pub fn apply_samples_and_size(
    options: &RenderOptions,
    scene: &mut Scene,
) -> Result<(), RenderFileError> {
    if let Some(n) = options.samples {
        scene.samples_per_side = Scene::samples_per_side_for(n);
    }
    // One side given: the other keeps the file's aspect ratio.
    let follow = |given: u32, of: u32, by: u32| {
        ((given as f64 * of as f64 / by as f64).round() as u32).clamp(1, MAX_IMAGE_SIDE as u32)
    };
    let size = match (options.width, options.height) {
        (Some(w), Some(h)) => Some((w, h)),
        (Some(w), None) => Some((w, follow(w, scene.height, scene.width))),
        (None, Some(h)) => Some((follow(h, scene.width, scene.height), h)),
        (None, None) => None,
    };
    if let Some((w, h)) = size {
        if !valid_pixels(w.into(), h.into()) {
            return Err(RenderFileError::Option(format!(
                "width x height: {w} x {h} is more than {MAX_IMAGE_PIXELS} pixels"
            )));
        }
        scene.resize(w, h);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small Cornell 2010 scene of `surfaces` under one light, 8 x 6
    /// pixels, written to `dir`.
    fn scene_file(dir: &Path, surfaces: &str) -> std::path::PathBuf {
        let path = dir.join("s.xml");
        let camera = "<camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera>";
        let light = "<light><position>3 4 5</position></light>";
        let xml = format!("<scene>{camera}<image>8 6</image>{surfaces}{light}</scene>");
        std::fs::write(&path, xml).unwrap();
        path
    }

    /// One unit sphere at the origin.
    fn sphere_scene(dir: &Path) -> std::path::PathBuf {
        scene_file(
            dir,
            r#"<surface type="Sphere"><center>0 0 0</center><radius>1</radius></surface>"#,
        )
    }

    fn no_cancel() -> AtomicBool {
        AtomicBool::new(false)
    }

    #[test]
    fn renders_the_file_at_its_own_size_by_default() {
        let dir = tempfile::tempdir().unwrap();
        let path = sphere_scene(dir.path());
        let r = render_file(&path, &RenderOptions::default(), &no_cancel()).unwrap();
        assert_eq!((r.film.width(), r.film.height()), (8, 6));
        // The sphere fills the centre, the corner sees nothing.
        assert!(r.film.get(4, 3).max_element() > 0.0);
        assert_eq!(r.film.get(0, 0), glam::DVec3::ZERO);
    }

    /// The options are `arbor render`'s pipeline: the same as loading the
    /// scene, applying the overrides and rendering by hand.
    #[test]
    fn options_act_as_the_command_applies_them() {
        let dir = tempfile::tempdir().unwrap();
        let path = sphere_scene(dir.path());
        let options = RenderOptions {
            width: Some(16),
            height: Some(10),
            samples: Some(4),
            accel: AccelKind::List,
            ..RenderOptions::default()
        };
        let got = render_file(&path, &options, &no_cancel()).unwrap().film;
        let mut scene = crate::load::load_scene(&path).unwrap().scene;
        scene.samples_per_side = 2;
        scene.resize(16, 10);
        let flat = FlattenedScene::new(&scene, DEFAULT_MAX_PLACEMENTS).unwrap();
        let tracer = Tracer::build(flat, &TracerOptions::default());
        let want = crate::render::render(&scene, &tracer, &|_| {}, &no_cancel()).unwrap();
        assert_eq!(got, want);
        // One side alone: the other follows the file's 8:6.
        let wide = RenderOptions {
            width: Some(20),
            ..RenderOptions::default()
        };
        let film = render_file(&path, &wide, &no_cancel()).unwrap().film;
        assert_eq!((film.width(), film.height()), (20, 15));
        let tall = RenderOptions {
            height: Some(3),
            ..RenderOptions::default()
        };
        let film = render_file(&path, &tall, &no_cancel()).unwrap().film;
        assert_eq!((film.width(), film.height()), (4, 3));
    }

    #[test]
    fn bad_options_and_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = sphere_scene(dir.path());
        let run = |o: RenderOptions| {
            render_file(&path, &o, &no_cancel())
                .unwrap_err()
                .to_string()
        };
        let e = run(RenderOptions {
            width: Some(0),
            ..RenderOptions::default()
        });
        assert!(e.starts_with("width: expected a whole number"), "{e}");
        let e = run(RenderOptions {
            samples: Some(0),
            ..RenderOptions::default()
        });
        assert!(e.starts_with("samples: expected"), "{e}");
        let e = run(RenderOptions {
            width: Some(65_536),
            height: Some(65_536),
            ..RenderOptions::default()
        });
        assert!(e.contains("more than"), "{e}");
        let missing = dir.path().join("missing.xml");
        let e = render_file(&missing, &RenderOptions::default(), &no_cancel()).unwrap_err();
        assert!(matches!(e, RenderFileError::Load(_)), "{e}");
        assert!(e.to_string().contains("missing.xml"), "{e}");
    }

    /// The limit is named, and no command-line flag (callers add their own).
    #[test]
    fn too_many_placements_name_the_file_and_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let path = scene_file(
            dir.path(),
            r#"<defs><surface type="Sphere" name="a"/></defs>
<surface ref="a"/><surface ref="a"/><surface ref="a"/>"#,
        );
        let options = RenderOptions {
            max_placements: 2,
            ..RenderOptions::default()
        };
        let e = render_file(&path, &options, &no_cancel()).unwrap_err();
        assert!(matches!(e, RenderFileError::Flatten { .. }), "{e}");
        let text = e.to_string();
        assert!(text.starts_with(&format!("{}: ", path.display())), "{text}");
        assert!(text.ends_with("3 times; the limit is 2"), "{text}");
        let ok = RenderOptions {
            max_placements: 3,
            ..RenderOptions::default()
        };
        assert!(render_file(&path, &ok, &no_cancel()).is_ok());
    }

    #[test]
    fn a_cancelled_render_gives_no_image() {
        let dir = tempfile::tempdir().unwrap();
        let path = sphere_scene(dir.path());
        let e = render_file(&path, &RenderOptions::default(), &AtomicBool::new(true)).unwrap_err();
        assert!(matches!(e, RenderFileError::Cancelled), "{e}");
    }
}
