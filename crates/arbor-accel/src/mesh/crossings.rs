//! Every crossing of the surface along a ray, and how many there are.
//!
//! A ray through an edge or vertex shared by several triangles meets each
//! of them in the plain watertight test; here each crossing is reported by
//! exactly one triangle ([`crate::triangle::watertight::intersect_triangle_owned`]'s ownership rule), so
//! counts are crossing counts: even through a closed mesh, 0 or 2 at a
//! silhouette edge, never 1.

use rayon::prelude::*;

use super::packet_query::{Crossings, EveryHit};
use super::{packet_answers, Index, MeshAccel, MeshHit, PER_TASK};
use crate::counters::{Counters, NoCounters};
use crate::ray::Ray;
use crate::wide::packet::{PACKET, PACKET16};

/// Every hit of a batch of rays, in ray order: ray `i`'s hits are the
/// `counts[i]` entries of `hits` after those of the rays before it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AllHits {
    /// Hits per ray.
    pub counts: Vec<u32>,
    /// The hits, ray after ray, each ray's sorted as
    /// [`MeshAccel::all_hits`] sorts them.
    pub hits: Vec<MeshHit>,
}

impl AllHits {
    /// The hits of ray `i`, with `offsets` from [`AllHits::offsets`].
    pub fn of(&self, offsets: &[usize], i: usize) -> &[MeshHit] {
        &self.hits[offsets[i]..offsets[i + 1]]
    }

    /// Where each ray's hits start in `hits` (one more entry than rays, the
    /// last being `hits.len()`).
    pub fn offsets(&self) -> Vec<usize> {
        let mut offsets = Vec::with_capacity(self.counts.len() + 1);
        offsets.push(0);
        for &c in &self.counts {
            offsets.push(offsets[offsets.len() - 1] + c as usize);
        }
        offsets
    }
}

impl MeshAccel {
    /// Every crossing of the surface within `[ray.tmin, ray.tmax]`, sorted
    /// by distance, ties by triangle index; each crossing once (see the
    /// module documentation).
    pub fn all_hits(&self, ray: &Ray) -> Vec<MeshHit> {
        let mut hits = Vec::new();
        self.all_hits_into(ray, &mut NoCounters, &mut hits);
        hits
    }

    /// [`MeshAccel::all_hits`] appended to `out`, counting nodes and tests
    /// into `counters`.
    pub fn all_hits_into<C: Counters>(&self, ray: &Ray, counters: &mut C, out: &mut Vec<MeshHit>) {
        let start = out.len();
        self.for_each_crossing(ray, counters, |hit| out.push(hit));
        sort_hits(&mut out[start..]);
        if self.offers_repeats() {
            // A triangle offered again gives the same answer (the test sees
            // the same ray), so its copies sit side by side after sorting.
            let mut kept = start;
            for i in start..out.len() {
                if kept == start || out[kept - 1].prim != out[i].prim {
                    out[kept] = out[i];
                    kept += 1;
                }
            }
            out.truncate(kept);
        }
    }

    /// How many crossings [`MeshAccel::all_hits`] finds, without storing
    /// them (where a structure may offer a triangle twice, only the
    /// triangles that reported one).
    pub fn count(&self, ray: &Ray) -> u32 {
        self.count_counted(ray, &mut NoCounters)
    }

    /// [`MeshAccel::count`], counting nodes and tests into `counters`.
    pub fn count_counted<C: Counters>(&self, ray: &Ray, counters: &mut C) -> u32 {
        if self.offers_repeats() {
            // A triangle reports at most one crossing, so distinct triangles
            // are distinct crossings: the first few on the stack (a ray
            // rarely crosses more), the rest in a list.
            const INLINE: usize = 32;
            let mut first = [0u32; INLINE];
            let (mut n, mut more) = (0, Vec::new());
            self.for_each_crossing(ray, counters, |hit| {
                let p = hit.prim;
                if !first[..n].contains(&p) && !more.contains(&p) {
                    if n < INLINE {
                        first[n] = p;
                        n += 1;
                    } else {
                        more.push(p);
                    }
                }
            });
            return (n + more.len()) as u32;
        }
        let mut n = 0;
        self.for_each_crossing(ray, counters, |_| n += 1);
        n
    }

