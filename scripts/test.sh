#!/usr/bin/env bash
# Runs every test of the project: the Rust workspace (unit, integration and doc tests), then the
# Python binding tests (builds the package from source into python/.venv).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace --locked
bash python/test.sh
