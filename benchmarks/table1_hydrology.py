"""Reproduce Table 1 of the Dendry paper: depressions of Dendry terrains against noise baselines.

Setup (the authors' Table 1 configuration): 512^2 pixels over the noise domain
[0, 4]^2, levels 2, eps 0.25, delta 0.1, beta 0.5, noise 0.05, a Perlin control
function on the rectangle (-0.2, -0.4)-(1.4, 0.7), seeds 0-9. Depressions are
the cells a priority-flood fill raises, counted as 8-connected components.

Our Perlin noise is not the authors', so which field the control shows matters: a
field with a minimum inside the rectangle gives the terrain a closed basin there,
and so can a valley too flat along its floor for the jitter (a level-1 key point
on it may lie below all 8 of its neighbours: a sink). The paper's drainage
guarantee holds "provided that the control function c does not include too low
local minima", so by default (``--control-seed draining``) seed s's terrain takes
the s-th control field, in seed order, on which water runs to the border: a 257^2
sampling of ``perlin(seed=k)`` over the rectangle has no depression. The fields
are chosen from the control alone, before any terrain is made. Other choices:
``--control-seed matched`` gives seed s the field ``perlin(seed=s)`` (ten fields,
most with an interior minimum), ``--control-seed N`` one field for all seeds.
The baselines (fBm and ridged multifractal, 8 octaves, frequency 4) use the same
seeds and size. ``--sinks`` adds a column with the level-1 sinks inside the
domain (key points lower than their 8 neighbours, whose segments have length
zero, so the rivers around end in a closed basin): every large Dendry depression
we measured sits around one.

``--drained`` fills the control's interior minima first (wdendrite.control.drained):
a variant, not the paper's setup. ``--search paper`` links with the paper's 3 x 3
cells (as the authors' code does) instead of our exact default (DendryParams.search).

Usage: python benchmarks/table1_hydrology.py [--size 512] [--seeds 10] [--control-seed draining|matched|N]
       [--frequency 1.0] [--drained] [--search exact|paper] [--sinks]
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np
import warp as wp

from wdendrite import control, hydrology
from wdendrite.dendry import DendryParams, dendry

PAPER = {"Multifractal (paper)": (35.9, 1352), "Ridged (paper)": (24.5, 2058), "Dendry (paper, 10 seeds)": (0.8, 52),
         "Dendry (authors' code, measured)": (1.10, 70), "Alps DEM (paper)": (3.3, 798)}


RECTANGLE = ((-0.2, -0.4), (1.4, 0.7))  # the control's rectangle, onto which the noise domain maps
DOMAIN = ((0.0, 0.0), (4.0, 4.0))


def _control(control_seed: int, frequency: float, drained: bool) -> control.Control:
    ctl = control.perlin(seed=control_seed, frequency=frequency, domain=RECTANGLE)
    return control.drained(ctl) if drained else ctl


def _params(seed: int, search: str) -> DendryParams:
    return DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=seed, search=search)


def dendry_terrain(size: int, seed: int, ctl: control.Control, search: str = "exact") -> np.ndarray:
    return dendry((size, size), domain=DOMAIN, params=_params(seed, search), control=ctl, output="elevation")


def draining_fields(count: int, frequency: float = 1.0) -> list[int]:
    """The first ``count`` control seeds whose field drains to the border: a 257^2 sampling of it
    over the rectangle has no depression (water anywhere on it runs off an edge)."""
    found, seed = [], 0
    while len(found) < count:
        if seed >= 100 * count + 100:
            raise RuntimeError(f"fewer than {count} draining fields among control seeds 0-{seed - 1}")
        if hydrology.depressions(_control(seed, frequency, False).grid((257, 257))).count == 0:
            found.append(seed)
        seed += 1
    return found


def level1_sinks(params: DendryParams, ctl: control.Control, domain=DOMAIN, *, points: bool = False) -> list[tuple]:
    """Level-1 cells inside ``domain`` (whose corners lie on level-1 cell corners) that the kernels
    link to themselves: no key point of their 8 neighbours lies lower, so their segments have
    length zero and the rivers around end there. As (column, row), read from the cached mode's
    level-1 segments (ends equal); with ``points``, their key points (x, y) in domain units."""
    from wdendrite.dendry import _cached_tree  # (the cached mode's cells: a diagnostic, not public API)
    from wdendrite.kernels import dendry as _kd

    cells, keyp, verts = _cached_tree((8, 8), domain=domain, params=params, control=ctl)[0]
    still = (keyp[:, 3] == float(_kd.STATE_SEGMENT)) & np.all(verts[:, 0, :2] == verts[:, int(_kd.PIECES), :2], axis=1)
    (x0, y0), (x1, y1) = ((round(v * params.resolution) for v in corner) for corner in domain)
    inside = still & (cells[:, 0] >= x0) & (cells[:, 0] < x1) & (cells[:, 1] >= y0) & (cells[:, 1] < y1)
    if points:
        return [(float(x) / params.resolution, float(y) / params.resolution) for x, y in keyp[inside, :2]]
    return [(int(i), int(j)) for i, j in cells[inside]]


def _largest_percent(mask: np.ndarray) -> float:
    """Share of the surface covered by the largest depression (a basin around a control minimum)."""
    from scipy.ndimage import label

    lab, n = label(mask, structure=np.ones((3, 3), int))
    return 100.0 * np.bincount(lab.ravel())[1:].max() / mask.size if n else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--control-seed", default="draining", help="'draining' (default), 'matched' or an integer")
    ap.add_argument("--frequency", type=float, default=1.0, help="Perlin control frequency (features per unit)")
    ap.add_argument("--drained", action="store_true", help="fill the control's interior minima first (not the paper's setup)")
    ap.add_argument("--search", default="exact", choices=["exact", "paper"], help="link neighbourhoods")
    ap.add_argument("--sinks", action="store_true", help="list each terrain's level-1 sinks (cells inside the domain)")
    args = ap.parse_args()
    if args.size < 2 or args.seeds < 1:
        ap.error(f"--size must be at least 2 and --seeds at least 1, got {args.size} and {args.seeds}")
    named = ("matched", "draining")
    if args.control_seed not in named and not (args.control_seed.isdigit() and int(args.control_seed) < 2**32):
        ap.error(f"--control-seed must be 'matched', 'draining' or an integer in [0, 2**32), got {args.control_seed!r}")
    if not (np.isfinite(args.frequency) and args.frequency > 0):
        ap.error(f"--frequency must be a positive number, got {args.frequency}")
    wp.config.quiet = True
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    rows = {"Dendry (ours)": [], "fBm (ours)": [], "Ridged (ours)": []}
    print(f"# Table 1 reproduction, {args.size}^2, seeds 0-{args.seeds - 1}, control seed {args.control_seed}, "
          f"control frequency {args.frequency}{', drained control' if args.drained else ''}, {args.search} search")
    if args.control_seed == "matched":
        fields = list(range(args.seeds))
    elif args.control_seed == "draining":
        fields = draining_fields(args.seeds, args.frequency)
        print(f"# draining control fields (control seeds) for Dendry seeds 0-{args.seeds - 1}: {fields}")
    else:
        fields = [int(args.control_seed)] * args.seeds
    extra = (" level-1 sinks |", " --- |") if args.sinks else ("", "")
    print("| seed | control seed | Dendry % | Dendry # | largest Dendry depression % | fBm % | fBm # | ridged % | ridged # |"
          + extra[0])
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |" + extra[1])
    t0 = time.perf_counter()
    for seed, cseed in enumerate(fields):
        ctl = _control(cseed, args.frequency, args.drained)  # (one control per seed: a drained one is a fill)
        terrains = {
            "Dendry (ours)": dendry_terrain(args.size, seed, ctl, args.search),
            "fBm (ours)": hydrology.fbm_terrain((args.size, args.size), seed=seed),
            "Ridged (ours)": hydrology.ridged_terrain((args.size, args.size), seed=seed),
        }
        cells = [str(cseed)]
        for name, z in terrains.items():
            d = hydrology.depressions(z)
            rows[name].append((d.percent, d.count))
            cells += [f"{d.percent:.2f}", str(d.count)]
            if name == "Dendry (ours)":
                cells.append(f"{_largest_percent(d.mask):.2f}")
        if args.sinks:
            sinks = level1_sinks(_params(seed, args.search), ctl)
            cells.append(" ".join(f"({i}, {j})" for i, j in sinks) or "-")
        print(f"| {seed} | " + " | ".join(cells) + " |")
    print()
    print("| method | depression surface | # of depressions |")
    print("| --- | ---: | ---: |")
    for name, vals in rows.items():
        v = np.array(vals)
        print(f"| {name}, mean of {len(v)} | {v[:, 0].mean():.2f} % | {v[:, 1].mean():.1f} |")
        if name == "Dendry (ours)":
            print(f"| {name}, median of {len(v)} | {np.median(v[:, 0]):.2f} % | {np.median(v[:, 1]):.1f} |")
    for name, (pct, cnt) in PAPER.items():
        print(f"| {name} | {pct} % | {cnt} |")
    if args.size != 512:  # (depression counts grow with the image)
        print(f"\n(the paper's Dendry rows and the authors' code were measured at 512^2, these at {args.size}^2)")
    print(f"\n(total {time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
