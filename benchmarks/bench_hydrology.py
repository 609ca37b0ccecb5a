"""Drainage area (D8 and D-infinity): wdendrite against pysheds and against plain NumPy.

Terrains: the Dendry terrain of the paper's Table 1 setup (seed 0, levels 2) at each
``--sizes``, and an fBm terrain (8 octaves) at the largest size. Each side gets the same
float64 elevation file and computes flow directions and accumulation, unfilled (the fill
is the same scikit-image reconstruction on every side, timed once on its own):

- ``wdendrite``: ``hydrology.flow_accumulation`` (a receiver kernel, one thread per cell,
  then one thread walking the flow graph; Warp's CPU device);
- ``pysheds``: ``Grid.flowdir`` + ``Grid.accumulation`` with the same routing (numba);
  it needs NumPy < 2.4 (it calls ``np.in1d``), so it usually lives in an environment of
  its own: pass its interpreter with ``--pysheds-python`` (default: this interpreter if
  it can import pysheds, else the column is skipped);
- ``numpy``: what a user writes without either: the receivers vectorized with NumPy, then
  a Python loop over the cells from highest to lowest (wdendrite's own code until
  2026-12-02).

With ``--filled`` the rows ``d8+fill`` and ``dinf+fill`` add each side's conditioning inside
its time: ours fills (scikit-image) and drains the flats towards lower terrain and away from
higher (``filled=True``); pysheds runs ``fill_depressions`` and ``resolve_flats``, the same
idea (Barnes et al. 2014) with other details: distances counted in steps of 1 rather than
2 and 3, the flats raised by tiny increments and then routed as slopes (so D-infinity
splits flow there, where ours keeps one receiver), hence "same" is lower on those rows.

Every measurement runs in a fresh process (``_measure.run_isolated``): wall time of the
call (compilation and JIT warmed up on a small terrain first) and the growth of the peak
resident set. Each side runs ``--repeat`` times, in turns; the median (range) of the
seconds and the median of the memory are printed, with each peer's time as a
multiple of ours and the share of cells where its areas equal ours (to 1e-6 relative: the
areas are compared as the float32 files the children save).

Usage: python benchmarks/bench_hydrology.py [--quick] [--repeat N] [--pysheds-python PATH]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

import numpy as np

from _measure import cpu_model, now, run_isolated, shown

# ---------------------------------------------------------------------------- the three sides (child processes)


def _quiet_warp():
    import logging

    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = logging.WARNING  # no start-up banner


def wdendrite_case(path: str, method: str):
    _quiet_warp()
    from wdendrite import hydrology

    routing, _, filled = method.partition("+")

    def area(z):
        return hydrology.flow_accumulation(z, method=routing, filled=bool(filled))

    def prepare():
        area(np.random.default_rng(0).random((32, 32)))  # load the kernels
        return np.load(path)

    return prepare, lambda z: {"_save": (path + ".wdendrite.npy", area(z))}


def pysheds_case(path: str, method: str):
    from pysheds.grid import Grid
    from pysheds.sview import Raster, ViewFinder

    routing, _, filled = method.partition("+")

    def area(z):
        vf = ViewFinder(shape=z.shape)
        grid = Grid(viewfinder=vf)
        dem = Raster(z, viewfinder=vf)
        if filled:  # pysheds' own conditioning: priority-flood fill, then flats made to drain
            dem = grid.resolve_flats(grid.fill_depressions(dem))
        fdir = grid.flowdir(dem, routing=routing)
        return np.asarray(grid.accumulation(fdir, routing=routing))

    def prepare():
        area(np.random.default_rng(0).random((32, 32)))  # numba compiles here
        return np.load(path)

    return prepare, lambda z: {"_save": (path + ".pysheds.npy", area(z))}


def numpy_case(path: str, method: str):
    return (lambda: np.load(path)), lambda z: {"_save": (path + ".numpy.npy", numpy_accumulation(z, method))}


_D8 = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])
_FACETS = [((0, 1), (-1, 1)), ((-1, 0), (-1, 1)), ((-1, 0), (-1, -1)), ((0, -1), (-1, -1)),
           ((0, -1), (1, -1)), ((1, 0), (1, -1)), ((1, 0), (1, 1)), ((0, 1), (1, 1))]


def _around(pad, off, shape):
    return pad[1 + off[0]: 1 + off[0] + shape[0], 1 + off[1]: 1 + off[1] + shape[1]]


def numpy_accumulation(z: np.ndarray, method: str) -> np.ndarray:
    """Receivers with NumPy array operations, then the areas passed on in a Python loop."""
    h, w = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    rows, cols = np.mgrid[0:h, 0:w]
    if method == "d8":
        drops = np.stack([(z - _around(pad, o, z.shape)) / np.hypot(*o) for o in _D8])
        best = np.argmax(drops, axis=0)
        falls = np.take_along_axis(drops, best[None], 0)[0] > 0
        recs = [np.where(falls, (rows + _D8[best, 0]) * w + cols + _D8[best, 1], -1).ravel()]
        shares = [np.ones(h * w)]
    else:
        slopes, angles = [], []
        for e1, e2 in _FACETS:
            z1, z2 = _around(pad, e1, z.shape), _around(pad, e2, z.shape)
            with np.errstate(invalid="ignore"):
                s1, s2 = z - z1, z1 - z2
                a = np.arctan2(s2, s1)
                sl = np.where(a < 0, s1, np.hypot(s1, s2))
                a = np.maximum(a, 0.0)
                sl = np.where(a > np.pi / 4, (z - z2) / np.sqrt(2.0), sl)
                a = np.minimum(a, np.pi / 4)
            slopes.append(np.where(np.isfinite(z1), sl, -np.inf))
            angles.append(np.where(np.isfinite(z1), a, 0.0))
        slopes, angles = np.stack(slopes), np.stack(angles)
        best = np.argmax(slopes, axis=0)
        falls = np.take_along_axis(slopes, best[None], 0)[0] > 0
        f2 = (np.take_along_axis(angles, best[None], 0)[0] / (np.pi / 4)).ravel()
        e1 = np.array([f[0] for f in _FACETS])[best]
        e2 = np.array([f[1] for f in _FACETS])[best]
        r1 = np.where(falls, (rows + e1[..., 0]) * w + cols + e1[..., 1], -1).ravel()
        r2 = np.where(falls, (rows + e2[..., 0]) * w + cols + e2[..., 1], -1).ravel()
        r2 = np.where(f2 > 0, r2, r1)
        recs, shares = [np.where(f2 < 1, r1, r2), r2], [1.0 - f2, f2]
    order = np.argsort(-z.ravel(), kind="stable")
    area = [1.0] * (h * w)
    rl = [r[order].tolist() for r in recs]
    fl = [f[order].tolist() for f in shares]
    if len(rl) == 1:
        for i, r in zip(order.tolist(), rl[0]):
            if r >= 0:
                area[r] += area[i]
    else:
        for i, r1, r2, f1, f2 in zip(order.tolist(), rl[0], rl[1], fl[0], fl[1]):
            if r1 >= 0:
                a = area[i]
                area[r1] += f1 * a
                area[r2] += f2 * a
    return np.asarray(area).reshape(h, w)


# ---------------------------------------------------------------------------- driver


def serpentine(h: int, w: int) -> np.ndarray:
    """The flat drainers' worst case: a one-cell-wide flat winding row by row through walls over
    the whole h x w terrain, out at (1, 0), its far end about h * w / 2 cells away (the tests use
    it too: its distances wrap the drainer's ring of buckets many times)."""
    z = np.full((h, w), 10.0)
    z[1:-1:2, 1:-1] = 5.0
    for r in range(2, h - 2, 2):
        z[r, w - 2 if r % 4 == 2 else 1] = 5.0
    z[1, 0] = 5.0
    return z


def _terrains(sizes: list[int], folder: str, serpentine_size: int = 0) -> list[tuple[str, str]]:
    _quiet_warp()
    from wdendrite import control, hydrology
    from wdendrite.dendry import DendryParams, dendry

    p = DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0)
    ctl = control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7)))
    out = []
    for n in sizes:
        z = dendry((n, n), domain=((0.0, 0.0), (4.0, 4.0)), params=p, control=ctl, output="elevation")
        out.append((f"dendry {n}^2", z))
    n = max(sizes)
    out.append((f"fbm {n}^2", hydrology.fbm_terrain((n, n), seed=0)))
    if serpentine_size:
        out.append((f"serpentine {serpentine_size}^2", serpentine(serpentine_size, serpentine_size)))
    files = []
    for name, z in out:
        path = os.path.join(folder, name.replace(" ", "_").replace("^", "") + ".npy")
        np.save(path, np.asarray(z, dtype=np.float64))
        files.append((name, path))
    return files


