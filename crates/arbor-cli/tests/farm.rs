//! `arbor farm` on a real Slurm cluster (started by `.ci/slurm.sh start`):
//! a scene rendered as 8 tiles by an array job and merged is byte-identical
//! to the same scene rendered in one process; a cancelled task is found and
//! resubmitted alone by re-running the command; a merge lacking a part
//! fails naming it. Without `sbatch` and a cluster answering `sinfo` the
//! Slurm test reports itself skipped, unless `ARBOR_REQUIRE_SLURM=1`.
//! The tests without a scheduler (dry runs, bad input) always run.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const ARBOR: &str = env!("CARGO_BIN_EXE_arbor");

fn scene(light: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<scene>
  <camera><viewPoint>0 0 5</viewPoint><viewDir>0 0 -1</viewDir><projDistance>2</projDistance></camera>
  <image>32 24</image>
  <samples>4</samples>
  <shader name="p" type="Phong"><diffuseColor>.9 .3 .1</diffuseColor><specularColor>1 1 1</specularColor><exponent>40</exponent></shader>
  <surface type="Sphere"><shader ref="p"/><radius>0.7</radius></surface>
  <surface type="Box"><minpt>-3 -2 -2</minpt><maxpt>3 -0.8 0</maxpt><shader type="Lambertian"><diffuseColor>.2 .6 .3</diffuseColor></shader></surface>
  <light><position>{light}</position></light>
</scene>
"#
    )
}

/// Runs a command with a deadline (a stuck scheduler must fail the test,
/// not hang it).
fn run(mut cmd: Command, secs: u64) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let deadline = Instant::now() + Duration::from_secs(secs);
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!(
                "timed out after {secs} s: {cmd:?}\n{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    child.wait_with_output().unwrap()
}

fn arbor(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(ARBOR);
    c.args(args)
        .current_dir(dir)
        .env("ARBOR_FARM_POLL_MS", "250");
    for (k, v) in env {
        c.env(k, v);
    }
    run(c, 300)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn ok(o: Output) -> Output {
    assert!(o.status.success(), "failed: {}", text(&o));
    o
}

fn tool(name: &str, args: &[&str]) -> Output {
    let mut c = Command::new(name);
    c.args(args);
    run(c, 60)
}

fn slurm_answers() -> bool {
    let up = |name: &str, args: &[&str]| {
        Command::new(name)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .output()
            .is_ok_and(|o| o.status.success() && !o.stdout.is_empty())
    };
    up("sbatch", &["--version"]) && up("sinfo", &["-h", "-o", "%T"])
}

/// A folder with scenes `a.xml` and `b.xml` (different lights) and their
/// full renders `a.png`, `b.png` made in one process.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, light) in [("a", "3 4 5"), ("b", "-3 4 5")] {
        fs::write(dir.path().join(format!("{name}.xml")), scene(light)).unwrap();
        ok(arbor(
            dir.path(),
            &[
                "render",
                &format!("{name}.xml"),
                "--quiet",
                "-o",
                &format!("{name}.png"),
            ],
            &[],
        ));
    }
    dir
}

/// Waits until no task of `job` is in the queue.
fn wait_gone(job: &str) {
    let deadline = Instant::now() + Duration::from_secs(180);
    loop {
        let q = tool("squeue", &["-h", "-r", "-o", "%A"]);
        if !String::from_utf8_lossy(&q.stdout)
            .lines()
            .any(|l| l.trim() == job)
        {
            return;
        }
        assert!(Instant::now() < deadline, "job {job} still queued");
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// The option that makes `arbor farm slurm` submit its jobs held: an
/// `#SBATCH --hold` line in both scripts. (Not the `SBATCH_HOLD`
/// environment variable: the sbatch of Debian 12's Slurm 22.05, as in CI,
/// has no such variable and submitted those jobs free to run, so a "held"
/// task could start whenever the node had a CPU free, as it did once when
/// the tests ran in parallel.)
const HOLD: &str = "--sbatch-arg=--hold";

/// Asserts that every queued task of the jobs `ids` is held, so that what
/// a test checks next cannot race with them running.
fn assert_held(ids: &[&str]) {
    if let Some(listed) = not_held(ids) {
        panic!("jobs {ids:?} are not all held:\n{listed}");
    }
}

/// The queue lines of the jobs `ids` when some task of theirs is not held
/// (or none is queued).
fn not_held(ids: &[&str]) -> Option<String> {
    let q = tool("squeue", &["-h", "-r", "-j", &ids.join(","), "-o", "%i %r"]);
    let listed = String::from_utf8_lossy(&q.stdout).into_owned();
    let held = !listed.trim().is_empty() && listed.lines().all(|l| l.ends_with(" JobHeldUser"));
    (!held).then_some(listed)
}

fn jobs(parts: &Path, kind: &str) -> Vec<String> {
    fs::read_to_string(parts.join("jobs.txt"))
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("{kind} ")).map(str::to_string))
        .collect()
}

