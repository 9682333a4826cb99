#!/usr/bin/env bash
# Cornell conformance: render every shared course scene with arbor and compare
# it with its reference image. One line per scene; fails when a scene is below
# 40 dB PSNR or below 99% of channel values within 2/255. A scene whose mesh
# file is absent is reported as skipped, never as passed.
# Usage: .ci/conformance.sh ARBOR_BINARY SHARED_DIR
set -uo pipefail
arbor=$1
shared=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0 skip=0
for xml in "$shared"/scenes/cornell-2010/*/*.xml "$shared"/scenes/cornell-2015/*.xml; do
  [ -e "$xml" ] || continue
  name=${xml#"$shared"/scenes/}
  dir=$(dirname "$xml")
  missing=""
  for mesh in $(grep -io '<data>[^<]*</data>' "$xml" | sed -e 's/<[^>]*>//g'); do
    [ -f "$dir/$mesh" ] || missing="$missing $mesh"
  done
  if [ -n "$missing" ]; then
    echo "SKIP $name (mesh file absent:$missing)"; skip=$((skip + 1)); continue
  fi
  if [ ! -f "$xml.soln.png" ]; then
    echo "SKIP $name (no reference image)"; skip=$((skip + 1)); continue
  fi
  png="$out/$(echo "$name" | tr / _).png"
  if ! err=$("$arbor" render "$xml" -o "$png" --quiet 2>&1); then
    echo "FAIL $name (render failed: $err)"; fail=$((fail + 1)); continue
  fi
  if line=$("$arbor" compare "$png" "$xml.soln.png" --min-psnr 40 --min-within2 0.99 2>&1); then
    echo "PASS $name $line"; pass=$((pass + 1))
  else
    echo "FAIL $name $line"; fail=$((fail + 1))
  fi
done
echo "conformance: $pass passed, $fail failed, $skip skipped"
[ "$fail" -eq 0 ] && [ "$pass" -gt 0 ]
