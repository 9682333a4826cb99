//! `arbor farm slurm`: one Slurm array job (a task per tile and scene;
//! several arrays when the tasks outnumber the cluster's `MaxArraySize`)
//! and a merge job that waits for them (`--dependency=afterok`). Parts
//! already on disk are the checkpoint: running the same command again
//! submits only the tiles that are neither done nor still queued or
//! running.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, SystemTime};

use anyhow::Context;
use arbor::film::ImageFormat;
use arbor_accel::AccelKind;
use clap::Args;

use crate::input::{load_input, ReadAs};

use super::{
    array_batches, index_list, max_array_size, parts_dir, recorded_jobs, render_tasks, squeue,
    Manifest, PartState,
};
use crate::output::write_text;
use crate::InputError;

/// Arguments of `arbor farm slurm`.
#[derive(Args, Debug)]
pub struct SlurmArgs {
    /// Scene files; several are the frames of a sequence.
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Tiles per scene (horizontal bands of whole rows; at most the image height).
    #[arg(long, value_name = "N")]
    pub tiles: u32,
    /// Slurm partition for every job.
    #[arg(long, value_name = "P", value_parser = parse_option_value)]
    pub partition: Option<String>,
    /// Time limit of each job (Slurm's format, e.g. `10:00` for ten minutes).
    #[arg(long, value_name = "T", value_parser = parse_option_value)]
    pub time: Option<String>,
    /// Account charged for every job.
    #[arg(long, value_name = "A", value_parser = parse_option_value)]
    pub account: Option<String>,
    /// Quality of service of every job.
    #[arg(long, value_name = "Q", value_parser = parse_option_value)]
    pub qos: Option<String>,
    /// Memory per node of each job (Slurm's format, e.g. `4G`).
    #[arg(long, value_name = "M", value_parser = parse_option_value)]
    pub mem: Option<String>,
    /// Generic resources of each job (e.g. `gpu:1`).
    #[arg(long, value_name = "G", value_parser = parse_option_value)]
    pub gres: Option<String>,
    /// Node features each job needs (e.g. `avx2`).
    #[arg(long, value_name = "C", value_parser = parse_option_value)]
    pub constraint: Option<String>,
    /// Any other sbatch option, given to every job as is; repeatable
    /// (e.g. `--sbatch-arg=--mail-type=END`).
    #[arg(long = "sbatch-arg", value_name = "ARG", allow_hyphen_values = true, value_parser = parse_sbatch_arg)]
    pub sbatch_args: Vec<String>,
    /// CPUs per render task (its render threads).
    #[arg(long, value_name = "C", default_value_t = 1)]
    pub cpus_per_task: u32,
    /// Acceleration structure of the render tasks (pixels never depend on it).
    #[arg(long, value_name = "NAME", default_value_t = AccelKind::DEFAULT, value_parser = crate::accel_arg::parse)]
    pub accel: AccelKind,
    /// Print the job scripts and what would be submitted; submit nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Wait for the merge job and fail if it does not produce the picture.
    #[arg(long)]
    pub wait: bool,
    /// The picture (`.png`/`.exr`) for one scene; a folder receiving
    /// `STEM.png` per scene for several.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Runs `arbor farm slurm`: check, load, see what is left to do, then
/// print (`--dry-run`) or submit the jobs.
pub fn run(args: SlurmArgs) -> anyhow::Result<()> {
    let output = check_args(&args)?;
    let manifest = load_scenes(&args.scenes, args.tiles, &output)?;
    let arbor = std::env::current_exe().context("finding the arbor executable")?;
    let plan = plan(&manifest)?;
    if plan.todo.is_empty() && plan.active.is_empty() && plan.pictures_done {
        println!(
            "{}: complete ({} tiles done, merged); nothing to submit",
            output.display(),
            plan.total
        );
        return Ok(());
    }
    let scripts = Scripts::new(&manifest, &args, &arbor, &plan);
    if args.dry_run {
        print_dry_run(&plan, &scripts);
        return Ok(());
    }
    create_folders(&manifest)?;
    write_text(&Manifest::path(&output), &manifest.to_text())?;
    let submitted_at = SystemTime::now();
    let merge_id = submit(&manifest, &plan, &scripts)?;
    if args.wait {
        wait_for_merge(&manifest, &merge_id, submitted_at)?;
    }
    Ok(())
}

/// Checks the flags and the output, before any scene is loaded; returns
/// the output as an absolute path.
fn check_args(args: &SlurmArgs) -> anyhow::Result<PathBuf> {
    if args.tiles == 0 {
        return Err(InputError("--tiles must be at least 1".into()).into());
    }
    if args.cpus_per_task == 0 {
        return Err(InputError("--cpus-per-task must be at least 1".into()).into());
    }
    let output = absolute(&args.output)?;
    let sequence = args.scenes.len() > 1;
    let is_picture = ImageFormat::from_path(&output).is_ok();
    if !sequence && !is_picture {
        return Err(InputError(format!(
            "{}: with one scene, -o names the picture: a .png or .exr file",
            output.display()
        ))
        .into());
    }
    if sequence && is_picture {
        return Err(InputError(format!(
            "{}: with several scenes, -o names a folder (it receives STEM.png per scene)",
            output.display()
        ))
        .into());
    }
    // The farm creates the folders it needs (the parts folder goes beside
    // the output).
    crate::output::check_creatable(&output, sequence, "-o")?;
    crate::output::check_creatable(&parts_dir(&output), true, "the parts folder")?;
    Ok(output)
}

/// What is left to do for a manifest, given the parts on disk and the
/// queue.
struct Plan {
    /// Task indices (scene x tiles + tile) to submit.
    todo: Vec<u32>,
    /// Tiles done and in all.
    done: usize,
    total: usize,
    /// Parts on disk that belong to another scene or cut.
    stale: usize,
    /// Task indices of earlier submissions still queued or running.
    active: HashSet<u32>,
    /// Their queue entries (the new merge waits for them too).
    active_tasks: Vec<super::QueueEntry>,
    /// Merge jobs of earlier submissions still queued.
    old_merges: HashSet<String>,
    /// Whether every picture exists.
    pictures_done: bool,
    /// This cluster's `MaxArraySize`, if it says.
    max_array_size: Option<u32>,
}

/// Reads the previous manifest, the recorded jobs and the queue, and the
/// state of every part.
fn plan(manifest: &Manifest) -> anyhow::Result<Plan> {
    let output = &manifest.output;
    let previous = std::fs::read_to_string(Manifest::path(output))
        .ok()
        .and_then(|t| Manifest::parse(&t));

    // What the queue still holds from earlier submissions for this output.
    let jobs = recorded_jobs(output);
    let queue = squeue().unwrap_or_default();
    let in_queue = |kind: &str| -> Vec<super::QueueEntry> {
        queue
            .iter()
            .filter(|e| jobs.iter().any(|j| j.kind == kind && j.id == e.job))
            .cloned()
            .collect()
    };
    let active_tasks = in_queue("render");
    let old_merges: HashSet<String> = in_queue("merge").into_iter().map(|e| e.job).collect();
    // Array indices only mean the same tiles under the same manifest.
    let same_layout = previous.as_ref().is_some_and(|p| {
        p.tiles == manifest.tiles
            && p.scenes.len() == manifest.scenes.len()
            && p.scenes
                .iter()
                .zip(&manifest.scenes)
                .all(|(a, b)| a.2 == b.2)
    });
    if !active_tasks.is_empty() && !same_layout {
        let ids: HashSet<&str> = active_tasks.iter().map(|e| e.job.as_str()).collect();
        return Err(InputError(format!(
            "{}: render tasks of a submission with other scenes or tile count are still queued or running (job {}); wait for them or scancel them",
            output.display(),
            ids.into_iter().collect::<Vec<_>>().join(", ")
        ))
        .into());
    }
    let active: HashSet<u32> = render_tasks(&jobs, &queue)
        .into_iter()
        .map(|(index, _)| index)
        .collect();

    let n = manifest.tiles;
    let mut todo = Vec::new();
    let (mut done, mut stale) = (0usize, 0usize);
    for s in 0..manifest.scenes.len() {
        for k in 0..n {
            let index = s as u32 * n + k;
            match manifest.part_state(s, k) {
                PartState::Done => done += 1,
                state => {
                    stale += (state == PartState::Stale) as usize;
                    if !active.contains(&index) {
                        todo.push(index);
                    }
                }
            }
        }
    }
    // Slurm refuses array task ids at or above MaxArraySize (with a terse
    // "Invalid job array specification").
    let max_array_size = max_array_size();
    if max_array_size == Some(0) {
        return Err(InputError(format!(
            "{}: this cluster's MaxArraySize is 0: job arrays are disabled, and the render tasks need one",
            output.display()
        ))
        .into());
    }
    Ok(Plan {
        todo,
        done,
        total: manifest.scenes.len() * n as usize,
        stale,
        active,
        active_tasks,
        old_merges,
        pictures_done: (0..manifest.scenes.len()).all(|s| manifest.picture(s).exists()),
        max_array_size,
    })
}

/// The job scripts of a submission: one render array per window of
/// `MaxArraySize` task indices (each shifted by an offset that its script
/// adds back), and the merge.
struct Scripts {
    /// Script path, text, offset and array task ids.
    renders: Vec<(PathBuf, String, u32, Vec<u32>)>,
    merge: (PathBuf, String),
}

impl Scripts {
    fn new(m: &Manifest, args: &SlurmArgs, arbor: &Path, plan: &Plan) -> Scripts {
        let parts = parts_dir(&m.output);
        let renders = array_batches(&plan.todo, plan.max_array_size)
            .into_iter()
            .map(|(offset, ids)| {
                let name = match offset {
                    0 => "render.sbatch".to_string(),
                    o => format!("render-{o}.sbatch"),
                };
                let script = render_script(m, args, arbor, offset, &ids);
                (parts.join(name), script, offset, ids)
            })
            .collect();
        let merge = (parts.join("merge.sbatch"), merge_script(m, args, arbor));
        Scripts { renders, merge }
    }
}

/// `--dry-run`: the scripts and what would be submitted.
fn print_dry_run(plan: &Plan, scripts: &Scripts) {
    for (path, script, _, _) in &scripts.renders {
        println!("# {}", path.display());
        println!("{script}");
    }
    println!("# {}", scripts.merge.0.display());
    println!("{}", scripts.merge.1);
    let todo = &plan.todo;
    println!(
        "# dry run: would submit {} (array {}{}), {} of {} tiles done, {} queued or running; then the merge job",
        crate::render::plural(todo.len() as u64, "render task", "render tasks"),
        if todo.is_empty() { "-".into() } else { index_list(todo) },
        if scripts.renders.len() > 1 {
            format!(
                "; {} array jobs, as MaxArraySize is {}",
                scripts.renders.len(),
                plan.max_array_size.unwrap_or_default()
            )
        } else {
            String::new()
        },
        plan.done,
        plan.total,
        plan.active.len()
    );
}

/// The parts folder with its logs and a folder per scene, and for a
/// sequence the output folder.
fn create_folders(m: &Manifest) -> anyhow::Result<()> {
    let parts = parts_dir(&m.output);
    let create = |dir: &Path| {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("{}: cannot create the folder: {e}", dir.display()))
    };
    create(&parts.join("logs"))?;
    for (_, stem, _) in &m.scenes {
        create(&parts.join(stem))?;
    }
    if m.is_sequence() {
        create(&m.output)?;
    }
    Ok(())
}