/// Whether a Slurm cluster answers; without one, the test is skipped with
/// a message, or fails when `ARBOR_REQUIRE_SLURM=1` (as in CI).
fn slurm_or_skip() -> bool {
    if slurm_answers() {
        return true;
    }
    if std::env::var("ARBOR_REQUIRE_SLURM").as_deref() == Ok("1") {
        panic!("ARBOR_REQUIRE_SLURM=1 but no Slurm cluster answers (sbatch, sinfo); start one with .ci/slurm.sh start DIR");
    }
    eprintln!(
        "SKIPPED: no Slurm cluster (sbatch and sinfo); set ARBOR_REQUIRE_SLURM=1 to fail instead"
    );
    false
}

#[test]
fn slurm_tiles_cancel_resume_and_missing_parts() {
    let Some(dir) = slurm_or_skip().then(setup) else {
        return;
    };
    let d = dir.path();

    // 1. One scene, 8 tiles, through Slurm: the same bytes as one process.
    let tiles8 = [
        "farm",
        "slurm",
        "a.xml",
        "--tiles",
        "8",
        "-o",
        "out/a.png",
        "--wait",
    ];
    let o = ok(arbor(d, &tiles8, &[]));
    assert!(text(&o).contains("array 0-7"), "{}", text(&o));
    assert!(fs::read(d.join("out/a.png")).unwrap() == fs::read(d.join("a.png")).unwrap());
    let parts = d.join("out/a.png.parts");
    assert_eq!(fs::read_dir(parts.join("a")).unwrap().count(), 8);
    // Done: running it again submits nothing.
    let o = ok(arbor(
        d,
        &["farm", "slurm", "a.xml", "--tiles", "8", "-o", "out/a.png"],
        &[],
    ));
    assert!(text(&o).contains("nothing to submit"), "{}", text(&o));

    // 2. A merge lacking a part fails naming it, through Slurm too.
    let lost = parts.join("a/tile-3-of-8.part");
    fs::remove_file(&lost).unwrap();
    let mut c = Command::new("sbatch");
    c.args(["--wait", "--parsable"])
        .arg(parts.join("merge.sbatch"));
    let o = run(c, 180);
    assert!(!o.status.success(), "a merge without tile 3 succeeded");
    let id = String::from_utf8_lossy(&o.stdout).trim().to_string();
    let log = fs::read_to_string(parts.join(format!("logs/merge-{id}.out"))).unwrap();
    assert!(
        log.contains("tile-3-of-8.part") && log.contains("missing part"),
        "{log}"
    );
    let o = arbor(
        d,
        &["merge", "out/a.png.parts/a/tile-0-of-8.part", "-o", "x.png"],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("missing tiles 1, 2, 3, 4, 5, 6, 7 of 8"),
        "{}",
        text(&o)
    );
    let o = ok(arbor(d, &["farm", "status", "out/a.png"], &[]));
    assert!(
        text(&o).contains("7/8 tiles done") && text(&o).contains("1 missing [3]"),
        "{}",
        text(&o)
    );
    // The checkpoint: the same command renders only tile 3 again.
    let o = ok(arbor(d, &tiles8, &[]));
    assert!(text(&o).contains("1 task, array 3 "), "{}", text(&o));
    assert!(fs::read(d.join("out/a.png")).unwrap() == fs::read(d.join("a.png")).unwrap());

    // 3. A sequence of two scenes, 4 tiles each, submitted held; one task
    // is cancelled before it runs.
    let seq = [
        "farm", "slurm", "a.xml", "b.xml", "--tiles", "4", "-o", "frames",
    ];
    let mut held = seq.to_vec();
    held.push(HOLD);
    ok(arbor(d, &held, &[]));
    let parts = d.join("frames.parts");
    let render = jobs(&parts, "render").pop().unwrap();
    let merge = jobs(&parts, "merge").pop().unwrap();
    assert_held(&[&render, &merge]);
    // Task 5 is scene b, tile 1.
    assert!(tool("scancel", &[&format!("{render}_5")]).status.success());
    assert!(tool("scontrol", &["release", &render]).status.success());
    assert!(tool("scontrol", &["release", &merge]).status.success());
    wait_gone(&render);
    let o = ok(arbor(d, &["farm", "status", "frames"], &[]));
    let status = text(&o);
    assert!(
        status.contains("a (") && status.contains("4/4 tiles done"),
        "{status}"
    );
    assert!(
        status.contains("3/4 tiles done") && status.contains("1 missing [1]"),
        "{status}"
    );
    assert!(!d.join("frames/b.png").exists());
    // Re-running the same command submits only the cancelled task.
    let mut again = seq.to_vec();
    again.push("--wait");
    let o = ok(arbor(d, &again, &[]));
    assert!(text(&o).contains("1 task, array 5 "), "{}", text(&o));
    for name in ["a", "b"] {
        assert!(
            fs::read(d.join(format!("frames/{name}.png"))).unwrap()
                == fs::read(d.join(format!("{name}.png"))).unwrap(),
            "frame {name} differs from the one-process render"
        );
    }
    // The stale merge job of the first submission is gone from the queue.
    wait_gone(&merge);
}

