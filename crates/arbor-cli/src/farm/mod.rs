//! Rendering on a cluster: partial renders (`arbor render --tile`), and
//! `arbor farm`, which cuts renders into Slurm array tasks, merges their
//! parts, and reports progress. See `docs/cluster.md`.
//!
//! Everything a farm render keeps lives in the parts folder `OUT.parts/`
//! beside the output: `farm.txt` (the manifest: tile count, output, and
//! each scene with its hash), `jobs.txt` (submitted job ids),
//! `render.sbatch` and `merge.sbatch` (the job scripts), `logs/`, and one
//! folder per scene, `STEM/`, holding `tile-K-of-N.part` files. The parts
//! present are the checkpoint: a re-run submits only the others.

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};

pub mod part;
pub mod slurm;
pub mod status;

/// Arguments of `arbor farm`.
#[derive(Args, Debug)]
pub struct FarmArgs {
    #[command(subcommand)]
    command: FarmCommand,
}

#[derive(Subcommand, Debug)]
enum FarmCommand {
    /// Submit a render (one or more scenes, as the frames of a sequence) as
    /// a Slurm array job of tiles plus a merge job that depends on it.
    #[command(
        after_help = "Example:\n  arbor farm slurm a.xml b.xml --tiles 16 --time 30:00 --mem 4G --sbatch-arg=--mail-type=END -o frames"
    )]
    Slurm(Box<slurm::SlurmArgs>),
    /// Tiles done, queued or running, and missing, for a farm render.
    #[command(after_help = "Example:\n  arbor farm status frames")]
    Status(status::StatusArgs),
}

/// Runs `arbor farm`.
pub fn run(args: FarmArgs) -> anyhow::Result<()> {
    match args.command {
        FarmCommand::Slurm(a) => slurm::run(*a),
        FarmCommand::Status(a) => status::run(a),
    }
}

/// The parts folder of output `out`: `OUT.parts` beside it.
pub fn parts_dir(out: &Path) -> PathBuf {
    let mut name = out.file_name().unwrap_or_default().to_os_string();
    name.push(".parts");
    out.with_file_name(name)
}

/// The file of tile `k` of `n` in a scene's parts folder. `K` is padded to
/// the width of `N - 1` so the files sort in order.
pub fn tile_file(scene_parts: &Path, k: u32, n: u32) -> PathBuf {
    let width = (n - 1).max(1).to_string().len();
    scene_parts.join(format!("tile-{k:0width$}-of-{n}.part"))
}

/// The manifest of a farm render, `OUT.parts/farm.txt`: what was
/// submitted, so that `farm status` needs neither the scenes nor the
/// original command line. Line format: `arbor-farm 1`, `tiles N`,
/// `output PATH`, then `scene HASH STEM PATH` per scene, in array order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Manifest {
    /// Tiles per scene.
    pub tiles: u32,
    /// The output image (one scene) or folder (several).
    pub output: PathBuf,
    /// The scenes: hash (hex), stem, absolute path.
    pub scenes: Vec<(String, String, PathBuf)>,
}

impl Manifest {
    /// The manifest file of output `out`.
    pub fn path(out: &Path) -> PathBuf {
        parts_dir(out).join("farm.txt")
    }

