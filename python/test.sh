#!/usr/bin/env bash
# Builds the isogrid Python package from source (one cargo release build, via pip and maturin)
# into a virtual environment and runs the binding tests. Needs Rust, Python >= 3.9 and pip.
#
#   python/test.sh [pytest args]
#
# ISOGRID_VENV picks the environment (default python/.venv, reused between runs; cargo's
# incremental build in python/target makes later runs quick). The CLI comparison tests use the
# `isogrid` binary from target/release or target/debug of this checkout (or $ISOGRID_CLI) and are
# skipped when there is none.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
venv="${ISOGRID_VENV:-$here/.venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$here[test]"
# Run from tests/ so that `import isogrid` finds the installed package, not the source folder.
cd "$here/tests"
exec "$venv/bin/python" -m pytest -q -p no:cacheprovider "$@"