/// The cluster options reach the jobs Slurm holds: submitted held, the
/// render array and the merge job both carry the account, the memory and
/// an option given through `--sbatch-arg` (this single-node cluster has no
/// QOS, GRES or node features to accept the others, which the dry run
/// checks).
#[test]
fn slurm_jobs_carry_the_cluster_options() {
    let Some(dir) = slurm_or_skip().then(setup) else {
        return;
    };
    let d = dir.path();
    ok(arbor(
        d,
        &[
            "farm",
            "slurm",
            "a.xml",
            "--tiles",
            "2",
            "-o",
            "opt.png",
            "--account",
            "arbor-acct",
            "--mem",
            "1M",
            "--sbatch-arg=--comment=arbor-farm-options",
            HOLD,
        ],
        &[],
    ));
    let parts = d.join("opt.png.parts");
    let ids = [
        jobs(&parts, "render").pop().unwrap(),
        jobs(&parts, "merge").pop().unwrap(),
    ];
    assert_held(&[&ids[0], &ids[1]]);
    for id in &ids {
        let o = tool("scontrol", &["show", "job", id]);
        let shown = text(&o);
        for needle in [
            "Account=arbor-acct",
            "Comment=arbor-farm-options",
            "MinMemoryNode=1M",
        ] {
            assert!(
                shown.contains(needle),
                "job {id}: `{needle}` not in:\n{shown}"
            );
        }
    }
    for id in &ids {
        assert!(tool("scancel", &[id]).status.success());
    }
    for id in &ids {
        wait_gone(id);
    }
}

/// Without a scheduler: `--dry-run` prints both scripts with the array,
/// the requeue flag, the dependency-free merge of every part, and the
/// absolute path of this very binary.
#[test]
fn dry_run_prints_the_scripts() {
    let dir = setup();
    let o = ok(arbor(
        dir.path(),
        &[
            "farm",
            "slurm",
            "a.xml",
            "b.xml",
            "--tiles",
            "3",
            "--partition",
            "gpu",
            "--time",
            "5:00",
            "--account",
            "proj42",
            "--qos",
            "short",
            "--mem",
            "4G",
            "--gres",
            "gpu:1",
            "--constraint",
            "avx2",
            "--sbatch-arg=--mail-type=END",
            "--sbatch-arg",
            "--nice=5",
            "--dry-run",
            "-o",
            "seq",
        ],
        &[],
    ));
    let t = text(&o);
    // Every job (both scripts) gets every cluster option.
    for option in [
        "#SBATCH --partition=gpu\n",
        "#SBATCH --time=5:00\n",
        "#SBATCH --account=proj42\n",
        "#SBATCH --qos=short\n",
        "#SBATCH --mem=4G\n",
        "#SBATCH --gres=gpu:1\n",
        "#SBATCH --constraint=avx2\n",
        "#SBATCH --mail-type=END\n",
        "#SBATCH --nice=5\n",
    ] {
        assert_eq!(t.matches(option).count(), 2, "`{option}` not in both:\n{t}");
    }
    for needle in [
        "#SBATCH --array=0-5",
        "#SBATCH --requeue",
        "#SBATCH --partition=gpu",
        "#SBATCH --time=5:00",
        "--tile \"$k/$tiles\"",
        "seq.parts/b/tile-2-of-3.part",
        "seq/b.png",
        ARBOR,
    ] {
        assert!(t.contains(needle), "`{needle}` not in:\n{t}");
    }
    // A dry run writes nothing.
    assert!(!dir.path().join("seq.parts").exists());
}