/// Submits the render arrays, then the merge job depending on them and on
/// the earlier tasks still queued; returns the merge job's id.
fn submit(m: &Manifest, plan: &Plan, scripts: &Scripts) -> anyhow::Result<String> {
    let output = &m.output;
    // A merge from an earlier run is replaced: it may wait forever on a
    // cancelled task, or run before the tiles submitted now.
    for id in &plan.old_merges {
        let _ = Command::new("scancel").arg(id).status();
    }
    let mut dependency: Vec<String> = Vec::new();
    for e in &plan.active_tasks {
        if let Some(t) = e.task {
            dependency.push(format!("{}_{t}", e.job));
        }
    }
    for (k, (path, script, offset, ids)) in scripts.renders.iter().enumerate() {
        write_text(path, script)?;
        let id = sbatch(&[], path)?;
        record_job(output, "render", &id, *offset)?;
        println!(
            "submitted render job {id}: {}, array {}{} ({} of {} tiles already done{})",
            crate::render::plural(ids.len() as u64, "task", "tasks"),
            index_list(ids),
            if *offset > 0 {
                format!(" + {offset}")
            } else {
                String::new()
            },
            plan.done,
            plan.total,
            if plan.stale > 0 {
                format!(
                    ", {} to redo",
                    crate::render::plural(plan.stale as u64, "stale part", "stale parts")
                )
            } else {
                String::new()
            }
        );
        dependency.insert(k, id);
    }
    if !plan.active.is_empty() {
        println!(
            "{} of earlier submissions still queued or running: not resubmitted",
            crate::render::plural(plan.active.len() as u64, "task", "tasks")
        );
    }
    let (path, script) = &scripts.merge;
    write_text(path, script)?;
    let dep_arg = format!("--dependency=afterok:{}", dependency.join(":"));
    let extra: Vec<&str> = if dependency.is_empty() {
        vec![]
    } else {
        vec![dep_arg.as_str()]
    };
    let merge_id = sbatch(&extra, path)?;
    record_job(output, "merge", &merge_id, 0)?;
    println!(
        "submitted merge job {merge_id}; parts in {}; progress: arbor farm status {}",
        parts_dir(output).display(),
        output.display()
    );
    Ok(merge_id)
}

