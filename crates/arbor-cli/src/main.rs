//! The `arbor` command: a thin layer over the `arbor` and `arbor-accel`
//! libraries. Exit status 0 on success, 2 on bad input or usage, 1 on other
//! failures.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod trace;

/// arbor: a ray tracer built around transformations and acceleration structures.
#[derive(Parser, Debug)]
#[command(name = "arbor", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Trace a batch of rays against a triangle mesh (the ray/hit file interface).
    Trace(trace::TraceArgs),
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Trace(args) => trace::run(args),
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
