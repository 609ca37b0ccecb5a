"""Compare two checkouts' Dendry rates in one process, alternating runs (old against new).

    git worktree add /tmp/before HEAD~3
    python scripts/ab_dendry.py /tmp/before .                       # the Table 1 setup, per pixel
    python scripts/ab_dendry.py /tmp/before . --search exact --output distance --runs 12
    python scripts/ab_dendry.py /tmp/before . --workload lichtenberg --window 64 --mode cached
    python scripts/ab_dendry.py /tmp/before . --levels 3 --search exact     # Table 1's setup at 3 levels

On a shared or throttled machine the same code can run 1.4x faster or slower from one
minute to the next, so two benchmark runs made one after the other cannot resolve a change of
a few per cent. This script copies each checkout's package under its own name into a
temporary directory (``wd_a``, ``wd_b``; the package's imports are relative), imports both,
and times them in turns on the same window, so both see the same phases of the machine. It
prints each side's median and best rate, the ratio of the medians, the median of the
run-by-run ratios, and whether the two images are equal bit for bit. Warp compiles each
side's kernels once (cached under its module names).
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _is_checkout(root) -> bool:
    """True when ``root`` holds a wdendrite checkout (its wdendrite/ and kernels/ folders)."""
    return (Path(root) / "wdendrite").is_dir() and (Path(root) / "kernels").is_dir()


def _copy(root: Path, name: str, into: Path) -> Path:
    """Copy the checkout at ``root`` into ``into`` as package ``name`` (its ``wdendrite`` with
    ``kernels`` inside); return the package's folder."""
    pkg = into / name
    shutil.copytree(root / "wdendrite", pkg, symlinks=False, ignore=shutil.ignore_patterns("kernels", "__pycache__"))
    shutil.copytree(root / "kernels", pkg / "kernels", ignore=shutil.ignore_patterns("__pycache__"))
    return pkg


def _load(root: Path, name: str, into: Path):
    """The checkout at ``root`` as package ``name``: its ``dendry`` and ``control`` modules."""
    _copy(root, name, into)
    return importlib.import_module(f"{name}.dendry"), importlib.import_module(f"{name}.control")


def _case(dendry_mod, control_mod, workload: str, search: str, levels: int | None = None):
    """Keyword arguments of ``dendry`` for ``workload`` and the image's side; ``levels`` replaces
    the workload's own (2 for Table 1, 6 for the Lichtenberg figure)."""
    if workload == "lichtenberg":
        p = dendry_mod.DendryParams(levels=levels or 6, eps=0.25, delta=0.05, rule="lichtenberg", resolution=2.0, search=search)
        return dict(domain=((-1.0, -1.0), (1.0, 1.0)), params=p, control=control_mod.lichtenberg()), 1024
    p = dendry_mod.DendryParams(levels=levels or 2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0, search=search)
    ctl = control_mod.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7)))
    return dict(domain=((0.0, 0.0), (4.0, 4.0)), params=p, control=ctl), 512


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path, help="root of the first checkout (holding wdendrite/ and kernels/)")
    ap.add_argument("new", type=Path, help="root of the second checkout")
    ap.add_argument("--workload", choices=["table1", "lichtenberg"], default="table1",
                    help="the paper's Table 1 setup (512^2, 2 levels) or the 1024^2 Lichtenberg figure (6 levels)")
    ap.add_argument("--search", choices=["exact", "paper"], default="paper")
    ap.add_argument("--output", choices=["distance", "elevation", "level"], default="elevation")
    ap.add_argument("--mode", choices=["pixel", "cached"], default="pixel")
    ap.add_argument("--levels", type=int, choices=range(1, 7), metavar="1..6",
                    help="levels instead of the workload's own (Table 1: 2, Lichtenberg: 6)")
    ap.add_argument("--window", type=int, default=160, help="side of the centred window timed in the per-pixel mode")
    ap.add_argument("--runs", type=int, default=10, help="runs of each side, in turns")
    args = ap.parse_args()
    for side in (args.old, args.new):
        if not _is_checkout(side):
            ap.error(f"{str(side)!r} is not a wdendrite checkout (no wdendrite/ and kernels/ in it)")
    if args.runs < 1 or args.window < 1:
        ap.error(f"--runs and --window must be at least 1, got {args.runs} and {args.window}")
    if args.workload == "lichtenberg" and args.output == "elevation":
        ap.error("the Lichtenberg figure has no elevation: use --output distance or level")

    import warp as wp

    wp.config.quiet = True
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        sides = {"old": _load(args.old.resolve(), "wd_a", Path(tmp)),
                 "new": _load(args.new.resolve(), "wd_b", Path(tmp))}
        rates: dict[str, list[float]] = {"old": [], "new": []}
        images = {}
        for name, (dmod, cmod) in sides.items():  # compile and warm up
            kw, _ = _case(dmod, cmod, args.workload, args.search, args.levels)
            dmod.dendry((16, 16), output=args.output, mode=args.mode, **kw)
        for _ in range(args.runs):
            for name, (dmod, cmod) in sides.items():
                kw, size = _case(dmod, cmod, args.workload, args.search, args.levels)
                w = min(args.window, size)
                window = None if args.mode == "cached" else ((size - w) // 2, (size - w) // 2, w, w)
                t = time.perf_counter()
                images[name] = dmod.dendry((size, size), window=window, output=args.output, mode=args.mode, **kw)
                rates[name].append(images[name].size / (time.perf_counter() - t))
    old, new = np.array(rates["old"]), np.array(rates["new"])
    same = np.array_equal(images["old"], images["new"], equal_nan=True)
    levels = f" {args.levels} levels" if args.levels else ""
    print(f"{args.workload}{levels} {args.search} {args.output} {args.mode}: "
          f"old median {np.median(old):,.0f} px/s (best {old.max():,.0f}), "
          f"new median {np.median(new):,.0f} px/s (best {new.max():,.0f}); "
          f"new/old {np.median(new) / np.median(old):.2f}x, run by run {np.median(new / old):.2f}x "
          f"({np.min(new / old):.2f}-{np.max(new / old):.2f}); same values: {same}")


if __name__ == "__main__":
    main()
