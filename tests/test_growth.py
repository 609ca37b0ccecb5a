"""grow(): the Fig 3.12 schedule, both fractal modes, warm starts equal cold starts, competition, bad input."""

import dataclasses

import numpy as np
import pytest

import wdendrite as wd
from wdendrite import growth, sssp
from wdendrite.growth import lower_dendrite_weights

LAT = wd.Lattice((96, 96), 8, weights=wd.weights.Uniform(r=10, seed=5))
PARAMS = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0)


def test_schedule_follows_fig_3_12():
    p = wd.FractalParams(count=5, d=400, alpha=2, beta=3, epsilon=60)
    assert p.schedule() == [(5, 400.0), (15, 200.0), (45, 100.0)]
    assert p.band == 40.0


@pytest.mark.parametrize("cheap", [0.0, 0.6, 1.0])
def test_grow_gives_a_valid_forest(cheap):
    den = wd.grow(LAT, [[48, 48]], PARAMS.__class__(**{**PARAMS.__dict__, "cheap": cheap}), seed=1)
    assert len({tuple(n) for n in den.nodes.tolist()}) == len(den)
    child = np.flatnonzero(den.parent >= 0)
    step = np.abs(den.nodes[den.parent[child]] - den.nodes[child])
    assert step.max() == 1 and step.sum(axis=1).min() >= 1
    assert np.all(den.parent[child] != child)
    # one tree rooted at the generator, and generations count up from the core outward
    assert den.nodes[den.roots].tolist() == [[48, 48]]
    gens = np.unique(den.generation)
    assert gens[0] == 0 and len(gens) > 1
    assert np.all(den.generation[child] >= den.generation[den.parent[child]])
    # endpoints never exceed what the schedule asked for
    assert len(den.endpoints) <= sum(m for m, _ in PARAMS.schedule())


def test_new_generators_attach_each_branch_to_the_existing_dendrite():
    den = wd.grow(LAT, [[48, 48]], PARAMS, seed=3)
    for g in range(1, den.generation.max() + 1):
        new = np.flatnonzero(den.generation == g)
        attach = den.parent[new]
        # a new branch leaves only from older nodes or its own generation
        assert np.all(den.generation[attach] <= g)
        assert np.any(den.generation[attach] < g)


def test_warm_starts_give_the_same_dendrite_as_cold_starts(monkeypatch):
    for cheap in (0.0, 0.5):
        p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0, cheap=cheap)
        warm = wd.grow(LAT, [[48, 48]], p, seed=7)
        real = sssp._search

        def cold(*args, warm_start=None, **kwargs):
            return real(*args, **kwargs)

        monkeypatch.setattr(growth, "_search", cold)
        again = wd.grow(LAT, [[48, 48]], p, seed=7)
        monkeypatch.setattr(growth, "_search", real)
        for f in ("nodes", "parent", "cost", "label", "generation", "endpoints"):
            np.testing.assert_array_equal(getattr(warm, f), getattr(again, f))


def test_cheap_former_paths_lower_only_dendrite_edges():
    cf = wd.shortest_paths(LAT, [[48, 48]])
    den = wd.trace(cf, [[10, 10], [80, 20]])
    low = lower_dendrite_weights(LAT, den, 0.5)
    changed = np.argwhere(low.weights != LAT.weights)
    assert len(changed) == len(den) - 1
    np.testing.assert_allclose(low.weights[tuple(changed.T)], LAT.weights[tuple(changed.T)] * 0.5)


def _edge_weights(lat, a, b):
    """Weights of the lattice edges a -> b (node coordinate arrays), from the weights array."""
    step = b - a
    w = np.empty(len(a), np.float32)
    for k, off in enumerate(lat.offsets):
        for sign in (1, -1):
            hit = np.all(step == sign * off, axis=1)
            low = a[hit] if sign == 1 else b[hit]  # an edge's weight sits at its lower end
            w[hit] = lat.weights[(np.full(hit.sum(), k),) + tuple(low.T)]
    return w


