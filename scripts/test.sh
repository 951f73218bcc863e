#!/usr/bin/env bash
# Runs every test of the project: the Rust workspace (unit, integration and doc tests), the
# Python binding tests (builds the package from source into python/.venv), then the web viewer's
# (web/test.sh: the .cgc reader in node, the viewer in chromium and firefox-esr against the native
# renderer, with the isogrid binary the workspace tests built).
set -euo pipefail
cd "$(dirname "$0")/.."
# The core, tracer, GPU, io, render front door, viewer and CLI crates keep module graphs without import cycles.
for crate in isogrid isogrid-trace isogrid-gpu isogrid-io isogrid-render isogrid-viewer isogrid-cli; do
  python3 scripts/check_module_cycles.py "crates/$crate/src"
done
cargo test --workspace --locked
bash python/test.sh
cargo build --locked -p isogrid-cli
bash web/test.sh
