#!/usr/bin/env python3
"""Peak anonymous and file-backed resident memory of a command (Linux): runs it and samples
RssAnon / RssFile from /proc/PID/status every 10 ms. Used for the `.cgc` memory-map figures in
docs/benchmarks-scale.md: a command that maps a .cgc file shows its payload under RssFile (page
cache), one that copies it under RssAnon.

usage: cgc_rss.py COMMAND [ARGS...]"""
import subprocess
import sys
import time


def sample(pid):
    fields = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("RssAnon", "RssFile"):
                    fields[key] = int(value.split()[0]) * 1024
    except (FileNotFoundError, ProcessLookupError):
        pass
    return fields


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
    peak = {"RssAnon": 0, "RssFile": 0}
    start = time.monotonic()
    while proc.poll() is None:
        for key, value in sample(proc.pid).items():
            peak[key] = max(peak[key], value)
        time.sleep(0.01)
    mib = {k: v / 2**20 for k, v in peak.items()}
    print(
        f"exit {proc.returncode}, {time.monotonic() - start:.1f} s, peak RssAnon "
        f"{mib['RssAnon']:.1f} MiB, peak RssFile {mib['RssFile']:.1f} MiB: {' '.join(sys.argv[1:])}"
    )
    sys.exit(proc.returncode)


if __name__ == "__main__":
    main()