    /// [`MeshAccel::all_hits`] for every ray, in parallel (camera-ray
    /// streams in packets on `bvh-wide`, as in
    /// [`MeshAccel::closest_batch_into`]).
    pub fn all_hits_batch(&self, rays: &[Ray]) -> AllHits {
        let packets = match &self.index {
            Index::Wide(bvh) if !bvh.has_repeats() && crate::wide::packet::looks_coherent(rays) => {
                Some(bvh)
            }
            _ => None,
        };
        let per_chunk: Vec<(Vec<u32>, Vec<MeshHit>)> = rays
            .par_chunks(PER_TASK)
            .map(|chunk| {
                let mut counts = Vec::with_capacity(chunk.len());
                let mut hits = Vec::new();
                let single = |ray: &Ray, counts: &mut Vec<u32>, hits: &mut Vec<MeshHit>| {
                    let before = hits.len();
                    self.all_hits_into(ray, &mut NoCounters, hits);
                    counts.push((hits.len() - before) as u32);
                };
                match packets {
                    Some(bvh) => {
                        for group in chunk.chunks(crate::wide::packet::packet_width()) {
                            if let Some(lanes) = packet_answers::<PACKET16, EveryHit>(bvh, group) {
                                append_lanes(lanes, &mut counts, &mut hits);
                                continue;
                            }
                            for half in group.chunks(PACKET) {
                                match packet_answers::<PACKET, EveryHit>(bvh, half) {
                                    Some(lanes) => append_lanes(lanes, &mut counts, &mut hits),
                                    None => half
                                        .iter()
                                        .for_each(|ray| single(ray, &mut counts, &mut hits)),
                                }
                            }
                        }
                    }
                    None => chunk
                        .iter()
                        .for_each(|ray| single(ray, &mut counts, &mut hits)),
                }
                (counts, hits)
            })
            .collect();
        let mut all = AllHits {
            counts: Vec::with_capacity(rays.len()),
            hits: Vec::with_capacity(per_chunk.iter().map(|(_, h)| h.len()).sum()),
        };
        for (counts, hits) in per_chunk {
            all.counts.extend(counts);
            all.hits.extend(hits);
        }
        all
    }

    /// [`MeshAccel::count`] for every ray, in parallel (coherent rays in
    /// packets, as in [`MeshAccel::closest_batch_into`]).
    pub fn count_batch(&self, rays: &[Ray]) -> Vec<u32> {
        let mut out = vec![0; rays.len()];
        self.count_batch_into(rays, &mut out);
        out
    }

    /// [`MeshAccel::count_batch`] into `out` (`out.len() == rays.len()`).
    ///
    /// # Panics
    /// If `out` and `rays` differ in length.
    pub fn count_batch_into(&self, rays: &[Ray], out: &mut [u32]) {
        self.batch_into::<Crossings>(rays, out, |ray| self.count(ray));
    }
}

/// Sorts one ray's hits as [`MeshAccel::all_hits`] returns them: by
/// distance, ties by triangle index.
fn sort_hits(hits: &mut [MeshHit]) {
    hits.sort_unstable_by(|x, y| x.hit.t.total_cmp(&y.hit.t).then(x.prim.cmp(&y.prim)));
}

/// Appends a packet's crossings, lane after lane, each lane's sorted.
fn append_lanes<const N: usize>(
    lanes: [Vec<MeshHit>; N],
    counts: &mut Vec<u32>,
    hits: &mut Vec<MeshHit>,
) {
    for mut lane in lanes {
        sort_hits(&mut lane);
        counts.push(lane.len() as u32);
        hits.extend(lane);
    }
}
