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

impl Group {
    /// Calls `visit` with each member in order and its matrix: `m`, the
    /// enclosing groups' matrix, times this group's transform. Stops at the
    /// first error, which it returns: how the flattening walks go down
    /// through a group.
    pub fn try_for_each_child<E>(
        &self,
        m: DMat4,
        mut visit: impl FnMut(&Surface, DMat4) -> Result<(), E>,
    ) -> Result<(), E> {
        let m = m * self.transform;
        self.children.iter().try_for_each(|c| visit(c, m))
    }
}
