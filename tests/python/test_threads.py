# The thread count is an argument, and the GIL is released while an algorithm runs: other
# Python threads run meanwhile, and calls from several threads run at once.
import threading
import time

import numpy as np
import pytest

import idas


@pytest.mark.parametrize("threads", [1, 2])
def test_thread_counts_give_valid_meshes(bunny, threads):
    v, f = bunny
    for algorithm in ("qslim", "shortest-edge"):
        dv, df, _ = idas.decimate(v, f, target_faces=1500, algorithm=algorithm, threads=threads)
        report = idas.info(dv, df)
        assert report["editable"] and report["closed"]
        assert report["euler_characteristic"] == 2
        assert len(df) <= 1600
    rv, rf, _ = idas.remesh(v, f, edge_length=0.04, iterations=2, threads=threads)
    report = idas.info(rv, rf)
    assert report["editable"] and report["euler_characteristic"] == 2


def test_gil_released_during_decimate(data):
    # armadillo (86k faces): long enough that a held GIL would starve the ticker below.
    v, f, _ = idas.read(data / "armadillo.obj", attributes=False)
    window = {}

    def work():
        window["start"] = time.perf_counter()
        idas.decimate(v, f, ratio=0.05, allow_self_intersections=True)
        window["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
    worker.join()
    start, end = window["start"], window["end"]
    assert end - start > 0.1
    # Ticks in the middle of the run: none at all if the GIL were held throughout.
    inside = [t for t in ticks if start + 0.2 * (end - start) < t < end - 0.2 * (end - start)]
    assert len(inside) > 1000


def test_calls_from_two_threads(bunny):
    v, f = bunny
    expected = idas.decimate(v, f, ratio=0.2, threads=2, deterministic=True)
    results = [None, None]

    def work(k):
        results[k] = idas.decimate(v, f, ratio=0.2, threads=2, deterministic=True)

    workers = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(timeout=60)
    for r in results:
        assert r is not None
        assert np.array_equal(r[0], expected[0]) and np.array_equal(r[1], expected[1])
