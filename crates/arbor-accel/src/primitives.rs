use crate::aabb::Aabb;
use glam::Vec3;

/// The index of a primitive in the set a structure was built over
/// (`0..len()`), as every API that names a primitive takes and returns it.
///
/// `u32`, not `usize`: the structures store one per primitive reference
/// (leaves, the wide BVH's packed triangles, hit files), where 4 bytes
/// instead of 8 halve the memory traversal streams through; builders refuse
/// more than `u32::MAX` primitives.
pub type PrimitiveId = u32;

/// A set of primitives an acceleration structure can index: all it needs is
/// how many there are and their bounding boxes.
///
/// The boxes must enclose everything the caller's exact test can hit, or
/// traversal may skip a hit.
pub trait Primitives: Sync {
    /// Number of primitives; they are identified by index `0..len()`.
    fn len(&self) -> usize;

    /// Whether there are none.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// A box enclosing primitive `index`.
    fn bounds(&self, index: PrimitiveId) -> Aabb;

    /// A box enclosing the part of primitive `index` inside `clip`, or `None`
    /// when no part of it lies inside. Spatial subdivision (grid, k-d tree)
    /// uses this to place primitives only where they really are; the default,
    /// the overlap of the primitive's box with `clip`, is always correct but
    /// looser than an exact clip.
    fn clipped_bounds(&self, index: PrimitiveId, clip: &Aabb) -> Option<Aabb> {
        let b = self.bounds(index).intersection(clip);
        (!b.is_empty()).then_some(b)
    }

    /// The corners of primitive `index` if it is a triangle. Spatial splits
    /// (the SBVH build) then cut the triangle itself; other primitives
    /// (`None`, the default) are cut as their boxes.
    fn corners(&self, index: PrimitiveId) -> Option<[Vec3; 3]> {
        let _ = index;
        None
    }
}

impl Primitives for [Aabb] {
    fn len(&self) -> usize {
        <[Aabb]>::len(self)
    }
    fn bounds(&self, index: PrimitiveId) -> Aabb {
        self[index as usize]
    }
}

impl Primitives for Vec<Aabb> {
    fn len(&self) -> usize {
        <[Aabb]>::len(self)
    }
    fn bounds(&self, index: PrimitiveId) -> Aabb {
        self[index as usize]
    }
}
