"""trace(): forest invariants, exact steps, shortest-path optimality against SciPy, extension, bad input."""

import os
import re
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import dijkstra

import wdendrite as wd
from wdendrite.lattice import half_offsets

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def traced(draw):
    ndim = draw(st.sampled_from([2, 3]))
    shape = tuple(draw(st.integers(2, 12 if ndim == 2 else 6)) for _ in range(ndim))
    conn = draw(st.sampled_from([4, 8] if ndim == 2 else [6, 26]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    k = len(half_offsets(ndim, conn))
    w = rng.uniform(0.5, 20.0, size=(k, *shape)).astype(np.float32)
    mask = rng.random(shape) < 0.85 if draw(st.booleans()) else None
    usable = np.argwhere(np.ones(shape, bool) if mask is None else mask)
    if len(usable) == 0:
        mask, usable = None, np.argwhere(np.ones(shape, bool))
    lat = wd.Lattice(shape, conn, weights=w, mask=mask)
    gens = usable[rng.choice(len(usable), size=min(len(usable), draw(st.integers(1, 3))), replace=False)]
    cf = wd.shortest_paths(lat, gens)
    reach = np.argwhere(np.isfinite(cf.dist))
    ends = reach[rng.choice(len(reach), size=min(len(reach), draw(st.integers(1, 12))), replace=False)]
    return lat, cf, ends


def check_forest(lat, cf, den, ends):
    nodes, parent = den.nodes, den.parent
    assert len({tuple(n) for n in nodes.tolist()}) == len(nodes), "a node appears twice"
    # roots are generators, every other node steps to a lattice neighbour
    gens = {tuple(g) for g in cf.generators.tolist()}
    assert {tuple(n) for n in nodes[parent < 0].tolist()} <= gens
    child = np.flatnonzero(parent >= 0)
    step = nodes[parent[child]] - nodes[child]
    allowed = {tuple(o) for o in lat.offsets.tolist()} | {tuple(o) for o in (-lat.offsets).tolist()}
    assert all(tuple(s) in allowed for s in step.tolist())
    # costs equal the cost field, fall strictly toward the root, and each step is exact
    np.testing.assert_array_equal(den.cost, cf.dist[tuple(nodes.T)])
    np.testing.assert_array_equal(den.label, cf.label[tuple(nodes.T)])
    assert np.all(den.cost[parent[child]] < den.cost[child])
    for c, s in zip(child, step):
        k = next(i for i, o in enumerate(lat.offsets) if np.array_equal(o, s) or np.array_equal(-o, s))
        lower = nodes[c] if np.array_equal(s, lat.offsets[k]) else nodes[parent[c]]
        w = lat.weights[(k,) + tuple(lower)]
        assert np.float32(den.cost[parent[c]] + w) == den.cost[c]
        assert den.label[parent[c]] == den.label[c]
    # a forest: depth is finite and each root's subtree holds its endpoints
    assert den.depth.max() < len(den)
    present = {tuple(n) for n in nodes[den.endpoints].tolist()}
    assert present == {tuple(e) for e in np.asarray(ends).tolist()}
    return step


@SETTINGS
@given(traced())
def test_trace_builds_a_forest_of_exact_least_cost_steps(case):
    lat, cf, ends = case
    den = wd.trace(cf, ends)
    check_forest(lat, cf, den, ends)


@SETTINGS
@given(traced())
def test_each_path_is_a_shortest_path_by_scipy(case):
    lat, cf, ends = case
    den = wd.trace(cf, ends)
    flat = np.ravel_multi_index(tuple(cf.generators.T), lat.shape)
    ref = dijkstra(lat.to_csgraph(), directed=False, indices=flat, min_only=True).reshape(lat.shape)
    g = lat.to_csgraph()
    for p in den.paths():
        idx = np.ravel_multi_index(tuple(den.nodes[p].T), lat.shape)
        length = sum(g[a, b] for a, b in zip(idx[:-1], idx[1:]))
        assert length == pytest.approx(ref[tuple(den.nodes[p[0]])], rel=1e-5, abs=1e-6)


@SETTINGS
@given(traced(), st.data())
def test_extending_equals_tracing_everything_at_once(case, data):
    lat, cf, ends = case
    split = data.draw(st.integers(0, len(ends)))
    first = wd.trace(cf, ends[:split]) if split else None
    both = wd.trace(cf, ends[split:], extend=first) if split < len(ends) else first
    once = wd.trace(cf, ends)
    as_set = lambda d: {(tuple(n), tuple(d.nodes[p]) if p >= 0 else None) for n, p in zip(d.nodes.tolist(), d.parent)}
    assert as_set(both) == as_set(once)
    if first is not None:
        np.testing.assert_array_equal(both.nodes[: len(first)], first.nodes)


def test_downstream_counts_and_paths():
    lat = wd.Lattice((40, 40), 8, weights=wd.weights.Uniform(seed=4))
    cf = wd.shortest_paths(lat, [[20, 20]])
    ends = wd.endpoints.random(lat, 25, seed=3)
    den = wd.trace(cf, ends)
    # brute force: walk each endpoint's path and count
    brute = np.zeros(len(den), int)
    for p in den.paths():
        brute[p] += 1
    np.testing.assert_array_equal(den.downstream, brute)
    assert den.downstream[den.roots].sum() == len(den.endpoints)
    depth = np.array([len(den.path(i)) - 1 for i in range(len(den))])
    np.testing.assert_array_equal(den.depth, depth)


def test_paths_is_a_list_of_every_endpoints_walk_to_its_root():
    lat = wd.Lattice((30, 30), 8, weights=wd.weights.Uniform(seed=5))
    den = wd.trace(wd.shortest_paths(lat, [[15, 15]]), wd.endpoints.random(lat, 12, seed=1))
    paths = den.paths()
    # a list users can take len() of and index, read twice, one entry per endpoint in its order
    assert isinstance(paths, list) and len(paths) == len(den.endpoints) == 12
    assert [p[0] for p in paths] == den.endpoints.tolist() and paths[3] is not den.paths()[3]
    for p in paths:  # each step goes to the parent, and the walk ends at a root
        assert p.dtype == np.int64 and np.array_equal(den.parent[p[:-1]], p[1:]) and den.parent[p[-1]] == -1


def test_trace_does_not_depend_on_the_order_of_the_endpoints(device):
    # walks claim nodes in whatever order threads run (on the CPU: the endpoints' order);
    # the dendrite must come out the same, bit for bit, whatever that order is
    lat = wd.Lattice((64, 64), 8, weights=wd.weights.Uniform(seed=9))
    cf = wd.shortest_paths(lat, [[5, 5], [50, 40]], device=device)
    ends = wd.endpoints.random(lat, 40, seed=2)
    a = wd.trace(cf, ends)
    for seed in range(3):
        b = wd.trace(cf, ends[np.random.default_rng(seed).permutation(len(ends))])
        for f in ("nodes", "parent", "cost", "label", "generation", "endpoints"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


def test_walk_marks_in_the_record_stamps_leave_searches_and_wraps_exact():
    # trace marks its walks in the records' stamp words: a search after it (cold or warm) must give
    # SciPy's costs, and a trace across the stamp ids' wrap the same dendrite as one before it
    lat = wd.Lattice((30, 40), 8, weights=wd.weights.Uniform(seed=6))
    gens = np.array([[3, 4], [25, 30]])
    cf = wd.shortest_paths(lat, gens, limit=60.0)
    ends = np.argwhere(np.isfinite(cf.dist))[::37]
    ref = wd.trace(cf, ends)
    stamps = lat.device_arrays().stamps
    stamps.last = stamps.LIMIT - 1
    again = wd.trace(cf, ends)
    assert stamps.last < 10**6
    for f in ("nodes", "parent", "cost", "label", "endpoints"):
        np.testing.assert_array_equal(getattr(again, f), getattr(ref, f))
    grown = wd.trace(cf, np.argwhere(np.isfinite(cf.dist))[5::41], extend=ref)
    assert grown.endpoints.dtype == grown.parent.dtype == np.int64 and ref.endpoints.dtype == np.int64
    more = np.concatenate([gens, ref.nodes])
    flat = np.ravel_multi_index(tuple(more.T), lat.shape)
    want = dijkstra(lat.to_csgraph(), directed=False, indices=flat, min_only=True)
    for warm in (cf, None):
        out = wd.shortest_paths(lat, more, warm_start=warm, limit=60.0 if warm is not None else None)
        expect = want.reshape(lat.shape)
        if warm is not None:
            expect = np.where(expect <= 60.0, expect, np.inf)
        np.testing.assert_allclose(out.dist, expect, rtol=1e-5)
        wd.trace(out, np.argwhere(np.isfinite(out.dist))[::53])


def test_competing_generators_grow_separate_trees():
    lat = wd.Lattice((60, 60), 8, weights=wd.weights.Uniform(seed=1))
    cf = wd.shortest_paths(lat, [[10, 10], [50, 50]])
    den = wd.trace(cf, wd.endpoints.random(lat, 60, seed=0))
    # every node lies in its own generator's region, and paths never change region
    np.testing.assert_array_equal(den.label, cf.label[tuple(den.nodes.T)])
    child = den.parent >= 0
    np.testing.assert_array_equal(den.label[child], den.label[den.parent[child]])
    assert set(den.label[den.roots]) == {0, 1}


MASK = np.ones((8, 8), bool)
MASK[:, 4] = False


@pytest.mark.parametrize(
    "ends,exc,words",
    [
        ([[8, 0]], ValueError, "(8, 0)"),
        ([[0, 4]], ValueError, "masked"),
        ([[0, 6]], ValueError, "unreachable"),
        ([[0.5, 1]], TypeError, "endpoints"),
        (np.zeros((0, 2), int), ValueError, "empty"),
        ([[1, 2], [3]], ValueError, "'endpoints' in rows of one length"),
    ],
)
def test_bad_endpoints(ends, exc, words):
    lat = wd.Lattice((8, 8), 4, mask=MASK)
    cf = wd.shortest_paths(lat, [[0, 0]])
    with pytest.raises(exc) as info:
        wd.trace(cf, ends)
    assert words in str(info.value)


def test_bad_trace_arguments():
    lat = wd.Lattice((8, 8))
    cf = wd.shortest_paths(lat, [[0, 0]], limit=3)
    with pytest.raises(ValueError, match="limit"):
        wd.trace(cf, [[7, 7]])
    with pytest.raises(TypeError, match="costfield"):
        wd.trace(np.zeros((8, 8)), [[1, 1]])
    with pytest.raises(TypeError, match="extend"):
        wd.trace(cf, [[1, 1]], extend="x")


def test_path_refuses_a_row_outside_the_dendrite():
    den = wd.trace(wd.shortest_paths(wd.Lattice((8, 8)), [[0, 0]]), [[7, 7], [3, 5]])
    n = len(den)
    assert den.path(np.int64(n - 1))[0] == n - 1 and den.path(0)[0] == 0
    # -1 had given a path from the last row, 10**6 a bare IndexError
    for row, exc in [(-1, ValueError), (n, ValueError), (10**6, ValueError), (1.0, TypeError), (True, TypeError),
                     ("0", TypeError)]:
        with pytest.raises(exc, match=rf"'row'.*{re.escape(repr(row))}"):
            den.path(row)
    with pytest.raises(ValueError, match=rf"'row' in \[0, {n}\), the dendrite's rows, but got -1"):
        den.path(-1)


def _reference_walk(lat, dist, label, start):
    """One endpoint's path by the documented rule, alone: from each node step to the first
    neighbour (half-offset order, the + neighbour before the - one) from which the edge
    reproduces the node's cost (in float32) and label."""
    path = [tuple(start)]
    shape = np.asarray(lat.shape)
    while True:
        node = np.asarray(path[-1])
        nxt = None
        for k, off in enumerate(lat.offsets):
            for sign in (1, -1):
                u = node + sign * off
                if np.any(u < 0) or np.any(u >= shape) or not np.isfinite(dist[tuple(u)]):
                    continue
                lower = node if sign == 1 else u
                w = lat.weights[(k,) + tuple(lower)]
                if np.float32(dist[tuple(u)] + w) == dist[tuple(node)] and label[tuple(u)] == label[tuple(node)]:
                    nxt = tuple(u)
                    break
            if nxt is not None:
                break
        if nxt is None:
            return path
        path.append(nxt)


@pytest.mark.parametrize("conn", [4, 8])
@pytest.mark.parametrize("ties", [False, True])
def test_paths_are_the_rules_descents_and_merge_once_they_meet(conn, ties):
    # independent reference: every endpoint's path walked alone in NumPy by the documented
    # predecessor rule. The dendrite's path of each endpoint must be exactly that walk; walks
    # that meet then share the rest because the rule depends only on the node, so the union
    # is a forest and paths never cross at a node without merging. Weights of 1 or 2 make
    # many equal-cost ways down, where the rule's order decides.
    k = 2 if conn == 4 else 4
    weights = (np.random.default_rng(4).integers(1, 3, (k, 40, 40)).astype(np.float32) if ties
               else wd.weights.Uniform(seed=6))
    lat = wd.Lattice((40, 40), conn, weights=weights)
    cf = wd.shortest_paths(lat, [[20, 20], [5, 32]])
    dist, label = cf.dist, cf.label
    den = wd.trace(cf, wd.endpoints.random(lat, 30, seed=1))
    gens = {tuple(g) for g in cf.generators.tolist()}
    walked = set()
    for e in den.endpoints:
        want = _reference_walk(lat, dist, label, den.nodes[e])
        got = [tuple(v) for v in den.nodes[den.path(e)].tolist()]
        assert got == want
        assert want[-1] in gens
        walked.update(zip(want, want[1:] + [None]))
    # nothing else: the dendrite is exactly the union of the walks (node and next node)
    mine = {(tuple(v), tuple(den.nodes[p]) if p >= 0 else None) for v, p in zip(den.nodes.tolist(), den.parent)}
    assert mine == walked
    assert len(walked) < sum(len(p) for p in den.paths())  # walks met and merged


def _diagonal_crossings(den) -> int:
    """Cells of a 2D dendrite whose two diagonals are both edges (they cross inside the cell)."""
    child = np.flatnonzero(den.parent >= 0)
    a, b = den.nodes[child], den.nodes[den.parent[child]]
    diag = np.all(np.abs(a - b) == 1, axis=1)
    lo = np.minimum(a[diag], b[diag])  # the cell's top-left corner
    main = (a[diag] - b[diag]).prod(axis=1) > 0  # (r, c) -> (r + 1, c + 1) vs the anti-diagonal
    one = {tuple(v) for v in lo[main].tolist()}
    two = {tuple(v) for v in lo[~main].tolist()}
    return len(one & two)


def test_8_connected_branches_can_cross_inside_a_cell_as_documented():
    # what the Dendrite docstring says: on an 8-connected lattice two diagonal edges of
    # different branches may cross inside one cell without a node in common (shortest paths
    # allow it); the counter is checked on a hand-made crossing first
    x = wd.Dendrite.from_arrays((3, 3), [[0, 0], [1, 1], [0, 1], [1, 0]], [-1, 0, -1, 2])
    assert _diagonal_crossings(x) == 1
    assert _diagonal_crossings(wd.Dendrite.from_arrays((3, 3), [[0, 0], [1, 1], [1, 0]], [-1, 0, 0])) == 0
    lat = wd.Lattice((64, 64), 8, weights=wd.weights.Uniform(seed=3))
    den = wd.grow(lat, [[32, 32]], wd.FractalParams(count=6, d=120.0, alpha=1.6, beta=3.0, epsilon=15.0))
    assert _diagonal_crossings(den) > 0


def _edge_weight(lat, a, b):
    """Weight of the lattice edge between nodes ``a`` and ``b`` (coordinates)."""
    step = np.asarray(b) - np.asarray(a)
    for k, off in enumerate(lat.offsets):
        if np.array_equal(step, off):
            return lat.weights[(k, *a)]
        if np.array_equal(step, -off):
            return lat.weights[(k, *b)]
    raise AssertionError(f"{a} and {b} are not neighbours")


@pytest.mark.parametrize("weights", [wd.weights.Polynomial(n=8, seed=0), wd.weights.Power(alpha=6.0, max=100.0, seed=3)])
def test_weights_beyond_float32_resolution_still_trace_every_endpoint(weights):
    # 1 + v^8 and R^6 span 12-16 orders of magnitude: float32 costs swallow the cheap edges, so
    # plateaus of equal costs appear, whose way down may lie toward higher node indices
    lat = wd.Lattice((120, 120), 8, weights=weights)
    cf = wd.shortest_paths(lat, [[60, 60]])
    ends = wd.endpoints.random(lat, 20, seed=0, min_spacing=10)
    den = wd.trace(cf, ends)
    assert den.depth.max() < len(den) and np.array_equal(den.nodes[den.parent < 0], [[60, 60]])
    assert len(den.endpoints) == 20
    np.testing.assert_array_equal(den.cost, cf.dist[tuple(den.nodes.T)])
    for row in np.flatnonzero(den.parent >= 0):  # every step reproduces its cost in float32
        up = den.parent[row]
        assert np.float32(den.cost[up] + _edge_weight(lat, den.nodes[row], den.nodes[up])) == den.cost[row]
        assert den.cost[up] <= den.cost[row]


def test_plateaus_are_crossed_alike_with_weights_not_stored():
    # on the CPU, where recomputed weights equal the stored ones bit for bit (CUDA's pow may not)
    dist = wd.weights.Polynomial(n=8, seed=0)
    ends = wd.endpoints.random((60, 60), 12, seed=1, min_spacing=6)
    dens = [wd.trace(wd.shortest_paths(wd.Lattice((60, 60), 8, weights=dist, store_weights=s), [[30, 30]],
                                       device="cpu"), ends)
            for s in (True, False)]
    for f in ("nodes", "parent", "cost", "label"):
        np.testing.assert_array_equal(getattr(dens[0], f), getattr(dens[1], f))


def test_a_plateau_whose_way_down_lies_toward_higher_indices_is_crossed(device):
    # edge (0,0)-(0,1) weighs 1e-6, nothing next to 1e6: both nodes cost 1e6 with the generator on either side
    w = np.ones((2, 1, 3), np.float32)
    w[0, 0, 0], w[0, 0, 1] = 1e-6, 1e6
    for gen, end, path in (([0, 2], [0, 0], [(0, 0), (0, 1), (0, 2)]), ([0, 0], [0, 2], [(0, 2), (0, 1), (0, 0)])):
        lat = wd.Lattice((1, 3), 4, weights=w if gen == [0, 2] else w[:, :, ::-1].copy())
        den = wd.trace(wd.shortest_paths(lat, [gen], device=device), [end])
        assert [tuple(n) for n in den.nodes[den.path(int(den.endpoints[0]))]] == path


def test_growth_with_very_wide_power_weights_grows():
    for seed in range(3):
        lat = wd.Lattice((32, 32), 8, weights=wd.weights.Power(alpha=6.0, max=100.0, seed=seed))
        top = float(np.nanmax(np.where(np.isfinite(d := wd.shortest_paths(lat, [[16, 16]]).dist), d, np.nan)))
        den = wd.grow(lat, [[16, 16]], wd.FractalParams(count=4, d=top / 2, alpha=1.5, beta=2.0, epsilon=top / 20),
                      seed=seed)
        assert len(den.endpoints) > 4 and den.depth.max() < len(den)


def _rounding_tie_lattice():
    """Node (0, 1) is reached from generator 0 at cost a = 100 + 2 ulp before its least cost
    b = 100 + 1 ulp from generator 1, and a + 1000 and b + 1000 both round to 1100 at (1, 1)."""
    f32 = np.float32
    ulp = np.spacing(f32(100))
    a, b, c1 = f32(100) + 2 * ulp, f32(100) + ulp, f32(50)
    c2 = f32(b - c1)
    assert f32(c1 + c2) == b and f32(a + f32(1000)) == f32(b + f32(1000))
    w = np.full((2, 2, 4), 1e5, np.float32)  # directions: (0, 1), then (1, 0)
    w[0, 0, 0], w[0, 0, 1], w[0, 0, 2] = a, c2, c1
    w[1, 0, 1] = 1000
    return wd.Lattice((2, 4), 4, weights=w)


@pytest.mark.parametrize("delta", [None, 1.0, 1.0e4])
def test_a_label_kept_by_a_rounding_tie_still_traces(delta, device):
    # with wide buckets the search relaxes (0, 1) at its first cost, and (1, 1) keeps generator
    # 0's label at the tied cost 1100 though no neighbour reproduces (1100, 0) any more; the
    # walk then steps by cost alone, into generator 1's region, and labels the path by it
    lat = _rounding_tie_lattice()
    kw = {} if delta is None else {"delta": delta}
    cf = wd.shortest_paths(lat, [[0, 0], [0, 3]], device=device, **kw)
    den = wd.trace(cf, [[1, 1]])
    assert [tuple(n) for n in den.nodes[den.path(int(np.flatnonzero((den.nodes == [1, 1]).all(1))[0]))]] == [
        (1, 1), (0, 1), (0, 2), (0, 3)]
    np.testing.assert_array_equal(den.cost, cf.dist[tuple(den.nodes.T)])
    child = np.flatnonzero(den.parent >= 0)
    steps = [(tuple(den.nodes[den.parent[c]]), tuple(den.nodes[c])) for c in child]
    for (u, v), c in zip(steps, child):  # each step an edge whose weight reproduces the cost in float32
        k = 0 if u[0] == v[0] else 1
        lower = min(u, v)
        assert np.float32(den.cost[den.parent[c]] + lat.weights[(k, *lower)]) == den.cost[c]
    assert (den.label == 1).all()  # the generator every path reaches
    if delta == 1.0e4 and device == "cpu":
        # the CPU's fixed relaxation order kept generator 0 there (a GPU's order may not)
        assert cf.label[1, 1] == 0


def test_from_arrays_round_trip_and_checks():
    lat = wd.Lattice((30, 30), 8, weights=wd.weights.Uniform(seed=2))
    den = wd.trace(wd.shortest_paths(lat, [[15, 15]]), wd.endpoints.random(lat, 8, seed=1))
    again = wd.Dendrite.from_arrays(den.shape, den.nodes, den.parent, cost=den.cost, label=den.label,
                                    generation=den.generation, endpoints=den.endpoints)
    np.testing.assert_array_equal(again.depth, den.depth)
    # extending the rebuilt dendrite works as with the original
    cf = wd.shortest_paths(lat, [[15, 15]])
    more = [[0, 0], [29, 29]]
    a, b = wd.trace(cf, more, extend=den), wd.trace(cf, more, extend=again)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.parent, b.parent)
    with pytest.raises(ValueError, match="cycle"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 1]], [1, 0])
    with pytest.raises(ValueError, match="twice"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 0]], [-1, 0])
    with pytest.raises(ValueError, match="outside the lattice"):
        wd.Dendrite.from_arrays((5, 5), [[0, 5]], [-1])
    with pytest.raises(ValueError, match="endpoints"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 1]], [-1, 0], endpoints=[-1])
    with pytest.raises(ValueError, match="endpoints"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 1]], [-1, 0], endpoints=[2])
    # fractional rows are refused, not truncated to a row
    with pytest.raises(TypeError, match="integer rows for 'endpoints'"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 1]], [-1, 0], endpoints=[1.5])
    # placement and per-node values are checked, not wrapped, truncated or left to fail later
    two = dict(shape=(5, 5), nodes=[[0, 0], [0, 1]], parent=[-1, 0])
    for kw, exc, match in [
        (dict(origin=(5.0,)), ValueError, "'origin'"),
        (dict(origin=(0.0, np.nan)), ValueError, "'origin'"),
        (dict(spacing=float("nan")), ValueError, "'spacing'"),
        (dict(spacing=0.0), ValueError, "'spacing'"),
        (dict(spacing=-2.0), ValueError, "'spacing'"),
        (dict(label=[0.7, 0.0]), TypeError, "'label'"),
        (dict(label=[-1, 0]), ValueError, r"'label' must lie in \[0, "),
        (dict(generation=[2**40, 0]), ValueError, "'generation' must lie in"),
        (dict(cost=[0.0, np.nan]), ValueError, "'cost' must be finite"),
    ]:
        with pytest.raises(exc, match=match):
            wd.Dendrite.from_arrays(**two, **kw)
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0, 0]], [-1])
    with pytest.raises(ValueError, match="neighbour"):
        wd.Dendrite.from_arrays((5, 5), [[0, 0], [0, 3]], [-1, 0])