    /// The manifest as text.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "arbor-farm 1\ntiles {}\noutput {}\n",
            self.tiles,
            self.output.display()
        );
        for (hash, stem, path) in &self.scenes {
            s.push_str(&format!("scene {hash} {stem} {}\n", path.display()));
        }
        s
    }

    /// Parses a manifest; `None` when it is not one.
    pub fn parse(text: &str) -> Option<Manifest> {
        let mut lines = text.lines();
        if lines.next()? != "arbor-farm 1" {
            return None;
        }
        let tiles = lines.next()?.strip_prefix("tiles ")?.parse().ok()?;
        let output = PathBuf::from(lines.next()?.strip_prefix("output ")?);
        let mut scenes = Vec::new();
        for line in lines {
            let mut f = line.strip_prefix("scene ")?.splitn(3, ' ');
            let (hash, stem, path) = (f.next()?, f.next()?, f.next()?);
            scenes.push((hash.to_string(), stem.to_string(), PathBuf::from(path)));
        }
        (tiles > 0 && !scenes.is_empty()).then_some(Manifest {
            tiles,
            output,
            scenes,
        })
    }

    /// Whether there are several scenes (then the output is a folder).
    pub fn is_sequence(&self) -> bool {
        self.scenes.len() > 1
    }

    /// The picture merged for scene `s`.
    pub fn picture(&self, s: usize) -> PathBuf {
        if self.is_sequence() {
            self.output.join(format!("{}.png", self.scenes[s].1))
        } else {
            self.output.clone()
        }
    }

    /// The part file of tile `k` of scene `s`.
    pub fn part(&self, s: usize, k: u32) -> PathBuf {
        tile_file(
            &parts_dir(&self.output).join(&self.scenes[s].1),
            k,
            self.tiles,
        )
    }

    /// The state of tile `k` of scene `s` on disk: done when its part is a
    /// whole file of this scene (same hash) and this cut.
    pub fn part_state(&self, s: usize, k: u32) -> PartState {
        let path = self.part(s, k);
        if !path.exists() {
            return PartState::Missing;
        }
        match arbor::partial::read_header(&path) {
            Ok(h)
                if h.tile == Some((k, self.tiles))
                    && arbor::partial::hash_hex(&h.scene_hash) == self.scenes[s].0 =>
            {
                PartState::Done
            }
            _ => PartState::Stale,
        }
    }
}

/// A tile's part file as found on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartState {
    /// A valid part of the current scene.
    Done,
    /// No file.
    Missing,
    /// A file that is damaged or belongs to another scene or cut: it will
    /// be rendered again.
    Stale,
}

/// A job submitted for an output, as `OUT.parts/jobs.txt` records it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordedJob {
    /// `render` or `merge`.
    pub kind: String,
    /// Slurm's job id.
    pub id: String,
    /// For a render array: added to an array task id, it gives the task
    /// index (scene x tiles + tile). Non-zero when the tasks outnumber the
    /// cluster's `MaxArraySize` and were split over several arrays.
    pub offset: u32,
}

/// The jobs submitted for an output, oldest first, from `OUT.parts/jobs.txt`
/// (lines `render ID`, `render ID +OFFSET` and `merge ID`).
pub fn recorded_jobs(out: &Path) -> Vec<RecordedJob> {
    parse_jobs(&std::fs::read_to_string(parts_dir(out).join("jobs.txt")).unwrap_or_default())
}

fn parse_jobs(text: &str) -> Vec<RecordedJob> {
    text.lines()
        .filter_map(|l| {
            let mut words = l.split_whitespace();
            let (kind, id) = (words.next()?, words.next()?);
            let offset = match words.next() {
                Some(w) => w.strip_prefix('+')?.parse().ok()?,
                None => 0,
            };
            Some(RecordedJob {
                kind: kind.to_string(),
                id: id.to_string(),
                offset,
            })
        })
        .collect()
}

/// The tasks of our render arrays that `queue` still holds, as pairs of
/// the task index (the array task id plus the offset its job was submitted
/// with) and the queue entry, in the order of `jobs` (oldest first).
pub fn render_tasks<'q>(
    jobs: &[RecordedJob],
    queue: &'q [QueueEntry],
) -> Vec<(u32, &'q QueueEntry)> {
    jobs.iter()
        .filter(|j| j.kind == "render")
        .flat_map(|j| {
            queue
                .iter()
                .filter(move |e| e.job == j.id)
                .filter_map(move |e| Some((e.task? + j.offset, e)))
        })
        .collect()
}

