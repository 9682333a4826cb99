//! The one way every command reads its input file. The library's format
//! registry ([`Format`]) picks the reader by extension; every failure is an
//! input error (exit 2) naming the file; the loader's warnings are printed
//! here, once, unless the command is quiet.

use std::path::Path;

use arbor::load::{Format, MeshData, Model};
use arbor::render::RenderOptions;
use arbor::scene::Scene;

use crate::InputError;

/// What a command reads its input as.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ReadAs<'a> {
    /// What `arbor render` draws (also `explain` and `farm`): a Cornell
    /// scene or a model framed by itself, with the options' samples and
    /// size; no file is the built-in default scene.
    Render(&'a RenderOptions),
    /// What `arbor info` describes: a model with its framing scene, or a
    /// Cornell scene; no file is the built-in default scene.
    Description,
    /// What `arbor trace` casts rays at: any mesh format as one mesh (glTF
    /// with its node transforms applied).
    Mesh,
    /// What `arbor bench` times: a Cornell scene through the renderer's
    /// tracer, any other format as `arbor trace`'s mesh.
    SceneOrMesh,
}

/// A command's input, read.
pub(crate) enum Input {
    /// A scene (a Cornell scene, a framed model or the default scene).
    Scene(Scene),
    /// A model and the scene that frames it (camera, floor, lights).
    Model {
        /// The framing scene.
        scene: Scene,
        /// The model as read (boxed: it is far larger than the others).
        model: Box<Model>,
    },
    /// One triangle mesh for ray casting.
    Mesh(MeshData),
}

impl Input {
    /// The scene to render or describe. Only [`ReadAs::Mesh`] and
    /// [`ReadAs::SceneOrMesh`] give a mesh, and their callers match on it.
    pub(crate) fn into_scene(self) -> anyhow::Result<Scene> {
        match self {
            Input::Scene(scene) | Input::Model { scene, .. } => Ok(scene),
            Input::Mesh(_) => {
                anyhow::bail!("internal error: a mesh was read where a scene was asked for")
            }
        }
    }

    /// The mesh to cast rays at ([`ReadAs::Mesh`] gives nothing else).
    pub(crate) fn into_mesh(self) -> anyhow::Result<MeshData> {
        match self {
            Input::Mesh(mesh) => Ok(mesh),
            _ => anyhow::bail!("internal error: a scene was read where a mesh was asked for"),
        }
    }
}

/// Reads `path` as `read_as` asks, printing the loader's warnings unless
/// `quiet`. `path` may be `None` only for [`ReadAs::Render`] and
/// [`ReadAs::Description`] (the built-in default scene).
pub(crate) fn load_input(
    path: Option<&Path>,
    read_as: ReadAs,
    quiet: bool,
) -> anyhow::Result<Input> {
    let input_error = |e: &dyn std::fmt::Display| anyhow::Error::from(InputError(e.to_string()));
    let Some(path) = path else {
        let mut scene = arbor::default_scene::classroom();
        if let ReadAs::Render(options) = read_as {
            arbor::render::apply_samples_and_size(options, &mut scene)
                .map_err(|e| input_error(&e))?;
        }
        return Ok(Input::Scene(scene));
    };
    let format = Format::from_path(path).map_err(|e| input_error(&e))?;
    let (input, warnings) = match read_as {
        ReadAs::Render(options) => {
            let loaded = arbor::render::load(path, options).map_err(|e| input_error(&e))?;
            (Input::Scene(loaded.scene), loaded.warnings)
        }
        ReadAs::Description if format.is_model() => {
            let (scene, model) =
                arbor::load::load_model_scene(path).map_err(|e| input_error(&e))?;
            let warnings = model.warnings.clone();
            (
                Input::Model {
                    scene,
                    model: Box::new(model),
                },
                warnings,
            )
        }
        ReadAs::Description => {
            let loaded = arbor::load::load_cornell_scene(path).map_err(|e| input_error(&e))?;
            (Input::Scene(loaded.scene), loaded.warnings)
        }
        ReadAs::SceneOrMesh if format == Format::Xml => {
            let loaded = arbor::load::load_cornell_scene(path).map_err(|e| input_error(&e))?;
            (Input::Scene(loaded.scene), loaded.warnings)
        }
        ReadAs::Mesh | ReadAs::SceneOrMesh => {
            let mesh = arbor::load::load_ray_mesh(path).map_err(|e| input_error(&e))?;
            (Input::Mesh(mesh), Vec::new())
        }
    };
    if !quiet {
        for w in &warnings {
            eprintln!("{w}");
        }
    }
    Ok(input)
}
