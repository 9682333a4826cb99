//! A mesh's edges by position: vertices welded where their positions are
//! equal (as the ray test sees them: it compares positions, not indices),
//! and each undirected edge with how many triangles use it, each way.

use rayon::prelude::*;

use glam::Vec3;

/// Every use of every edge, sorted so that an edge's uses are neighbours.
pub(crate) struct EdgeUses {
    /// Per use: (smaller welded id << 32 | larger welded id, whether the
    /// triangle runs from the larger to the smaller).
    uses: Vec<(u64, bool)>,
    /// A vertex index at each welded position.
    representative: Vec<u32>,
}

impl EdgeUses {
    /// The edges of `triangles`, by sorting rather than hashing (a million
    /// triangles: 0.65 s hashed, a quarter of that sorted). Edges of zero
    /// length are left out.
    pub(crate) fn of(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        // +0 and -0 are the same point.
        let mut by_position: Vec<([u32; 3], u32)> = (0..vertices.len() as u32)
            .into_par_iter()
            .map(|i| {
                let v = vertices[i as usize] + Vec3::ZERO;
                (v.to_array().map(f32::to_bits), i)
            })
            .collect();
        by_position.par_sort_unstable();
        let mut welded = vec![0u32; vertices.len()];
        let mut representative = Vec::new();
        for (k, &(position, i)) in by_position.iter().enumerate() {
            if k == 0 || by_position[k - 1].0 != position {
                representative.push(i);
            }
            welded[i as usize] = representative.len() as u32 - 1;
        }
        let mut uses: Vec<(u64, bool)> = triangles
            .par_iter()
            .flat_map_iter(|t| {
                let v = t.map(|i| welded[i as usize]);
                [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])]
                    .into_iter()
                    .filter(|(a, b)| a != b)
                    .map(|(a, b)| (u64::from(a.min(b)) << 32 | u64::from(a.max(b)), a > b))
            })
            .collect();
        uses.par_sort_unstable();
        EdgeUses {
            uses,
            representative,
        }
    }

    /// Each edge's uses.
    fn edges(&self) -> impl Iterator<Item = &[(u64, bool)]> {
        self.uses.chunk_by(|x, y| x.0 == y.0)
    }

    /// How many edges are not used exactly twice, once each way.
    pub(crate) fn open(&self) -> usize {
        self.edges()
            .filter(|uses| !matches!(uses, [(_, false), (_, true)]))
            .count()
    }

    /// Two vertex indices of each edge that an odd number of triangles use
    /// (where the parity of a ray's crossings changes as the ray sweeps
    /// across the edge).
    pub(crate) fn odd(&self) -> Vec<[u32; 2]> {
        self.edges()
            .filter(|uses| uses.len() % 2 == 1)
            .map(|uses| {
                let key = uses[0].0;
                [(key >> 32) as u32, key as u32].map(|id| self.representative[id as usize])
            })
            .collect()
    }
}
