//! Random geometry (NaN, infinities, degenerate and huge triangles included)
//! and random rays (zero and denormal direction components included): every
//! acceleration structure must build without panicking and answer exactly
//! what brute force answers (`../accel_check.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../one_thread.rs"]
mod one_thread;

#[path = "../accel_check.rs"]
mod accel_check;

fuzz_target!(init: one_thread::run_rayon_on_this_thread(), |data: &[u8]| {
    accel_check::check(data);
});
