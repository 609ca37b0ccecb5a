"""Depressions of DEM-amplified Dendry terrains, against the drained control's ``slope``.

Setup (notebook 05's DEM amplification): a 16 x 16 fBm map (``hydrology.fbm_terrain``,
seed 4) scaled to [0, 1] is the image control on [0, 1]^2, filled by
``control.drained(..., slope=S)`` (129 samples, the default), and drives a terrain over
the domain [0, 16]^2, one level-1 cell per map pixel (eps 0.25, delta 0.1, beta 0.5,
noise 0.05, seed 2). For each slope the script prints the level-1 sinks inside the
domain (key points below their 8 neighbours, see ``table1_hydrology.level1_sinks``),
the terrain's depressions (surface and count), the share of the raised surface lying in
basins around a sink, and the correlation of the terrain with the map (the map as the
control reads it, before the fill): how much the fill's tilt moves the terrain away from
the DEM.

The filled basins of the map are nearly flat with the default slope (1e-4 of the range
per sample); a valley narrower than a level-1 cell, or a spill point a sample wide, then
leaves a key point below all 8 of its jittered neighbours, and the rivers around end in a
closed basin. A steeper tilt drains them at the cost of fidelity to the map; so do level-1
outlets (``DendryParams.outlets``), without tilting the map. Each slope runs with the paper's
Table 1 parameters and with the terrain command's (``DendryParams.terrain``: outlets, free
jitter below level 1, primitives nearly on a grid).

Usage: python benchmarks/dem_hydrology.py [--size 1024] [--levels 2] [--slopes 1e-4 1e-3 1e-2]
       [--params paper|terrain|both]
"""

from __future__ import annotations

import argparse
import logging

import numpy as np
import warp as wp

from table1_hydrology import level1_sinks  # (this folder, on the path when run as a script)
from wdendrite import control, hydrology
from wdendrite.dendry import DendryParams, dendry

DOMAIN = ((0.0, 0.0), (16.0, 16.0))


def dem_map() -> control.Control:
    """The 16 x 16 fBm map scaled to [0, 1], as an image control on [0, 1]^2 (before any fill)."""
    coarse = hydrology.fbm_terrain((16, 16), seed=4)
    return control.image((coarse - coarse.min()) / np.ptp(coarse), domain=((0.0, 0.0), (1.0, 1.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="terrain side in pixels (notebook 05: 256)")
    ap.add_argument("--levels", type=int, default=2, help="tree levels (notebook 05: 3)")
    ap.add_argument("--slopes", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2])
    ap.add_argument("--params", default="both", choices=["paper", "terrain", "both"])
    args = ap.parse_args()
    if args.size < 16:
        ap.error(f"--size must be at least 16, got {args.size}")
    wp.config.quiet = True
    wp.config.log_level = logging.WARNING
    wp.init()
    from scipy.ndimage import label

    raw = dem_map()
    ref = raw.grid((args.size, args.size))
    made = {"paper": DendryParams.table1(levels=args.levels, seed=2),
            "terrain": DendryParams.terrain(levels=args.levels, seed=2)}
    chosen = ("paper", "terrain") if args.params == "both" else (args.params,)
    step = args.size / (DOMAIN[1][0] - DOMAIN[0][0])  # pixels per domain unit
    print(f"# DEM amplification, 16^2 map -> {args.size}^2 terrain, levels {args.levels}, drained control (129 samples)")
    print("| params | slope | level-1 sinks | depressions % | depressions # | raised surface in basins around a sink | "
          "correlation with the map |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name, slope in ((n, s) for n in chosen for s in args.slopes):
        params = made[name]
        try:
            ctl = control.drained(raw, slope=slope)
        except ValueError as e:  # (a slope whose rises alone climb past the map's range)
            print(f"| {name} | {slope:g} | refused: {e} | | | | |")
            continue
        sinks = level1_sinks(params, ctl, DOMAIN, points=True)
        z = dendry((args.size, args.size), domain=DOMAIN, params=params, control=ctl, output="elevation")
        d = hydrology.depressions(z)
        lab, _ = label(d.mask, structure=np.ones((3, 3), int))
        # the basins that hold a sink's key point (row i of the image lies at y = (i + 0.5) / step)
        held = {int(lab[min(int(y * step), args.size - 1), min(int(x * step), args.size - 1)]) for x, y in sinks} - {0}
        share = np.isin(lab, list(held)).sum() / max(int(d.mask.sum()), 1)
        corr = float(np.corrcoef(z.ravel(), ref.ravel())[0, 1])
        print(f"| {name} | {slope:g} | {len(sinks)} | {d.percent:.2f} | {d.count} | {100 * share:.0f} % | {corr:.3f} |")


if __name__ == "__main__":
    main()
