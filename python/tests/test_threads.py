"""The GIL is released during extraction, and concurrent calls from threads are safe."""

import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import isogrid
from conftest import same_grid, sphere


def test_other_python_threads_run_during_extraction():
    """A waiting thread gets the GIL while `extract` runs, and only then.

    With a long switch interval the interpreter never preempts the main thread, so the helper
    thread can run only when the main thread gives the GIL away: inside `extract` if it is
    released there, otherwise not before `extract` has returned and the check has been made.
    """
    a = sphere(shape_zyx=(160, 160, 160), centre_xyz=(80, 80, 80), radius=70, dtype=np.uint8)
    go, done = threading.Event(), threading.Event()

    def helper():
        go.wait()
        done.set()

    interval = sys.getswitchinterval()
    sys.setswitchinterval(30.0)
    try:
        t = threading.Thread(target=helper)
        t.start()  # runs until go.wait() blocks, which hands the GIL back
        go.set()  # wakes the helper, which now waits for the GIL
        isogrid.extract(a, iso=1, threads=1)
        ran_during_extract = done.is_set()
    finally:
        sys.setswitchinterval(interval)
        go.set()
        t.join()
    assert ran_during_extract


def test_concurrent_extractions_agree():
    volumes = [sphere(radius=r, dtype=np.uint8) for r in (4.0, 6.0, 8.0)]
    expected = [isogrid.extract(v, iso=1) for v in volumes]
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(lambda i: isogrid.extract(volumes[i % 3], iso=1, threads=2), range(12)))
    for i, g in enumerate(results):
        assert same_grid(g, expected[i % 3])