@pytest.mark.parametrize(
    "nodes, parent, error, match",
    [
        ([[0.9, 0], [0, 1.7]], [-1, 0], TypeError, "nodes"),
        ([[0, 0], [0, 9]], [-1, 0], ValueError, r"'nodes' row 1 = \(0, 9\)"),
        ([[0, 0], [0, 1]], [5, -1], ValueError, "'parent' row 0 = 5"),
        ([[0, 0], [0, 1]], [-1.0, 0.0], TypeError, "parent"),
    ],
)
def test_from_arrays_names_the_bad_row(nodes, parent, error, match):
    with pytest.raises(error, match=match):
        wd.Dendrite.from_arrays((4, 4), nodes, parent)


@pytest.mark.parametrize("generation, error", [("a", TypeError), (1.7, TypeError), (-5, ValueError), (True, TypeError),
                                               (2**31, ValueError)])
def test_trace_checks_generation_before_any_kernel(generation, error, launches):
    cf = wd.shortest_paths(wd.Lattice((8, 8)), [[0, 0]])
    launches.clear()
    with pytest.raises(error, match="generation"):
        wd.trace(cf, [[5, 5]], generation=generation)
    assert launches == []


def test_trace_refuses_to_extend_a_dendrite_on_masked_nodes(launches):
    mask = np.ones((8, 8), bool)
    mask[0] = False
    cf = wd.shortest_paths(wd.Lattice((8, 8), mask=mask), [[1, 0]])
    den = wd.Dendrite.from_arrays((8, 8), [[0, 0], [0, 1]], [-1, 0])
    launches.clear()
    with pytest.raises(ValueError, match=r"'extend' row 0 = \(0, 0\) is a masked-out node"):
        wd.trace(cf, [[5, 5]], extend=den)
    assert launches == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the resident size from /proc")