def _agree(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.isclose(a, b, rtol=1e-6, atol=0.0).mean())


def _pysheds_python(arg: str | None) -> str | None:
    python = arg or sys.executable
    ok = subprocess.run([python, "-c", "import pysheds.grid"], capture_output=True).returncode == 0
    if not ok and arg:
        raise SystemExit(f"--pysheds-python {arg!r} cannot import pysheds")
    return python if ok else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--repeat", type=int, default=5, help="fresh-process runs per side, in turns (default 5)")
    ap.add_argument("--pysheds-python", default=None, help="interpreter of an environment with pysheds")
    ap.add_argument("--quick", action="store_true", help="256^2 only, one run (a smoke test)")
    ap.add_argument("--filled", action="store_true",
                    help="also filled terrains ('+fill'): our fill and flat draining against pysheds' "
                         "fill_depressions + resolve_flats, each side's fill inside its time")
    ap.add_argument("--serpentine", type=int, default=0, metavar="N",
                    help="also an N x N terrain whose one flat winds through all of it (the flat draining's "
                         "worst case; 0: none)")
    args = ap.parse_args()
    if args.quick:
        args.sizes, args.repeat = [256], 1
    peer = _pysheds_python(args.pysheds_python)
    print(f"# Drainage area, {now()}, {cpu_model()}; seconds: median (range) of {args.repeat} fresh-process runs "
          "per side, in turns; MiB: medians; pysheds: "
          f"{'yes (' + peer + ')' if peer else 'not found (pass --pysheds-python)'}")
    print("| terrain | method | wdendrite s | MiB | pysheds s | MiB | pysheds / ours | same | NumPy s | MiB | NumPy / ours | same |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as folder:
        for name, path in _terrains(args.sizes, folder, args.serpentine):
            for method in ("d8", "dinf") + (("d8+fill", "dinf+fill") if args.filled else ()):
                sides = [("wdendrite", "wdendrite_case", None)]
                if peer:
                    sides.append(("pysheds", "pysheds_case", peer))
                if "+" not in method:  # (the NumPy way has no fill of its own)
                    sides.append(("numpy", "numpy_case", None))
                runs = {s: [] for s, _, _ in sides}
                for _ in range(args.repeat):
                    for side, fn, python in sides:
                        runs[side].append(run_isolated("bench_hydrology", fn, python=python, path=path, method=method))
                ours_t = [r["seconds"] for r in runs["wdendrite"]]
                ours_s = statistics.median(ours_t)
                ours = np.load(runs["wdendrite"][0]["result"]["file"]).astype(np.float64)
                ours_mib = statistics.median(r["peak_mib"] for r in runs["wdendrite"])
                cells = [name, method, shown(ours_t), f"{ours_mib:.0f}"]
                for side in ("pysheds", "numpy"):
                    if side not in runs:
                        cells += ["-"] * 4
                        continue
                    t = [r["seconds"] for r in runs[side]]
                    s = statistics.median(t)
                    theirs = np.load(runs[side][0]["result"]["file"]).astype(np.float64)
                    cells += [shown(t), f"{statistics.median(r['peak_mib'] for r in runs[side]):.0f}",
                              f"{s / ours_s:.1f}x", f"{_agree(ours, theirs):.4f}"]
                print("| " + " | ".join(cells) + " |", flush=True)
        # the fill every side would run first (scikit-image), for scale
        import time

        from wdendrite import hydrology

        z = np.load(path)
        t = time.perf_counter()
        hydrology.fill(z)
        print(f"\nfill ({name}, scikit-image reconstruction, the same for every side): {time.perf_counter() - t:.2f} s",
              flush=True)


if __name__ == "__main__":
    main()
