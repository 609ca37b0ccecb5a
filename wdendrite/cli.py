"""The ``wdendrite`` command."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def _costs(args) -> None:
    import warp as wp

    from . import Lattice, shortest_paths, weights
    from .io import save_png

    wp.config.quiet = True
    n = args.size
    lat = Lattice((n, n), connectivity=8, weights=weights.Uniform(r=10.0, seed=args.seed))
    rng = np.random.default_rng(args.seed)
    gens = rng.integers(0, n, size=(args.generators, 2))
    t0 = time.perf_counter()
    cf = shortest_paths(lat, gens, device=args.device)
    dt = time.perf_counter() - t0
    d = cf.dist
    # banded costs show the wavefronts; the label field tints each generator's region
    bands = 0.5 + 0.5 * np.cos(d / (d[np.isfinite(d)].max() / 12.0) * 2 * np.pi)
    tint = (cf.label * 0.61803) % 1.0
    rgb = np.stack([bands * (0.4 + 0.6 * tint), bands * 0.7, bands * (1.0 - 0.6 * tint)], axis=-1)
    save_png(args.out, rgb, overwrite=args.force)
    print(f"{n}x{n} lattice, {args.generators} generators: shortest paths in {dt:.3f} s "
          f"({cf.rounds} rounds) -> {args.out}")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="wdendrite", description="Dendritic shapes grown with NVIDIA Warp kernels.")
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("costs", help="shortest-path cost field of a random lattice, as a PNG")
    c.add_argument("--size", type=int, default=256, help="lattice side in nodes (default: 256)")
    c.add_argument("--generators", type=int, default=5, help="number of random generators (default: 5)")
    c.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    c.add_argument("--device", default=None, help="Warp device: cpu, cuda, cuda:N (default: Warp's default)")
    c.add_argument("-o", "--out", default="costs.png", help="output PNG (default: costs.png)")
    c.add_argument("--force", action="store_true", help="overwrite an existing output")
    c.set_defaults(run=_costs)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        args.run(args)
    except (ValueError, TypeError, FileExistsError, MemoryError) as exc:
        print(f"wdendrite: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
