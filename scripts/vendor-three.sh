#!/usr/bin/env bash
# Fetches the pinned three.js from the npm registry (`npm pack`), checks the
# package's sha256 and copies the files the explain page embeds into
# crates/arbor-cli/assets/explain/three/ (with three.js's LICENSE). The files
# are committed, so `cargo build` never fetches anything; run this only to
# update three.js: change VERSION and SHA256 together, run it, rebuild, and
# run .ci/browser.sh.
set -euo pipefail
VERSION=0.187.0
SHA256=ff540832ded0cfe919764d24a3d88f3e2a05f23303f876423e4f893841e90728

repo=$(cd "$(dirname "$0")/.." && pwd)
dest="$repo/crates/arbor-cli/assets/explain/three"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

(cd "$work" && npm pack --silent "three@$VERSION" >/dev/null)
tarball="$work/three-$VERSION.tgz"
actual=$(sha256sum "$tarball" | cut -d' ' -f1)
if [ "$actual" != "$SHA256" ]; then
  echo "vendor-three.sh: three@$VERSION has sha256 $actual, expected $SHA256" >&2
  exit 1
fi
tar -xzf "$tarball" -C "$work"

mkdir -p "$dest"
cp "$work/package/LICENSE" "$dest/LICENSE"
cp "$work/package/build/three.core.js" "$dest/three.core.js"
cp "$work/package/build/three.module.js" "$dest/three.module.js"
cp "$work/package/examples/jsm/controls/OrbitControls.js" "$dest/OrbitControls.js"
printf 'three.js %s from the npm package three@%s (sha256 %s),\nfetched by scripts/vendor-three.sh. Unmodified; the page maps their imports.\n' \
  "$VERSION" "$VERSION" "$SHA256" >"$dest/VERSION"
echo "vendor-three.sh: three.js $VERSION copied to ${dest#"$repo"/}"