@pytest.mark.parametrize("cheap", [0.0, 0.5])
def test_costs_add_up_along_the_dendrite_from_every_root(cheap):
    # whatever field each iteration searched (distance to the dendrite, or cheap former paths),
    # a grown dendrite's cost is the sum of the lattice's own weights from the root, as for one trace
    p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0, cheap=cheap)
    den = wd.grow(LAT, [[48, 48], [10, 80]], p, seed=5)
    assert den.generation.max() >= 2
    np.testing.assert_array_equal(den.cost[den.roots], 0.0)
    child = np.flatnonzero(den.parent >= 0)
    parent = den.parent[child]
    w = _edge_weights(LAT, den.nodes[child], den.nodes[parent])
    np.testing.assert_allclose(den.cost[child] - den.cost[parent], w, rtol=0, atol=2e-5 * den.cost.max())
    assert np.all(den.cost[child] >= den.cost[parent])
    # every branch of a later generation starts from the cost of the node it joins (not from 0)
    joins = child[den.generation[child] > den.generation[parent]]
    assert len(joins) and np.all(den.cost[joins] > den.cost[den.parent[joins]])


@pytest.mark.parametrize("cheap", [0.0, 0.5])
def test_no_endpoint_lands_on_the_dendrite_it_grows_from(cheap, monkeypatch):
    # with the default r (a tenth of the first d) the last bands reach below cost 0: they must not
    # offer the dendrite's own nodes, which would add no path
    p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=5.0, cheap=cheap)
    assert p.schedule()[-1][1] < p.band
    drawn = []
    real = growth._trace

    def spy(cf, ends, *, extend=None, **kwargs):
        drawn.append((np.asarray(ends).copy(), None if extend is None else extend.nodes.copy()))
        return real(cf, ends, extend=extend, **kwargs)

    monkeypatch.setattr(growth, "_trace", spy)
    wd.grow(LAT, [[48, 48]], p, seed=3)
    assert len(drawn) == len(p.schedule())
    for ends, before in drawn[1:]:
        on = {tuple(v) for v in before.tolist()}
        assert not [e for e in ends.tolist() if tuple(e) in on]


@pytest.mark.parametrize("cheap", [0.0, 0.3, 1.0])
def test_endpoints_lie_in_the_band_of_costs_from_the_dendrite(cheap, monkeypatch):
    # thesis Fig 3.12 and Fig 3.15 ("endpoints are placed at successively smaller path cost from
    # the structure"), in both modes: SciPy's costs from the generators and the dendrite so far
    # (on the lattice's own weights) put every endpoint of iteration i in (d_i - r, d_i + r)
    from scipy.sparse.csgraph import dijkstra

    p = wd.FractalParams(count=6, d=150.0, alpha=1.6, beta=2.5, epsilon=25.0, cheap=cheap)
    gens = np.array([[48, 48]])
    drawn = []
    real = growth._trace

    def spy(cf, ends, *, extend=None, generation=None, **kwargs):
        drawn.append((generation, np.asarray(ends).copy(), None if extend is None else extend.nodes.copy()))
        return real(cf, ends, extend=extend, generation=generation, **kwargs)

    monkeypatch.setattr(growth, "_trace", spy)
    den = wd.grow(LAT, gens, p, seed=4)
    assert len(drawn) >= 3 and den.generation.max() >= 2
    graph, r = LAT.to_csgraph(), p.band
    for it, ends, before in drawn:
        d = p.schedule()[it][1]
        structure = gens if before is None else np.concatenate([gens, before])
        cost = dijkstra(graph, indices=np.ravel_multi_index(tuple(structure.T), LAT.shape), min_only=True)
        c = cost[np.ravel_multi_index(tuple(ends.T), LAT.shape)]
        slack = 1e-4 * (d + r)  # float32 sums against SciPy's float64
        assert np.all(c > max(d - r, 0.0) - slack) and np.all(c < d + r + slack), (it, c.min(), c.max())


