"""The ``wdendrite`` command."""

from __future__ import annotations

import logging
import argparse
import sys
import time

import numpy as np


def _costs(args) -> None:
    import warp as wp

    from . import Lattice, shortest_paths, weights
    from .io import save_png

    wp.config.log_level = logging.WARNING  # no start-up banner
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


def _fractal(args) -> None:
    import warp as wp

    from . import FractalParams, Lattice, grow, weights
    from .io import save_png

    wp.config.log_level = logging.WARNING  # no start-up banner
    n = args.size
    lat = Lattice((n, n), connectivity=8, weights=weights.Uniform(r=10.0, seed=args.seed))
    # a sparse, readable fractal: the first branches reach most of the way out
    params = FractalParams(count=6, d=1.2 * n, alpha=1.8, beta=2.5, epsilon=0.12 * n, cheap=args.cheap)
    t0 = time.perf_counter()
    den = grow(lat, [[n // 2, n // 2]], params, seed=args.seed, device=args.device, progress=not args.quiet)
    dt = time.perf_counter() - t0
    # brightness grows with the number of endpoints a node carries (thicker trunks)
    img = np.zeros(lat.shape)
    img[tuple(den.nodes.T)] = 0.35 + 0.65 * np.log1p(den.downstream) / np.log1p(den.downstream.max())
    save_png(args.out, img, overwrite=args.force)
    print(f"fractal dendrite on {n}x{n}: {len(den.endpoints)} endpoints, {len(den)} nodes "
          f"in {dt:.3f} s -> {args.out}")


def _common(p, out: str) -> None:
    p.add_argument("--size", type=int, default=256, help="lattice side in nodes (default: 256)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    p.add_argument("--device", default=None, help="Warp device: cpu, cuda, cuda:N (default: Warp's default)")
    p.add_argument("-o", "--out", default=out, help=f"output PNG (default: {out})")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="wdendrite", description="Dendritic shapes grown with NVIDIA Warp kernels.")
    sub = p.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fractal", help="a fractal dendrite grown from the centre (thesis Fig 3.12), as a PNG")
    _common(f, "fractal.png")
    f.add_argument("--cheap", type=float, default=0.0,
                   help="D, weight factor of the dendrite's edges; 0 = new generators (default: 0)")
    f.set_defaults(run=_fractal)
    c = sub.add_parser("costs", help="shortest-path cost field of a random lattice, as a PNG")
    _common(c, "costs.png")
    c.add_argument("--generators", type=int, default=5, help="number of random generators (default: 5)")
    c.set_defaults(run=_costs)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.size < 8:
        print(f"wdendrite: error: --size must be at least 8, got {args.size}", file=sys.stderr)
        return 2
    try:
        args.run(args)
    except (ValueError, TypeError, FileExistsError, MemoryError) as exc:
        print(f"wdendrite: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
