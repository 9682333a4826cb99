//! A crowd of triangles copied from a few random seeds (large copies across
//! small ones, NaN, infinities and degenerate seeds included) and random
//! rays: every build with spatial splits must answer closest hits,
//! occlusion, counts and every hit exactly as brute force does
//! (`../spatial_check.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

#[path = "../accel_check.rs"]
#[allow(dead_code)]
mod accel_check;

#[path = "../spatial_check.rs"]
mod spatial_check;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    spatial_check::check(data);
});
