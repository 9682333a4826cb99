//! What the batch query commands (`trace`, `inside`, `nearest`) share: the
//! mesh they load, the record files they read, and the timing of repeated
//! runs. (Their answer files go through [`crate::output`].)

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use arbor_accel::{AccelKind, BuildQuality, MeshAccel};
use clap::Args;

use crate::accel_arg::QualityArg;
use crate::input::{load_input, ReadAs};
use crate::InputError;

/// How a batch query command runs: threads, repetitions, structure.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub threads: Option<u32>,
    /// Build and answer the queries this many times; the best build and the
    /// median and fastest pass are reported.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,
    /// Acceleration structure (default: bvh-wide; point queries search a
    /// binary BVH either way).
    #[arg(long, value_name = "NAME", value_parser = crate::accel_arg::parse)]
    pub accel: Option<AccelKind>,
    #[command(flatten)]
    pub build: QualityArg,
}

/// The structure a batch command builds: its kind and build quality.
#[derive(Clone, Copy, Debug)]
pub struct Structure {
    /// Which structure.
    pub kind: AccelKind,
    /// How carefully it is built.
    pub quality: BuildQuality,
}

impl RunArgs {
    /// What every batch command starts with: the structure asked for (or
    /// the default), a pool of the threads asked for, and pending outputs
    /// removed on an interrupt.
    pub fn start(&self) -> anyhow::Result<(Structure, rayon::ThreadPool)> {
        let kind = self.accel.unwrap_or(AccelKind::DEFAULT);
        self.build.check(kind)?;
        let pool = crate::thread_pool(self.threads.map(|n| n as usize))?;
        crate::output::remove_pending_on_interrupt();
        Ok((
            Structure {
                kind,
                quality: self.build.quality,
            },
            pool,
        ))
    }
}

/// Loads `path` as a triangle mesh (polygons split as fans, triangles
/// numbered in file order) and builds `structure` over it `repeat` times on
/// the current pool; returns the last build and the fastest build's time in
/// milliseconds (Embree's is timed the same way, its buffer copies
/// included).
pub fn load_and_build(
    path: &Path,
    structure: Structure,
    repeat: usize,
) -> anyhow::Result<(MeshAccel, f64)> {
    let kind = structure.kind;
    let params = MeshAccel::params(kind).with_quality(structure.quality);
    let data = load_input(Some(path), ReadAs::Mesh, true)?.into_mesh()?;
    let mut best = f64::INFINITY;
    let mut built = None;
    for _ in 0..repeat.max(1) {
        let (positions, triangles) = (data.positions.clone(), data.triangles.clone());
        let start = Instant::now();
        let mesh = MeshAccel::build_with(positions, triangles, kind, &params)
            .map_err(|e| InputError(format!("{}: {e}", path.display())))?;
        best = best.min(ms_since(start));
        built = Some(mesh);
    }
    let mesh = built.context("internal error: no structure was built")?;
    Ok((mesh, best))
}

/// Reads a file of fixed-size little-endian records with no header; `what`
/// names them in errors ("a ray file holds 32-byte records (...)").
pub fn read_records(path: &Path, size: usize, what: &str, layout: &str) -> anyhow::Result<Vec<u8>> {
    let bytes = std::fs::read(path).map_err(|e| {
        InputError(format!(
            "{}: cannot read the {what} file: {e}",
            path.display()
        ))
    })?;
    if bytes.len() % size != 0 {
        return Err(InputError(format!(
            "{}: a {what} file holds {size}-byte records ({layout}), but its length {} is not \
             a multiple of {size}",
            path.display(),
            bytes.len()
        ))
        .into());
    }
    Ok(bytes)
}

/// The `i`-th little-endian `f32` of a record.
pub fn f32_at(record: &[u8], i: usize) -> f32 {
    let mut word = [0u8; 4];
    word.copy_from_slice(&record[4 * i..4 * i + 4]);
    f32::from_le_bytes(word)
}

/// Runs `pass` `repeat` times; returns the median (the upper one for an
/// even count, as `embree_trace` takes it) and fastest time in milliseconds.
pub fn timed(repeat: usize, mut pass: impl FnMut()) -> (f64, f64) {
    let mut times: Vec<f64> = (0..repeat.max(1))
        .map(|_| {
            let start = Instant::now();
            pass();
            ms_since(start)
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}

/// Milliseconds since `start`.
pub fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// `x` rounded to three decimals, for the JSON summaries (microseconds are
/// all a millisecond timing can say).
pub fn millis(x: f64) -> f64 {
    (x * 1e3).round() / 1e3
}

/// Millions of queries per second at `ms` for `n` queries (0 for no time).
pub fn mega_per_s(n: usize, ms: f64) -> f64 {
    if ms > 0.0 {
        millis(n as f64 / (ms * 1e3))
    } else {
        0.0
    }
}