#[test]
fn farm_input_errors() {
    let dir = setup();
    let d = dir.path();
    fs::create_dir(d.join("other")).unwrap();
    fs::copy(d.join("a.xml"), d.join("other/a.xml")).unwrap();
    // Each command line as typed (words split at spaces).
    for (args, needle) in [
        ("slurm a.xml --tiles 25 -o x.png --dry-run", "at most 24"),
        ("slurm a.xml --tiles 0 -o x.png --dry-run", "at least 1"),
        ("slurm a.xml --tiles 2 -o x --dry-run", ".png or .exr"),
        ("slurm a.xml b.xml --tiles 2 -o x.png --dry-run", "folder"),
        (
            "slurm a.xml other/a.xml --tiles 2 -o x --dry-run",
            "same name",
        ),
        ("slurm none.xml --tiles 2 -o x.png --dry-run", "none.xml"),
        ("status nowhere.png", "no farm render"),
        (
            "slurm a.xml --tiles 2 -o x.png --sbatch-arg=mail",
            "expected an sbatch option",
        ),
        ("slurm a.xml --tiles 2 -o x.png --account a\nb", "one line"),
        (
            "slurm a.xml --tiles 2 -o a.xml/x.png --dry-run",
            "a.xml is not a folder",
        ),
    ] {
        let mut a = vec!["farm"];
        a.extend(args.split(' '));
        let o = arbor(d, &a, &[]);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {}", text(&o));
        assert!(text(&o).contains(needle), "{a:?}: {}", text(&o));
    }
    let leftovers: Vec<PathBuf> = fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().contains(".parts"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// More render tasks than the cluster's `MaxArraySize` allows array task
/// ids for (sbatch itself would only say "Invalid job array
/// specification"): they go in several arrays, each script adding its
/// offset back, and `farm status` maps the queued tasks to their tiles.
/// Submitted held, checked, then cancelled: running a thousand tasks is
/// not the point.
#[test]
fn tasks_beyond_max_array_size_go_in_several_arrays() {
    if !slurm_or_skip() {
        return;
    }
    let config = tool("scontrol", &["show", "config"]);
    let max: u32 = text(&config)
        .lines()
        .find_map(|l| {
            let (k, v) = l.split_once('=')?;
            (k.trim() == "MaxArraySize").then(|| v.trim().parse().ok())?
        })
        .expect("scontrol show config names MaxArraySize");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 24 tiles (one per row) per scene, enough scenes to pass the limit.
    let count = max / 24 + 1;
    let scenes: Vec<String> = (0..count).map(|i| format!("s{i}.xml")).collect();
    for name in &scenes {
        fs::write(d.join(name), scene("3 4 5")).unwrap();
    }
    let mut args = vec!["farm", "slurm"];
    args.extend(scenes.iter().map(String::as_str));
    args.extend(["--tiles", "24", "-o", "seq", HOLD]);
    let o = ok(arbor(d, &args, &[]));
    let parts = d.join("seq.parts");
    let renders = jobs(&parts, "render");
    let merge = jobs(&parts, "merge").pop().unwrap();
    let cancel_all = || {
        for id in renders.iter().map(|r| r.split(' ').next().unwrap()) {
            tool("scancel", &[id]);
        }
        tool("scancel", &[&merge]);
    };
    let mut ids: Vec<&str> = renders
        .iter()
        .map(|r| r.split(' ').next().unwrap())
        .collect();
    ids.push(&merge);
    if let Some(listed) = not_held(&ids) {
        cancel_all();
        panic!("jobs {ids:?} are not all held:\n{listed}");
    }
    let tasks = count * 24;
    let windows = tasks.div_ceil(max) as usize;
    if renders.len() != windows {
        cancel_all();
        panic!(
            "{} render jobs for {tasks} tasks:\n{}",
            renders.len(),
            text(&o)
        );
    }
    // The second array: ids from 0, shifted by MaxArraySize.
    assert_eq!(
        renders[1].split(' ').nth(1),
        Some(format!("+{max}").as_str())
    );
    let script = fs::read_to_string(parts.join(format!("render-{max}.sbatch"))).unwrap();
    let last = tasks - 1 - max;
    assert!(
        script.contains(&format!("#SBATCH --array=0-{last}\n"))
            && script.contains(&format!("i=$((SLURM_ARRAY_TASK_ID + {max}))")),
        "{script}"
    );
    // Every tile is queued, none missing: the offsets are undone.
    let status = text(&arbor(d, &["farm", "status", "seq"], &[]));
    cancel_all();
    for i in 0..count {
        let line = status
            .lines()
            .find(|l| l.starts_with(&format!("s{i} (")))
            .unwrap_or_else(|| panic!("no line for scene s{i}:\n{status}"));
        assert!(
            line.contains("24 queued") && line.contains("0 missing"),
            "{line}"
        );
    }
    for id in renders
        .iter()
        .map(|r| r.split(' ').next().unwrap().to_string())
    {
        wait_gone(&id);
    }
    wait_gone(&merge);
}