/// Loads every scene (checking it, and that it has at least `tiles` rows)
/// and builds the manifest with their hashes.
fn load_scenes(scenes: &[PathBuf], tiles: u32, output: &Path) -> anyhow::Result<Manifest> {
    let mut out = Vec::new();
    let mut stems = HashSet::new();
    for path in scenes {
        let abs = path
            .canonicalize()
            .map_err(|e| InputError(format!("{}: cannot read scene file: {e}", path.display())))?;
        // The same loader as `arbor render`, so the hash is the tasks' own.
        let options = arbor::render::RenderOptions::default();
        let scene = load_input(Some(&abs), ReadAs::Render(&options), true)?.into_scene()?;
        if tiles > scene.height {
            return Err(InputError(format!(
                "{}: --tiles {tiles}: the image has {} rows; at most {} tiles",
                path.display(),
                scene.height,
                scene.height
            ))
            .into());
        }
        let stem = abs
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if stem.is_empty() || stem.contains(char::is_whitespace) {
            return Err(InputError(format!(
                "{}: a farm scene needs a file name without spaces",
                path.display()
            ))
            .into());
        }
        if !stems.insert(stem.clone()) {
            return Err(InputError(format!(
                "{}: another scene has the same name `{stem}`; the pictures would collide",
                path.display()
            ))
            .into());
        }
        let hash = arbor::partial::hash_hex(&arbor::partial::scene_hash(&scene));
        out.push((hash, stem, abs));
    }
    Ok(Manifest {
        tiles,
        output: output.to_path_buf(),
        scenes: out,
    })
}

