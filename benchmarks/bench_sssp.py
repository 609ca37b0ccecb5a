"""Shortest paths on lattices: wdendrite against SciPy's Dijkstra and scikit-image's MCP.

All three solve the same problem on the same lattice: node costs ``c = 1 + 10 R``
(R uniform), edge ``u-v`` of length ``l`` costs ``l * (c[u] + c[v]) / 2`` (what
``skimage.graph.MCP_Geometric`` charges), from one generator at the centre or
8 random generators. Each measurement runs in its own process and covers the
whole computation from the weight array: wdendrite builds its Lattice, SciPy
its sparse graph, MCP its cost object, and each ends holding its cost array
(written to disk for the cross-check after the clock stops). Results are
checked against SciPy.

SciPy's graph is as lean as SciPy allows: one CSR matrix holding both directions
of every edge (so ``dijkstra`` runs with ``directed=True`` and makes no transpose),
built straight from the weight arrays with int32 indices and float64 weights (the
types its graph routines compute with, so they copy nothing), without a COO
detour through int64 coordinates.

Each case runs ``--repeat`` times (default 5), the three tools in turns; the
median and the range of each are printed, and ratios of the medians. A second
table gives whole-process figures from the same runs: the seconds from a fresh
process's launch to the end of its imports (for wdendrite: Warp's start and the
loading of its compiled kernels from the cache) and the peak resident set of the
whole process (interpreter, libraries, inputs and search), ours and SciPy's.

Usage: python benchmarks/bench_sssp.py [--quick] [--repeat N] [--no-mcp] [--device cpu|cuda]
"""

from __future__ import annotations

import argparse
import itertools
import logging
import os
import tempfile
import time

import numpy as np

from _measure import cpu_model, now, run_isolated, shown, spread

CASES = [
    # (shape, connectivity)
    ((1024, 1024), 4), ((1024, 1024), 8),
    ((2048, 2048), 4), ((2048, 2048), 8),
    ((128, 128, 128), 6), ((256, 256, 256), 6),
]
QUICK = [((256, 256), 4), ((256, 256), 8), ((32, 32, 32), 6)]


