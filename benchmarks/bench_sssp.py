"""Shortest paths on lattices: wdendrite against SciPy's Dijkstra and scikit-image's MCP.

All three solve the same problem on the same lattice: node costs ``c = 1 + 10 R``
(R uniform), edge ``u-v`` of length ``l`` costs ``l * (c[u] + c[v]) / 2`` (what
``skimage.graph.MCP_Geometric`` charges), from one generator at the centre or
8 random generators. Each measurement runs in its own process and covers the
whole computation from the weight array: wdendrite builds its Lattice, SciPy
its sparse graph, MCP its cost object, and each ends holding its cost array
(written to disk for the cross-check after the clock stops). Results are
checked against SciPy.

Usage: python benchmarks/bench_sssp.py [--quick] [--device cpu|cuda]
"""

from __future__ import annotations

import argparse
import logging
import os
import tempfile

import numpy as np

from _measure import now, run_isolated

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


def _edge_weights(cost, connectivity):
    from wdendrite.lattice import half_offsets

    offs = half_offsets(cost.ndim, connectivity)
    w = np.zeros((len(offs), *cost.shape), np.float32)
    for k, o in enumerate(offs):
        src = tuple(slice(max(0, -d), n - max(0, d)) for d, n in zip(o, cost.shape))
        dst = tuple(slice(max(0, d), n - max(0, -d)) for d, n in zip(o, cost.shape))
        w[k][src] = np.float32(np.sqrt((o**2).sum())) * 0.5 * (cost[src] + cost[dst])
    return w


def wdendrite_case(shape, connectivity, gens, out, device="cpu"):
    def prepare():
        import warp as wp

        import wdendrite as wd

        wp.config.log_level = logging.WARNING  # no start-up banner
        wp.init()
        wd.shortest_paths(wd.Lattice((4,) * len(shape), connectivity), [[0] * len(shape)], device=device)  # load kernels
        cost, g = _inputs(tuple(shape), gens)
        return wd, _edge_weights(cost, connectivity), g

    def run(state):
        wd, w, g = state
        lat = wd.Lattice(tuple(shape), connectivity, weights=w)
        cf = wd.shortest_paths(lat, g, device=device)
        return {"rounds": cf.rounds, "relaxed_per_node": cf.relaxed / lat.num_nodes, "_save": (out, cf.dist)}

    return prepare, run


def scipy_case(shape, connectivity, gens, out):
    def prepare():
        cost, g = _inputs(tuple(shape), gens)
        return _edge_weights(cost, connectivity), g

    from scipy import sparse
    from scipy.sparse.csgraph import dijkstra

    from wdendrite.lattice import half_offsets

    def run(state):
        w, g = state
        n = int(np.prod(shape))
        index = np.arange(n).reshape(shape)
        rows, cols, vals = [], [], []
        for k, o in enumerate(half_offsets(len(shape), connectivity)):
            src = tuple(slice(max(0, -d), s - max(0, d)) for d, s in zip(o, shape))
            dst = tuple(slice(max(0, d), s - max(0, -d)) for d, s in zip(o, shape))
            rows.append(index[src].ravel())
            cols.append(index[dst].ravel())
            vals.append(w[k][src].ravel())
        r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals).astype(np.float64)
        graph = sparse.csr_matrix((v, (r, c)), shape=(n, n))
        del r, c, v, rows, cols, vals
        flat = np.ravel_multi_index(tuple(g.T), shape)
        dist = dijkstra(graph, directed=False, indices=flat, min_only=True)
        return {"_save": (out, dist.reshape(shape))}

    return prepare, run


def mcp_case(shape, connectivity, gens, out):
    def prepare():
        cost, g = _inputs(tuple(shape), gens)
        return cost, g

    from skimage.graph import MCP_Geometric

    def run(state):
        cost, g = state
        mcp = MCP_Geometric(cost, fully_connected=connectivity in (8, 26))
        dist, _ = mcp.find_costs([tuple(p) for p in g])
        return {"_save": (out, dist)}

    return prepare, run


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a smoke test)")
    ap.add_argument("--device", default="cpu", help="Warp device for wdendrite (default: cpu)")
    ap.add_argument("--no-mcp", action="store_true", help="skip scikit-image's MCP (the slowest peer)")
    args = ap.parse_args()
    cases = QUICK if args.quick else CASES
    print(f"# bench_sssp  {now()}  device={args.device}")
    print(f"{'lattice':>16} {'conn':>4} {'gens':>4} | {'wdendrite s':>11} {'MiB':>7} | {'scipy s':>8} {'MiB':>7} |"
          f" {'MCP s':>7} {'MiB':>7} | {'t/scipy':>7} {'mem/scipy':>9} {'t/MCP':>6} | {'max rel err':>11} rounds relax/node")
    with tempfile.TemporaryDirectory() as tmp:
        for shape, conn in cases:
            for gens in (1, 8):
                f = {m: os.path.join(tmp, f"{m}.npy") for m in ("wd", "sp", "mcp")}
                wd = run_isolated("bench_sssp", "wdendrite_case", shape=list(shape), connectivity=conn, gens=gens,
                                  out=f["wd"], device=args.device)
                sp = run_isolated("bench_sssp", "scipy_case", shape=list(shape), connectivity=conn, gens=gens,
                                  out=f["sp"])
                mc = None
                if not args.no_mcp:
                    mc = run_isolated("bench_sssp", "mcp_case", shape=list(shape), connectivity=conn, gens=gens,
                                      out=f["mcp"])
                a, b = np.load(f["wd"]), np.load(f["sp"])
                err = float(np.max(np.abs(a - b) / np.maximum(b, 1e-30)))
                if mc is not None:
                    err = max(err, float(np.max(np.abs(np.load(f["mcp"]) - b) / np.maximum(b, 1e-30))))
                mcs = f"{mc['seconds']:7.3f} {mc['peak_mib']:7.0f}" if mc else f"{'-':>7} {'-':>7}"
                mcr = f"{wd['seconds'] / mc['seconds']:6.2f}" if mc else f"{'-':>6}"
                print(f"{'x'.join(map(str, shape)):>16} {conn:>4} {gens:>4} | {wd['seconds']:11.3f} "
                      f"{wd['peak_mib']:7.0f} | {sp['seconds']:8.3f} {sp['peak_mib']:7.0f} | {mcs} | "
                      f"{wd['seconds'] / sp['seconds']:7.2f} {wd['peak_mib'] / sp['peak_mib']:9.2f} {mcr} | "
                      f"{err:11.1e} {wd['result']['rounds']:6d} {wd['result']['relaxed_per_node']:.2f}", flush=True)


if __name__ == "__main__":
    main()
