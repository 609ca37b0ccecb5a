"""How many link searches a demand-driven per-pixel Dendry build would run, against the eager build.

    python scripts/demand_dendry.py                                   # Lichtenberg figure, 6 levels, exact
    python scripts/demand_dendry.py --workload table1 --levels 3
    python scripts/demand_dendry.py --search paper --pixels 80

The per-pixel mode used to build, for each pixel, every cell of its planned blocks at the levels
below the finest, although most of those segments never come near a search. This script measured
what a build driven by demand would save, before one was written. The kernels now
draw levels 2..n-1 on demand from 3 levels on (``kernels/dendry.py:prepare_levels``),
with the ``key`` bound below, a cell's searches gathered per level into one box
(``want_box``); the script still measures the bounds one search at a time.
It takes the cells of the cached mode (the same values the per-pixel mode draws) around a window
and, for sample pixels of it, replays two builds in Python (distance output):

- *eager*: the cells with a segment in the pixel's planned blocks (levels 2 to n - 1; the finest
  level is drawn lazily already and counted as in the demand build);
- *demand*: a cell is searched only when a bound says its segment could matter. The pixel first
  needs its own finest cell; the polyline through that cell's key point bounds its answer
  (``limit``). A cell within the query's neighbourhoods is needed when its segment may come
  within ``limit`` of the pixel. A needed cell needs its parent, then every cell of its own link
  search whose segment may come within ``bound`` of its key point, where ``bound`` is the
  distance from the key point to a polyline known to be on the tree. Two bounds are replayed:
  ``key``, the distance to the parent's key point, and ``polyline``, the distance to the
  polyline through it (which needs that polyline drawn). A segment of a cell with key point
  ``q`` stays within ``reach * link_span(d)`` of ``q`` (``kernels/dendry.py:segment_reach``,
  ``link_span``) where ``d`` is that cell's own bound.

Level-1 cells count as drawn in both (their links need no search). The last column weighs each
searched cell by the cells its link search reads, ``(level - 1) (2 rl + 1)^2``: the eager and
demand totals bound the speed-up a demand-driven build could reach before its own overhead.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import random
import sys

import numpy as np


def _piece_gap(u: np.ndarray, poly: np.ndarray) -> float:
    """Distance from ``u`` to the polyline ``poly`` (k, 2)."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    den = (ab * ab).sum(1)
    t = np.clip(((u - a) * ab).sum(1) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    return float(np.sqrt((((a + t[:, None] * ab) - u) ** 2).sum(1)).min())


class Tree:
    """The cached mode's cells of every level, looked up by (level, cell)."""

    def __init__(self, levels, p, reach, states):
        self.cells = [None] + [{tuple(c): (k, v) for c, k, v in zip(*lv)} for lv in levels]
        self.p, self.reach = p, reach
        self.none, self.inherited, self.segment = states
        # the longest piece of the tree bounds the terrain rule's link span
        self.longest = max(float(np.linalg.norm(np.diff(v[:5, :2], axis=0), axis=1).max())
                           for lv in self.cells[1:] for k, v in lv.values() if k[3] == self.segment)

    def state(self, l, c):
        return self.cells[l][c][0][3]

    def key(self, l, c):
        return self.cells[l][c][0][:2].astype(np.float64)

    def owner_gap(self, q, l, c):
        """Distance from ``q`` to the polyline through the key point of cell ``c`` of level ``l``."""
        while self.state(l, c) == self.inherited:
            l, c = l - 1, (c[0] >> 1, c[1] >> 1)
        return _piece_gap(q, self.cells[l][c][1][:5, :2].astype(np.float64))

    def link_span(self, d):
        if self.p.rule == "lichtenberg":
            return 2.0 * d
        return math.sqrt(d * d + self.longest * self.longest / 16.0)


def _demand(tree: Tree, u: np.ndarray, bound: str) -> list[int]:
    """Cells searched per level (index 1..n) by a demand-driven build of pixel ``u`` (grid units)."""
    p = tree.p
    n = p.levels
    _, rq, rl = p.radii()  # (level 1, whose radius r1 is, counts as drawn)
    built: set = set()
    searched = [0] * (n + 1)

    def parent(l, c):
        return l - 1, (c[0] >> 1, c[1] >> 1)

    def gap_to_tree(q, l, c):
        """Distance from ``q`` to a known point of the tree through cell (l, c)'s key point."""
        if tree.state(l, c) == tree.none:
            return math.inf
        return tree.owner_gap(q, l, c) if bound == "polyline" else float(np.linalg.norm(q - tree.key(l, c)))

    def may_reach(l, c, x, within):
        """True when the segment of cell (l, c) may come within ``within`` of ``x``."""
        if tree.state(l, c) != tree.segment:
            return False
        q = tree.key(l, c)
        d = gap_to_tree(q, *parent(l, c))
        return float(np.linalg.norm(x - q)) - tree.reach[l - 1] * (tree.link_span(d) + 1e-6) <= within * 1.001

    def need(l, c):
        if l == 1 or (l, c) in built:
            return
        built.add((l, c))
        need(*parent(l, c))
        if tree.state(l, c) != tree.segment:
            return
        searched[l] += 1
        q = tree.key(l, c)
        within = gap_to_tree(q, *parent(l, c))
        for i in range(1, l - 1):  # level 1 (i = l - 1) is drawn
            anc = (c[0] >> i, c[1] >> i)
            for dy in range(-rl, rl + 1):
                for dx in range(-rl, rl + 1):
                    z = (anc[0] + dx, anc[1] + dy)
                    need(*parent(l - i, z))  # (its bound reads its parent)
                    if may_reach(l - i, z, q, within):
                        need(l - i, z)

    cu = tuple(int(math.floor(v * 2 ** (n - 1))) for v in u)
    need(n, cu)
    limit = tree.owner_gap(u, n, cu) if tree.state(n, cu) != tree.none else math.inf
    for l in range(n, 1, -1):
        cl = tuple(int(math.floor(v * 2 ** (l - 1))) for v in u)
        for dy in range(-rq, rq + 1):
            for dx in range(-rq, rq + 1):
                z = (cl[0] + dx, cl[1] + dy)
                need(*parent(l, z))
                if may_reach(l, z, u, limit):
                    need(l, z)
    return searched


def _eager(tree: Tree, u: np.ndarray) -> list[int]:
    """Cells with a segment per level in the per-pixel blocks of pixel ``u`` (the finest: 0)."""
    from wdendrite.dendry import _plan_ranges

    n = tree.p.levels
    cu = [int(math.floor(v * 2 ** (n - 1))) for v in u]
    rx, ry = _plan_ranges(tree.p, cu[0], cu[0]), _plan_ranges(tree.p, cu[1], cu[1])
    out = [0] * (n + 1)
    for l in range(2, n):
        out[l] = sum(tree.state(l, (i, j)) == tree.segment
                     for i in range(rx[l][0], rx[l][1] + 1) for j in range(ry[l][0], ry[l][1] + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workload", choices=["table1", "lichtenberg"], default="lichtenberg",
                    help="the paper's Table 1 setup (512^2) or the 1024^2 Lichtenberg figure (6 levels)")
    ap.add_argument("--levels", type=int, default=None, help="levels (default: 2 for table1, 6 for lichtenberg)")
    ap.add_argument("--search", choices=["exact", "paper"], default="exact")
    ap.add_argument("--window", type=int, default=64, help="side of the centred window the pixels come from")
    ap.add_argument("--pixels", type=int, default=40, help="sample pixels")
    ap.add_argument("--seed", type=int, default=1, help="seed of the sample")
    args = ap.parse_args()
    for name in ("window", "pixels"):
        if getattr(args, name) < 1:
            sys.exit(f"demand_dendry: --{name} must be at least 1, got {getattr(args, name)}")

    import warp as wp

    wp.config.quiet = True
    from ab_dendry import _case
    import wdendrite.kernels.dendry as kd
    from wdendrite import control

    dmod = sys.modules["wdendrite.dendry"]  # (the module: the package's name ``dendry`` is its function)
    kw, size = _case(dmod, control, args.workload, args.search)
    p = kw["params"]
    if args.levels is not None:
        p = dataclasses.replace(p, levels=args.levels)
        kw["params"] = p
    n = p.levels
    if n < 3:
        sys.exit("demand_dendry: needs 3 levels or more (with 2, no level lies between the drawn level 1 "
                 "and the finest, which the per-pixel mode already draws lazily)")
    w = min(args.window, size)
    (x0, y0), (x1, y1) = kw["domain"]
    (cx0, cy0), (cx1, cy1) = kw["control"].domain  # (the query domain maps onto it)
    # the window's pixels, with a margin of cells around it: the cached mode's blocks then hold every
    # cell the sample pixels' neighbourhoods reach
    lo_px, hi_px = (size - w) // 2, (size - w) // 2 + w
    margin = 64 * size / ((x1 - x0) * p.resolution * 2 ** (n - 1))  # 64 finest cells, in pixels
    a, b = max(0, int(lo_px - margin)), min(size, int(hi_px + margin))
    fx = lambda px: x0 + px * (x1 - x0) / size  # noqa: E731
    fy = lambda px: y0 + px * (y1 - y0) / size  # noqa: E731
    sub = ((fx(a), fy(a)), (fx(b), fy(b)))
    to_c = lambda v, lo, hi, clo, chi: clo + (v - lo) / (hi - lo) * (chi - clo)  # noqa: E731
    csub = ((to_c(sub[0][0], x0, x1, cx0, cx1), to_c(sub[0][1], y0, y1, cy0, cy1)),
            (to_c(sub[1][0], x0, x1, cx0, cx1), to_c(sub[1][1], y0, y1, cy0, cy1)))
    levels = dmod._cached_tree((b - a, b - a), domain=sub, control_domain=csub, params=p, control=kw["control"],
                               device="cpu")
    tree = Tree(levels, p, dmod._reach_factors(p),
                (float(kd.STATE_NONE), float(kd.STATE_INHERITED), float(kd.STATE_SEGMENT)))
    rng = random.Random(args.seed)
    totals = {name: np.zeros(n + 1) for name in ("eager", "key", "polyline")}
    for _ in range(args.pixels):
        px, py = lo_px + rng.randrange(w), lo_px + rng.randrange(w)
        u = np.array([fx(px + 0.5), fy(py + 0.5)]) * p.resolution
        totals["eager"] += _eager(tree, u)
        for name in ("key", "polyline"):
            totals[name] += _demand(tree, u, name)
    rl = p.radii()[2]
    weight = np.array([max(l - 1, 0) * (2 * rl + 1) ** 2 for l in range(n + 1)])
    print(f"{args.workload}, {n} levels, {args.search} search (radii {p.radii()}), distance, "
          f"{args.pixels} pixels of the centred {w}^2 window: link searches per pixel")
    print("| build | " + " | ".join(f"level {l}" for l in range(2, n + 1)) + " | cells read (levels 2 to n - 1) |")
    print("| --- |" + " ---: |" * (n - 1) + " ---: |")
    for name, row in totals.items():
        row = row / args.pixels
        finest = "-" if name == "eager" else f"{row[n]:.1f}"
        work = float((row[2:n] * weight[2:n]).sum())
        cells = " | ".join(f"{v:.1f}" for v in row[2:n])
        print(f"| {name} | {cells} | {finest} | {work:,.0f} |")


if __name__ == "__main__":
    main()
