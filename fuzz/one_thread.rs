//! Makes rayon run all its work on the fuzzing thread itself, shared by the
//! fuzz targets through `#[path]`.
//!
//! libFuzzer steers by the code coverage each input produces. With worker
//! threads, how often rayon's scheduling code spins or sleeps varies from
//! run to run, so the same input gives different coverage and runs with the
//! same seed drift apart. With one pool thread that is the calling thread,
//! every `join` and parallel iterator runs inline, the coverage of an input
//! is a function of the input, and `-seed=N -runs=M` (the CI smoke) repeats
//! exactly.

/// Makes the calling thread the only thread of rayon's global pool. Call
/// once, before any rayon work (the `init:` block of `fuzz_target!`).
pub fn run_rayon_on_this_thread() {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .use_current_thread()
        .build_global()
        .expect("rayon's global pool is configured before its first use");
}
