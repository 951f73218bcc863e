"""What the GPU frame-time scripts (bench_gpu_color.py, bench_gpu_labels.py) share: the release
CLI run with --json, one timed GPU render, their common options, and the table's output."""
import json
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(exe, args):
    """Runs the CLI; its JSON when --json is among `args`."""
    env = dict(os.environ, NODEVICE_SELECT="1")
    out = subprocess.run([exe] + args, check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout) if "--json" in args else None


def add_options(ap):
    ap.add_argument("--exe", default=os.path.join(ROOT, "target/release/isogrid"))
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--data", default=os.path.join(ROOT, "data"))
    ap.add_argument("--out", default=None, help="also write the table here")


def render_gpu_ms(args, source, extra, view):
    """`isogrid render SOURCE EXTRA --backend gpu` from `view`: (adapter, timestamp medians in ms)."""
    r = run(args.exe, ["render"] + source + extra + [
        "--backend", "gpu", "--view", view, "--size", args.size, "--frames", str(args.frames), "--json"])
    return r.get("adapter"), r["gpu_ms"]


def fmt(v):
    return "n/a" if v is None else f"{v:.3f}"


def emit(lines, out):
    """Prints the table and writes it to `out` where given."""
    text = "\n".join(lines) + "\n"
    print(text)
    if out:
        with open(out, "w") as f:
            f.write(text)
