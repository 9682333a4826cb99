//! The `arbor` command: a thin layer over the `arbor` and `arbor-accel`
//! libraries. Exit status 0 on success, 2 on bad input or usage, 1 on other
//! failures.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod accel_arg;
mod batch;
mod bench;
mod compare;
mod explain;
mod farm;
mod huge_pages;
mod info;
mod input;
mod merge;
mod output;
mod overrides;
mod points;
mod preview_signal;
mod render;
mod trace;

#[global_allocator]
static ALLOCATOR: huge_pages::HugePageAlloc = huge_pages::HugePageAlloc;

/// arbor: a ray tracer built around transformations and acceleration structures.
#[derive(Parser, Debug)]
#[command(
    name = "arbor",
    version,
    after_help = "Exit status: 0 on success, 2 for bad input or usage, 1 for other failures.\nEach command's --help has an example."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to a PNG or EXR image (no scene: the built-in default scene).
    #[command(
        after_help = "Examples:\n  arbor render scene.xml -o scene.png\n  arbor render model.glb --quick              # a quarter size, one sample\n  arbor render scene.xml --size 1920x1080 --spp 16 -D exposure=2"
    )]
    Render(render::RenderArgs),
    /// Describe a scene: settings, hierarchy, unique and instanced primitives.
    #[command(after_help = "Example:\n  arbor info model.obj --json model.json")]
    Info(info::InfoArgs),
    /// Compare two images: PSNR, mean/max error, fraction within 2/255.
    #[command(
        after_help = "Example:\n  arbor compare out.png reference.png --diff diff.png --min-psnr 40"
    )]
    Compare(compare::CompareArgs),
    /// Trace a batch of rays against a triangle mesh (the ray/hit file
    /// interface): closest hits, occlusion, every hit, hit counts.
    #[command(
        after_help = "Examples:\n  arbor trace --mesh bunny.obj --rays rays.bin --hits hits.bin\n  arbor trace --mesh bunny.obj --rays rays.bin --query count --hits counts.bin"
    )]
    Trace(trace::TraceArgs),
    /// Inside or outside a closed triangle mesh, for a batch of points.
    Inside(points::InsideArgs),
    /// The closest point of a triangle mesh (and the distance, signed with
    /// --signed), for a batch of points.
    Nearest(points::NearestArgs),
    /// Benchmark the acceleration structures on a mesh or scene: build time,
    /// size, shape, Mrays/s and nodes and tests per ray.
    #[command(
        after_help = "Example:\n  arbor bench buddha100k.msh --accel bvh-wide,grid --json bench.json"
    )]
    Bench(bench::BenchArgs),
    /// Assemble partial images (`render --tile`) into one PNG or EXR.
    #[command(
        after_help = "Example:\n  arbor merge s.tile-0-of-2.part s.tile-1-of-2.part -o s.png"
    )]
    Merge(merge::MergeArgs),
    /// Render on a cluster: submit tiles as Slurm array jobs, show progress.
    #[command(
        after_help = "Examples:\n  arbor farm slurm shot.xml --tiles 64 --partition gpu --account proj42 -o shot.png\n  arbor farm status shot.png"
    )]
    Farm(farm::FarmArgs),
    /// Write a self-contained HTML page that shows the scene graph, the
    /// acceleration structures and camera rays' traversals of them (or one
    /// ray's traversal as JSON).
    #[command(
        after_help = "Examples:\n  arbor explain scene.xml -o scene.html\n  arbor explain model.obj --accel bvh-sah,kdtree -o model.html\n  arbor explain scene.xml --ray 120,80 --json ray.json   # one ray, no page"
    )]
    Explain(explain::ExplainArgs),
}

/// An error that is the user's input's fault (exit status 2), as opposed to
/// an internal or system failure (exit status 1).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

/// A rayon pool of `threads` workers (default: one per core).
pub fn thread_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    if threads == Some(0) {
        return Err(InputError("--threads must be at least 1".into()).into());
    }
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        builder = builder.num_threads(n);
    }
    Ok(builder.build()?)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Info(args) => info::run(args),
        Command::Trace(args) => trace::run(args),
        Command::Inside(args) => points::run_inside(args),
        Command::Nearest(args) => points::run_nearest(args),
        Command::Bench(args) => bench::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Farm(args) => farm::run(args),
        Command::Explain(args) => explain::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("{err:#}");
            if err.downcast_ref::<InputError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
