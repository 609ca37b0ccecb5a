"""Independent pieces of work run on several CPU cores at once.

Warp's CPU device runs each launch on one thread, but it lets go of Python's interpreter
lock while a launch runs (``ctypes`` calls release it; BENCHMARKS.md measures two threads
launching at once), so plain threads put every core to work without copying data between
processes. Each piece must be independent of the others (its own scratch arrays, its own
part of the output); the results then do not depend on how many threads ran them.
"""

from __future__ import annotations

import os
import warnings
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

import numpy as np

__all__ = ["BAND_PIXELS", "cores", "each", "image_bands", "row_bands", "workers"]

BAND_PIXELS = 1 << 16
"""Fewest pixels in a band of rows given a thread of its own: below it starting the thread and
the band's own set-up cost about what its pixels take off the others."""


def cores() -> int:
    """The number of CPU cores this process may run on (its affinity mask, not the machine's count)."""
    count = getattr(os, "process_cpu_count", None)  # Python 3.13+
    if count is not None:
        return max(1, count() or 1)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # (no affinity masks on macOS and Windows)
        return max(1, os.cpu_count() or 1)


def workers(value, name: str = "workers") -> int:
    """``value`` as a number of threads: None means every core (:func:`cores`).

    More than :func:`cores` is capped at it with a ``UserWarning`` that says so (threads
    beyond the cores only take turns on them).

    Raises:
        TypeError: not an integer (or None).
        ValueError: below 1.
    """
    have = cores()
    if value is None:
        return have
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"Expected an integer >= 1 (or None: every core) for '{name}', but got {value!r}")
    if value < 1:
        raise ValueError(f"Expected '{name}' >= 1 (or None: every core), but got {value!r}")
    if value > have:
        warnings.warn(f"'{name}' = {int(value)} is more than the {have} cores this process may use: using {have}",
                      UserWarning, stacklevel=3)
        return have
    return int(value)


def row_bands(rows: int, pieces: int, *, least: int = 1) -> list[tuple[int, int]]:
    """``(first, stop)`` rows of at most ``pieces`` bands of near-equal height covering ``rows``
    rows, each at least ``least`` rows high (one band when ``rows < 2 * least``)."""
    count = max(1, min(int(pieces), rows // max(1, int(least))))
    edges = [rows * k // count for k in range(count + 1)]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:])]


def image_bands(shape, pieces: int, *, least: int | None = None) -> list[tuple[int, int]]:
    """:func:`row_bands` of an (H, W, ...) image: at most ``pieces`` bands, each of at least
    ``least`` pixels (default :data:`BAND_PIXELS`)."""
    h, w = int(shape[0]), max(1, int(shape[1]))
    return row_bands(h, pieces, least=-(-(BAND_PIXELS if least is None else least) // w))


def each(fn, items, threads: int) -> list:
    """``[fn(item) for item in items]``, computed by up to ``threads`` threads; results in order.

    One thread (or one item) runs in the calling thread. The first exception raised by a
    piece (in the order of ``items``, among those that failed) is raised once every piece
    started has ended; pieces not yet started are cancelled (also when this thread is interrupted).
    """
    items = list(items)
    threads = min(int(threads), len(items))
    if threads <= 1:
        return [fn(item) for item in items]
    pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="wdendrite")
    try:
        futures = [pool.submit(fn, item) for item in items]
        wait(futures, return_when=FIRST_EXCEPTION)
    finally:  # (after a failure, or an interrupt of this thread: the pieces not started never start)
        pool.shutdown(wait=True, cancel_futures=True)
    for f in futures:
        if not f.cancelled() and f.exception() is not None:
            raise f.exception()
    return [f.result() for f in futures]
