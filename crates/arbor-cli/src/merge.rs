//! `arbor merge`: partial images (`arbor render --tile`/`--region`) back
//! into one picture, after checking that they belong together and cover the
//! image exactly once.

use std::path::{Path, PathBuf};

use arbor::film::{Film, ImageFormat};
use arbor::partial::{Assembly, PartHeader, Partial};
use clap::Args;

use crate::InputError;

/// Arguments of `arbor merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The part files (`.part`), in any order.
    #[arg(required = true, value_name = "PARTS")]
    pub parts: Vec<PathBuf>,
    /// The picture to write: `.png` (8-bit) or `.exr` (linear float),
    /// written to a temporary file and renamed.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `arbor merge`.
pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    crate::output::check_writable(&args.output, "-o")?;
    ImageFormat::from_path(&args.output).map_err(|e| InputError(e.to_string()))?;
    let film = merge_files(&args.parts)?;
    crate::output::stage_film(&args.output, &film.0, film.1)?.commit()?;
    if !args.quiet {
        eprintln!(
            "wrote {} ({}x{}) from {} parts",
            args.output.display(),
            film.0.width(),
            film.0.height(),
            args.parts.len()
        );
    }
    Ok(())
}

/// Checks every part's header first (cheap, and every error is found
/// before any pixel is read), then reads the pixels into one film.
pub fn merge_files(paths: &[PathBuf]) -> anyhow::Result<(Film, arbor::scene::Variant)> {
    // Every absent part is named at once: that is the list to re-render.
    let absent: Vec<String> = paths
        .iter()
        .filter(|p| !p.exists())
        .map(|p| p.display().to_string())
        .collect();
    match absent.len() {
        0 => {}
        1 => return Err(InputError(format!("{}: missing part (no such file)", absent[0])).into()),
        n => {
            return Err(InputError(format!(
                "merge: {n} parts missing (no such file): {}",
                absent.join(", ")
            ))
            .into())
        }
    }
    let mut headers: Vec<(PathBuf, PartHeader)> = Vec::with_capacity(paths.len());
    for path in paths {
        // The same file twice is a duplicate, whatever it holds.
        if let Some((first, _)) = headers.iter().find(|(p, _)| same_file(p, path)) {
            return Err(InputError(format!(
                "{}: duplicate part: given twice (also as {})",
                path.display(),
                first.display()
            ))
            .into());
        }
        let header = arbor::partial::read_header(path).map_err(|e| InputError(e.to_string()))?;
        headers.push((path.clone(), header));
    }
    let assembly = Assembly::check(&headers).map_err(|e| {
        InputError(if e.path.as_os_str().is_empty() {
            format!("merge: {}", e.message)
        } else {
            e.to_string()
        })
    })?;
    let mut film = Film::new(assembly.width, assembly.height);
    for (path, header) in &headers {
        let part = Partial::read(path).map_err(|e| InputError(e.to_string()))?;
        // The file may have changed since its header was read.
        if &part.header != header {
            return Err(InputError(format!("{}: changed while merging", path.display())).into());
        }
        Assembly::place(&mut film, &part);
    }
    Ok((film, assembly.variant))
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}
