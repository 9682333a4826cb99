//! The hash maps of arbor's loaders, flattening and tile merging: std's,
//! with one difference in fuzzing builds.
//!
//! Normal builds use std's randomly keyed hasher, which keeps crafted names
//! in a hostile scene from colliding on purpose. Fuzzing builds
//! (`cfg(fuzzing)`, which `cargo fuzz` sets) use fixed keys: libFuzzer steers
//! by the coverage each input produces, and with random keys the hash
//! table's probing, and so the coverage of the same input, changes from run
//! to run, so that two runs with the same seed (the CI's fuzz smoke) would
//! drift apart. Nothing depends on the order of these maps' entries.

#[cfg(fuzzing)]
type State = std::hash::BuildHasherDefault<std::collections::hash_map::DefaultHasher>;
#[cfg(not(fuzzing))]
type State = std::collections::hash_map::RandomState;

/// std's `HashMap` with the hasher chosen above; make one with `default()`.
pub(crate) type HashMap<K, V> = std::collections::HashMap<K, V, State>;

/// std's `HashSet` with the hasher chosen above; make one with `default()`
/// or `collect()`.
pub(crate) type HashSet<T> = std::collections::HashSet<T, State>;
