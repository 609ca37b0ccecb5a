"""Dendry throughput in pixels per second: wdendrite against the authors' C++, run live.

Workloads: the paper's Table 1 setup (noise domain [0, 4]^2, eps 0.25, delta 0.1,
beta 0.5, noise 0.05, Perlin control on (-0.2, -0.4)-(1.4, 0.7), seed 0) at
``--size`` (512) and ``--levels`` (2), ``--outputs`` (elevation), and the
Lichtenberg figure (6 levels, eps 0.25, delta 0.05, distance) at
``--lichtenberg-size`` (1024; 0 skips it).

The peer is the authors' library (``dendry_peer.py`` builds it with our driver
``dendry_peer.cpp``: ``-O3 -march=native``, one thread, kept in a cache folder
outside the repository). Each case runs ``--repeat`` times (default 5) in turns:
the peer, then ours pixel by pixel (``mode="pixel"``, the paper's evaluation) and
with cached cells (``mode="cached"``) for each ``--search``: ``exact``, our
default, searches as wide as measured to miss no link; ``paper`` searches the
paper's 3 x 3 cells for links, as the peer does. The peer and our per-pixel mode
evaluate the same pixels: every ``--row-step``-th row of the image (by default
the least step that keeps them within 2^18 pixels: every row of the 512^2 image,
every 4th of the 1024^2 figure; our per-pixel mode then takes one call per row,
whose set-up it pays), or with ``--pixel-window N`` a centred N x N window; the
cached mode computes the whole image. Pixels per
second are printed as median (range) per side, and the ratios as the median
(range) over the repeats, each ours against the peer's run of the same turn.
Only the evaluation is timed: the peer's pixel loop, our ``dendry`` call from
its arguments to the NumPy image (kernels compiled and loaded before).

A sanity line per case shows that both compute the same kind of value: the
range and mean over the peer's pixels (elevations in control units; distances in
domain units, where the peer's level-1 cell is 1 and ours ``1 / resolution``).

Without a C++ compiler (or without the peer's source) the ratios fall back to
the peer figures recorded below from an earlier run, and the output says so on
every line that uses them.

Then ``dendry_points`` in its three modes (``--points`` random points: uniform
over the image's domain, in 40 tight clusters over a domain 500 times wider, and
in 1000 small clusters over it), ``--repeat`` runs with the modes in turns,
against the peer's per-pixel rate of the same setup measured above (it has no
point API).

Usage: python benchmarks/bench_dendry.py [--quick] [--size 512] [--levels 2] [--outputs elevation distance]
       [--lichtenberg-size 1024] [--row-step N | --pixel-window N] [--search exact paper] [--points 20000]
       [--repeat 5] [--device cpu]
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np
import warp as wp

import dendry_peer
from _measure import cpu_model, interleaved, now, shown, spread
from wdendrite import control
from wdendrite.dendry import DendryParams, dendry, dendry_points

# The peer's pixels per second, used only when it cannot be built here: its driver run by hand on
# 2026-12-07 22:43 UTC (Intel Xeon VM, 2 cores, g++ 12.2 -O3 -march=native, one thread) on centred
# windows of these setups (128^2 of the Table 1 image, 64^2 of the Lichtenberg figure), faster than
# BENCHMARKS.md's runs on the then busier machine, so ratios against them err low.
RECORDED = {("table1", 2, "elevation"): 14_700.0, ("lichtenberg", 6, "distance"): 9_400.0}
RECORDED_NOTE = "recorded 2026-12-07 on an Intel Xeon VM by hand, NOT measured in this run"


def _case(kind: str, levels: int, search: str = "exact"):
    if kind == "lichtenberg":
        p = DendryParams(levels=levels, eps=0.25, delta=0.05, rule="lichtenberg", resolution=2.0, search=search)
        return dict(domain=((-1.0, -1.0), (1.0, 1.0)), params=p, control=control.lichtenberg())
    p = DendryParams(levels=levels, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0, search=search)
    ctl = control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7)))
    return dict(domain=((0.0, 0.0), (4.0, 4.0)), params=p, control=ctl)


def _ours(size: int, pixels, device, **kw) -> tuple[float, np.ndarray]:
    """Seconds and values of ours on ``pixels`` (see ``_pixels``; None: the whole image)."""
    if pixels is None:
        windows = [None]
    else:
        r0, c0, rows, cols, step = pixels
        windows = [(r0, c0, rows, cols)] if step == 1 else [(r0 + k * step, c0, 1, cols) for k in range(rows)]
    t = time.perf_counter()
    out = [dendry((size, size), window=win, device=device, **kw) for win in windows]
    wp.synchronize_device(device)
    return time.perf_counter() - t, np.concatenate(out)


def _pixels(size: int, side: int | None, step: int | None) -> tuple[int, int, int, int, int]:
    """(row0, col0, rows, cols, step): a centred ``side`` square, else every ``step``-th row (default:
    the least step keeping them within 2^18 pixels)."""
    if side is not None:
        side = min(side, size)
        return ((size - side) // 2, (size - side) // 2, side, side, 1)
    step = step or -(-size * size // 2**18)
    return (0, 0, -(-size // step), size, step)


def _sanity(values: np.ndarray) -> str:
    ok = values[np.isfinite(values)]
    return f"[{ok.min():.4g}, {ok.max():.4g}] mean {ok.mean():.4g}" if ok.size else "no finite value"


def _measure_case(kind, size, levels, out, args, device, peer):
    """Prints the table's rows for one workload; returns the peer's median px/s (or the recorded
    one, None without either) and a line comparing both sides' values."""
    win = _pixels(size, args.pixel_window, args.row_step)
    pixels = win[2] * win[3]
    peer_rates, ours = [], {}
    sanity = {}
    for _ in range(args.repeat):
        if peer is not None:
            run = dendry_peer.run(peer, f"{kind}-{out}", levels=levels, shape=(size, size), pixels=win)
            peer_rates.append(run.pixels / run.seconds)
            sanity["peer"] = f"[{run.min:.4g}, {run.max:.4g}] mean {run.mean:.4g}"
        for search in args.search:
            kw = dict(_case(kind, levels, search), output=out)
            t, img = _ours(size, win, device, mode="pixel", **kw)
            ours.setdefault(("pixel", search), []).append(pixels / t)
            sanity[f"ours, {search} search"] = _sanity(img)
            t, _ = _ours(size, None, device, mode="cached", **kw)
            ours.setdefault(("cached", search), []).append(size * size / t)
    recorded = peer is None
    if recorded:
        rate = RECORDED.get((kind, levels, out))
        peer_rates = [rate] * args.repeat if rate else []
    if not peer_rates:
        peer_txt = "-"
    else:
        peer_txt = f"{peer_rates[0]:,.0f} (recorded)" if recorded else shown(peer_rates, ",.0f")
    label = f"{kind} {size}^2, {levels} levels, {out}"
    for (mode, search), rates in ours.items():
        if peer_rates:
            ratio = shown([o / p for o, p in zip(rates, peer_rates)], ".1f", "x")
        else:
            ratio = "- (no peer figure)"
        print(f"| {label} | {search} | {mode} | {shown(rates, ',.0f')} | {peer_txt} | {ratio} |", flush=True)
    r0, c0, rows, cols, step = win
    if rows * step >= size and cols == size:
        what = "the whole image" if step == 1 else f"one row in {step}"
    else:
        what = f"window {(r0, c0, rows, cols)}"
    line = f"# {label} ({what}): " + "; ".join(f"{k} {v}" for k, v in sanity.items())
    return (spread(peer_rates)[0] if peer_rates else None), line


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="a small run: per-pixel modes on a 64^2 window (32^2 for the Lichtenberg figure), "
                         "2000 points")
    ap.add_argument("--size", type=int, default=512, help="side of the Table 1 image")
    ap.add_argument("--levels", type=int, nargs="+", default=[2], help="Table 1 levels, 1-5 (the peer's range)")
    ap.add_argument("--outputs", nargs="+", default=["elevation"], choices=["elevation", "distance"])
    ap.add_argument("--lichtenberg-size", type=int, default=1024, help="side of the Lichtenberg figure (0: skip it)")
    ap.add_argument("--pixel-window", type=int, default=None,
                    help="time the per-pixel modes (the peer's and ours) on a centred square of this side "
                         "(default: rows spread over the whole image, see --row-step)")
    ap.add_argument("--row-step", type=int, default=None,
                    help="time the per-pixel modes on every N-th row of the image (default: the least N that "
                         "keeps them within 2^18 pixels; 1: the whole image)")
    ap.add_argument("--search", nargs="+", default=["exact", "paper"], choices=["exact", "paper"])
    ap.add_argument("--points", type=int, default=None,
                    help="random points per dendry_points case, in each mode (0: skip them; else at least 1000; "
                         "default 20000, 2000 with --quick); those cases take the Table 1 setup at 2 levels and "
                         "the Lichtenberg figure, exact search")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each side per case, in turns (default 5)")
    ap.add_argument("--device", default=None)
    args = ap.parse_args()
    if args.points is None:
        args.points = 2000 if args.quick else 20000
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if min(args.size, args.pixel_window or 1, args.row_step or 1) < 1:
        ap.error(f"--size, --pixel-window and --row-step must be at least 1, got {args.size}, {args.pixel_window} "
                 f"and {args.row_step}")
    if not all(1 <= lv <= 5 for lv in args.levels):
        ap.error(f"--levels must lie in 1-5 (the peer's terrain levels), got {args.levels}")
    if args.lichtenberg_size < 0:
        ap.error(f"--lichtenberg-size must be 0 (skip) or positive, got {args.lichtenberg_size}")
    if args.points < 0 or 0 < args.points < 1000:
        ap.error(f"--points must be 0 (skip) or at least 1000 (1000 clusters of at least one point), got {args.points}")
    wp.config.quiet = True
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    try:
        device = wp.get_device(args.device)
    except (RuntimeError, ValueError) as exc:
        ap.error(f"--device {args.device!r}: {exc}")
    peer, how = dendry_peer.build()
    # warm-up: compile (or load) every kernel once
    for out in ("distance", "elevation"):
        for mode in ("cached", "pixel"):
            for search in args.search:
                dendry((16, 16), output=out, mode=mode, device=device, **_case("table1", 2, search))
                dendry((16, 16), output="distance", mode=mode, device=device, **_case("lichtenberg", 6, search))
    print(f"# Dendry throughput  {now()}  {cpu_model()}  device {device} ({device.name}), one launch stream")
    if peer is None:
        print(f"# !!! THE PEER WAS NOT RUN: {how}.\n# !!! Ratios divide by the peer's px/s {RECORDED_NOTE}.")
    else:
        print(f"# peer: the authors' Dendry, {how}, run in this run")
    print(f"# px/s: median (range) of {args.repeat} runs per side, in turns; ratio: ours / the peer's run of the "
          "same turn, median (range)")
    print("| workload | search | mode | ours px/s | peer px/s | ratio |")
    print("| --- | --- | --- | ---: | ---: | ---: |")
    measured = {}
    cases = [("table1", args.size, lv, out) for lv in args.levels for out in args.outputs]
    if args.lichtenberg_size > 0:
        cases.append(("lichtenberg", args.lichtenberg_size, 6, "distance"))
    saved, lines = args.pixel_window, []
    for kind, size, levels, out in cases:
        if args.quick and saved is None:
            args.pixel_window = 32 if kind == "lichtenberg" else 64
        measured[(kind, levels, out)], line = _measure_case(kind, size, levels, out, args, device, peer)
        lines.append(line)
        args.pixel_window = saved
    print("\n# the same kind of values on both sides: range and mean over the peer's pixels (elevations in "
          "control units, distances in domain units)")
    print("\n".join(lines))
    if args.points > 0:
        _point_rates(args.points, device, measured, args.repeat, recorded=peer is None)


