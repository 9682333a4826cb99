//! Morton codes: points quantised in their bounding box, with the bits of
//! the three coordinates interleaved, so that sorting by code walks space
//! along a Z-order curve (near codes, near points). PLOC sorts primitives
//! by them; the batch point queries answer their points in that order, so
//! that consecutive queries visit the same nodes and triangles while they
//! are still in cache.

use glam::Vec3;
use rayon::prelude::*;

use crate::aabb::Aabb;

/// Cells per axis, less one: 21 bits a coordinate fill 63 bits.
const CELLS: f32 = 2_097_151.0;

/// Quantises points of `bounds` to the code grid.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MortonGrid {
    min: Vec3,
    scale: Vec3,
}

impl MortonGrid {
    /// The grid over `bounds` (an axis of zero extent quantises to 0).
    pub(crate) fn new(bounds: &Aabb) -> Self {
        let extent = bounds.max - bounds.min;
        MortonGrid {
            min: bounds.min,
            scale: Vec3::select(
                extent.cmpgt(Vec3::ZERO),
                Vec3::splat(CELLS) / extent,
                Vec3::ZERO,
            ),
        }
    }

    /// The code of `p` (points outside the box clamp to its faces; NaN
    /// coordinates quantise to 0).
    #[inline]
    pub(crate) fn code(&self, p: Vec3) -> u64 {
        let q = ((p - self.min) * self.scale).clamp(Vec3::ZERO, Vec3::splat(CELLS));
        spread(q.x as u64) | spread(q.y as u64) << 1 | spread(q.z as u64) << 2
    }
}

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The indices of `points` sorted by Morton code over the finite points'
/// box (ties, and non-finite points, by index: the order is deterministic).
pub(crate) fn order(points: &[Vec3]) -> Vec<u32> {
    let bounds = points
        .iter()
        .filter(|p| p.is_finite())
        .fold(Aabb::EMPTY, |b, &p| b.grow(p));
    let grid = MortonGrid::new(&bounds);
    let mut keyed: Vec<(u64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, &p)| (grid.code(p), i as u32))
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// `answer(i)` for every index of `points`, computed in parallel in
/// Morton order of the points and returned in the points' own order.
pub(crate) fn answer_in_order<T: Copy + Send + Sync>(
    points: &[Vec3],
    per_task: usize,
    answer: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    answer_in_order_carrying(points, per_task, || (), |_, i| answer(i))
}

/// [`answer_in_order`] where each task carries a state from one point to
/// the next in Morton order (a fresh `init()` per task): the answer near
/// the point before, to start the next search from.
pub(crate) fn answer_in_order_carrying<T: Copy + Send + Sync, S>(
    points: &[Vec3],
    per_task: usize,
    init: impl Fn() -> S + Sync + Send,
    answer: impl Fn(&mut S, usize) -> T + Sync + Send,
) -> Vec<T> {
    let order = order(points);
    let answers: Vec<T> = order
        .par_iter()
        .with_min_len(per_task)
        .map_init(&init, |state, &i| answer(state, i as usize))
        .collect();
    let mut rank = vec![0u32; points.len()];
    for (k, &i) in order.iter().enumerate() {
        rank[i as usize] = k as u32;
    }
    rank.par_iter().map(|&k| answers[k as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_moves_bits_to_every_third() {
        assert_eq!(spread(1), 1);
        assert_eq!(spread(2), 8);
        assert_eq!(spread(0x1f_ffff).count_ones(), 21);
    }

    #[test]
    fn order_is_a_permutation_that_groups_near_points() {
        // Two clusters, interleaved in the input: sorted, each is contiguous.
        let points: Vec<Vec3> = (0..64)
            .map(|i| {
                let base = if i % 2 == 0 {
                    Vec3::ZERO
                } else {
                    Vec3::splat(100.0)
                };
                base + Vec3::new((i / 2) as f32 * 0.01, 0.0, 0.0)
            })
            .collect();
        let order = order(&points);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..64).collect::<Vec<u32>>());
        let sides: Vec<bool> = order.iter().map(|&i| i % 2 == 1).collect();
        assert_eq!(sides.windows(2).filter(|w| w[0] != w[1]).count(), 1);
    }

    #[test]
    fn answers_come_back_in_input_order() {
        let points: Vec<Vec3> = (0..1000)
            .map(|i| {
                let z = if i % 97 == 0 { f32::NAN } else { i as f32 };
                Vec3::new(((i * 7919) % 1000) as f32, (i % 13) as f32, z)
            })
            .collect();
        let answers = answer_in_order(&points, 16, |i| i * 3);
        assert_eq!(answers, (0..1000).map(|i| i * 3).collect::<Vec<_>>());
    }
}
