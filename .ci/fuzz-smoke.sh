#!/usr/bin/env bash
# Fuzz smoke: every cargo-fuzz target of fuzz/ for a short while over its
# committed corpus; any crash, panic, failed check, timeout or memory blow-up
# fails. Needs only the stable toolchain: cargo-fuzz wants nightly flags,
# which RUSTC_BOOTSTRAP=1 allows (AddressSanitizer included, on x86_64 Linux).
#
# The runs are reproducible: a fixed seed, a fixed number of runs per target
# (about 20 s each on the CI machine), no corpus reload (libFuzzer rereads
# its corpus folder every second by default, a clock in the loop), address
# space randomisation off (setarch -R; pointer values reach hashing and
# comparisons) and, in the targets and the library, nothing else that
# varies between processes (fuzz/one_thread.rs,
# crates/arbor/src/hash_map.rs). So the smoke passes or fails the same way
# on every machine with the same toolchain, and running this script before
# pushing shows what CI will see (checked: two runs give identical logs for
# every target; xml, the last to drift, until -reload=0, is identical over
# its 400,000 runs). A time limit of twice SECONDS per
# target only guards against a slow machine: it cuts the same sequence of
# inputs short, so it can find nothing a full run would not. Finding new
# bugs is the job of long fuzzing runs (docs/robustness.md), not of this
# gate.
# Usage: .ci/fuzz-smoke.sh [SECONDS_PER_TARGET] (default 30).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
seed=1
targets=(xml msh obj ply stl gltf accel accel_spatial)
# Runs per target: about 20 seconds each at the executions per second
# measured on the development machine (-O -a build, 11-18 s there; accel
# 15,000 since its check also builds and traces TriangleBvh and checks every
# ray twice, as decoded and looking behind its origin: 12 s from the
# committed corpus alone, as CI starts; a local corpus grown by long runs
# adds its own replay first; accel_spatial 1,000, about 17 s: each input
# makes eight builds with spatial splits over a crowd of about a hundred
# triangles).
declare -A runs=([xml]=400000 [msh]=1200000 [obj]=500000 [ply]=450000
  [stl]=800000 [gltf]=120000 [accel]=15000 [accel_spatial]=1000)
export RUSTC_BOOTSTRAP=1

# libfuzzer-sys compiles libFuzzer, which is C++.
if ! command -v c++ >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq g++ >/dev/null
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  cargo install cargo-fuzz --locked
fi
cargo fuzz --version

# One build for every target: release with debug assertions (overflow checks
# on, as in a debug build), AddressSanitizer.
started=$SECONDS
cargo fuzz build -O -a
echo "fuzz build: $((SECONDS - started)) s"

# Without address space randomisation where the machine allows it.
no_aslr=""
if setarch "$(uname -m)" -R true 2>/dev/null; then
  no_aslr="setarch $(uname -m) -R"
else
  echo "fuzz smoke: setarch -R not available, runs may differ from other machines'"
fi

# New inputs go to a scratch folder; the committed corpus is only read.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$scratch/$t"
  corpus=("$scratch/$t")
  [ -d "fuzz/corpus/$t" ] && corpus+=("fuzz/corpus/$t")
  started=$SECONDS
  if ! $no_aslr cargo fuzz run -O -a "$t" "${corpus[@]}" -- \
      -seed="$seed" -runs="${runs[$t]}" -reload=0 -max_total_time=$((2 * seconds)) \
      -timeout=20 -rss_limit_mb=2048 \
      >"$scratch/$t.log" 2>&1; then
    # The failed check first (the stack trace after it is long), then the
    # end of the log with the input and how to reproduce it.
    grep -A4 -m1 -E 'panicked at|ERROR: (libFuzzer|AddressSanitizer)' "$scratch/$t.log" || true
    tail -n 30 "$scratch/$t.log"
    echo "fuzz smoke: target $t FAILED; the input is in fuzz/artifacts/$t/" >&2
    failed+=("$t")
    continue
  fi
  echo "$t: $(grep -E '^Done [0-9]+ runs' "$scratch/$t.log") ($((SECONDS - started)) s)"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz smoke: failed: ${failed[*]}" >&2
  exit 1
fi
