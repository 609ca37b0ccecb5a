"""The papers' dendrite workloads: wdendrite against SciPy's Dijkstra plus NumPy backtracking.

Each workload is run both ways in one process on the same lattice, generators
and endpoints (the fractal one draws its endpoints from each side's own cost
field with the same seed and schedule):

- simple dendrite: 600^2, 8-connected, weights 1 + 10 R, 15 endpoints;
- fractal dendrite: 512^2, new generators, schedule reaching about 8930 endpoints;
- lightning structure: 600^2, power weights (alpha 3), 24 endpoints denser low;
- 3D tree: 80^3, 26-connected, upward tropism, 17 endpoints in the crown;
- coral: 50^3, 26-connected, 24 endpoints, then refinement with 3^3 sublattices.

Both sides start from the same float32 edge weights (an array made before the
clock starts) and build what they search inside the timing: wdendrite its
``Lattice`` from the array, SciPy its sparse graph. The SciPy side is what a
user would write without us: build the sparse graph from the weights
(``Lattice.to_csgraph``; for the refined lattice only its usable edges are
evaluated), run
``scipy.sparse.csgraph.dijkstra(min_only=True, return_predecessors=True)`` and
walk the predecessors with vectorized NumPy. The graph holds both directions
of every edge, so it is searched as a directed graph: the same costs as with
``directed=False``, which also makes and scans the transpose on every call
(20-25 % slower here). Its refinement step reuses our NumPy sublattice
builder, so only the path planning differs.

The fractal workload gives SciPy the warm start ours has (see ``scipy_fractal``):
each iteration searches from the nodes just added, bounded by the band's top, and
keeps the lower cost, which gives the same draws, paths and node counts as a search
from scratch each iteration (BENCHMARKS.md gives both times).

Each side runs ``--repeat`` times (default 5, alternating with the other side);
the median and the range of each side are printed, and the ratio of the medians,
so one disturbed run on a shared machine does not decide the ratio.

Usage: python benchmarks/bench_dendrites.py [--quick] [--repeat N]
"""

from __future__ import annotations

import argparse
import logging

import numpy as np
import warp as wp

from _measure import cpu_model, interleaved, now, shown, spread

import wdendrite as wd
from wdendrite.refine import refined_lattice

PAPER = {"simple": "0.94 s", "fractal": "7.55 s", "lightning": "4.16 s", "tree": "3.65 s", "coral": "3.06 s"}


# ---------------------------------------------------------------- the peer

def scipy_paths(lat: wd.Lattice, gens: np.ndarray, limit=np.inf):
    from scipy.sparse.csgraph import dijkstra

    flat = np.ravel_multi_index(tuple(np.asarray(gens).T), lat.shape)
    dist, pred, _ = dijkstra(lat.to_csgraph(), directed=True, indices=flat, min_only=True,
                             return_predecessors=True, limit=limit)
    return dist, pred


def scipy_backtrack(pred: np.ndarray, starts: np.ndarray, visited: np.ndarray) -> np.ndarray:
    """Flat indices of the nodes on the paths from ``starts`` (stopping at visited nodes); marks them."""
    out = []
    cur = np.unique(starts)
    cur = cur[~visited[cur]]
    while len(cur):
        visited[cur] = True
        out.append(cur)
        cur = np.unique(pred[cur])
        cur = cur[(cur >= 0)]
        cur = cur[~visited[cur]]
    return np.concatenate(out) if out else np.zeros(0, np.int64)


def scipy_trace(lat, gens, ends):
    dist, pred = scipy_paths(lat, gens)
    visited = np.zeros(lat.num_nodes, bool)
    flat = np.ravel_multi_index(tuple(np.asarray(ends).T), lat.shape)
    return scipy_backtrack(pred, flat, visited)


def scipy_fractal(lat, gens, params: wd.FractalParams, seed):
    """SciPy's fractal growth with the warm start ours has: after the first search, each iteration
    searches only from the nodes the last one added, up to this iteration's band top (``limit=``),
    and keeps the lower of the old and the new cost (and its predecessor) at every node. The
    generators only grow and the band's top only falls, so every cost below it, the only costs
    a draw reads, equals that of a search from all the generators."""
    from scipy.sparse.csgraph import dijkstra

    rng = np.random.default_rng(seed)
    r = params.band
    visited = np.zeros(lat.num_nodes, bool)
    fresh = np.ravel_multi_index(tuple(np.asarray(gens).T), lat.shape)
    graph = lat.to_csgraph()
    dist = pred = None
    count = 0
    for m, d in params.schedule():
        if len(fresh):
            new_dist, new_pred, _ = dijkstra(graph, directed=True, indices=fresh, min_only=True,
                                             return_predecessors=True, limit=d + r)
            if dist is None:
                dist, pred = new_dist, new_pred
            else:
                lower = new_dist < dist
                dist[lower] = new_dist[lower]
                pred[lower] = new_pred[lower]
        # as wdendrite's growth: the band never reaches below cost 0 (the dendrite itself)
        band = np.flatnonzero((dist > max(d - r, 0.0)) & (dist < d + r))
        pick = band[rng.choice(len(band), size=min(m, len(band)), replace=False)]
        count += len(pick)
        fresh = scipy_backtrack(pred, pick, visited)
    return int(visited.sum()), count


# ---------------------------------------------------------------- workloads

