"""Dendry throughput in pixels per second against the authors' C++ implementation.

Workload: the paper's Table 1 setup (noise domain [0, 4]^2, eps 0.25, delta 0.1,
beta 0.5, noise 0.05, Perlin control on (-0.2, -0.4)-(1.4, 0.7)) at levels 1-6,
distance and elevation, and a 1024^2 Lichtenberg figure with 6 levels. The
cached mode computes whole images; the per-pixel mode, whose cost per pixel
does not depend on the image size, is timed on a ``--pixel-window`` square
window of the image. Each image case is run ``--repeat`` times after a warm-up that
compiles the kernels; the median and the best rate are printed. Peer: the authors' C++
(-O3) on a machine like ours, one core.
``--search`` picks the neighbourhoods (DendryParams.search): ``exact``, our
default, searches as wide as measured to miss no link; ``paper`` searches the
paper's 3 x 3 cells for links, as the peer does. Then ``dendry_points`` in its three
modes (``--points`` random points: uniform over the image's domain, in 40 tight
clusters over a domain 500 times wider, and in 1000 small clusters over it).

Usage: python benchmarks/bench_dendry.py [--sizes 512 1024] [--levels 1 2 3 4 5 6] [--pixel-window 96]
       [--lichtenberg-size 1024] [--search exact paper] [--points 20000] [--repeat 3] [--device cpu]
"""

from __future__ import annotations

import argparse
import itertools
import logging
import time

import numpy as np
import warp as wp

from wdendrite import control
from wdendrite.dendry import DendryParams, dendry, dendry_points

# seconds for a 512^2 image (Table 1 setup) or the Lichtenberg figure, authors' C++ on one core
PEER = {("table1", 1, "elevation", 512): 10.7, ("table1", 2, "elevation", 512): 13.7,
        ("table1", 3, "elevation", 512): 24.5, ("table1", 2, "distance", 512): 11.0,
        ("lichtenberg", 6, "distance", 1024): 113.0}


def _case(kind: str, levels: int, search: str = "exact"):
    if kind == "lichtenberg":
        p = DendryParams(levels=levels, eps=0.25, delta=0.05, rule="lichtenberg", resolution=2.0, search=search)
        return dict(domain=((-1.0, -1.0), (1.0, 1.0)), params=p, control=control.lichtenberg())
    p = DendryParams(levels=levels, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0, search=search)
    ctl = control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7)))
    return dict(domain=((0.0, 0.0), (4.0, 4.0)), params=p, control=ctl)


def _rate(size: int, mode: str, window: int, device, **kw) -> float:
    window = min(window, size)  # (a window as large as the image: the whole image, pixel by pixel)
    win = None if mode == "cached" else ((size - window) // 2, (size - window) // 2, window, window)
    t = time.perf_counter()
    out = dendry((size, size), window=win, mode=mode, device=device, **kw)
    wp.synchronize_device(device)
    return out.size / (time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--pixel-window", type=int, default=96)
    ap.add_argument("--lichtenberg-size", type=int, default=1024, help="side of the Lichtenberg figure (0: skip it)")
    ap.add_argument("--search", nargs="+", default=["exact", "paper"], choices=["exact", "paper"])
    ap.add_argument("--points", type=int, default=20000,
                    help="random points per dendry_points case, in each mode (0: skip the point cases; else at "
                         "least 1000); those cases take the Table 1 setup at 2 levels and the Lichtenberg figure, "
                         "exact search, whatever --levels and --search say")
    ap.add_argument("--repeat", type=int, default=3,
                    help="times each image case is run; the median and the best rate are printed")
    ap.add_argument("--device", default=None)
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if min(args.sizes) < 1 or args.pixel_window < 1:
        ap.error(f"--sizes and --pixel-window must be at least 1, got {args.sizes} and {args.pixel_window}")
    if not all(1 <= lv <= 6 for lv in args.levels):
        ap.error(f"--levels must lie in 1-6, got {args.levels}")
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
    # warm-up: compile every kernel once
    for out in ("distance", "elevation"):
        for mode in ("cached", "pixel"):
            for search in args.search:
                dendry((16, 16), output=out, mode=mode, device=device, **_case("table1", 2, search))
    print(f"# Dendry throughput on {device} ({device.name}), one launch stream, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(f"# px/s: median and best of {args.repeat} runs; ratios against the peer's px/s")
    print("| workload | size | levels | output | search | mode | px/s median | px/s best | peer px/s "
          "| ratio median | ratio best |")
    print("| --- | ---: | ---: | --- | --- | --- | ---: | ---: | ---: | ---: | ---: |")
    cases = [("table1", size, lv, out) for size in args.sizes for lv in args.levels for out in ("distance", "elevation")]
    if args.lichtenberg_size > 0:
        cases.append(("lichtenberg", args.lichtenberg_size, 6, "distance"))
    for (kind, size, levels, out), search in itertools.product(cases, args.search):
        kw = _case(kind, levels, search)
        for mode in ("cached", "pixel"):
            rates = [_rate(size, mode, args.pixel_window, device, output=out, **kw) for _ in range(args.repeat)]
            mid, best = float(np.median(rates)), max(rates)
            peer = PEER.get((kind, levels, out, size))
            peer_rate = size * size / peer if peer else None
            ratios = f"{mid / peer_rate:.1f}x | {best / peer_rate:.1f}x" if peer_rate else "- | -"
            peer_txt = f"{peer_rate:,.0f}" if peer_rate else "-"
            print(f"| {kind} | {size}^2 | {levels} | {out} | {search} | {mode} | {mid:,.0f} | {best:,.0f} | {peer_txt} "
                  f"| {ratios} |", flush=True)
    if args.points > 0:
        _point_rates(args.points, device)


def _point_rates(count: int, device) -> None:
    """dendry_points in each mode: points uniform over the image's domain, and the same number
    in 40 tight clusters spread over a domain 500 times wider (one tile each), and in 1000 small
    clusters over it (mostly one tile each)."""
    rng = np.random.default_rng(0)
    print(f"\n# dendry_points, {count} points per case; peer: its per-pixel rate (it has no point API)")
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
        size = 1024 if kind == "lichtenberg" else 512
        peer = PEER.get((kind, levels, out, size))
        sets = (("uniform", uniform, kw["domain"]), ("40 clusters", clusters, wide),
                (f"1000 clusters of {small}", many, wide))
        for name, pts, domain in sets:
            case = dict(kw, domain=domain)
            for mode in ("pixel", "cached", "auto"):
                dendry_points(pts[:50], output=out, mode=mode, device=device, **case)  # compile, warm
                t = time.perf_counter()
                dendry_points(pts, output=out, mode=mode, device=device, **case)
                wp.synchronize_device(device)
                rate = len(pts) / (time.perf_counter() - t)
                ratio = f"{rate / (size * size / peer):.1f}x" if peer else "-"
                peer_txt = f"{size * size / peer:,.0f}" if peer else "-"
                print(f"| {kind} | {levels} | {out} | {name} | {mode} | {rate:,.0f} | {peer_txt} | {ratio} |", flush=True)


if __name__ == "__main__":
    main()