/// The render tasks `todo` (ascending task indices) as array jobs: pairs
/// of an offset and the array task ids (`task index - offset`), each array
/// holding the indices of one window `[k max, (k + 1) max)`, so that every
/// array task id lies below `max`, the cluster's `MaxArraySize` (Slurm
/// refuses higher ones). Without a known limit, one array at offset 0.
pub fn array_batches(todo: &[u32], max: Option<u32>) -> Vec<(u32, Vec<u32>)> {
    let mut batches: Vec<(u32, Vec<u32>)> = Vec::new();
    for &t in todo {
        let offset = max.map_or(0, |m| t / m * m);
        match batches.last_mut() {
            Some((o, ids)) if *o == offset => ids.push(t - offset),
            _ => batches.push((offset, vec![t - offset])),
        }
    }
    batches
}

/// One line of `squeue`: a job, or one task of an array job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct QueueEntry {
    /// The (array) job id.
    pub job: String,
    /// The array task id, for a task that has its own line.
    pub task: Option<u32>,
    /// PENDING, RUNNING, ...
    pub state: String,
    /// Why it is pending (e.g. `DependencyNeverSatisfied`).
    pub reason: String,
}

/// Every job in the queue, array tasks one per line; `None` when `squeue`
/// is missing or fails (no Slurm here).
pub fn squeue() -> Option<Vec<QueueEntry>> {
    let out = std::process::Command::new("squeue")
        .args(["-h", "-r", "-o", "%F|%K|%T|%r"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    Some(parse_squeue(&String::from_utf8_lossy(&out.stdout)))
}

/// Parses `squeue -h -r -o '%F|%K|%T|%r'`: the array job id (a plain job's
/// own id), the array task id (`N/A` for a plain job), state and reason.
/// (`%A|%a`, used before, is each task's own job id and the *account*: no
/// task was ever recognised.) A pending array whose tasks are still folded
/// shows a range (`3-7%2`); it is expanded.
pub fn parse_squeue(text: &str) -> Vec<QueueEntry> {
    let mut out = Vec::new();
    for line in text.lines() {
        let f: Vec<&str> = line.trim().splitn(4, '|').collect();
        if f.len() < 3 {
            continue;
        }
        let entry = |task| QueueEntry {
            job: f[0].to_string(),
            task,
            state: f[2].to_string(),
            reason: f.get(3).unwrap_or(&"").to_string(),
        };
        match parse_index_list(f[1].split('%').next().unwrap_or("")) {
            Some(tasks) => out.extend(tasks.into_iter().map(|t| entry(Some(t)))),
            None => out.push(entry(None)),
        }
    }
    out
}

/// This cluster's `MaxArraySize` (array indices must lie below it; Slurm's
/// default is 1001), from `scontrol show config`; `None` when `scontrol`
/// is missing or does not say.
pub fn max_array_size() -> Option<u32> {
    let out = std::process::Command::new("scontrol")
        .args(["show", "config"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    parse_max_array_size(&String::from_utf8_lossy(&out.stdout))
}

/// The `MaxArraySize = N` line of `scontrol show config`.
fn parse_max_array_size(config: &str) -> Option<u32> {
    config.lines().find_map(|line| {
        let (key, value) = line.split_once('=')?;
        (key.trim() == "MaxArraySize").then(|| value.trim().parse().ok())?
    })
}

/// Parses a Slurm index list like `0-3,7,9`; `None` if it is not one.
pub fn parse_index_list(text: &str) -> Option<Vec<u32>> {
    let text = text.trim_start_matches('[').trim_end_matches(']');
    let mut out = Vec::new();
    for piece in text.split(',') {
        match piece.split_once('-') {
            Some((a, b)) => {
                let (a, b): (u32, u32) = (a.parse().ok()?, b.parse().ok()?);
                if b < a || b - a > 1_000_000 {
                    return None;
                }
                out.extend(a..=b);
            }
            None => out.push(piece.parse().ok()?),
        }
    }
    Some(out)
}

/// Formats indices (sorted) as a Slurm index list with ranges: `0-3,7`.
pub fn index_list(indices: &[u32]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < indices.len() {
        let start = indices[i];
        while i + 1 < indices.len() && indices[i + 1] == indices[i] + 1 {
            i += 1;
        }
        parts.push(if indices[i] == start {
            start.to_string()
        } else {
            format!("{start}-{}", indices[i])
        });
        i += 1;
    }
    parts.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_array_size_from_the_config() {
        let config = "Configuration data as of 2026-11-23T16:00:00\nMailProg                = /bin/mail\nMaxArraySize            = 1001\nMaxJobCount             = 10000\n";
        assert_eq!(parse_max_array_size(config), Some(1001));
        assert_eq!(parse_max_array_size("MaxJobCount = 5\n"), None);
        assert_eq!(parse_max_array_size("MaxArraySize = lots\n"), None);
    }

    #[test]
    fn index_lists() {
        assert_eq!(index_list(&[0, 1, 2, 3, 7, 9, 10]), "0-3,7,9-10");
        assert_eq!(index_list(&[5]), "5");
        assert_eq!(parse_index_list("0-3,7"), Some(vec![0, 1, 2, 3, 7]));
        assert_eq!(parse_index_list("[2-3]"), Some(vec![2, 3]));
        assert_eq!(parse_index_list("N/A"), None);
    }

    #[test]
    fn arrays_stay_below_max_array_size() {
        assert_eq!(
            array_batches(&[0, 1, 2, 7], None),
            vec![(0, vec![0, 1, 2, 7])]
        );
        assert_eq!(
            array_batches(&[0, 1, 2, 7], Some(1001)),
            vec![(0, vec![0, 1, 2, 7])]
        );
        // MaxArraySize 4: ids 0-3 only; windows 0-3, 4-7, 8-11.
        assert_eq!(
            array_batches(&[1, 3, 4, 9, 10, 11], Some(4)),
            vec![(0, vec![1, 3]), (4, vec![0]), (8, vec![1, 2, 3])]
        );
        assert!(array_batches(&[], Some(4)).is_empty());
        for (offset, ids) in array_batches(&(0..2500).collect::<Vec<_>>(), Some(1001)) {
            assert!(ids.iter().all(|&i| i < 1001), "offset {offset}");
        }
    }

    #[test]
    fn job_records() {
        let jobs = parse_jobs("render 12\nmerge 13\nrender 14 +1001\nrender 15 1001\n");
        let short: Vec<_> = jobs
            .iter()
            .map(|j| (j.kind.as_str(), j.id.as_str(), j.offset))
            .collect();
        // A third word without its `+` is not ours: the line is skipped.
        assert_eq!(
            short,
            [
                ("render", "12", 0),
                ("merge", "13", 0),
                ("render", "14", 1001)
            ]
        );
    }

    #[test]
    fn squeue_lines() {
        let e = parse_squeue("12|3|RUNNING|None\n12|4-5%2|PENDING|JobArrayTaskLimit\n13|N/A|PENDING|DependencyNeverSatisfied\n");
        assert_eq!(e.len(), 4);
        assert_eq!(e[2].task, Some(5));
        assert_eq!(e[3].task, None);
        assert_eq!(e[3].reason, "DependencyNeverSatisfied");
    }

    #[test]
    fn manifest_round_trip() {
        let m = Manifest {
            tiles: 12,
            output: PathBuf::from("/r/out dir"),
            scenes: vec![
                ("ab".into(), "a".into(), PathBuf::from("/s/a b.xml")),
                ("cd".into(), "b".into(), PathBuf::from("/s/b.xml")),
            ],
        };
        assert_eq!(Manifest::parse(&m.to_text()), Some(m.clone()));
        assert_eq!(m.picture(1), PathBuf::from("/r/out dir/b.png"));
        assert_eq!(
            m.part(0, 3),
            PathBuf::from("/r/out dir.parts/a/tile-03-of-12.part")
        );
        assert_eq!(Manifest::parse("nonsense"), None);
    }
}
