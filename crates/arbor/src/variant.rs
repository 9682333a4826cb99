//! The format variant a scene follows, at the bottom of the crate because
//! surfaces (the sphere's hit rule) and the film (its byte conversion) depend
//! on it as much as the scene does.

/// Which edition of the Cornell course's conventions a scene follows
/// (`docs/cornell-scene-format.md` §1). They differ in camera model, light
/// falloff, shading details, recursion limits and output conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// The Fall 2010 framework (no `type` on `<camera>`).
    Cornell2010,
    /// The Fall 2015 framework (typed cameras and lights, exposure, ...).
    Cornell2015,
}
