//! The `--accel` value of every subcommand: one parser, so every command
//! accepts the same names and reports a wrong one the same way.

use arbor_accel::{AccelKind, UnknownAccel};

/// Parses an accelerator name (`list`, `bvh-wide`, ...); the error lists the
/// names there are.
pub fn parse(name: &str) -> Result<AccelKind, UnknownAccel> {
    name.parse()
}