@pytest.mark.parametrize("cheap", [0.0, 0.2, 0.6])
def test_every_node_is_labelled_by_the_generator_its_path_reaches(cheap):
    # competing dendrites: with cheap former paths the costs of a later iteration may make another
    # generator nearest to an old node; the branches joining it still belong to its dendrite
    gens = np.array([[32, 32], [5, 5], [60, 10]])
    lat = wd.Lattice((64, 64), 8, weights=wd.weights.Uniform(r=10, seed=1))
    for seed in range(4):
        den = wd.grow(lat, gens, wd.FractalParams(count=4, d=120.0, alpha=1.6, beta=3.0, epsilon=15.0, cheap=cheap),
                      seed=seed)
        assert den.generation.max() >= 2
        # every row's root, by pointer jumping
        root = np.where(den.parent >= 0, den.parent, np.arange(len(den)))
        for _ in range(64):
            root = root[root]
        np.testing.assert_array_equal(gens[den.label], den.nodes[root])


def test_cheap_former_paths_refuse_a_start_no_generator_reaches():
    # a wall splits the lattice; the start dendrite lies beyond it: new generators grow from it,
    # cheap former paths (which trace every branch to the generators) say why they cannot
    mask = np.ones((40, 40), bool)
    mask[:, 20] = False
    lat = wd.Lattice((40, 40), 8, weights=wd.weights.Uniform(r=10, seed=1), mask=mask)
    start = wd.Dendrite.from_arrays((40, 40), [[20, 30], [21, 30], [22, 30]], [-1, 0, 1])
    p = wd.FractalParams(count=3, d=60.0, alpha=1.6, beta=3.0, epsilon=15.0)
    assert len(wd.grow(lat, [[20, 5]], p, start=start, seed=0)) > 3
    with pytest.raises(ValueError, match=r"'start' row 0 = \(20, 30\) cannot be reached"):
        wd.grow(lat, [[20, 5]], dataclasses.replace(p, cheap=0.5), start=start, seed=0)


def test_competition_keeps_dendrites_apart():
    den = wd.grow(LAT, [[20, 20], [75, 75]], PARAMS, seed=2)
    child = den.parent >= 0
    np.testing.assert_array_equal(den.label[child], den.label[den.parent[child]])
    assert sorted(den.label[den.roots].tolist()) == [0, 1]
    # each tree is whole: every node's path ends at the root of its own label
    roots = {int(den.label[r]): tuple(den.nodes[r]) for r in den.roots}
    for row in np.random.default_rng(0).choice(len(den), 50, replace=False):
        assert tuple(den.nodes[den.path(row)[-1]]) == roots[int(den.label[row])]


def test_progress_true_shows_a_bar_of_the_iterations_and_grows_the_same(capsys):
    plain = wd.grow(LAT, [[48, 48]], PARAMS, seed=11)
    shown = wd.grow(LAT, [[48, 48]], PARAMS, seed=11, progress=True)
    err = capsys.readouterr().err
    n = len(PARAMS.schedule())
    assert "growing" in err and f"{n}/{n}" in err  # tqdm's bar, on stderr, completed
    np.testing.assert_array_equal(plain.nodes, shown.nodes)


def test_progress_callback_and_reproducibility():
    seen = []
    a = wd.grow(LAT, [[48, 48]], PARAMS, seed=11, progress=lambda i, n, d: seen.append((i, n, len(d))))
    b = wd.grow(LAT, [[48, 48]], PARAMS, seed=11)
    assert [s[0] for s in seen] == list(range(1, len(PARAMS.schedule()) + 1))
    assert seen[-1][2] == len(a)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    c = wd.grow(LAT, [[48, 48]], PARAMS, seed=12)
    assert not np.array_equal(a.nodes, c.nodes) or len(a) != len(c)