def simple(quick):
    n = 150 if quick else 600
    lat = wd.Lattice((n, n), 8, weights=wd.weights.Uniform(r=10, seed=1))
    gens = np.array([[n // 2, n // 2]])
    ends = wd.endpoints.random(lat, 15, seed=2)
    return lat, gens, ends


def lightning(quick):
    n = 150 if quick else 600
    lat = wd.Lattice((n, n), 8, weights=wd.weights.Power(alpha=3, max=11, seed=3))
    gens = np.array([[0, n // 2]])
    ends = wd.endpoints.biased(lat, 24, seed=4, power=3)
    return lat, gens, ends


def tree(quick):
    n = 30 if quick else 80
    lat = wd.Lattice((n, n, n), 26, weights=wd.weights.Uniform(r=10, seed=5) * wd.weights.Tropism("top", strength=1.0))
    gens = np.array([[0, n // 2, n // 2]])
    crown = wd.endpoints.Disc(center=(int(n * 0.7), n // 2, n // 2), radius=n * 0.3)
    ends = wd.endpoints.random(lat, 17, seed=6, within=crown)
    return lat, gens, ends


def coral(quick):
    n = 24 if quick else 50
    lat = wd.Lattice((n, n, n), 26, weights=wd.weights.Uniform(r=10, seed=7))
    gens = np.array([[0, n // 2, n // 2]])
    ends = wd.endpoints.random(lat, 24, seed=8, within=wd.endpoints.Box((n // 2, 0, 0), (n, n, n)))
    return lat, gens, ends


FRACTAL = wd.FractalParams(count=8, d=700.0, alpha=1.6, beta=3.0, epsilon=40.0)


def _rebuilder(lat: wd.Lattice):
    """A callable building ``lat`` again from a copy of its weights (a C-ordered float32
    array made now, before any timing), as a user holding the weights would: timed on our
    side as SciPy's graph building is on its side."""
    weights = np.ascontiguousarray(lat.weights)
    return lambda: wd.Lattice(lat.shape, lat.connectivity, weights=weights, mask=lat.mask)


def _sides(name, quick):
    """The workload's two sides as zero-argument callables (ours, SciPy's) and a describer of their results."""
    if name == "fractal":
        n = 256 if quick else 512
        lat = wd.Lattice((n, n), 8, weights=wd.weights.Uniform(r=10, seed=9))
        gens = np.array([[n // 2, n // 2]])
        params = FRACTAL if not quick else wd.FractalParams(count=10, d=350.0, alpha=1.6, beta=3.0, epsilon=20.0)
        rebuilt = _rebuilder(lat)
        ours = lambda: wd.grow(rebuilt(), gens, params, seed=0)
        theirs = lambda: scipy_fractal(lat, gens, params, seed=0)
        return ours, theirs, lambda den, res: f"{len(den.endpoints)} / {res[1]} endpoints, {len(den)} / {res[0]} nodes"
    lat, gens, ends = {"simple": simple, "lightning": lightning, "tree": tree, "coral": coral}[name](quick)

    rebuilt = _rebuilder(lat)

    def ours():
        own = rebuilt()
        den = wd.trace(wd.shortest_paths(own, gens), ends)
        return wd.refine(den, own, n=3, e=0.75, seed=0)[0] if name == "coral" else den

    coarse = wd.trace(wd.shortest_paths(lat, gens), ends)  # SciPy's refinement starts from it (outside the timing)

    def theirs():
        size = len(scipy_trace(lat, gens, ends))
        if name == "coral":
            # the same refinement, planned with SciPy on the same sublattice builder
            fine_lat, roots, fends, _ = refined_lattice(coarse, lat, n=3, e=0.75, seed=0)
            size = len(scipy_trace(fine_lat, roots, fends))
        return size

    return ours, theirs, lambda den, size: f"{len(den)} / {size} nodes"


def run(name, quick, repeat):
    """Seconds of ``repeat`` runs of each side (alternating), and the sizes both made."""
    ours, theirs, describe = _sides(name, quick)
    runs = interleaved({"ours": ours, "theirs": theirs}, repeat)
    (t_ours, den), (t_theirs, res) = runs["ours"], runs["theirs"]
    return t_ours, t_theirs, describe(den, res)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke test)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each side per workload (default 5)")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1, got {args.repeat}")
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    for warm in (simple, tree):  # load the kernels and SciPy outside the measurements
        lat, gens, ends = warm(True)
        wd.trace(wd.shortest_paths(lat, gens), ends)
        scipy_trace(lat, gens, ends)
    print(f"# bench_dendrites  {now()}  {cpu_model()}  device={wp.get_device()}")
    print(f"# seconds: median (range) of {args.repeat} runs per side, alternating; speed-up: ratio of the medians")
    print("| workload | wdendrite s | SciPy + NumPy s | speed-up | paper (2007 CPU) | sizes (ours / SciPy) |")
    print("| --- | ---: | ---: | ---: | ---: | --- |")
    for name in ("simple", "fractal", "lightning", "tree", "coral"):
        ours, theirs, note = run(name, args.quick, args.repeat)
        ratio = spread(theirs)[0] / spread(ours)[0]
        print(f"| {name} | {shown(ours)} | {shown(theirs)} | {ratio:.1f}x | {PAPER[name]} | {note} |", flush=True)


if __name__ == "__main__":
    main()
