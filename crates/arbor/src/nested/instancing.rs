//! `--instancing flat|nested|auto`: how a scene's references are traced.

use crate::census::Census;
use crate::scene::Scene;

/// `auto`'s threshold: a scene placing at most this many copies of shared
/// geometry is traced flat (today's two levels, exactly: pictures, stats
/// and heatmaps unchanged); above it, nested. Chosen by measurement
/// (docs/acceleration.md): on the deep field flat is faster at 10^4
/// copies, nested faster and 18x smaller at 10^6.
pub const AUTO_FLAT_AT_MOST: u64 = 1 << 16;

/// `auto`'s budget for a nested scene: each level takes in up to this
/// many children from flattened subtrees ([`crate::nested::build`]'s
/// rule). Chosen by measurement (docs/acceleration.md): taking the deep
/// field's 10^4-bunny subtrees into their parents costs 11 % fewer
/// instructions a pixel than nesting them, for 7 MB; 10^6 at a level costs
/// 1 GB.
pub const AUTO_FLATTEN_BUDGET: u64 = 1 << 14;

/// How references are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Instancing {
    /// Every chain of references composed down to one placement per copy
    /// (two levels; memory follows the copies).
    Flat,
    /// Every shared definition that places others its own level, built
    /// once.
    Nested,
    /// Flat for a scene of at most [`AUTO_FLAT_AT_MOST`] copies, else
    /// nested, flattening subtrees within [`AUTO_FLATTEN_BUDGET`] a level.
    #[default]
    Auto,
}

/// What [`Instancing::plan`] chose for a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The flat tracer.
    Flat,
    /// The nested tracer, each level flattening subtrees within a budget.
    Nested {
        /// How many children each level may take in from flattened
        /// subtrees ([`crate::nested::build`]; 1: nested throughout).
        flatten_budget: u64,
    },
}

impl Instancing {
    /// The tracer for `scene`. `auto` counts the scene's placements over
    /// the DAG (linear in its size); a scene the census refuses goes flat,
    /// whose own checks then report it as they always did.
    pub fn plan(self, scene: &Scene) -> Plan {
        let nested = |flatten_budget| Plan::Nested { flatten_budget };
        match self {
            Instancing::Flat => Plan::Flat,
            Instancing::Nested => nested(1),
            Instancing::Auto => match Census::new(&scene.surfaces, scene.variant) {
                Ok(c) if c.placements > u128::from(AUTO_FLAT_AT_MOST) => {
                    nested(AUTO_FLATTEN_BUDGET)
                }
                _ => Plan::Flat,
            },
        }
    }
}

/// The words of `--instancing`.
const NAMES: &[(&str, Instancing)] = &[
    ("flat", Instancing::Flat),
    ("nested", Instancing::Nested),
    ("auto", Instancing::Auto),
];

impl std::str::FromStr for Instancing {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        crate::option_names::parse(s, "instancing", NAMES)
    }
}

impl std::fmt::Display for Instancing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(crate::option_names::name(self, NAMES))
    }
}
