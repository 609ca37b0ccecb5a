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
copy). All three files are compared bit for bit. Each way runs ``--repeat``
times (default 5), the three in turns; the median and the range are printed,
and ratios of the medians. Everything runs on one core.

Run: ``python benchmarks/bench_tiles.py`` (``--quick`` for a smoke test).
"""

from __future__ import annotations

import argparse
import functools
import tempfile
from pathlib import Path

import numpy as np

from _measure import cpu_model, interleaved, now, shown, spread


def ramp(window):
    r0, c0, h, w = window
    return np.add.outer(np.arange(r0, r0 + h) * 1000.0, np.arange(c0, c0 + w)).astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each way per case, in turns (default 5)")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    import dask.array as da
    import distributed
    import warp as wp

    wp.config.quiet = True
    from wdendrite import batch
    from wdendrite._models import TABLE1, dendry_setup

    repeat = args.repeat
    setup = dendry_setup(256 if args.quick else 1024, TABLE1, extent=4.0, control="perlin", frequency=1.0,
                         drained=True, seed=0)
    terrain = functools.partial(batch._dendry_tile, setup=setup, output="elevation", device="cpu")
    cases = [("trivial", ramp, (256, 256) if args.quick else (512, 512), 16),
             ("terrain", terrain, setup["shape"], 64 if args.quick else 128)]
    print(f"# bench_tiles  {now()}  {cpu_model()}  seconds: median (range) of {repeat} runs per way, in turns")
    print("| workload | image | tiles | write_tiled s | write_tiled on Dask s | da.store s | da.store / Dask "
          "| da.store / write_tiled |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp, \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                     dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        tmp = Path(tmp)
        for name, fn, shape, tile in cases:
            fn((0, 0, 1, 1))  # compiled before any timing
            tiles = len(batch.tile_windows(shape, tile))
            def store():
                from numpy.lib.format import open_memmap

                mm = open_memmap(tmp / "store.npy", mode="w+", dtype=np.float32, shape=shape)
                da.store(batch.tiled_array(fn, shape, tile), mm, lock=False, scheduler="threads", num_workers=1)
                mm.flush()
                del mm

            runs = interleaved({"plain": lambda: batch.write_tiled(fn, shape, tile, tmp / "plain.npy"),
                                "mapped": lambda: batch.write_tiled(fn, shape, tile, tmp / "map.npy", client=client),
                                "stored": store}, repeat)
            plain, mapped, stored = (runs[k][0] for k in ("plain", "mapped", "stored"))
            a, b, c = (np.load(tmp / f) for f in ("plain.npy", "map.npy", "store.npy"))
            assert np.array_equal(a, b) and np.array_equal(a, c), "the three files differ"
            mid = {k: spread(v)[0] for k, v in (("plain", plain), ("mapped", mapped), ("stored", stored))}
            print(f"| {name} | {'x'.join(map(str, shape))} | {tiles} | {shown(plain)} | {shown(mapped)} | "
                  f"{shown(stored)} | {mid['stored'] / mid['mapped']:.2f}x | {mid['stored'] / mid['plain']:.2f}x |")


if __name__ == "__main__":
    main()
