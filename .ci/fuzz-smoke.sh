#!/usr/bin/env bash
# Fuzz smoke: every cargo-fuzz target of fuzz/ for a short while over its
# committed corpus; any crash, panic, failed check, timeout or memory blow-up
# fails. Needs only the stable toolchain: cargo-fuzz wants nightly flags,
# which RUSTC_BOOTSTRAP=1 allows (AddressSanitizer included, on x86_64 Linux).
# Usage: .ci/fuzz-smoke.sh [SECONDS_PER_TARGET] (default 30).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
targets=(xml msh obj ply stl gltf accel)
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

# New inputs go to a scratch folder; the committed corpus is only read.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$scratch/$t"
  corpus=("$scratch/$t")
  [ -d "fuzz/corpus/$t" ] && corpus+=("fuzz/corpus/$t")
  started=$SECONDS
  if ! cargo fuzz run -O -a "$t" "${corpus[@]}" -- \
      -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2048 \
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
