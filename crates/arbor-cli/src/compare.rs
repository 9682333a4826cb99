//! `arbor compare`: how close two pictures are.

use std::path::{Path, PathBuf};

use arbor::compare::{compare_rgb8, difference_image};
use arbor::film::encode_png;

use crate::output::has_png_extension;
use crate::InputError;
use clap::Args;

/// Arguments of `arbor compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The first image (e.g. a render).
    pub a: PathBuf,
    /// The second image (e.g. the reference).
    pub b: PathBuf,
    /// Write the per-channel difference, amplified 16 times, to this PNG.
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Fail (exit status 1) when the PSNR is below this many dB.
    #[arg(long, value_name = "DB")]
    pub min_psnr: Option<f64>,
    /// Fail (exit status 1) when fewer than this fraction of channel values
    /// are within 2/255.
    #[arg(long, value_name = "FRACTION")]
    pub min_within2: Option<f64>,
}

fn read_rgb8(path: &Path) -> anyhow::Result<image::RgbImage> {
    let img = image::open(path)
        .map_err(|e| InputError(format!("{}: cannot read image: {e}", path.display())))?;
    Ok(img.to_rgb8())
}

/// Runs `arbor compare`: prints PSNR, mean and max absolute error, and the
/// fraction of channel values within 2/255.
pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    if let Some(path) = &args.diff {
        crate::output::check_writable(path, "--diff")?;
        if !has_png_extension(path) {
            return Err(
                InputError(format!("{}: --diff writes a .png file", path.display())).into(),
            );
        }
    }
    let a = read_rgb8(&args.a)?;
    let b = read_rgb8(&args.b)?;
    if a.dimensions() != b.dimensions() {
        return Err(InputError(format!(
            "{} is {}x{} but {} is {}x{}; expected images of the same size",
            args.a.display(),
            a.width(),
            a.height(),
            args.b.display(),
            b.width(),
            b.height()
        ))
        .into());
    }
    let c =
        compare_rgb8(a.as_raw(), b.as_raw()).ok_or_else(|| InputError("empty images".into()))?;
    println!(
        "psnr {:.2} dB  mean_abs {:.4}  max_abs {}  within_2 {:.6}  identical_pixels {:.6}",
        c.psnr, c.mean_abs, c.max_abs, c.within_2, c.identical_pixels
    );
    if let Some(path) = &args.diff {
        let d = difference_image(a.as_raw(), b.as_raw(), 16);
        crate::output::write_atomic(path, |w| encode_png(w, a.width(), a.height(), &d))?;
    }
    if args.min_psnr.is_some_and(|m| c.psnr < m) || args.min_within2.is_some_and(|m| c.within_2 < m)
    {
        anyhow::bail!("below the required agreement");
    }
    Ok(())
}