def _inputs(shape, gens):
    rng = np.random.default_rng(12345)
    cost = (1.0 + 10.0 * rng.random(shape, dtype=np.float32)).astype(np.float32)
    if gens == 1:
        g = np.array([[n // 2 for n in shape]])
    else:
        g = np.random.default_rng(7).integers(0, min(shape), size=(gens, len(shape)))
    return cost, g


def _half_offsets(ndim: int, connectivity: int) -> np.ndarray:
    """``wdendrite.lattice.half_offsets`` without importing wdendrite (and Warp) into SciPy's
    processes, whose whole-process figures would carry them; ours checks that the two agree."""
    full = connectivity in (8, 26)
    offs = [o for o in itertools.product((-1, 0, 1), repeat=ndim)
            if any(o) and o > (0,) * ndim and (full or sum(map(abs, o)) == 1)]
    offs.sort(key=lambda o: (sum(map(abs, o)), [-abs(v) for v in reversed(o)], o))
    return np.array(offs, dtype=np.int64)


def _edge_weights(cost, connectivity):
    offs = _half_offsets(cost.ndim, connectivity)
    w = np.zeros((len(offs), *cost.shape), np.float32)
    for k, o in enumerate(offs):
        src = tuple(slice(max(0, -d), n - max(0, d)) for d, n in zip(o, cost.shape))
        dst = tuple(slice(max(0, d), n - max(0, -d)) for d, n in zip(o, cost.shape))
        w[k][src] = np.float32(np.sqrt((o**2).sum())) * 0.5 * (cost[src] + cost[dst])
    return w


def wdendrite_case(shape, connectivity, gens, out, device="cpu"):
    import warp as wp

    import wdendrite as wd
    from wdendrite.lattice import half_offsets

    assert np.array_equal(half_offsets(len(shape), connectivity), _half_offsets(len(shape), connectivity))
    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    wd.shortest_paths(wd.Lattice((4,) * len(shape), connectivity), [[0] * len(shape)], device=device)  # load kernels

    def prepare():
        cost, g = _inputs(tuple(shape), gens)
        return _edge_weights(cost, connectivity), g

    def run(state):
        w, g = state
        lat = wd.Lattice(tuple(shape), connectivity, weights=w)
        cf = wd.shortest_paths(lat, g, device=device)
        return {"rounds": cf.rounds, "relaxed_per_node": cf.relaxed / lat.num_nodes, "_save": (out, cf.dist)}

    return prepare, run


def lean_csr(w: np.ndarray, shape: tuple, connectivity: int):
    """Both directions of every edge of the lattice as one CSR matrix, int32 indices, float64 weights.

    Row ``i`` holds node ``i``'s neighbours in increasing order; the arrays are written in place,
    one edge direction at a time, so nothing larger than the matrix is ever held."""
    from scipy import sparse

    n = int(np.prod(shape))
    strides = np.array([int(np.prod(shape[i + 1:])) for i in range(len(shape))])
    halves = _half_offsets(len(shape), connectivity)
    # (flat offset, direction, sign): by flat offset, so each row's columns come out sorted
    dirs = sorted([(int(o @ strides), k, 1) for k, o in enumerate(halves)]
                  + [(-int(o @ strides), k, -1) for k, o in enumerate(halves)])

    def region(o):  # nodes whose neighbour at offset o lies inside, and those neighbours
        src = tuple(slice(max(0, -d), s - max(0, d)) for d, s in zip(o, shape))
        dst = tuple(slice(max(0, d), s - max(0, -d)) for d, s in zip(o, shape))
        return src, dst

    degree = np.zeros(shape, np.int32)
    for _, k, sign in dirs:
        degree[region(sign * halves[k])[0]] += 1
    indptr = np.zeros(n + 1, np.int32)
    np.cumsum(degree, dtype=np.int32, out=indptr[1:])
    del degree
    indices = np.empty(int(indptr[-1]), np.int32)
    data = np.empty(int(indptr[-1]), np.float64)
    slot = indptr[:-1].reshape(shape).copy()  # the next free entry of each row
    index = np.arange(n, dtype=np.int32).reshape(shape)
    for flat, k, sign in dirs:
        src, dst = region(sign * halves[k])
        pos = slot[src].ravel()
        indices[pos] = index[dst].ravel()
        # the edge's weight is stored at its lower-index end: w[k] at src for +o, at dst for -o
        data[pos] = w[k][src if sign > 0 else dst].ravel()
        slot[src] += 1
    return sparse.csr_matrix((data, indices, indptr), shape=(n, n), copy=False)


def scipy_case(shape, connectivity, gens, out):
    from scipy.sparse.csgraph import dijkstra

    def prepare():
        cost, g = _inputs(tuple(shape), gens)
        return _edge_weights(cost, connectivity), g

    def run(state):
        w, g = state
        graph = lean_csr(w, tuple(shape), connectivity)
        flat = np.ravel_multi_index(tuple(g.T), shape)
        dist = dijkstra(graph, directed=True, indices=flat, min_only=True)
        return {"index_dtype": str(graph.indices.dtype), "_save": (out, dist.reshape(shape))}

    return prepare, run


def mcp_case(shape, connectivity, gens, out):
    from skimage.graph import MCP_Geometric

    def prepare():
        return _inputs(tuple(shape), gens)

    def run(state):
        cost, g = state
        mcp = MCP_Geometric(cost, fully_connected=connectivity in (8, 26))
        dist, _ = mcp.find_costs([tuple(p) for p in g])
        return {"_save": (out, dist)}

    return prepare, run


def _side(shape) -> str:
    return f"{shape[0]}^{len(shape)}" if len(set(shape)) == 1 else "x".join(map(str, shape))


def _rel_err(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(b, 1e-30)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke test)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each tool per case, in turns (default 5)")
    ap.add_argument("--device", default="cpu", help="Warp device for wdendrite (default: cpu)")
    ap.add_argument("--no-mcp", action="store_true", help="skip scikit-image's MCP (the slowest peer)")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    cases = QUICK if args.quick else CASES
    tools = ("wd", "sp") if args.no_mcp else ("wd", "sp", "mcp")
    print(f"# bench_sssp  {now()}  {cpu_model()}  device={args.device}")
    print(f"# seconds and peak MiB of the computation: median (range) of {args.repeat} runs per tool, in turns")
    print("| lattice | conn | gens | wdendrite s | MiB | SciPy s | MiB | MCP s | MiB | t/SciPy | mem/SciPy | t/MCP "
          "| max rel err | rounds | relaxed/node |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    whole = []
    with tempfile.TemporaryDirectory() as tmp:
        for shape, conn in cases:
            for gens in (1, 8):
                runs = {t: [] for t in tools}
                err = 0.0
                for _ in range(args.repeat):
                    f = {t: os.path.join(tmp, f"{t}.npy") for t in tools}
                    common = dict(shape=list(shape), connectivity=conn, gens=gens, whole_process=True)
                    runs["wd"].append(run_isolated("bench_sssp", "wdendrite_case", out=f["wd"], device=args.device,
                                                   **common))
                    runs["sp"].append(run_isolated("bench_sssp", "scipy_case", out=f["sp"], **common))
                    if "mcp" in tools:
                        runs["mcp"].append(run_isolated("bench_sssp", "mcp_case", out=f["mcp"], **common))
                    ref = np.load(f["sp"])
                    err = max(err, *(_rel_err(np.load(f[t]), ref) for t in tools if t != "sp"))
                assert runs["sp"][0]["result"]["index_dtype"] == "int32", runs["sp"][0]["result"]
                secs = {t: [r["seconds"] for r in runs[t]] for t in tools}
                mib = {t: [r["peak_mib"] for r in runs[t]] for t in tools}
                med = {t: (spread(secs[t])[0], spread(mib[t])[0]) for t in tools}
                mcp = (f"{shown(secs['mcp'])} | {shown(mib['mcp'], '.0f')}" if "mcp" in tools else "- | -")
                t_mcp = f"{med['wd'][0] / med['mcp'][0]:.2f}" if "mcp" in tools else "-"
                last = runs["wd"][-1]["result"]
                print(f"| {_side(shape)} | {conn} | {gens} | {shown(secs['wd'])} | {shown(mib['wd'], '.0f')} "
                      f"| {shown(secs['sp'])} | {shown(mib['sp'], '.0f')} | {mcp} | {med['wd'][0] / med['sp'][0]:.2f} "
                      f"| {med['wd'][1] / med['sp'][1]:.2f} | {t_mcp} | {err:.1e} | {last['rounds']} "
                      f"| {last['relaxed_per_node']:.2f} |", flush=True)
                whole.append((shape, conn, gens, runs))
    print("\n# whole process, the same runs: seconds from launch to the end of the imports (wdendrite: and Warp's "
          "start with its kernels loaded from the cache), and the process's peak resident set in MiB")
    print("| lattice | conn | gens | wdendrite start s | SciPy start s | wdendrite process MiB | SciPy process MiB "
          "| process MiB ratio |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for shape, conn, gens, runs in whole:
        st = {t: [r["startup_seconds"] for r in runs[t]] for t in ("wd", "sp")}
        pk = {t: [r["process_peak_mib"] for r in runs[t]] for t in ("wd", "sp")}
        ratio = spread(pk["wd"])[0] / spread(pk["sp"])[0]
        print(f"| {_side(shape)} | {conn} | {gens} | {shown(st['wd'], '.2f')} | {shown(st['sp'], '.2f')} "
              f"| {shown(pk['wd'], '.0f')} | {shown(pk['sp'], '.0f')} | {ratio:.2f} |")


if __name__ == "__main__":
    main()
