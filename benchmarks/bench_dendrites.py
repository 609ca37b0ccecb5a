"""The papers' dendrite workloads: wdendrite against SciPy's Dijkstra plus NumPy backtracking.

Each workload is run both ways in one process on the same lattice, generators
and endpoints (the fractal one draws its endpoints from each side's own cost
field with the same seed and schedule):

- simple dendrite: 600^2, 8-connected, weights 1 + 10 R, 15 endpoints;
- fractal dendrite: 512^2, new generators, schedule reaching about 8930 endpoints;
- lightning structure: the lightning preset's default path planning on 600^2 power weights (alpha 3):
  the main channel, then the branch candidates of its two graphs (18 and 54), each stage over
  its graph's lattice with the structure's edges made cheap per row descended (three searches);
- 3D tree: 80^3, 26-connected, upward tropism, 17 endpoints in the crown, then meshed as the elm
  preset meshes its trees (smooth centre lines, one closed body, voxel 0.5);
- coral: 50^3, 26-connected, 24 endpoints, then refinement with 7^3 sublattices (the coral
  preset's default, the thesis' smallest) and meshing as the coral preset (voxel 0.4).

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
builder, so only the path planning differs. Its meshes start from the same
smooth centre lines (our NumPy :func:`wdendrite.skeleton.skeleton`, on the
dendrite its predecessors give) and take what a user would write for the
distance field: the samples, spaced at most half a voxel apart, marked on
the grid, ``scipy.ndimage.distance_transform_edt`` with indices for the
nearest sample's radius, then scikit-image's marching cubes.

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
from wdendrite.geometry import meshable, skeleton_mesh
from wdendrite.refine import refined_lattice
from wdendrite.skeleton import skeleton

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
    return scipy_backtrack(pred, flat, visited), dist, pred


def scipy_dendrite(lat, gens, ends, origin=None, spacing=1.0):
    """The dendrite SciPy's predecessors give (the same nodes and parents as ours)."""
    nodes, dist, pred = scipy_trace(lat, gens, ends)
    nodes = np.sort(nodes)
    up = pred[nodes]
    parent = np.where(up >= 0, np.searchsorted(nodes, np.maximum(up, 0)), -1)
    coords = np.stack(np.unravel_index(nodes, lat.shape), axis=1)
    return wd.Dendrite.from_arrays(lat.shape, coords, parent, cost=dist[nodes], origin=origin, spacing=spacing)


def scipy_body(lines, voxel):
    """The closed surface around ``lines`` by SciPy's EDT of the marked samples and scikit-image's marching cubes."""
    from scipy import ndimage
    from skimage.measure import marching_cubes

    lines = meshable(lines, voxel)  # (the same radii as ours)
    seg = lines.segments
    a, b = lines.points[seg[:, 0]], lines.points[seg[:, 1]]
    steps = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (0.5 * voxel)).astype(int), 1)
    t = np.concatenate([np.arange(k) / k for k in steps])
    which = np.repeat(np.arange(len(seg)), steps)
    pts = a[which] + t[:, None] * (b - a)[which]
    rad = lines.radius[seg[which, 0]] * (1 - t) + lines.radius[seg[which, 1]] * t
    reach = rad.max() + 3 * voxel
    lo = pts.min(axis=0) - reach
    shape = tuple(np.ceil((pts.max(axis=0) + reach - lo) / voxel).astype(int) + 1)
    cell = np.rint((pts - lo) / voxel).astype(int)
    grid_r = np.zeros(shape)
    np.maximum.at(grid_r, tuple(cell.T), rad)
    d, idx = ndimage.distance_transform_edt(grid_r == 0, return_indices=True)
    field = (d * voxel - grid_r[tuple(idx)]).astype(np.float32)
    v, f, _, _ = marching_cubes(field, 0.0, spacing=(voxel,) * 3)
    return v + lo, f