def test_walk_tables_cost_memory_only_where_written():
    # the walks' node tables span the whole padded lattice and get a few scattered writes (a
    # dendrite in a large sparse refined lattice). NumPy's own large arrays ask for huge pages,
    # where each such write makes 2 MiB resident (128 writes: 256 MiB); these cost a page each.
    from wdendrite import _memory

    def resident():
        return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    before = resident()
    table = _memory.sparse_table(2**26, np.int32)
    table[np.arange(0, 2**26, 2**19)] = 7  # 128 writes, 2 MiB apart
    grown = resident() - before
    assert table.dtype == np.int32 and table.shape == (2**26,) and table.flags.writeable
    assert int(table.sum()) == 7 * 128 and grown < 16 * 2**20, grown
    small = _memory.sparse_table(10, bool)
    assert small.dtype == bool and not small.any()


def test_a_dendrites_arrays_are_read_only_and_its_endpoints_distinct():
    lat = wd.Lattice((16, 16), 8)
    den = wd.trace(wd.shortest_paths(lat, [[8, 8]]), [[0, 0], [15, 15]])
    depth = den.depth.copy()
    for name in ("nodes", "parent", "cost", "label", "generation", "endpoints"):
        with pytest.raises(ValueError, match="read-only"):  # (a write had left the cached depth stale)
            getattr(den, name)[0] = 1
    np.testing.assert_array_equal(den.depth, depth)
    parent = den.parent.copy()
    wd.Dendrite.from_arrays(den.shape, den.nodes, parent)
    parent[0] = parent[0]  # the caller's own arrays stay writeable
    with pytest.raises(ValueError, match="'endpoints' lists row 1 more than once"):  # (downstream counted it twice)
        wd.Dendrite.from_arrays(den.shape, den.nodes, den.parent, endpoints=[1, 1])


