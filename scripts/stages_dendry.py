"""Time each stage of Dendry's per-pixel pipeline by cutting it short, in one process.

    python scripts/stages_dendry.py                          # Table 1 setup, paper search, elevation
    python scripts/stages_dendry.py --search exact --runs 8
    python scripts/stages_dendry.py /tmp/before --output distance

Neither of the other profiles measures time per stage. ``profile_dendry.py --count`` counts
instructions, and on this machine those have not predicted time: a change that removed 7 % of
them gained 1-3 %. Its sampling mode attributes time through ``addr2line``, which is
unreliable where LLVM merged code: it put 17 % of a single-octave Perlin control's time under
``ridged``. This script takes the plain way: it makes one copy of the checkout's package per
stage, each with the per-pixel kernel returning right after that stage, and times the copies
in turns on the same window. The difference between two cuts is the time of the stage between
them, with everything before it kept as it is. The cuts (in ``kernels/dendry.py``):

0. plan: the slot's blocks planned, and for elevation the primitives' key points;
1. points: the level-1 key points drawn (:func:`build`'s first loop);
2. level-1 segments: ``fill_links1``;
3. build: levels 2..n, the query's finest cells and the pixel's bound (:func:`pixel_limit`);
4. finish: the finest cells beyond the query's (``finish``);
5. whole: the shortlist, the queries and, for elevation, the blend of the primitives.

A cut leaves the compiler free to drop whatever the later stages alone would need, so a stage's
time is what it costs once the rest is gone. Each copy is compiled on its own, and the compiler
lays each one out differently, so a small stage can come out a little below zero: the paper
search's distances gave -0.06 us for the build stage, whose single query cell costs little.
The copies live in a temporary directory. The values of the cut copies mean nothing; the last
copy is the whole pipeline, and its rate heads the table.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SCRIPTS = Path(__file__).resolve().parent
sys.path.insert(0, str(SCRIPTS))
from ab_dendry import _case, _copy, _is_checkout  # noqa: E402  (the same workloads as the A/B timings)

STAGES = ["plan", "points", "level-1 segments", "build", "finish", "whole"]

# (text after which a cut is inserted, the cut; {k} is the stage the copy stops after)
_CUTS = [
    ("GOLDEN = wp.constant(wp.uint32(0x9E3779B9))", "\nSTAGE = wp.constant({k})  # stages_dendry.py: the last stage run"),
    ("        if output == OUT_ELEVATION:\n            prim = prim_points(s, u)\n",
     "        if STAGE == 0:\n            first = float(qlo[0])\n            for k0 in range(25):\n"
     "                first += prim.pr2[k0]  # (so that the primitives' key points are drawn)\n"
     "            return first\n"),
    ("            fill_point1(s, ctl, bases, slot, j * b[2] + i, wp.vec2i(b[0] + i, b[1] + j), pts1)\n",
     "    if STAGE == 1:\n        return wp.vec2(pts1[nonneg(base)][0], 0.0)\n"),
    ("    fill_links1(s, ctl, blocks, bases, slot, clo, chi, u, s.near1, pts1, keyp, verts)\n",
     "    if STAGE == 2:\n        return wp.vec2(keyp[nonneg(bases[nonneg(slot * SLOT + 1)])][0], 0.0)\n"),
    ("        built = build(s, ctl, blocks, bases, slot, u, output, qlo, qhi, prim, pts1, keyp, verts)\n",
     "        if STAGE < 4:\n            return built[0]\n"),
    ("        finish(s, ctl, blocks, bases, slot, qlo, qhi, u, limit, demand, pts1, keyp, verts)\n",
     "        if STAGE == 4:\n            return limit\n"),
]


def _cut_copy(root: Path, into: Path, k: int):
    """The checkout at ``root`` as package ``wd_stage{k}``, its per-pixel kernel stopping after stage ``k``."""
    name = f"wd_stage{k}"
    f = _copy(root, name, into) / "kernels" / "dendry.py"
    src = f.read_text()
    for anchor, cut in _CUTS:
        if src.count(anchor) != 1:
            raise SystemExit(f"{f.name}: expected one {anchor.strip()!r} to cut after; the script needs updating")
        src = src.replace(anchor, anchor + cut.format(k=k))
    f.write_text(src)
    return importlib.import_module(f"{name}.dendry"), importlib.import_module(f"{name}.control")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", type=Path, nargs="?", default=SCRIPTS.parent,
                    help="the checkout to time (default: this one)")
    ap.add_argument("--search", choices=["exact", "paper"], default="paper")
    ap.add_argument("--output", choices=["distance", "elevation", "level"], default="elevation")
    ap.add_argument("--levels", type=int, choices=range(1, 7), metavar="1..6", help="levels instead of Table 1's 2")
    ap.add_argument("--window", type=int, default=128, help="side of the centred window timed")
    ap.add_argument("--runs", type=int, default=6, help="runs of each copy, in turns")
    args = ap.parse_args()
    if not _is_checkout(args.root):
        ap.error(f"{str(args.root)!r} is not a wdendrite checkout (no wdendrite/ and kernels/ in it)")
    if args.runs < 1 or args.window < 1:
        ap.error(f"--runs and --window must be at least 1, got {args.runs} and {args.window}")

    import warp as wp

    wp.config.quiet = True
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        copies = [_cut_copy(args.root.resolve(), Path(tmp), k) for k in range(len(STAGES))]
        for dmod, cmod in copies:  # compile and warm up
            kw, _ = _case(dmod, cmod, "table1", args.search, args.levels)
            dmod.dendry((16, 16), output=args.output, mode="pixel", **kw)
        times = [[] for _ in copies]
        for _ in range(args.runs):
            for k, (dmod, cmod) in enumerate(copies):
                kw, size = _case(dmod, cmod, "table1", args.search, args.levels)
                w = min(args.window, size)
                t = time.perf_counter()
                image = dmod.dendry((size, size), window=((size - w) // 2, (size - w) // 2, w, w),
                                   output=args.output, mode="pixel", **kw)
                times[k].append((time.perf_counter() - t) / image.size * 1e6)
    med = [float(np.median(t)) for t in times]
    levels = f", {args.levels} levels" if args.levels else ""
    print(f"table1{levels}, {args.search} search, {args.output}, per pixel, {args.window}^2 window, "
          f"median of {args.runs} runs: {1e6 / med[-1]:,.0f} px/s whole")
    print("| stage | us per pixel | share |")
    print("| --- | ---: | ---: |")
    prev = 0.0
    for name, m in zip(STAGES, med):
        print(f"| {name} | {m - prev:.3f} | {100.0 * (m - prev) / med[-1]:.0f} % |")
        prev = m
    print(f"| total | {med[-1]:.3f} | 100 % |")


if __name__ == "__main__":
    main()
