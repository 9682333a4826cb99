#!/usr/bin/env bash
# The Python package as a user installs it: `pip install ./python` into a
# fresh virtual environment (maturin and PyO3 come from the registries),
# then its pytest tests, which include trimesh 5.2's own ray tests run from
# ../shared with arbor as trimesh's intersector and Open3D 0.20's ray casting
# tutorials run with arbor's RaycastingScene in place of Open3D's, compared
# with Open3D's answers. Any failure, a skipped test
# or pytest's exit 5 ("no tests ran") fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
shared=$(cd "${ARBOR_SHARED:-../shared}" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python3 -m venv "$work/venv"
py="$work/venv/bin/python"
"$py" -m pip install --quiet --upgrade pip
"$py" -m pip install --quiet ./python
"$py" -m pip install --quiet pytest trimesh==5.2.0 embreex scipy rtree manifold3d open3d-cpu
# open3d-cpu's library links Debian's libusb-1.0 (for its RealSense camera
# support); without it `import open3d` fails and the Open3D drop-in tests,
# which compare arbor.RaycastingScene with Open3D's, would be skipped.
"$py" -c 'import open3d' 2>/dev/null ||
  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libusb-1.0-0 >/dev/null; }
"$py" -c 'import open3d'

# The tests compare answers with `arbor trace`.
cargo build --release -p arbor-cli
export ARBOR_CLI="$repo/target/release/arbor" ARBOR_REQUIRE_CLI=1
export ARBOR_SHARED="$shared" ARBOR_REQUIRE_TEST_DATA=1 ARBOR_NO_SKIPS=1
# From outside the source tree, so `import arbor` finds the installed package
# rather than the source tree; no cache written into the repository.
cd "$work" && "$py" -m pytest -p no:cacheprovider -ra "$repo/python/tests" && status=0 || status=$?
if [ "$status" -eq 5 ]; then
  echo "python.sh: pytest collected no tests" >&2
fi
exit "$status"
