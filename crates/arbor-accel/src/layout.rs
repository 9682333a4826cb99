//! What a built structure looks like, for drawing it and for naming the
//! nodes a [`crate::counters::Recorder`] saw: per node its box, depth, children and
//! primitive count (the k-d tree's split too), or the grid's cells.

use crate::aabb::Aabb;
use glam::Vec3;

/// One node of a tree, as drawn (by default: an empty box at the root's
/// depth, no children, no primitives).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayoutNode {
    /// The node's box (a k-d tree node: its region of space).
    pub bounds: Aabb,
    /// Depth below the root (root = 0).
    pub depth: u32,
    /// Children, as indices into the same list (none for a leaf).
    pub children: Vec<u32>,
    /// Primitives a leaf holds (0 for interior nodes).
    pub primitives: u32,
    /// A k-d tree interior node's split: axis (0, 1, 2) and plane position.
    pub split: Option<(u8, f32)>,
}

/// A uniform grid, as drawn: its cells and which of them hold primitives.
#[derive(Clone, Debug, PartialEq)]
pub struct GridLayout {
    /// The grid's box.
    pub bounds: Aabb,
    /// Cells along x, y and z.
    pub resolution: [u32; 3],
    /// Cell boundaries per axis (`resolution + 1` values).
    pub planes: [Vec<f32>; 3],
    /// Indices `x + nx * (y + ny * z)` of the cells holding primitives.
    pub occupied: Vec<u32>,
}

impl GridLayout {
    /// Size of a cell (the grid's extent over its resolution).
    pub fn cell_size(&self) -> Vec3 {
        let r = self.resolution;
        self.bounds.extent() / Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
    }

    /// The box of cell `c` (`x + nx * (y + ny * z)`), exactly as traversal
    /// bounds it.
    pub fn cell_box(&self, c: u32) -> Aabb {
        let [nx, ny, _] = self.resolution;
        let at = [c % nx, (c / nx) % ny, c / (nx * ny)];
        let min = Vec3::from_array(std::array::from_fn(|a| self.planes[a][at[a] as usize]));
        let max = Vec3::from_array(std::array::from_fn(|a| self.planes[a][at[a] as usize + 1]));
        Aabb::new(min, max)
    }
}

/// A built structure's shape, in the numbering its traversal reports.
#[derive(Clone, Debug, PartialEq)]
pub enum Layout {
    /// Brute force: no nodes.
    List,
    /// A BVH, the wide BVH or the k-d tree: its nodes, root first.
    Tree {
        /// The nodes; a visit's [`Layout::index`] points into this list.
        nodes: Vec<LayoutNode>,
        /// The wide BVH's leaves: traversal numbers them `leaf_base +
        /// first primitive slot`; this lists those slots, ascending, and
        /// leaf `k` of it is node `leaf_base + k`. Empty for binary trees.
        leaf_slots: Vec<u32>,
        /// Number of 8-wide nodes (the first leaf's index); 0 otherwise.
        leaf_base: u32,
    },
    /// The uniform grid.
    Grid(GridLayout),
}

impl Layout {
    /// The index into [`Layout::Tree`]'s `nodes` (or the cell index) of the
    /// node traversal reported as `number` ([`crate::counters::Visit::node`]); the
    /// same number except for the wide BVH's leaves.
    pub fn index(&self, number: u32) -> u32 {
        match self {
            Layout::Tree {
                leaf_slots,
                leaf_base,
                ..
            } if !leaf_slots.is_empty() && number >= *leaf_base => {
                let slot = number - leaf_base;
                let k = leaf_slots.partition_point(|&s| s < slot);
                debug_assert_eq!(leaf_slots.get(k), Some(&slot), "not a leaf's first slot");
                leaf_base + k as u32
            }
            _ => number,
        }
    }

    /// The box of the node or cell at `index` (see [`Layout::index`]).
    pub fn bounds(&self, index: u32) -> Option<Aabb> {
        match self {
            Layout::List => None,
            Layout::Tree { nodes, .. } => nodes.get(index as usize).map(|n| n.bounds),
            Layout::Grid(g) => {
                let cells: u32 = g.resolution.iter().product();
                (index < cells).then(|| g.cell_box(index))
            }
        }
    }
}
