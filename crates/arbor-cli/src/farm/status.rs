//! `arbor farm status OUT`: per scene, the tiles done (valid parts on
//! disk), queued or running (from `squeue`, when there is one), and
//! missing; and whether the picture has been merged.

use std::collections::HashMap;
use std::path::PathBuf;

use clap::Args;

use super::{index_list, recorded_jobs, render_tasks, squeue, Manifest, PartState};
use crate::InputError;

/// Arguments of `arbor farm status`.
#[derive(Args, Debug)]
pub struct StatusArgs {
    /// The output given to `arbor farm slurm -o`.
    pub output: PathBuf,
}

/// Runs `arbor farm status`.
pub fn run(args: StatusArgs) -> anyhow::Result<()> {
    let output = if args.output.is_absolute() {
        args.output.clone()
    } else {
        std::env::current_dir()?.join(&args.output)
    };
    let path = Manifest::path(&output);
    let text = std::fs::read_to_string(&path).map_err(|_| {
        InputError(format!(
            "{}: no farm render here (no {})",
            args.output.display(),
            path.display()
        ))
    })?;
    let m = Manifest::parse(&text)
        .ok_or_else(|| InputError(format!("{}: not a farm manifest", path.display())))?;
    let jobs = recorded_jobs(&output);
    let queue = squeue();
    // State of each task index among our render jobs, newest job last so
    // that it wins.
    let mut tasks: HashMap<u32, String> = HashMap::new();
    let mut merge_state = None;
    if let Some(queue) = &queue {
        for (index, e) in render_tasks(&jobs, queue) {
            tasks.insert(index, e.state.clone());
        }
        for job in jobs.iter().filter(|j| j.kind == "merge") {
            for e in queue.iter().filter(|e| e.job == job.id) {
                merge_state = Some(format!("merge job {}: {} ({})", job.id, e.state, e.reason));
            }
        }
    }
    let mut all_done = true;
    for (s, (_, stem, scene)) in m.scenes.iter().enumerate() {
        let (mut done, mut running, mut queued, mut missing, mut stale) =
            (0, Vec::new(), Vec::new(), Vec::new(), 0);
        for k in 0..m.tiles {
            let state = m.part_state(s, k);
            if state == PartState::Done {
                done += 1;
                continue;
            }
            stale += (state == PartState::Stale) as u32;
            match tasks.get(&(s as u32 * m.tiles + k)).map(String::as_str) {
                Some("RUNNING") | Some("COMPLETING") => running.push(k),
                Some(_) => queued.push(k),
                None => missing.push(k),
            }
        }
        all_done &= done == m.tiles;
        let picture = m.picture(s);
        println!(
            "{stem} ({}): {done}/{} tiles done, {} running{}, {} queued{}, {} missing{}{}; picture {}",
            scene.display(),
            m.tiles,
            running.len(),
            list(&running),
            queued.len(),
            list(&queued),
            missing.len(),
            list(&missing),
            if stale > 0 {
                format!(" ({stale} stale parts)")
            } else {
                String::new()
            },
            if picture.exists() {
                format!("{} written", picture.display())
            } else {
                "not merged yet".into()
            }
        );
    }
    match (&queue, merge_state) {
        (None, _) => println!("(squeue unavailable: queued and running tasks are not shown)"),
        (Some(_), Some(state)) => println!("{state}"),
        (Some(_), None) if !all_done => {
            println!("no job of this render is in the queue: run the same `arbor farm slurm` command again to submit the missing tiles")
        }
        _ => {}
    }
    Ok(())
}

fn list(tiles: &[u32]) -> String {
    if tiles.is_empty() {
        String::new()
    } else {
        format!(" [{}]", index_list(tiles))
    }
}