@pytest.mark.parametrize("how", ["as traced", "pickled", "deep-copied"])
def test_a_dendrites_cached_arrays_are_read_only_too(how):
    import copy
    import pickle

    lat = wd.Lattice((16, 16), 8)
    den = wd.trace(wd.shortest_paths(lat, [[8, 8]]), [[0, 0], [15, 15], [0, 15]])
    den.depth  # cached before the copy, so the copy carries it
    den = {"as traced": den, "pickled": pickle.loads(pickle.dumps(den)), "deep-copied": copy.deepcopy(den)}[how]
    # depth and downstream against a walk of the parent pointers
    depth = [len(den.path(r)) - 1 for r in range(len(den))]
    down = np.zeros(len(den), int)
    for p in den.paths():
        down[p] += 1
    np.testing.assert_array_equal(den.depth, depth)
    np.testing.assert_array_equal(den.downstream, down)
    assert repr(den) == f"Dendrite(shape=(16, 16), nodes={len(den)}, roots=1, endpoints=3, generations=1)"
    for name in ("nodes", "parent", "cost", "label", "generation", "endpoints", "depth", "order", "downstream"):
        with pytest.raises(ValueError, match="read-only"):  # (a write to depth had changed later renders)
            getattr(den, name)[0] = 1
    np.testing.assert_array_equal(den.depth, depth)