@pytest.mark.parametrize(
    "kwargs,words",
    [
        (dict(alpha=1.0), "alpha"),
        (dict(alpha=0.5), "alpha"),
        (dict(beta=0.9), "beta"),
        (dict(epsilon=0.0), "epsilon"),
        (dict(epsilon=-1.0), "epsilon"),
        (dict(count=0), "count"),
        (dict(d=-5.0), "'d'"),
        (dict(r=0.0), "'r'"),
        (dict(cheap=1.5), "cheap"),
        (dict(cheap=-0.1), "cheap"),
        (dict(d=10.0, epsilon=20.0), "'d' (10.0) must exceed 'epsilon'"),
        (dict(alpha=1 + 1e-7, beta=1.0), "about 29957324 iterations"),  # would run for ever, in effect
        (dict(alpha=1 + 1e-9), "'alpha'"),
        (dict(d=1e6, epsilon=1.0, beta=1e6), "'beta'"),  # 1e6^34 endpoints overflow
    ],
)
def test_parameters_that_cannot_terminate_or_make_sense(kwargs, words):
    with pytest.raises(ValueError) as info:
        wd.FractalParams(**kwargs)
    assert words in str(info.value)


def test_schedules_of_exactly_the_longest_length_are_allowed():
    p = wd.FractalParams(count=1, d=2.0**1000, epsilon=1.0, alpha=2.0, beta=1.0)
    assert len(p.schedule()) == p.MAX_ITERATIONS
    with pytest.raises(ValueError, match="'alpha'"):
        wd.FractalParams(count=1, d=2.0**1001, epsilon=1.0, alpha=2.0, beta=1.0)


@pytest.mark.parametrize(
    "kwargs,error,words",
    [
        (dict(seed=-1), ValueError, "'seed'"),
        (dict(seed=1.5), TypeError, "'seed'"),
        (dict(progress="yes"), TypeError, "'progress'"),
        (dict(within=np.ones((10, 10), bool)), ValueError, "'within'"),
        (dict(start="x"), TypeError, "'start'"),
        (dict(start=wd.trace(wd.shortest_paths(wd.Lattice((20, 20), 4), [[0, 0]]), [[5, 5]])), ValueError,
         "'start' has shape (20, 20)"),
    ],
)
def test_bad_growth_arguments_raise_before_any_search(kwargs, error, words, monkeypatch):
    monkeypatch.setattr(growth, "shortest_paths", lambda *a, **k: pytest.fail("searched before checking"))
    monkeypatch.setattr(growth, "_search", lambda *a, **k: pytest.fail("searched before checking"))
    with pytest.raises(error) as info:
        wd.grow(LAT, [[48, 48]], PARAMS, **kwargs)
    assert words in str(info.value)


def test_a_bad_device_is_refused_before_a_hashed_lattices_weights_are_made(monkeypatch):
    # cheap former paths give a hashed lattice its weights array first: the device came after it
    lat = wd.Lattice((30, 30), 8, weights=wd.weights.Uniform(seed=1), store_weights=False)
    monkeypatch.setattr(wd.Lattice, "with_weights", lambda *a, **k: pytest.fail("weights made before checking"))
    with pytest.raises(ValueError, match="'device'.*'cuda:7'"):
        wd.grow(lat, [[15, 15]], wd.FractalParams(count=2, d=10, epsilon=2, cheap=0.5), device="cuda:7")


def test_progress_accepts_none_and_numpy_bools():
    a = wd.grow(LAT, [[48, 48]], PARAMS, seed=4, progress=None)
    b = wd.grow(LAT, [[48, 48]], PARAMS, seed=4, progress=np.False_)
    np.testing.assert_array_equal(a.nodes, b.nodes)


def test_a_start_that_cannot_grow_raises_as_without_one():
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5]])
    with pytest.raises(ValueError, match="lower 'd'"):
        wd.grow(LAT, [[48, 48]], wd.FractalParams(d=1e6, epsilon=5e5, alpha=2.0), start=start)


