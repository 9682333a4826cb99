//! The limits every stage enforces on its input, at the bottom of the crate
//! so that the loaders, the flattening step, the renderer and the CLI can all
//! name them without importing one another.

/// Largest image side accepted (pixels).
pub const MAX_IMAGE_SIDE: i64 = 65_536;
/// Largest image accepted (pixels in all).
pub const MAX_IMAGE_PIXELS: i64 = 1 << 28;
/// Largest `<samples>` value accepted.
pub const MAX_SAMPLES: i64 = 1 << 16;
/// Deepest group nesting accepted (deeper scenes would exhaust the stack).
pub const MAX_NESTING: usize = 1_000;
/// Default limit on placements of shared geometry.
pub const DEFAULT_MAX_PLACEMENTS: u64 = 1 << 22;
/// The most instance levels (references inside references) the nested
/// tracer follows: each is one frame of a ray's traversal. Deeper scenes
/// are refused when building (a hundred copies per level, 32 levels are
/// 10^64 copies: far more than any picture needs).
pub const MAX_INSTANCE_LEVELS: usize = 32;