def _point_rates(count: int, device, peer_rates: dict, repeat: int, *, recorded: bool) -> None:
    """dendry_points in each mode: points uniform over the image's domain, and the same number
    in 40 tight clusters spread over a domain 500 times wider (one tile each), and in 1000 small
    clusters over it (mostly one tile each)."""
    rng = np.random.default_rng(0)
    note = f" ({RECORDED_NOTE})" if recorded else ", measured above"
    print(f"\n# dendry_points, {count} points per case; points/s: median (range) of {repeat} runs, the modes in "
          f"turns; peer: its per-pixel rate of the setup{note} (median)")
    print("| workload | levels | output | points | mode | points/s | peer px/s | ratio |")
    print("| --- | ---: | --- | --- | --- | ---: | ---: | ---: |")
    for kind, levels, out in (("table1", 2, "distance"), ("table1", 2, "elevation"), ("lichtenberg", 6, "distance")):
        kw = _case(kind, levels)
        (x0, y0), (x1, y1) = kw["domain"]
        span = np.array([x1 - x0, y1 - y0])
        uniform = np.array([x0, y0]) + rng.random((count, 2)) * span
        wide = ((x0, y0), (x0 + 500 * span[0], y0 + 500 * span[1]))
        centres = np.array([x0, y0]) + rng.random((40, 1, 2)) * 500 * span
        clusters = (centres + rng.random((40, count // 40, 2)) * 0.05 * span).reshape(-1, 2)
        # small clusters: whether a tile's fixed cost pays off decides
        small = count // 1000
        centres = np.array([x0, y0]) + rng.random((1000, 1, 2)) * 500 * span
        many = (centres + rng.random((1000, small, 2)) * 0.02 * span).reshape(-1, 2)
        peer = peer_rates.get((kind, levels, out))
        sets = (("uniform", uniform, kw["domain"]), ("40 clusters", clusters, wide),
                (f"1000 clusters of {small}", many, wide))
        for name, pts, domain in sets:
            case = dict(kw, domain=domain)
            sides = {}
            for mode in ("pixel", "cached", "auto"):
                dendry_points(pts[:50], output=out, mode=mode, device=device, **case)  # compile, warm

                def run(mode=mode):
                    dendry_points(pts, output=out, mode=mode, device=device, **case)
                    wp.synchronize_device(device)

                sides[mode] = run
            for mode, (seconds, _) in interleaved(sides, repeat).items():
                rates = [len(pts) / t for t in seconds]
                ratio = shown([r / peer for r in rates], ".1f", "x") if peer else "-"
                peer_txt = f"{peer:,.0f}" if peer else "- (not measured)"
                print(f"| {kind} | {levels} | {out} | {name} | {mode} | {shown(rates, ',.0f')} | {peer_txt} | {ratio} |",
                      flush=True)


if __name__ == "__main__":
    main()
