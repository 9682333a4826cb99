//! The `--accel` value of every subcommand: one parser, so every command
//! accepts the same names and reports a wrong one the same way; and the
//! `--quality` option of the commands that build mesh structures.

use arbor_accel::{AccelKind, BuildQuality, UnknownAccel};

use crate::InputError;

/// `--quality` of `trace`, `inside`, `nearest` and `bench`: one definition,
/// so the option reads and fails the same way in each.
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct QualityArg {
    /// Build quality of the ray structure: fast (default) or high (spatial
    /// splits: a slower build for faster tracing; only bvh-wide and bvh-sah
    /// have it, and `bench --accel all` then means those two).
    #[arg(long, value_name = "Q", default_value = "fast", value_parser = <BuildQuality as std::str::FromStr>::from_str)]
    pub quality: BuildQuality,
}

impl QualityArg {
    /// Whether `kind` can be built at this quality; the error is the
    /// command's one-line input error.
    pub fn check(&self, kind: AccelKind) -> Result<(), InputError> {
        kind.check_quality(self.quality)
            .map_err(|e| InputError(format!("--quality {} {e}", self.quality)))
    }
}

/// Parses an accelerator name (`list`, `bvh-wide`, ...); the error lists the
/// names there are.
pub fn parse(name: &str) -> Result<AccelKind, UnknownAccel> {
    name.parse()
}

/// One item of a list of accelerators (`arbor bench --accel A,B`): a name,
/// or `all`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelChoice {
    /// Every structure except the brute-force `list`.
    All,
    /// One structure.
    One(AccelKind),
}

/// Parses one item of a list: `all` or a name.
pub fn parse_choice(name: &str) -> Result<AccelChoice, String> {
    if name == "all" {
        return Ok(AccelChoice::All);
    }
    parse(name)
        .map(AccelChoice::One)
        .map_err(|e| format!("{e} (or all)"))
}

/// The structures a list names, each once, in the order first named.
pub fn expand(choices: &[AccelChoice]) -> Vec<AccelKind> {
    let mut out = Vec::new();
    for choice in choices {
        let kinds = match choice {
            AccelChoice::All => AccelKind::ALL
                .iter()
                .copied()
                .filter(|&k| k != AccelKind::List)
                .collect(),
            AccelChoice::One(k) => vec![*k],
        };
        for k in kinds {
            if !out.contains(&k) {
                out.push(k);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn list(spec: &str) -> Result<Vec<AccelKind>, String> {
        let choices: Result<Vec<_>, _> = spec.split(',').map(parse_choice).collect();
        Ok(expand(&choices?))
    }

    #[test]
    fn accel_lists() {
        let all = list("all").unwrap();
        assert_eq!(all.len(), AccelKind::ALL.len() - 1);
        assert!(!all.contains(&AccelKind::List));
        assert_eq!(
            list("grid,kdtree,grid").unwrap(),
            vec![AccelKind::Grid, AccelKind::KdTree]
        );
        assert_eq!(list("list,all").unwrap().len(), AccelKind::ALL.len());
        let e = list("grid,octree").unwrap_err();
        assert!(
            e.contains("unknown accelerator 'octree'") && e.contains("or all"),
            "{e}"
        );
        assert!(list("").is_err());
    }
}
