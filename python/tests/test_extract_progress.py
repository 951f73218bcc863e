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


# A field of many surfaces (a gyroid-like sum of waves) on n³ samples, its surfaces made denser
# until one call runs for over a second on one thread, whatever the machine's speed: the call must
# be long enough that stopping it soon can be told from running to its end. (Denser surfaces, not
# more samples, so that the volume stays the same size; built a plane at a time.)
INTERRUPTED = """
import sys, time, numpy as np, isogrid, isogrid.skimage
what, n = sys.argv[1], int(sys.argv[2])
def field(periods):
    x = np.linspace(0, 2 * np.pi * periods, n, dtype=np.float32)
    s, c = np.sin(x), np.cos(x)
    v = np.empty((n, n, n), np.float32)
    for i in range(n):
        v[i] = s[i] * c[:, None] + s[:, None] * c[None, :] + s[None, :] * c[i]
    return v
def run(v):
    if what == "extract":
        isogrid.extract(v, iso=0.0, threads=1)
    elif what == "marching_cubes":
        isogrid.marching_cubes(v, iso=0.0, threads=1)
    else:
        isogrid.skimage.marching_cubes(v, 0.0)
periods = 6
while True:
    v = field(periods)
    start = time.perf_counter()
    run(v)
    full = time.perf_counter() - start
    if full > 1.2 or periods >= 32:
        break
    periods = min(32, periods * max(1.25, min(2.0, 1.5 / full)))
print(full, flush=True)
print("started", flush=True)
run(v)
print("finished", flush=True)
"""


@pytest.mark.parametrize("what,n", [("extract", 512), ("marching_cubes", 448), ("skimage", 256)])
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
