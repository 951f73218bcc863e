"""``progress=`` and cancellation of extraction and Marching Cubes: the callback hears increasing
counts, and an exception from it (as Ctrl-C, which the same watcher turns into
``KeyboardInterrupt``) stops the work and is raised."""
import numpy as np
import pytest

import isogrid


def ball(n):
    x = np.linspace(-1.0, 1.0, n, dtype=np.float32)
    return np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)


class Stop(Exception):
    pass


@pytest.mark.parametrize("run", ["extract", "marching_cubes"])
def test_progress_counts_up_and_an_exception_in_it_stops_the_work(run):
    volume = ball(256)
    work = getattr(isogrid, run)
    calls = []
    out = work(volume, iso=0.5, threads=1, progress=lambda done, total: calls.append((done, total)))
    assert out is not None and calls
    done = [d for d, _ in calls]
    assert done == sorted(done) and calls[-1][0] == calls[-1][1] > 0

    def stop_at_once(done, total):
        raise Stop(f"stopped at {done} of {total}")

    with pytest.raises(Stop, match="stopped at"):
        work(volume, iso=0.5, threads=1, progress=stop_at_once)
    with pytest.raises(ValueError, match="callable"):
        work(volume, iso=0.5, progress=3)


# A field with many surfaces (a gyroid-like sum of waves), sized so that each call runs for a
# second or more on one thread.
INTERRUPTED = """
import sys, time, numpy as np, isogrid, isogrid.skimage
what, n = sys.argv[1], int(sys.argv[2])
x = np.linspace(0, 12 * np.pi, n, dtype=np.float32)
s, c = np.sin(x), np.cos(x)
v = (s[:, None, None] * c[None, :, None] + s[None, :, None] * c[None, None, :]
     + s[None, None, :] * c[:, None, None]).astype(np.float32)
def run():
    if what == "extract":
        isogrid.extract(v, iso=0.0, threads=1)
    elif what == "marching_cubes":
        isogrid.marching_cubes(v, iso=0.0, threads=1)
    else:
        isogrid.skimage.marching_cubes(v, 0.0)
start = time.perf_counter()
run()
print(time.perf_counter() - start, flush=True)
print("started", flush=True)
run()
print("finished", flush=True)
"""


@pytest.mark.parametrize("what,n", [("extract", 448), ("marching_cubes", 384), ("skimage", 256)])
def test_ctrl_c_stops_the_work_soon(what, n):
    # A real SIGINT while the call runs: KeyboardInterrupt in a small part of the call's time.
    # (They ran to their end regardless of Ctrl-C, 3-10 s on 1024³.)
    import signal
    import subprocess
    import sys
    import time

    child = subprocess.Popen([sys.executable, "-c", INTERRUPTED, what, str(n)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    full = float(child.stdout.readline())
    assert child.stdout.readline().strip() == "started"
    time.sleep(0.2)
    sent = time.perf_counter()
    child.send_signal(signal.SIGINT)
    stdout, stderr = child.communicate(timeout=120)
    latency = time.perf_counter() - sent
    assert full > 1.0, f"{what} took {full:.2f} s: too quick to interrupt"
    assert child.returncode != 0 and "finished" not in stdout, stderr
    assert "KeyboardInterrupt" in stderr, stderr
    assert latency < 0.4 * full, f"{what}: stopped {latency:.2f} s after SIGINT; the call takes {full:.2f} s"