# the 3D workloads' bodies: the elm and coral presets' radii, voxels and smoothing
BODIES = {
    "tree": dict(radius=wd.render.Taper(2.4, 0.6, beta=0.3, along="path"),
                 side=wd.render.Taper(1.5, 0.35, beta=0.2, along="branch"), voxel=0.5),
    "coral": dict(radius=wd.render.Taper(1.6, 0.7, along="path"), side=None, voxel=0.4),
}
REFINE_N = 7


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
    """The path planning of the lightning preset's default (``wdendrite.lightning``), in three stages
    over 600^2 8-connected lattices of power weights (alpha 3): the main channel (one search from
    the top, one endpoint at the bottom); then 18 candidate endpoints of the first graph's branches
    and 54 of the second's, each stage searched over its graph's lattice whose structure edges cost
    ``descent`` per row and traced onto the structure. The lattices and endpoints are made by a run
    of our own beforehand (keeping every traced branch: the preset's choice among them is NumPy
    work on both sides alike, left out)."""
    from wdendrite import lightning as lt
    from wdendrite.sssp import _cost_per_node

    n = 150 if quick else 600
    p = lt.LightningParams()
    rng = np.random.default_rng(3)
    gens = np.array([[2, n // 2]])
    lats = [wd.Lattice((n, n), 8, weights=wd.weights.Power(alpha=p.alpha, seed=k)) for k in (3, 4)]
    den = wd.trace(wd.shortest_paths(lats[0], gens), [[n - 3, int(n * 0.45)]])
    stages = [(lats[0], np.array([[n - 3, int(n * 0.45)]]))]
    for lat, count, reach, top, spacing in ((lats[0], p.forks, 0.3, n // 8, 0.08), (lats[1], p.minor_forks, 0.18, n // 6, 0.04)):
        region = lt._near(den.nodes, (n, n), 0.03 * n, reach * n, top)
        ends = lt._candidates(lat, "forks", count, region, rng, spacing * n)
        desc = lt._descent(lat, den, p.descent * _cost_per_node(lat, tuple(gens[0]), n / 3))
        den = wd.trace(wd.shortest_paths(desc, gens), ends, extend=den)
        stages.append((desc, ends))
    return stages, gens


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
    if name == "lightning":
        stages, gens = lightning(quick)
        rebuilt = [(_rebuilder(lat), ends) for lat, ends in stages]

        def ours():
            den = None
            for build, ends in rebuilt:
                den = wd.trace(wd.shortest_paths(build(), gens), ends, extend=den)
            return den

        def theirs():
            visited = np.zeros(stages[0][0].num_nodes, bool)
            for lat, ends in stages:
                _, pred = scipy_paths(lat, gens)
                scipy_backtrack(pred, np.ravel_multi_index(tuple(ends.T), lat.shape), visited)
            return int(visited.sum())

        return ours, theirs, lambda den, size: f"{len(den)} / {size} nodes"
    lat, gens, ends = {"simple": simple, "tree": tree, "coral": coral}[name](quick)

    rebuilt = _rebuilder(lat)
    if name == "simple":
        def ours():
            own = rebuilt()
            return wd.trace(wd.shortest_paths(own, gens), ends)

        return ours, lambda: len(scipy_trace(lat, gens, ends)[0]), lambda den, size: f"{len(den)} / {size} nodes"

    body = BODIES[name]

    def lines_of(den):
        return skeleton(den, body["radius"], side=body["side"], sigma=2.0, min_radius=body["voxel"])

    def ours():
        own = rebuilt()
        den = wd.trace(wd.shortest_paths(own, gens), ends)
        if name == "coral":
            den = wd.refine(den, own, n=REFINE_N, e=0.75, seed=0)[0]
        return den, skeleton_mesh(lines_of(den), voxel=body["voxel"])

    coarse = wd.trace(wd.shortest_paths(lat, gens), ends)  # SciPy's refinement starts from it (outside the timing)

    def theirs():
        if name == "coral":
            # the same refinement, planned with SciPy on the same sublattice builder
            len(scipy_trace(lat, gens, ends)[0])
            fine_lat, roots, fends, origin = refined_lattice(coarse, lat, n=REFINE_N, e=0.75, seed=0)
            den = scipy_dendrite(fine_lat, roots, fends, origin=tuple(origin), spacing=1.0 / REFINE_N)
        else:
            den = scipy_dendrite(lat, gens, ends)
        return den, scipy_body(lines_of(den), body["voxel"])

    def describe(ours_out, theirs_out):
        (den, mesh), (sden, (v, f)) = ours_out, theirs_out
        tri = v[f]
        volume = abs(np.einsum("ij,ij->", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))) / 6.0
        return (f"{len(den)} / {len(sden)} nodes; mesh {len(mesh.faces)} / {len(f)} faces, volume {mesh.volume:.0f} / "
                f"{volume:.0f}, closed {mesh.is_watertight}")

    return ours, theirs, describe


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
        den = wd.trace(wd.shortest_paths(lat, gens), ends)
        scipy_trace(lat, gens, ends)
    skeleton_mesh(skeleton(den, 1.0), voxel=0.5)
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
