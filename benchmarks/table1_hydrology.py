"""Table 1 of the Dendry paper on its own protocol: depressions of Dendry terrains beside noise terrains.

Protocol (the paper, section 6): one Perlin control function, ten Dendry seeds, the mean of the
ten terrains. Setup (the authors' Table 1 configuration, ../shared/papers/README.md): 512^2
pixels over the noise domain [0, 4]^2, levels 2, eps 0.25, delta 0.1, beta 0.5, noise 0.05, the
Perlin control function on the rectangle (-0.2, -0.4)-(1.4, 0.7). Depressions are the cells a
priority-flood fill raises, counted as 8-connected components.

Our Perlin noise is not the authors', so one control field could flatter or handicap either
method: the protocol runs for each of the control seeds 0-9 in turn (with the ten Dendry seeds
0-9 on each: 100 terrains, none left out), and prints per control seed the mean of its ten
terrains, then over all of them the mean, the median and the worst terrain.

Two methods, each on every terrain:

- ``terrain``: what ``wdendrite terrain`` makes by default (``wdendrite._models.TERRAIN`` on the
  drained control): Table 1's parameters with our additions (level-1 outlets, free jitter below
  level 1, primitives nearly on a grid; see ``wdendrite.DendryParams``).
- ``paper``: the method as the paper publishes it (``wdendrite._models.TABLE1``), on the
  control as it is.

The baselines (fBm and ridged multifractal, 8 octaves, frequency 4) take the Dendry seeds 0-9
at the same size.

Variants of the ``terrain`` method (each named as such in the output, never as the paper's):
``--set FIELD=VALUE`` changes a DendryParams field of it (repeatable; VALUE a number, true, false,
none or a comma list), ``--raw-control`` leaves its control undrained.

Usage: python benchmarks/table1_hydrology.py [--size 512] [--seeds 10] [--control-seeds 10]
       [--method terrain|paper|both] [--search exact|paper] [--set FIELD=VALUE ...] [--raw-control] [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import time

import numpy as np
import warp as wp

from wdendrite import hydrology
from wdendrite._models import TABLE1, TERRAIN, dendry_setup
from wdendrite.dendry import DendryParams, dendry

PAPER = {"Multifractal (paper)": (35.9, 1352), "Ridged (paper)": (24.5, 2058), "Dendry (paper, 10 seeds)": (0.8, 52),
         "Dendry (authors' code, measured)": (1.10, 70), "Alps DEM (paper)": (3.3, 798)}
METHODS = {"terrain": (TERRAIN, True), "paper": (TABLE1, False)}
"""Each method's Dendry parameters and whether its control is drained first."""

DOMAIN = ((0.0, 0.0), (4.0, 4.0))


def terrain(method: str, size: int, seed: int, control_seed: int, search: str = "exact",
            variant: tuple | None = None) -> np.ndarray:
    """The (size, size) elevation of Dendry seed ``seed`` on the Perlin control of ``control_seed``,
    made as the ``terrain`` command makes it (its setup function) with ``method``'s parameters, or
    with ``variant``'s (params, drained) instead."""
    params, drained = METHODS[method] if variant is None else variant
    setup = dendry_setup(size, params, extent=4.0, control="perlin", frequency=1.0, drained=drained,
                         seed=control_seed, output="elevation")
    setup["params"] = dataclasses.replace(setup["params"], seed=seed, search=search)
    return dendry(**setup, output="elevation")


def measure(method: str, size: int, seeds: int, control_seeds: int, search: str = "exact",
            variant: tuple | None = None) -> np.ndarray:
    """(control_seeds, seeds, 2) depression surface (%) and count of every terrain of the protocol."""
    out = np.zeros((control_seeds, seeds, 2))
    for cs in range(control_seeds):
        for s in range(seeds):
            d = hydrology.depressions(terrain(method, size, s, cs, search, variant))
            out[cs, s] = d.percent, d.count
    return out


def _value(text: str):
    """A --set value: a number, true, false, none, or a comma list of numbers (a tuple)."""
    low = text.strip().lower()
    if low in ("true", "false", "none"):
        return {"true": True, "false": False, "none": None}[low]
    if "," in text:
        return tuple(float(v) for v in text.split(","))
    return int(text) if text.strip().lstrip("-").isdigit() else float(text)


def level1_sinks(params: DendryParams, ctl, domain=DOMAIN, *, points: bool = False) -> list[tuple]:
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