def test_a_start_whose_labels_do_not_index_the_generators_raises():
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48], [5, 5]]), [[90, 90], [6, 30]])
    assert start.label.max() == 1
    with pytest.raises(ValueError, match="labels range over"):
        wd.grow(LAT, [[48, 48]], PARAMS, start=start)


def test_empty_bands_raise_with_the_fix_the_costs_call_for():
    # the costs from (48, 48) on LAT, by SciPy's Dijkstra: the advice follows where the bands miss them
    from scipy.sparse.csgraph import dijkstra

    ref = dijkstra(LAT.to_csgraph(), indices=np.ravel_multi_index((48, 48), LAT.shape))
    low, high = ref[ref > 0].min(), ref.max()
    with pytest.raises(ValueError, match=rf"span \[{low:.4g}, {high:.4g}\].*all below the last band: lower 'd'"):
        wd.grow(LAT, [[48, 48]], wd.FractalParams(d=1e6, epsilon=5e5, alpha=2.0))
    # d below the cheapest edge: lowering it cannot help (the advice had said so)
    with pytest.raises(ValueError, match=r"all above the first band: raise 'd'"):
        wd.grow(LAT, [[48, 48]], wd.FractalParams(d=low / 4, epsilon=low / 40, r=low / 8))
    # bands narrower than the gaps between them
    gap = wd.FractalParams(d=high * 0.9, epsilon=high * 0.01, alpha=8.0, r=1e-5)
    with pytest.raises(ValueError, match="between the bands: raise 'r'"):
        wd.grow(LAT, [[48, 48]], gap)


def test_spaced_bands_take_as_many_endpoints_as_fit():
    # one iteration whose band holds about 60 endpoints 6 nodes apart: asking for more must not
    # give fewer (the band is filled greedily in random order, never redrawn with a smaller count)
    lat = wd.Lattice((80, 80), 8, weights=wd.weights.Uniform(r=10, seed=2))
    got = []
    for count in (40, 64, 200):
        p = wd.FractalParams(count=count, d=150.0, alpha=2.0, beta=1.0, epsilon=100.0, r=30.0, min_spacing=6.0)
        den = wd.grow(lat, [[40, 40]], p, seed=0)
        ends = den.nodes[den.endpoints]
        gaps = np.sqrt(((ends[:, None] - ends[None]) ** 2).sum(-1))[np.triu_indices(len(ends), 1)]
        assert gaps.min() >= 6.0
        got.append(len(ends))
    assert got[0] == 40 and got[0] < got[1] <= got[2] < 200, got


def test_masks_confine_growth_to_a_surface():
    # a spherical shell one node thick: growth must stay on it (lichen on a rock)
    z, y, x = np.mgrid[:24, :24, :24]
    r = np.sqrt((z - 11.5) ** 2 + (y - 11.5) ** 2 + (x - 11.5) ** 2)
    shell = (r > 9.0) & (r <= 10.5)
    lat = wd.Lattice((24, 24, 24), 26, weights=wd.weights.Uniform(seed=3), mask=shell)
    seed_node = np.argwhere(shell)[0]
    den = wd.grow(lat, [seed_node], wd.FractalParams(count=4, d=40.0, alpha=2.0, beta=2.0, epsilon=6.0), seed=0)
    assert len(den) > 20
    assert shell[tuple(den.nodes.T)].all()


def test_masked_letters_keep_paths_inside():
    mask = np.zeros((30, 60), bool)
    mask[5:25, 5:10] = mask[5:25, 20:25] = mask[13:17, 5:25] = True  # an "H"
    lat = wd.Lattice((30, 60), 8, weights=wd.weights.Uniform(seed=1), mask=mask)
    cf = wd.shortest_paths(lat, [[15, 15]])
    assert np.isinf(cf.dist[~mask]).all() and np.isfinite(cf.dist[mask]).all()
    den = wd.trace(cf, [[5, 5], [24, 9], [6, 24], [24, 20]])
    assert mask[tuple(den.nodes.T)].all()


