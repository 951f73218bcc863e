#!/usr/bin/env bash
# The web viewer's tests: installs its npm packages when missing, type-checks and builds it, then
# runs the node test runner over web/test (shader sharing, the .cgc reader, and the browser tests,
# which skip with a printed reason where chromium, firefox-esr or WebGPU is missing). The browser
# tests use the isogrid binary of target/debug (or $ISOGRID_BIN): build it first.
set -euo pipefail
cd "$(dirname "$0")"
if ! command -v node >/dev/null 2>&1; then
  echo "web tests skipped: no node (install nodejs and npm)" >&2
  exit 0
fi
[ -d node_modules ] || npm ci --no-audit --no-fund
npx tsc --noEmit
# Into build/ (ignored): the tests check that the committed web/dist equals a fresh build.
node -e "import('./build.mjs').then((m) => m.build('build/dist'))"
export NODEVICE_SELECT=1
# One test file at a time (they rebuild build/node); Node 18 has no --test-concurrency flag, and
# runs files one by one on 2 cores anyway.
if node --help | grep -q -- --test-concurrency; then
  node --test --test-concurrency=1 test/
else
  node --test test/
fi
