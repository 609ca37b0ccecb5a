"""Running independent pieces on several threads: bands, order of results, errors, the core count."""

import os
import threading

import pytest

from wdendrite import _parallel


@pytest.mark.parametrize("rows, pieces, least", [(1, 4, 1), (7, 3, 1), (100, 4, 30), (100, 4, 60), (5, 9, 1)])
def test_row_bands_cover_every_row_once(rows, pieces, least):
    bands = _parallel.row_bands(rows, pieces, least=least)
    assert bands[0][0] == 0 and bands[-1][1] == rows
    assert all(a[1] == b[0] for a, b in zip(bands, bands[1:]))
    assert 1 <= len(bands) <= pieces
    assert len(bands) == 1 or min(b - a for a, b in bands) >= least
    assert max(b - a for a, b in bands) - min(b - a for a, b in bands) <= 1


def test_each_keeps_the_order_and_uses_threads():
    seen = set()
    barrier = threading.Barrier(3, timeout=10)

    def piece(k):
        seen.add(threading.get_ident())
        if k < 3:
            barrier.wait()  # the first three run at once, or this times out
        return k * k

    assert _parallel.each(piece, range(7), 3) == [k * k for k in range(7)]
    assert len(seen) == 3


def test_each_raises_the_first_failure_and_one_thread_runs_in_the_caller():
    def piece(k):
        if k in (2, 4):
            raise KeyError(k)
        return k

    with pytest.raises(KeyError, match="2"):
        _parallel.each(piece, range(6), 2)
    here = threading.get_ident()
    assert _parallel.each(lambda k: threading.get_ident(), range(3), 1) == [here] * 3


def test_cores_counts_the_processs_affinity():
    if hasattr(os, "sched_getaffinity") and not hasattr(os, "process_cpu_count"):
        assert _parallel.cores() == len(os.sched_getaffinity(0))
    assert _parallel.cores() >= 1
    assert _parallel.workers(None) == _parallel.cores()
    assert _parallel.workers(1) == 1


def test_each_starts_no_piece_after_a_failure():
    import time

    started = []

    def piece(k):
        started.append(k)
        if k == 0:
            raise ValueError("first")
        time.sleep(0.2)

    with pytest.raises(ValueError, match="first"):
        _parallel.each(piece, range(20), 2)
    assert len(started) < 10  # (all 20 would take 2 s on the other thread)