fn absolute(path: &Path) -> anyhow::Result<PathBuf> {
    if path.is_absolute() {
        return Ok(path.to_path_buf());
    }
    Ok(std::env::current_dir()
        .context("finding the current directory")?
        .join(path))
}

/// Quotes `s` for bash (single quotes).
fn q(s: impl AsRef<std::ffi::OsStr>) -> String {
    format!("'{}'", s.as_ref().to_string_lossy().replace('\'', r"'\''"))
}

/// The `#SBATCH` lines every job gets: partition, time, account, QOS,
/// memory, generic resources, constraint and the `--sbatch-arg`s.
fn common_options(s: &mut String, args: &SlurmArgs) {
    let named = [
        ("partition", &args.partition),
        ("time", &args.time),
        ("account", &args.account),
        ("qos", &args.qos),
        ("mem", &args.mem),
        ("gres", &args.gres),
        ("constraint", &args.constraint),
    ];
    for (name, value) in named {
        if let Some(v) = value {
            let _ = writeln!(s, "#SBATCH --{name}={v}");
        }
    }
    for arg in &args.sbatch_args {
        let _ = writeln!(s, "#SBATCH {arg}");
    }
}

/// A value for an `#SBATCH` line (for clap): one line, not empty.
fn parse_option_value(text: &str) -> Result<String, String> {
    if text.trim().is_empty() || text.contains(['\n', '\r']) {
        return Err(format!("`{text}`: expected a value on one line"));
    }
    Ok(text.to_string())
}

