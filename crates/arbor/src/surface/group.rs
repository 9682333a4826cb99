//! The group: surfaces under a common transformation, nested to any depth.

use glam::DMat4;

use super::Surface;

/// Children sharing a transformation. The transformation composes the
/// group's `<translate>`, `<rotate>` and `<scale>` elements in the order of
/// the format variant (spec §5.5); a child's world matrix is its parents'
/// matrices multiplied down the hierarchy.
#[derive(Clone, Debug)]
pub struct Group {
    /// Object-to-parent matrix.
    pub transform: DMat4,
    /// The members.
    pub children: Vec<Surface>,
}