def _report(name: str, res: np.ndarray) -> list[str]:
    """Per-control-seed lines and the summary row of one method's results."""
    lines = [f"\n## {name}\n", "| control seed | mean % | mean # | worst % (Dendry seed) |", "| ---: | ---: | ---: | ---: |"]
    for cs, row in enumerate(res):
        w = int(np.argmax(row[:, 0]))
        lines.append(f"| {cs} | {row[:, 0].mean():.2f} | {row[:, 1].mean():.1f} | {row[w, 0]:.2f} ({w}) |")
    flat = res.reshape(-1, 2)
    cs, s = np.unravel_index(int(np.argmax(res[..., 0])), res.shape[:2])
    lines.append(f"\n{name}, all {len(flat)} terrains: mean {flat[:, 0].mean():.2f} % and {flat[:, 1].mean():.1f} "
                 f"depressions; median {np.median(flat[:, 0]):.2f} % and {np.median(flat[:, 1]):.0f}; worst "
                 f"{res[cs, s, 0]:.2f} % (control seed {cs}, Dendry seed {s}); above 3 %: "
                 f"{int((flat[:, 0] > 3.0).sum())}")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--seeds", type=int, default=10, help="Dendry seeds 0..N-1 per control")
    ap.add_argument("--control-seeds", type=int, default=10, help="Perlin control seeds 0..N-1")
    ap.add_argument("--method", default="both", choices=["terrain", "paper", "both"])
    ap.add_argument("--search", default="exact", choices=["exact", "paper"], help="link neighbourhoods")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="change a DendryParams field of the terrain method (a variant, named as such)")
    ap.add_argument("--raw-control", action="store_true", help="the terrain method on the undrained control (a variant)")
    ap.add_argument("--quick", action="store_true", help="256^2, 3 seeds on 2 controls (not the protocol)")
    args = ap.parse_args()
    variant, changes = None, []
    if args.set or args.raw_control:
        fields = {}
        for item in args.set:
            name, _, text = item.partition("=")
            try:
                fields[name] = _value(text)
            except ValueError:
                ap.error(f"--set takes FIELD=VALUE with a number, true, false, none or a comma list, got {item!r}")
            changes.append(f"{name}={text}")
        try:
            variant = (dataclasses.replace(TERRAIN, **fields), not args.raw_control)
        except (TypeError, ValueError) as exc:
            ap.error(f"--set: {exc}")
        changes += ["an undrained control"] if args.raw_control else []
    if args.quick:
        args.size, args.seeds, args.control_seeds = 256, 3, 2
    if args.size < 2 or args.seeds < 1 or args.control_seeds < 1:
        ap.error(f"--size must be at least 2, --seeds and --control-seeds at least 1, got {args.size}, "
                 f"{args.seeds} and {args.control_seeds}")
    wp.config.quiet = True
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    protocol = (args.size, args.seeds, args.control_seeds) == (512, 10, 10)
    print(f"# Table 1, {args.size}^2, Dendry seeds 0-{args.seeds - 1} on each of the Perlin controls 0-"
          f"{args.control_seeds - 1}, {args.search} search"
          + ("" if protocol else " (NOT the paper's protocol: 512^2, 10 seeds, 10 controls)"))
    t0 = time.perf_counter()
    lines = []
    for method in (("terrain", "paper") if args.method == "both" else (args.method,)):
        res = measure(method, args.size, args.seeds, args.control_seeds, args.search,
                      variant if method == "terrain" else None)
        title = {"terrain": "the terrain command's defaults", "paper": "the paper's method, as published"}[method]
        if method == "terrain" and variant is not None:
            title = "a variant: the terrain command's defaults with " + ", ".join(changes)
        lines += _report(f"Dendry, {title}", res)
    base = {"fBm": hydrology.fbm_terrain, "ridged": hydrology.ridged_terrain}
    lines += ["\n## baselines and the paper\n", "| method | depression surface | # of depressions |", "| --- | ---: | ---: |"]
    for name, make in base.items():
        v = np.array([(d.percent, d.count) for d in
                      (hydrology.depressions(make((args.size, args.size), seed=s)) for s in range(args.seeds))])
        lines.append(f"| {name} (ours), mean of {len(v)} | {v[:, 0].mean():.2f} % | {v[:, 1].mean():.1f} |")
    lines += [f"| {name} | {pct} % | {cnt} |" for name, (pct, cnt) in PAPER.items()]
    print("\n".join(lines))
    if args.size != 512:  # (depression counts grow with the image)
        print(f"\n(the paper's figures and the authors' code were measured at 512^2, these at {args.size}^2)")
    print(f"\n(total {time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