/// An `--sbatch-arg` (for clap): one sbatch option on one line.
fn parse_sbatch_arg(text: &str) -> Result<String, String> {
    let text = parse_option_value(text)?;
    if !text.starts_with('-') {
        return Err(format!(
            "`{text}`: expected an sbatch option, e.g. --sbatch-arg=--mail-type=END"
        ));
    }
    Ok(text)
}

/// The array job: task `i` renders tile `i mod N` of scene `i div N`.
/// The render array script for the task indices `offset + ids`.
fn render_script(m: &Manifest, args: &SlurmArgs, arbor: &Path, offset: u32, ids: &[u32]) -> String {
    let parts = parts_dir(&m.output);
    let mut s = String::from("#!/bin/bash\n# arbor farm: render tasks, one per tile and scene (task i = array task id + offset;\n# tile i mod N of scene i div N).\n");
    let _ = writeln!(s, "#SBATCH --job-name=arbor-render");
    let _ = writeln!(s, "#SBATCH --array={}", index_list(ids));
    let _ = writeln!(s, "#SBATCH --requeue");
    let _ = writeln!(s, "#SBATCH --cpus-per-task={}", args.cpus_per_task);
    let _ = writeln!(
        s,
        "#SBATCH --output={}",
        parts.join("logs/render-%A_%a.out").display()
    );
    common_options(&mut s, args);
    let _ = writeln!(s, "set -eu\ntiles={}", m.tiles);
    let scenes: Vec<String> = m.scenes.iter().map(|x| q(&x.2)).collect();
    let dirs: Vec<String> = m.scenes.iter().map(|x| q(parts.join(&x.1))).collect();
    let _ = writeln!(s, "scenes=({})", scenes.join(" "));
    let _ = writeln!(s, "parts=({})", dirs.join(" "));
    let width = (m.tiles - 1).max(1).to_string().len();
    let _ = writeln!(
        s,
        "i=$((SLURM_ARRAY_TASK_ID + {offset}))\nscene=$((i / tiles))\nk=$((i % tiles))\npart=\"${{parts[$scene]}}/$(printf 'tile-%0{width}d-of-%d.part' \"$k\" \"$tiles\")\""
    );
    let _ = writeln!(
        s,
        "exec {} render \"${{scenes[$scene]}}\" --tile \"$k/$tiles\" --threads {} --accel {} --quiet --stats -o \"$part\"",
        q(arbor),
        args.cpus_per_task,
        args.accel
    );
    s
}

