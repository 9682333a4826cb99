//! `--instancing flat|nested|auto`: how a scene's references are traced.

use crate::census::Census;
use crate::scene::Scene;

/// `auto` traces flat every scene placing at most this many copies of
/// shared geometry (today's two levels, exactly: pictures, stats and
/// heatmaps of every existing scene unchanged).
pub const AUTO_FLAT_AT_MOST: u64 = 1 << 16;

/// ... and, up to this many copies, every scene whose picture casts at
/// least as many camera rays (pixels times samples) as it places copies;
/// above both, nested. Chosen by measurement (docs/acceleration.md): flat
/// costs a build per copy and about half the nested tracer's work a ray,
/// so at 640x480 it is faster up to some 3 x 10^5 copies (10^5: 0.6 s
/// against 0.8 s) and slower at 5 x 10^5 and beyond; the cap bounds flat's
/// memory near 300 MB.
pub const AUTO_FLAT_FOR_RAYS_AT_MOST: u64 = 1 << 20;

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
    /// Flat for a scene of few copies ([`auto_flat_at_most`]: at most
    /// [`AUTO_FLAT_AT_MOST`], or as many as its camera rays up to
    /// [`AUTO_FLAT_FOR_RAYS_AT_MOST`]), else nested, flattening subtrees
    /// within [`AUTO_FLATTEN_BUDGET`] a level.
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
                Ok(c) if c.placements > u128::from(auto_flat_at_most(scene)) => {
                    nested(AUTO_FLATTEN_BUDGET)
                }
                _ => Plan::Flat,
            },
        }
    }
}

/// The most copies `auto` traces flat in `scene`: [`AUTO_FLAT_AT_MOST`],
/// or its camera rays up to [`AUTO_FLAT_FOR_RAYS_AT_MOST`].
pub fn auto_flat_at_most(scene: &Scene) -> u64 {
    let sps = u64::from(scene.samples_per_side);
    let rays = u64::from(scene.width) * u64::from(scene.height) * sps * sps;
    AUTO_FLAT_AT_MOST.max(rays.min(AUTO_FLAT_FOR_RAYS_AT_MOST))
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
