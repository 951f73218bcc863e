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