def test_unstored_weights_with_cheap_former_paths_and_a_region():
    hashed = wd.Lattice((96, 96), 8, weights=wd.weights.Uniform(r=10, seed=5), store_weights=False)
    p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0, cheap=0.5)
    a = wd.grow(hashed, [[48, 48]], p, seed=3)
    b = wd.grow(LAT, [[48, 48]], p, seed=3)  # the same weights, stored
    np.testing.assert_array_equal(a.nodes, b.nodes)
    # endpoints confined to a region the band barely reaches: fewer endpoints, no error
    box = wd.endpoints.Box((0, 0), (20, 96))
    den = wd.grow(LAT, [[48, 48]], PARAMS, seed=1, within=box)
    assert box.mask(LAT.shape)[tuple(den.nodes[den.endpoints].T)].all()


def test_a_start_dendrite_makes_its_edges_cheap_from_the_first_iteration():
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5], [90, 90]])
    p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0, cheap=0.3)
    den = wd.grow(LAT, [[48, 48]], p, seed=2, start=start)
    np.testing.assert_array_equal(den.nodes[: len(start)], start.nodes)
    # the first iteration searched with the lowered start edges: each new node's cost is the
    # start node its branch joins plus the rise of the lowered field from there
    lowered = wd.shortest_paths(lower_dendrite_weights(LAT, start, 0.3), [[48, 48]]).dist
    # the start's rows are generation 0, so the first iteration is generation 1
    assert (den.generation[: len(start)] == 0).all() and den.generation[len(start):].min() == 1
    first = len(start) + np.flatnonzero(den.generation[len(start):] == 1)
    assert len(first)
    join = den.parent[first].copy()
    while np.any(join >= len(start)):
        join = np.where(join >= len(start), den.parent[np.maximum(join, 0)], join)
    field = lambda rows: lowered[tuple(den.nodes[rows].T)]  # noqa: E731
    np.testing.assert_array_equal(den.cost[first], den.cost[join] + (field(first) - field(join)))


@pytest.mark.parametrize("cheap", [0.0, 0.3])
def test_a_hand_placed_start_gets_path_costs(cheap):
    # the same paths given as plain arrays (costs 0 by default) grow exactly as the traced ones,
    # whose costs are path costs: growth recomputes a start's costs over the lattice's weights
    traced = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5], [90, 90]])
    plain = wd.Dendrite.from_arrays(LAT.shape, traced.nodes, traced.parent, label=traced.label)
    assert (plain.cost == 0).all() and traced.cost.max() > 0
    p = wd.FractalParams(count=4, d=150.0, alpha=2.0, beta=3.0, epsilon=15.0, cheap=cheap)
    a = wd.grow(LAT, [[48, 48]], p, seed=2, start=traced)
    b = wd.grow(LAT, [[48, 48]], p, seed=2, start=plain)
    np.testing.assert_array_equal(a.cost[: len(traced)], traced.cost)  # bit for bit
    np.testing.assert_array_equal(b.cost, a.cost)
    np.testing.assert_array_equal(b.nodes, a.nodes)


def test_a_start_with_a_step_that_is_no_lattice_edge_is_refused(monkeypatch):
    # a path traced on an 8-connected lattice has diagonal steps a 4-connected one lacks
    four = wd.Lattice(LAT.shape, 4, weights=wd.weights.Uniform(seed=1))
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5]])
    calls = []
    monkeypatch.setattr(growth, "shortest_paths", lambda *a, **k: calls.append(1))
    monkeypatch.setattr(growth, "_search", lambda *a, **k: calls.append(1))
    for cheap in (0.0, 0.5):
        with pytest.raises(ValueError, match=r"'start' row \d+ = .* steps to its parent by .* no edge of the 4-connected"):
            wd.grow(four, [[48, 48]], dataclasses.replace(PARAMS, cheap=cheap), start=start)
    with pytest.raises(ValueError, match=r"'dendrite' row \d+ .* no edge"):
        lower_dendrite_weights(four, start, 0.5)
    assert calls == []


