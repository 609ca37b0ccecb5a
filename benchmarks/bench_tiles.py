"""Tiled images written to disk: wdendrite's ``write_tiled`` against Dask's own ``store``.

Workloads:

- ``trivial``: tiles that cost nothing to compute (a ramp), so the figures are
  the writers' own overhead per tile.
- ``terrain``: a Dendry terrain (the paper's Table 1 setup), tile by tile.

Each is written three ways into an NPY file: ``write_tiled`` in this process
(no Dask), ``write_tiled`` on a one-worker, one-thread Dask ``LocalCluster``
(one task per tile), and the way a Dask user would without us: the same tiles
as the blocks of a Dask array (:func:`wdendrite.batch.tiled_array`) stored into
a NumPy memmap with ``dask.array.store`` on Dask's threaded scheduler with one
thread (a memmap cannot be shipped to a cluster's workers: they would write a
copy). All three files are compared bit for bit. Times are the best of
``--repeat`` runs; everything runs on one core.

Run: ``python benchmarks/bench_tiles.py`` (``--quick`` for a smoke test).
"""

from __future__ import annotations

import argparse
import functools
import tempfile
import time
from pathlib import Path

import numpy as np


def ramp(window):
    r0, c0, h, w = window
    return np.add.outer(np.arange(r0, r0 + h) * 1000.0, np.arange(c0, c0 + w)).astype(np.float32)


def _best(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, one run")
    ap.add_argument("--repeat", type=int, default=3, help="runs per case (best kept)")
    args = ap.parse_args()
    import dask.array as da
    import distributed
    import warp as wp

    wp.config.quiet = True
    from wdendrite import batch
    from wdendrite._models import TABLE1, dendry_setup

    repeat = 1 if args.quick else args.repeat
    setup = dendry_setup(256 if args.quick else 1024, TABLE1, extent=4.0, control="perlin", frequency=1.0,
                         drained=True, seed=0)
    terrain = functools.partial(batch._dendry_tile, setup=setup, output="elevation", device="cpu")
    cases = [("trivial", ramp, (256, 256) if args.quick else (512, 512), 16),
             ("terrain", terrain, setup["shape"], 64 if args.quick else 128)]
    print("# bench_tiles  %s  best of %d" % (time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), repeat))
    print(f"{'workload':>9} {'image':>10} {'tiles':>6} | {'plain s':>8} {'dask map s':>10} {'da.store s':>10} | "
          f"{'store/map':>9} {'store/plain':>11}")
    with tempfile.TemporaryDirectory() as tmp, \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                     dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        tmp = Path(tmp)
        for name, fn, shape, tile in cases:
            fn((0, 0, 1, 1))  # compiled before any timing
            tiles = len(batch.tile_windows(shape, tile))
            plain = _best(lambda: batch.write_tiled(fn, shape, tile, tmp / "plain.npy"), repeat)
            mapped = _best(lambda: batch.write_tiled(fn, shape, tile, tmp / "map.npy", client=client), repeat)

            def store():
                from numpy.lib.format import open_memmap

                mm = open_memmap(tmp / "store.npy", mode="w+", dtype=np.float32, shape=shape)
                da.store(batch.tiled_array(fn, shape, tile), mm, lock=False, scheduler="threads", num_workers=1)
                mm.flush()
                del mm

            stored = _best(store, repeat)
            a, b, c = (np.load(tmp / f) for f in ("plain.npy", "map.npy", "store.npy"))
            assert np.array_equal(a, b) and np.array_equal(a, c), "the three files differ"
            print(f"{name:>9} {'x'.join(map(str, shape)):>10} {tiles:>6} | {plain:8.3f} {mapped:10.3f} {stored:10.3f} | "
                  f"{stored / mapped:8.2f}x {stored / plain:10.2f}x")


if __name__ == "__main__":
    main()
