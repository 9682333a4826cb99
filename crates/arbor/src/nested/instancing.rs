//! `--instancing flat|nested|auto`: how a scene's references are traced.

use crate::census::Census;
use crate::scene::Scene;

/// `auto`'s threshold: a scene placing at most this many copies of shared
/// geometry is traced flat (today's two levels, exactly: pictures, stats
/// and heatmaps unchanged); above it, nested. Chosen by measurement
/// (docs/acceleration.md): on the deep field flat is faster at 10^4
/// copies, nested faster and 18x smaller at 10^6.
pub const AUTO_FLAT_AT_MOST: u64 = 1 << 16;

/// How references are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Instancing {
    /// Every chain of references composed down to one placement per copy
    /// (two levels; memory follows the copies).
    Flat,
    /// Every shared definition its own level, built once.
    Nested,
    /// Flat for a scene of at most [`AUTO_FLAT_AT_MOST`] copies, else nested.
    #[default]
    Auto,
}

/// What [`Instancing::plan`] chose for a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The flat tracer.
    Flat,
    /// The nested tracer, flattening subtrees of at most this many copies
    /// ([`crate::nested::build`]).
    Nested {
        /// The subtree size flattened into its parent's level (1: nested
        /// throughout; every plan uses it so far, see [`AUTO_FLAT_AT_MOST`]).
        flatten_at_most: u64,
    },
}

impl Instancing {
    /// The tracer for `scene`. `auto` counts the scene's placements over
    /// the DAG (linear in its size); a scene the census refuses goes flat,
    /// whose own checks then report it as they always did.
    pub fn plan(self, scene: &Scene) -> Plan {
        let nested = |flatten_at_most| Plan::Nested { flatten_at_most };
        match self {
            Instancing::Flat => Plan::Flat,
            Instancing::Nested => nested(1),
            Instancing::Auto => match Census::new(&scene.surfaces, scene.variant) {
                Ok(c) if c.placements > u128::from(AUTO_FLAT_AT_MOST) => nested(1),
                _ => Plan::Flat,
            },
        }
    }
}

impl std::str::FromStr for Instancing {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "flat" => Ok(Instancing::Flat),
            "nested" => Ok(Instancing::Nested),
            "auto" => Ok(Instancing::Auto),
            _ => Err(format!(
                "unknown instancing '{s}'; expected flat, nested or auto"
            )),
        }
    }
}

impl std::fmt::Display for Instancing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Instancing::Flat => "flat",
            Instancing::Nested => "nested",
            Instancing::Auto => "auto",
        })
    }
}