def test_from_arrays_keeps_no_reference_to_the_callers_arrays():
    cost = np.array([0.0, 1.0, 2.0], np.float32)  # already float32: the check had handed it back as it was
    label = np.zeros(3, np.int32)
    den = wd.Dendrite.from_arrays((4, 4), [[0, 0], [0, 1], [0, 2]], [-1, 0, 1], cost=cost, label=label)
    cost[:] = 99.0
    label[:] = 5
    np.testing.assert_array_equal(den.cost, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(den.label, 0)


@pytest.mark.parametrize("change", ["nodes", "shape", "narrower"])
def test_replace_cannot_move_a_dendrite(change):
    # the moved copy had kept the old node index, and walks extending it stopped at the old nodes
    import dataclasses

    lat = wd.Lattice((16, 16), 8)
    den = wd.trace(wd.shortest_paths(lat, [[8, 8]]), [[0, 3], [15, 12]])
    moved = {"nodes": np.minimum(den.nodes + [0, 1], 15), "shape": (20, 20), "narrower": (16, 10)}[change]
    change = "shape" if change == "narrower" else change  # (nodes beyond the new width: NumPy's error had shown)
    with pytest.raises(ValueError, match="Dendrite.from_arrays"):
        dataclasses.replace(den, **{change: moved})
    again = dataclasses.replace(den, cost=den.cost * 2)  # other fields may change
    np.testing.assert_array_equal(again.cost, den.cost * 2)
