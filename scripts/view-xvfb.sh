#!/usr/bin/env bash
# Runs `isogrid view ARGS...` on a virtual X screen, for machines without a display (CI, servers).
# Needs: apt-get install xvfb (xvfb-run, Xvfb), and a Vulkan driver (mesa-vulkan-drivers = lavapipe).
# The screen is 24-bit: xvfb-run's default 8-bit screen has no visual a Vulkan surface accepts.
#
#   scripts/view-xvfb.sh volume.nrrd --iso-normalized 0.5 --frames 3 --screenshot out.png
#
# ISOGRID=path/to/isogrid picks the binary (default: target/release/isogrid, else `isogrid` on PATH).
set -euo pipefail
# Paths in ARGS stay relative to the caller's directory: no cd.
root="$(cd "$(dirname "$0")/.." && pwd)"
target="${CARGO_TARGET_DIR:-$root/target}"
bin="${ISOGRID:-}"
if [ -z "$bin" ]; then
  if [ -x "$target/release/isogrid" ]; then
    bin="$target/release/isogrid"
  else
    bin=isogrid
  fi
fi
command -v xvfb-run >/dev/null 2>&1 || { echo "xvfb-run not found: apt-get install xvfb" >&2; exit 1; }
export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
exec xvfb-run -a -s "-screen 0 1920x1080x24 -nolisten tcp" "$bin" view "$@"
