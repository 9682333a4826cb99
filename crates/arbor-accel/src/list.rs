//! Brute force: every primitive tested against every ray, the reference
//! every other structure must agree with.

use crate::accel::{AccelStats, Accelerator};
use crate::counters::count_test;
use crate::counters::Counters;
use crate::primitives::{PrimitiveId, Primitives};
use crate::ray::Ray;

/// Brute force: every primitive is tested against every ray. The reference
/// that every other structure is tested against.
#[derive(Clone, Debug, Default)]
pub struct List {
    count: u32,
}

impl List {
    /// Indexes `prims` (only their number matters).
    pub fn build<P: Primitives + ?Sized>(prims: &P) -> Self {
        List {
            count: u32::try_from(prims.len()).expect("more than 2^32 primitives"),
        }
    }
}

impl Accelerator for List {
    /// None: the list tests every primitive, whatever its box.
    fn unbounded(&self) -> &[PrimitiveId] {
        &[]
    }

    fn closest_bounded<C, F>(&self, mut ray: Ray, counters: &mut C, hit: &mut F)
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> Option<f32>,
    {
        for prim in 0..self.count {
            count_test(counters, prim);
            if let Some(t) = hit(prim, &ray) {
                ray.tmax = ray.tmax.min(t);
            }
        }
    }

    fn occluded_bounded<C, F>(&self, ray: &Ray, counters: &mut C, hit: &mut F) -> bool
    where
        C: Counters,
        F: FnMut(PrimitiveId, &Ray) -> bool,
    {
        (0..self.count).any(|prim| {
            count_test(counters, prim);
            hit(prim, ray)
        })
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            nodes: 1,
            leaves: 1,
            max_depth: 0,
            memory_bytes: std::mem::size_of::<Self>(),
            sah_cost: None,
        }
    }
}