/// The merge job: every scene's parts, listed by name so that a missing
/// one is reported by name.
fn merge_script(m: &Manifest, args: &SlurmArgs, arbor: &Path) -> String {
    let parts = parts_dir(&m.output);
    let mut s = String::from("#!/bin/bash\n# arbor farm: merge the parts of each scene.\n");
    let _ = writeln!(s, "#SBATCH --job-name=arbor-merge");
    let _ = writeln!(
        s,
        "#SBATCH --output={}",
        parts.join("logs/merge-%j.out").display()
    );
    common_options(&mut s, args);
    let _ = writeln!(s, "status=0");
    for (i, _) in m.scenes.iter().enumerate() {
        let files: Vec<String> = (0..m.tiles).map(|k| q(m.part(i, k))).collect();
        let _ = writeln!(
            s,
            "{} merge {} -o {} || status=2",
            q(arbor),
            files.join(" "),
            q(m.picture(i))
        );
    }
    let _ = writeln!(s, "exit $status");
    s
}

/// Appends `KIND ID` (and ` +OFFSET` for a shifted render array) to
/// `OUT.parts/jobs.txt` (see [`super::RecordedJob`]).
fn record_job(output: &Path, kind: &str, id: &str, offset: u32) -> anyhow::Result<()> {
    use std::io::Write;
    let path = parts_dir(output).join("jobs.txt");
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    let shift = if offset > 0 {
        format!(" +{offset}")
    } else {
        String::new()
    };
    writeln!(f, "{kind} {id}{shift}").with_context(|| format!("{}: cannot write", path.display()))
}

/// Submits `script`; returns the job id.
fn sbatch(extra: &[&str], script: &Path) -> anyhow::Result<String> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(extra)
        .arg(script)
        .output()
        .map_err(|e| anyhow::anyhow!("cannot run sbatch (is Slurm installed here?): {e}"))?;
    if !out.status.success() {
        anyhow::bail!(
            "sbatch {} failed: {}",
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        anyhow::bail!("sbatch printed no job id: {}", text.trim());
    }
    Ok(id)
}

/// Polls the queue until the merge job has left it, then checks that it
/// wrote every picture. A merge that can never start (a render task failed
/// or was cancelled) is reported with the tiles that are missing.
fn wait_for_merge(m: &Manifest, merge_id: &str, since: SystemTime) -> anyhow::Result<()> {
    let poll = std::env::var("ARBOR_FARM_POLL_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2000);
    loop {
        let Some(queue) = squeue() else {
            anyhow::bail!("--wait: squeue failed; cannot follow job {merge_id}");
        };
        let Some(entry) = queue.iter().find(|e| e.job == merge_id) else {
            break;
        };
        if entry.reason.contains("DependencyNeverSatisfied") {
            let _ = Command::new("scancel").arg(merge_id).status();
            anyhow::bail!(
                "merge job {merge_id} cannot run: a render task failed or was cancelled; {}; run the same command again to resubmit them",
                missing_summary(m)
            );
        }
        std::thread::sleep(Duration::from_millis(poll));
    }
    for s in 0..m.scenes.len() {
        let picture = m.picture(s);
        let fresh = std::fs::metadata(&picture)
            .and_then(|md| md.modified())
            .is_ok_and(|t| t >= since - Duration::from_secs(2));
        if !fresh {
            anyhow::bail!(
                "merge job {merge_id} did not write {} ({}); see {}",
                picture.display(),
                missing_summary(m),
                parts_dir(&m.output)
                    .join(format!("logs/merge-{merge_id}.out"))
                    .display()
            );
        }
    }
    println!("merged: {}", m.output.display());
    Ok(())
}

/// `missing tiles: a 3, 5; b 0` or `all tiles done`.
pub fn missing_summary(m: &Manifest) -> String {
    let mut lines = Vec::new();
    for (s, (_, stem, _)) in m.scenes.iter().enumerate() {
        let missing: Vec<String> = (0..m.tiles)
            .filter(|&k| m.part_state(s, k) != PartState::Done)
            .map(|k| k.to_string())
            .collect();
        if !missing.is_empty() {
            lines.push(format!("{stem} {}", missing.join(", ")));
        }
    }
    if lines.is_empty() {
        "all tiles done".into()
    } else {
        format!("missing tiles: {}", lines.join("; "))
    }
}