def test_growth_refuses_an_empty_region_and_factors_that_round_to_zero():
    with pytest.raises(ValueError, match="'within' holds no usable node"):
        wd.grow(LAT, [[48, 48]], PARAMS, within=np.zeros(LAT.shape, bool))
    with pytest.raises(ValueError, match=r"'cheap' = 1e-46 is below float32's smallest normal"):
        wd.FractalParams(cheap=1e-46)
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5]])
    with pytest.raises(ValueError, match=r"'factor' = 1e-40 is below.*use a larger factor"):
        lower_dendrite_weights(LAT, start, 1e-40)
    # iterations numbered after the start's generations must fit int32: said before any search
    old = dataclasses.replace(start, generation=np.full(len(start), 2**31 - 2, np.int32))
    with pytest.raises(ValueError, match=r"'start' has generations up to 2147483646"):
        wd.grow(LAT, [[48, 48]], PARAMS, start=old)
    assert wd.FractalParams(cheap=1e-30).cheap == 1e-30


def test_new_generators_on_or_off_the_dendrite_become_roots_only_when_off_it():
    # walks stop at nodes of cost 0 (the dendrite's nodes, all generators here) unless they are
    # first generators not yet on the dendrite: those become roots, the others are never repeated
    start = wd.trace(wd.shortest_paths(LAT, [[48, 48]]), [[5, 5], [90, 90]])
    on_path = [int(v) for v in start.nodes[len(start) // 3]]  # a generator the start passes through
    p = wd.FractalParams(count=6, d=90.0, alpha=1.5, beta=3.0, epsilon=20.0)
    den = wd.grow(LAT, [[48, 48], on_path, [90, 5]], p, seed=4, start=start)
    assert len({tuple(n) for n in den.nodes.tolist()}) == len(den), "a node appears twice"
    np.testing.assert_array_equal(den.nodes[: len(start)], start.nodes)
    roots = {tuple(n) for n in den.nodes[den.roots].tolist()}
    assert tuple(on_path) not in roots and (48, 48) in roots
    assert (90, 5) in roots  # reached from the far corner's band: its own tree
    child = np.flatnonzero(den.parent >= 0)
    step = np.abs(den.nodes[den.parent[child]] - den.nodes[child])
    assert step.max() == 1 and step.sum(axis=1).min() >= 1
    np.testing.assert_array_equal(den.label[child], den.label[den.parent[child]])


@pytest.mark.parametrize("top", [True, False])
def test_walks_cross_plateaus_of_weights_negligible_against_the_cost(top):
    # weights must be positive, so only generators cost 0; but a weight below the float32 spacing of
    # the cost so far (1e-45 after 10 steps of 1) adds nothing: column 0 is a plateau of cost 10, left
    # at its top or bottom corner, where dist[next] + w == dist[here] holds both ways; the walks must
    # neither loop nor stop on it, whether its way out lies toward lower or higher node indices
    w = np.ones((2, 20, 20), np.float32)  # direction 0: (0, 1), direction 1: (1, 0)
    w[1, :, 0] = 1e-45
    lat = wd.Lattice((20, 20), 4, weights=w)
    np.testing.assert_array_equal(lat.offsets, [[0, 1], [1, 0]])
    gens = np.array([[0, 10]] if top else [[19, 10]])
    den = wd.trace(wd.shortest_paths(lat, gens), [[5, 15]] if top else [[14, 15]])
    cf = wd.shortest_paths(lat, np.concatenate([gens, den.nodes]))
    assert (cf.dist[:, 0] == 10).all()  # the plateau
    assert (cf.dist == 0).sum() == len(den)
    ends = [[2, 3], [18, 5]]
    out = wd.trace(cf, ends, extend=den)
    assert len({tuple(n) for n in out.nodes.tolist()}) == len(out), "a node appears twice"
    child = np.flatnonzero(out.parent >= 0)
    step = np.abs(out.nodes[out.parent[child]] - out.nodes[child]).sum(axis=1)
    assert np.all(step == 1)
    assert {tuple(n) for n in out.nodes[out.endpoints].tolist()} >= {tuple(e) for e in ends}
    # every path ends at a generator of the cost field
    g = {tuple(n) for n in cf.generators.tolist()}
    for e in ends:
        row = int(np.flatnonzero((out.nodes == e).all(axis=1))[0])
        assert tuple(out.nodes[out.path(row)[-1]]) in g
    # one walk goes along the plateau (up to its top corner, or down to its bottom one)
    row = int(np.flatnonzero((out.nodes == (ends[1] if top else ends[0])).all(axis=1))[0])
    assert (out.nodes[out.path(row)][:, 1] == 0).sum() >= 13


@pytest.mark.parametrize("field", ["count", "d", "alpha", "beta", "epsilon", "cheap"])
def test_fractal_params_refuse_text(field):
    kw = dict(count=2, d=6.0, alpha=2.0, beta=2.0, epsilon=1.0)
    kw[field] = "2"
    with pytest.raises((TypeError, ValueError), match=rf"'{field}'.*'2'"):
        wd.FractalParams(**kw)


def test_an_endpoint_count_overflow_names_the_schedule_that_makes_it():
    # a huge d makes the schedule long, and the counts overflow long before its end: the message
    # names d and epsilon, which set the length, not only count and beta
    with pytest.raises(ValueError, match=r"iteration 25 of about 37 \(from 'd' = 1e\+20 down to 'epsilon' = 1\.0\); "
                                         r"lower 'beta' or 'count', or 'd'"):
        wd.FractalParams(count=6, beta=4, d=1e20, epsilon=1.0, alpha=3.5)


def test_fractal_params_keep_plain_values_whatever_numpy_values_made_them():
    import json
    from dataclasses import asdict

    p = wd.FractalParams(count=np.int64(4), d=np.array(300.0), alpha=np.float32(1.5), beta=np.int32(2),
                         epsilon=np.float64(20), r=np.float32(10), cheap=np.float32(0.5), min_spacing=np.int16(2))
    ref = wd.FractalParams(count=4, d=300.0, alpha=1.5, beta=2.0, epsilon=20.0, r=10.0, cheap=0.5, min_spacing=2.0)
    assert p == ref and hash(p) == hash(ref) and repr(p) == repr(ref)
    assert json.loads(json.dumps(asdict(p))) == asdict(ref)  # (a 0-d array had broken JSON records)
    assert p.schedule() == ref.schedule()


def test_an_interrupted_growth_closes_its_progress_bar(monkeypatch):
    import tqdm.auto

    bars = []

    class Bar:
        def __init__(self, *args, **kwargs):
            self.closed = False
            bars.append(self)

        def update(self, n=1):
            pass

        def close(self):
            self.closed = True

    monkeypatch.setattr(tqdm.auto, "tqdm", Bar)
    monkeypatch.setattr(growth, "_trace", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(KeyboardInterrupt):
        wd.grow(LAT, [[48, 48]], PARAMS, progress=True)
    assert len(bars) == 1 and bars[0].closed  # (had been left open, its line on the screen)


def test_empty_bands_advice_reads_the_costs_inside_within():
    # the advice had read the whole lattice's costs and said "raise 'r'" where 'within' held none
    from scipy.sparse.csgraph import dijkstra

    within = wd.endpoints.Disc((2, 2), 1.5)
    ref = dijkstra(LAT.to_csgraph(), indices=np.ravel_multi_index((48, 48), LAT.shape)).reshape(LAT.shape)
    inside = ref[within.mask(LAT.shape)]
    words = rf"inside 'within' span \[{inside.min():.4g}, {inside.max():.4g}\] on this lattice, all above the first band"
    with pytest.raises(ValueError, match=words + ": raise 'd'"):
        wd.grow(LAT, [[48, 48]], wd.FractalParams(d=100, epsilon=20), within=within)
