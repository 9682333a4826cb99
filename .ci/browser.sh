#!/usr/bin/env bash
# The `arbor explain` page in a real browser: Debian's headless Chromium and
# chromedriver (installed here when missing; no browser is downloaded at run
# time) driven by selenium from a fresh virtual environment, over pages the
# given binary writes for a Cornell scene and the classroom. Screenshots go
# to target/browser-screenshots (or ARBOR_SCREENSHOTS). A skipped test or
# pytest's exit 5 ("no tests ran") fails the script.
# Usage: .ci/browser.sh ARBOR_BINARY
set -euo pipefail
[ $# -eq 1 ] || { echo "usage: .ci/browser.sh ARBOR_BINARY" >&2; exit 2; }
arbor=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
[ -x "$arbor" ] || { echo "browser.sh: $1 is not an executable" >&2; exit 2; }
cd "$(dirname "$0")/.."
repo=$PWD
shared=$(cd "${ARBOR_SHARED:-../shared}" && pwd)

if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null
fi
/usr/bin/chromium --version

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 -m venv "$work/venv"
py="$work/venv/bin/python"
"$py" -m pip install --quiet --upgrade pip
"$py" -m pip install --quiet selenium==4.40.0 pytest==8.4.2

export ARBOR_BIN="$arbor" ARBOR_SHARED="$shared" PYTHONDONTWRITEBYTECODE=1
export ARBOR_SCREENSHOTS="${ARBOR_SCREENSHOTS:-$repo/target/browser-screenshots}"
cd "$repo/tests/browser"
"$py" -m pytest -p no:cacheprovider -ra . && status=0 || status=$?
if [ "$status" -eq 5 ]; then
  echo "browser.sh: pytest collected no tests" >&2
fi
if [ "$status" -eq 0 ]; then
  echo "browser.sh: screenshots in $ARBOR_SCREENSHOTS"
fi
exit "$status"
