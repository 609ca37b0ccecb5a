"""shortest_paths against SciPy's Dijkstra, tie rule, warm starts, limit, bad input."""

import math
import re

import numpy as np
import pytest
import warp as wp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import dijkstra

import wdendrite as wd
from wdendrite import _checks
from wdendrite.lattice import half_offsets
from wdendrite.sssp import _search

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def problems(draw, integer_weights=False):
    """A random small lattice (2D or 3D, any connectivity, maybe masked) and generators."""
    ndim = draw(st.sampled_from([2, 3]))
    sizes = st.integers(1, 9) if ndim == 2 else st.integers(1, 5)
    shape = tuple(draw(sizes) for _ in range(ndim))
    conn = draw(st.sampled_from([4, 8] if ndim == 2 else [6, 26]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    k = len(half_offsets(ndim, conn))
    if integer_weights:
        w = rng.integers(1, 4, size=(k, *shape)).astype(np.float32)
    else:
        w = rng.uniform(0.5, 20.0, size=(k, *shape)).astype(np.float32)
    mask = None
    if draw(st.booleans()):
        mask = rng.random(shape) < draw(st.floats(0.3, 1.0))
        if not mask.any():
            mask.flat[0] = True
    usable = np.argwhere(mask) if mask is not None else np.argwhere(np.ones(shape, bool))
    g = draw(st.integers(1, 6))
    gens = usable[rng.integers(0, len(usable), size=g)]
    return wd.Lattice(shape, conn, weights=w, mask=mask), gens


def _scipy_all(lat, gens):
    """(G, N) float64 costs from each generator alone."""
    flat = np.ravel_multi_index(tuple(gens.T), lat.shape)
    return dijkstra(lat.to_csgraph(), directed=False, indices=flat)


def _check_against_scipy(lat, gens, cf, limit=np.inf):
    per_gen = _scipy_all(lat, gens)
    ref = per_gen.min(axis=0)
    ref = np.where(ref <= limit, ref, np.inf)
    dist = cf.dist.ravel()
    label = cf.label.ravel()
    assert cf.dist.shape == lat.shape and cf.dist.dtype == np.float32
    assert cf.label.shape == lat.shape and cf.label.dtype == np.int32
    reached = np.isfinite(ref)
    np.testing.assert_array_equal(np.isfinite(dist), reached)
    np.testing.assert_allclose(dist[reached], ref[reached], rtol=1e-5, atol=1e-6)
    assert np.all(label[~reached] == -1)
    lab = label[reached]
    assert np.all((lab >= 0) & (lab < len(gens)))
    np.testing.assert_allclose(per_gen[lab, np.flatnonzero(reached)], dist[reached], rtol=1e-5, atol=1e-6)
    return per_gen


@SETTINGS
@given(problems())
def test_matches_scipy_dijkstra(problem):
    lat, gens = problem
    _check_against_scipy(lat, gens, wd.shortest_paths(lat, gens))


@SETTINGS
@given(problems(integer_weights=True))
def test_ties_go_to_the_lowest_generator_row(problem):
    # integer weights make float32 sums exact, so ties can be checked exactly
    lat, gens = problem
    cf = wd.shortest_paths(lat, gens)
    per_gen = _check_against_scipy(lat, gens, cf)
    dist = cf.dist.ravel()
    for v in np.flatnonzero(np.isfinite(dist)):
        assert cf.label.ravel()[v] == np.flatnonzero(per_gen[:, v] == dist[v])[0]


@SETTINGS
@given(problems(), st.floats(0.0, 40.0))
def test_limit_keeps_costs_up_to_the_bound(problem, limit):
    lat, gens = problem
    cf = wd.shortest_paths(lat, gens, limit=limit)
    _check_against_scipy(lat, gens, cf, limit=limit)


@pytest.mark.parametrize("schedule", ["one launch", "host rounds", "generations"])
def test_a_limit_between_two_float32_values_keeps_no_cost_above_it(schedule):
    # integer weights give exact costs (SciPy's float64 and the kernels' float32 agree); a limit a
    # hair below a cost c rounds to c in float32, which had kept the nodes costing c: they cost more
    # than the limit and must be unreached, in the costs, the labels, a band read and a warm start
    rng = np.random.default_rng(7)
    w = rng.integers(1, 4, size=(2, 12, 13)).astype(np.float32)
    lat = wd.Lattice((12, 13), 4, weights=w)
    gens = np.array([[0, 0], [11, 12]])
    ref = _scipy_all(lat, gens).min(axis=0).reshape(lat.shape)
    c = float(np.sort(ref.ravel())[ref.size // 2])  # a cost some nodes have
    limit = c - 2.0**-30  # (float32 holds no number between c - 2**-30 and c for such a c)
    assert np.float32(limit) == c and (ref == c).any()
    hooks = {"one launch": {}, "host rounds": {"host_rounds": True}, "generations": {"fifo": False}}[schedule]
    cf = _search(lat, gens, limit=limit, device="cpu", **hooks)
    _check_against_scipy(lat, gens, cf, limit=limit)
    assert np.array_equal(np.isfinite(cf.dist), ref <= limit) and np.all(cf.label[ref == c] == -1)
    warm = _search(lat, np.vstack([gens, [[5, 6]]]), limit=limit, warm_start=cf, device="cpu", **hooks)
    assert not np.any(np.isfinite(warm.dist) & (warm.dist > limit))
    with pytest.raises(ValueError, match="limit"):  # (a trace reads the states of its endpoints alone)
        wd.trace(cf, np.argwhere(ref == c)[:1])


@SETTINGS
@given(problems(), st.floats(0.05, 100.0), st.booleans())
def test_result_does_not_depend_on_bucket_width_or_schedule(problem, delta, fifo):
    # fifo=False is the generation-round schedule GPUs use; it runs on the CPU here (labels of
    # rounding ties may follow a GPU's thread timing, so the comparison is the CPU's)
    lat, gens = problem
    a = wd.shortest_paths(lat, gens, device="cpu")
    b = _search(lat, gens, delta=delta, fifo=fifo, device="cpu")
    np.testing.assert_array_equal(a.dist.view(np.uint32), b.dist.view(np.uint32))
    np.testing.assert_array_equal(a.label, b.label)


@SETTINGS
@given(problems(), st.floats(0.01, 100.0), st.one_of(st.just(np.inf), st.floats(0.0, 40.0)), st.data())
def test_one_launch_search_equals_buckets_driven_from_the_host(problem, delta, limit, data):
    # the work queue's buckets emptied in one launch (the CPU default) against one launch per
    # bucket from the host: the same costs and labels bit for bit, the same buckets and
    # relaxations (the same queue order), cold and warm
    lat, gens = problem
    split = data.draw(st.integers(1, len(gens)))
    runs = []
    for host in (False, True):
        first = _search(lat, gens[:split], limit=limit, delta=delta, host_rounds=host, device="cpu")
        cold = (first.dist.copy(), first.label.copy(), first.rounds, first.relaxed)
        warm = _search(lat, gens, limit=limit, delta=delta, warm_start=first, host_rounds=host,
                                 device="cpu")
        runs.append((cold, (warm.dist, warm.label, warm.rounds, warm.relaxed)))
    for (one, host) in zip(*runs):
        np.testing.assert_array_equal(one[0].view(np.uint32), host[0].view(np.uint32))
        np.testing.assert_array_equal(one[1], host[1])
        assert one[2:] == host[2:]
    _check_against_scipy(lat, gens, wd.shortest_paths(lat, gens, limit=limit, delta=delta), limit=limit)


@pytest.mark.parametrize("store", [True, False])
@pytest.mark.parametrize("shape, conn", [((9, 11), 4), ((9, 11), 8), ((5, 6, 7), 6), ((5, 6, 7), 26)])
def test_each_lattice_is_searched_by_the_kernel_compiled_for_its_records(shape, conn, store, monkeypatch):
    # stored weights: the one-launch kernel whose record layout was fixed at compile time for this
    # connectivity; hashed weights: the general one. Other tests compare their results with the
    # host's buckets (the general relax kernel): on random stored lattices above, on stored and
    # hashed ones below.
    import inspect

    from wdendrite.kernels import sssp as ks

    launched = []
    real_launch = wp.launch
    monkeypatch.setattr(wp, "launch", lambda kernel, *a, **k: (launched.append(kernel), real_launch(kernel, *a, **k))[1])
    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=10, seed=3), store_weights=store)
    gens = np.zeros((1, len(shape)), np.int64)
    cf = wd.shortest_paths(lat, gens, device="cpu")
    k = len(half_offsets(len(shape), conn))
    assert k in ks.SEARCH_DIRECTIONS
    searches = [kern for kern in launched if kern in ks.SEARCH_KERNELS.values()]
    assert searches == [ks.SEARCH_KERNELS[k if store else 0]]
    # and each kernel is compiled for the count it is filed under
    assert all(inspect.getclosurevars(kern.func).nonlocals["fixed_weights"] == n_weights for n_weights, kern in ks.SEARCH_KERNELS.items())
    _check_against_scipy(lat, gens, cf)


def test_records_of_another_stride_are_searched_by_the_general_kernel(monkeypatch):
    # a compiled layout is only used for the records it was compiled for: with wider records
    # (a stride the kernels were not compiled for) the search still equals the host's buckets
    import wdendrite.lattice as lattice_mod
    from wdendrite.kernels import sssp as ks

    monkeypatch.setattr(lattice_mod, "record_stride", lambda n_weights: ks.record_stride(n_weights) + 2)
    lat = wd.Lattice((20, 20), 8, weights=wd.weights.Uniform(r=10, seed=4))
    assert lat.device_arrays("cpu").stride == ks.record_stride(4) + 2
    gens = np.array([[3, 4], [15, 12]])
    one = wd.shortest_paths(lat, gens, device="cpu")
    one = (one.dist.copy(), one.label.copy(), one.rounds, one.relaxed)
    host = _search(lat, gens, host_rounds=True, device="cpu")
    np.testing.assert_array_equal(one[0].view(np.uint32), host.dist.view(np.uint32))
    np.testing.assert_array_equal(one[1], host.label)
    assert one[2:] == (host.rounds, host.relaxed)
    _check_against_scipy(lat, gens, host)


@pytest.mark.parametrize("store", [True, False])
@pytest.mark.parametrize("shape, conn", [((40, 50), 8), ((12, 13, 14), 26)])
def test_one_launch_search_equals_host_buckets_on_larger_lattices(shape, conn, store):
    # many buckets (a narrow delta) over stored and hashed weights, with a mask and a limit
    rng = np.random.default_rng(5)
    mask = rng.random(shape) < 0.9
    lat = wd.Lattice(shape, conn, weights=wd.weights.Power(alpha=3, max=11, seed=2), mask=mask,
                     store_weights=store)
    gens = np.argwhere(mask)[rng.integers(0, mask.sum(), 4)]
    for delta, limit in ((0.3, np.inf), (None, 60.0)):
        one = wd.shortest_paths(lat, gens, delta=delta, limit=limit, device="cpu")
        one = (one.dist.copy(), one.label.copy(), one.rounds, one.relaxed)
        host = _search(lat, gens, delta=delta, limit=limit, host_rounds=True, device="cpu")
        np.testing.assert_array_equal(one[0].view(np.uint32), host.dist.view(np.uint32))
        np.testing.assert_array_equal(one[1], host.label)
        assert one[2:] == (host.rounds, host.relaxed) and one[2] > (20 if delta else 0)


@SETTINGS
@given(problems(), st.floats(0.0, 40.0), st.integers(1, 9))
def test_generation_round_schedule_matches_scipy(problem, limit, threads):
    # the GPU schedule: threads stride over each frontier generation
    lat, gens = problem
    cf = _search(lat, gens, limit=limit, fifo=False, max_threads=threads, device="cpu")
    _check_against_scipy(lat, gens, cf, limit=limit)
    ref = wd.shortest_paths(lat, gens, limit=limit, device="cpu")
    assert cf.dist.tobytes() == ref.dist.tobytes() and cf.label.tobytes() == ref.label.tobytes()


@SETTINGS
@given(problems(), st.data())
def test_warm_start_equals_cold_start(problem, data):
    lat, gens = problem
    split = data.draw(st.integers(1, len(gens)))
    first = wd.shortest_paths(lat, gens[:split])
    # lower a random subset of the weights, as cheap former paths do
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    factor = np.where(rng.random(lat.weights.shape) < 0.3, rng.uniform(0.0, 1.0, lat.weights.shape), 1.0)
    lat2 = lat.with_weights((lat.weights * factor).astype(np.float32))
    lat2 = lat2 if data.draw(st.booleans()) else lat
    warm = wd.shortest_paths(lat2, gens, warm_start=first)
    cold = wd.shortest_paths(lat2, gens)
    np.testing.assert_array_equal(warm.dist.view(np.uint32), cold.dist.view(np.uint32))
    np.testing.assert_array_equal(warm.label, cold.label)


@SETTINGS
@given(problems(), st.data())
def test_warm_start_after_edges_lowered_in_place_equals_cold_start(problem, data):
    # growth with cheap former paths lowers its own lattice's edges in place and names them
    lat, gens = problem
    own = lat.with_weights(lat.weights)
    split = data.draw(st.integers(1, len(gens)))
    fifo = data.draw(st.booleans())
    first = _search(own, gens[:split], fifo=fifo)
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    dirs = rng.integers(0, len(lat.offsets), size=data.draw(st.integers(0, 12)))
    coords = np.stack([rng.integers(0, n, size=len(dirs)) for n in lat.shape], axis=1).reshape(-1, lat.ndim)
    inside = np.all((coords + lat.offsets[dirs] >= 0) & (coords + lat.offsets[dirs] < lat.shape), axis=1)
    dirs, coords = dirs[inside], coords[inside]
    dirs, keep = np.unique(np.ravel_multi_index((dirs, *coords.T), lat.weights.shape), return_index=True)
    dirs, coords = np.unravel_index(dirs, lat.weights.shape)[0], coords[keep]
    factor = data.draw(st.floats(0.01, 1.0))
    expected = lat.weights.copy()
    idx = (dirs, *coords.T)
    expected[idx] = expected[idx] * np.float32(factor)
    if data.draw(st.booleans()):
        lowered = own._lower_in_place(dirs, coords, factor, "cpu")
    else:  # records other than the host's (a GPU's) take the new weights from the search itself
        lowered = (own.padded_indices(coords), dirs.astype(np.int32), expected[idx], None)
    warm = _search(own, gens, warm_start=first, lowered=lowered, fifo=fifo)
    np.testing.assert_array_equal(own.weights, expected)
    cold = wd.shortest_paths(lat.with_weights(expected), gens)
    np.testing.assert_array_equal(warm.dist.view(np.uint32), cold.dist.view(np.uint32))
    np.testing.assert_array_equal(warm.label, cold.label)
    with pytest.raises(ValueError, match="own lattice"):
        _search(lat.with_weights(expected), gens, warm_start=warm, lowered=lowered)


@SETTINGS
@given(problems(), st.data())
def test_warm_start_with_a_lower_limit_equals_cold_start(problem, data):
    lat, gens = problem
    split = data.draw(st.integers(1, len(gens)))
    high = data.draw(st.floats(0.0, 60.0))
    low = data.draw(st.floats(0.0, high))
    first = wd.shortest_paths(lat, gens[:split], limit=high)
    warm = wd.shortest_paths(lat, gens, limit=low, warm_start=first)
    cold = wd.shortest_paths(lat, gens, limit=low)
    np.testing.assert_array_equal(warm.dist.view(np.uint32), cold.dist.view(np.uint32))
    np.testing.assert_array_equal(warm.label, cold.label)
    # and backtracking from the warm field gives the cold field's paths
    ends = np.argwhere(np.isfinite(cold.dist))
    a, b = wd.trace(warm, ends), wd.trace(cold, ends)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.parent, b.parent)


def test_deterministic_bits_on_a_larger_lattice(device):
    lat = wd.Lattice((96, 128), 8, weights=wd.weights.Uniform(r=10, seed=3))
    gens = np.random.default_rng(1).integers(0, 96, size=(12, 2))
    runs = [wd.shortest_paths(lat, gens, device=device) for _ in range(2)]
    assert runs[0].dist.tobytes() == runs[1].dist.tobytes()
    assert runs[0].label.tobytes() == runs[1].label.tobytes()
    _check_against_scipy(lat, gens, runs[0])


def test_masked_wall_leaves_unreachable_region(device):
    mask = np.ones((20, 30), bool)
    mask[:, 15] = False
    lat = wd.Lattice((20, 30), 8, weights=wd.weights.Uniform(seed=0), mask=mask)
    cf = wd.shortest_paths(lat, [[5, 3]], device=device)
    assert np.isinf(cf.dist[:, 15:]).all() and (cf.label[:, 15:] == -1).all()
    assert np.isfinite(cf.dist[:, :15]).all()


def test_warm_start_relaxes_only_near_the_change():
    lat = wd.Lattice((200, 200), 4, weights=wd.weights.Uniform(seed=2))
    cold = wd.shortest_paths(lat, [[100, 100]])
    warm = wd.shortest_paths(lat, [[100, 100], [0, 0]], warm_start=cold)
    # only the region the new corner generator wins is touched again
    assert warm.rounds < cold.rounds
    again = wd.shortest_paths(lat, [[100, 100], [0, 0]])
    assert warm.dist.tobytes() == again.dist.tobytes()


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_cost_fields_pickle_and_the_copy_serves_searches_and_walks(how):
    import copy
    import pickle

    rng = np.random.default_rng(3)
    mask = np.ones((15, 17), bool)
    mask[7, 2:] = False  # a wall, so some costs go round it
    lat = wd.Lattice((15, 17), 8, weights=rng.uniform(0.5, 9.0, (4, 15, 17)).astype(np.float32), mask=mask)
    gens = np.array([[0, 3], [14, 16], [3, 12]])
    cf = wd.shortest_paths(lat, gens[:2])
    twin = pickle.loads(pickle.dumps(cf)) if how == "pickle" else copy.deepcopy(cf)
    assert twin.lattice is not lat and twin.device == cf.device and twin.limit == cf.limit
    _check_against_scipy(twin.lattice, gens[:2], twin)
    ends = np.argwhere(np.isfinite(cf.dist))[::7]
    a, b = wd.trace(cf, ends), wd.trace(twin, ends)
    assert np.array_equal(a.parent, b.parent) and np.array_equal(a.nodes, b.nodes)
    # a warm start from the copy (whose costs are not in any lattice's records) equals a cold search
    warm = wd.shortest_paths(twin.lattice, gens, warm_start=twin)
    _check_against_scipy(twin.lattice, gens, warm)


def test_device_arrays_are_kept(device):
    lat = wd.Lattice((8, 9))
    cf = wd.shortest_paths(lat, [[0, 0]], device=device)
    assert cf.dist_array.shape == (8, 9) and str(cf.dist_array.device) == device
    assert np.shares_memory(cf.dist, cf.dist) and cf.dist[0, 0] == 0
    assert cf.dist[7, 8] == 15.0  # Manhattan distance with unit weights


LAT = wd.Lattice((6, 7), 4, mask=np.pad(np.ones((5, 7), bool), ((0, 1), (0, 0))))


@pytest.mark.parametrize(
    "gens,kwargs,exc,words",
    [
        (np.zeros((0, 2), int), {}, ValueError, "empty"),
        ([], {}, ValueError, "generators"),
        ([[1.0, 2.0]], {}, TypeError, "float64"),
        ([1, 2], {}, ValueError, "[point]"),
        ([[1, 2, 3]], {}, ValueError, "(G, 2)"),
        ([[6, 0]], {}, ValueError, "(6, 0)"),
        ([[6, 2]], {}, ValueError, "(6, 2) lies outside the lattice of shape (6, 7); coordinates are (row, col) = "
                                   "(y, x): did you mean (2, 6)?"),
        ([[0, -1]], {}, ValueError, "(0, -1)"),
        ([[5, 3]], {}, ValueError, "masked"),
        ([[0, 0]], {"limit": -1}, ValueError, "limit"),
        ([[0, 0]], {"limit": float("nan")}, ValueError, "limit"),
        ([[0, 0]], {"delta": 0}, ValueError, "delta"),
        ([[0, 0]], {"warm_start": "x"}, TypeError, "warm_start"),
        # ragged rows had raised NumPy's "inhomogeneous shape", naming nothing
        ([[1, 2], [3]], {}, ValueError, "'generators' in rows of one length, but got rows of different lengths"),
        # unsigned coordinates beyond int64 had been wrapped and reported as row -9223372036854775808
        (np.array([[1, 1], [2**63, 0]], np.uint64), {}, ValueError,
         "'generators' has coordinates beyond int64: 9223372036854775808 at index (1, 0)"),
    ],
)
def test_bad_input(gens, kwargs, exc, words):
    with pytest.raises(exc) as info:
        wd.shortest_paths(LAT, gens, **kwargs)
    assert words in str(info.value)


def test_bad_lattice_type():
    with pytest.raises(TypeError, match="lattice"):
        wd.shortest_paths(np.ones((3, 3)), [[0, 0]])


def test_warm_start_mismatches():
    lat = wd.Lattice((5, 5), 4, weights=wd.weights.Uniform(seed=1))
    cf = wd.shortest_paths(lat, [[0, 0], [4, 4]])
    with pytest.raises(ValueError, match="begin with"):
        wd.shortest_paths(lat, [[4, 4], [0, 0]], warm_start=cf)
    with pytest.raises(ValueError, match="raises"):
        wd.shortest_paths(lat.with_weights(lat.weights * 2), [[0, 0], [4, 4]], warm_start=cf)
    with pytest.raises(ValueError, match="does not match"):
        wd.shortest_paths(wd.Lattice((5, 6)), [[0, 0], [4, 4]], warm_start=cf)
    with pytest.raises(ValueError, match="mask"):
        wd.shortest_paths(wd.Lattice((5, 5), mask=np.ones((5, 5), bool)), [[0, 0], [4, 4]], warm_start=cf)
    capped = wd.shortest_paths(lat, [[0, 0], [4, 4]], limit=5.0)
    with pytest.raises(ValueError, match="exceeds the warm start's limit"):
        wd.shortest_paths(lat, [[0, 0], [4, 4]], warm_start=capped, limit=10.0)


def test_a_cost_fields_generators_are_its_own_and_read_only():
    # walks and warm starts trust the rows the search checked: a write had let a warm start
    # take a generator far outside the lattice
    gens = np.array([[0, 0], [4, 4]])
    cf = wd.shortest_paths(wd.Lattice((5, 5)), gens)
    gens[0] = [3, 3]  # the caller's array stays theirs
    np.testing.assert_array_equal(cf.generators, [[0, 0], [4, 4]])
    with pytest.raises(ValueError, match="read-only"):
        cf.generators[0] = [3000000, 3000000]


def test_a_cuda_memory_check_counts_what_the_pool_lets_go_at_a_synchronization(monkeypatch):
    # a stand-in CUDA device whose pool holds 2 GiB of freed blocks until a synchronization
    gpu = type("FakeCuda", (), {"is_cuda": True, "__str__": lambda self: "cuda:0"})()
    state = {"free": 1 << 30}
    monkeypatch.setattr(wp, "get_device", lambda d=None: gpu)
    monkeypatch.setattr(wp, "synchronize_device", lambda d=None: state.update(free=3 << 30))
    monkeypatch.setattr(_checks, "available_bytes", lambda device: state["free"])
    _checks.fits_in_memory(2 << 30, "cuda:0", "a search")  # fits once the pool has let go
    with pytest.raises(MemoryError, match="needs about 4.00 GiB on device 'cuda:0', but only 3.00 GiB"):
        _checks.fits_in_memory(4 << 30, "cuda:0", "a search")


def test_too_big_for_memory_is_refused_before_work(monkeypatch):
    monkeypatch.setattr(_checks, "available_bytes", lambda device: 1000)
    with pytest.raises(MemoryError, match="GiB"):
        wd.shortest_paths(wd.Lattice((64, 64)), [[0, 0]])


@pytest.mark.parametrize(
    "shape,conn,dist,uses_pow",
    [
        ((40, 52), 8, wd.weights.Uniform(r=10, seed=3), False),
        ((40, 52), 4, wd.weights.Power(alpha=3, max=11, seed=1) * wd.weights.Tropism("bottom", strength=2.0), True),
        ((12, 14, 10), 26, wd.weights.Polynomial(n=4, seed=2) + wd.weights.Tropism("axis", strength=5.0), True),
        ((12, 14, 10), 6, wd.weights.Uniform(r=50, seed=8), False),
    ],
)
def test_unstored_weights_give_the_stored_result(shape, conn, dist, uses_pow, device):
    stored = wd.Lattice(shape, conn, weights=dist)
    hashed = wd.Lattice(shape, conn, weights=dist, store_weights=False)
    assert not hashed.stores_weights and hashed.nbytes_per_node() < stored.nbytes_per_node()
    np.testing.assert_array_equal(hashed.weights, stored.weights)
    gens = np.random.default_rng(0).integers(0, min(shape), size=(3, len(shape)))
    a = wd.shortest_paths(stored, gens, device=device)
    b = wd.shortest_paths(hashed, gens, device=device)
    if uses_pow and wp.get_device(device).is_cuda:
        # the stored weights come from the CPU's pow, the recomputed ones from CUDA's, which may
        # differ by a unit in the last place (as the Lattice docstring says): costs agree closely
        np.testing.assert_allclose(b.dist, a.dist, rtol=1e-5)
        return
    assert a.dist.tobytes() == b.dist.tobytes() and a.label.tobytes() == b.label.tobytes()
    # the generation-round schedule (GPUs) weighs hashed edges with the same code
    c = _search(hashed, gens, device=device, fifo=False, max_threads=7)
    assert a.dist.tobytes() == c.dist.tobytes() and a.label.tobytes() == c.label.tobytes()
    ends = np.argwhere(np.isfinite(a.dist))[::7]
    da, db = wd.trace(a, ends), wd.trace(b, ends)
    np.testing.assert_array_equal(da.nodes, db.nodes)
    np.testing.assert_array_equal(da.parent, db.parent)


def test_unstored_weights_need_a_distribution():
    with pytest.raises(ValueError, match="store_weights"):
        wd.Lattice((4, 4), weights=np.ones((2, 4, 4)), store_weights=False)


def test_warm_start_checks_new_generator_rows_and_names_them_in_the_whole_list():
    # generators that begin with the warm start's are checked from there on; errors count rows in the whole list
    mask = np.ones((20, 20), bool)
    mask[5, 5] = False
    lat = wd.Lattice((20, 20), 8, weights=wd.weights.Uniform(seed=2), mask=mask)
    first = np.array([[1, 1], [10, 12]])
    cf = wd.shortest_paths(lat, first, limit=30.0)
    for bad, words in (([[5, 5]], "row 2 = (5, 5) is a masked-out node"), ([[3, 20]], "row 2 = (3, 20) lies outside")):
        with pytest.raises(ValueError, match=re.escape(words)):
            wd.shortest_paths(lat, np.concatenate([first, np.array(bad)]), warm_start=cf, limit=30.0)
    more = np.concatenate([first, np.array([[15, 3]])])
    warm = wd.shortest_paths(lat, more, warm_start=cf, limit=30.0)
    cold = wd.shortest_paths(lat, more, limit=30.0)
    assert warm.dist.tobytes() == cold.dist.tobytes() and warm.label.tobytes() == cold.label.tobytes()
    assert warm.generators.dtype == np.int64 and np.array_equal(warm.generators, more)


def test_stamp_ids_wrap_safely():
    # the record stamps are int32 ids that only grow; near the limit they are cleared and restart
    lat = wd.Lattice((40, 50), 8, weights=wd.weights.Uniform(seed=4))
    ref = wd.shortest_paths(lat, [[3, 4], [30, 40]])
    stamps = lat.device_arrays().stamps
    stamps.last = stamps.LIMIT - 10
    for fifo in (True, False):
        again = _search(lat, [[3, 4], [30, 40]], fifo=fifo)
        assert again.dist.tobytes() == ref.dist.tobytes() and again.label.tobytes() == ref.label.tobytes()
    assert stamps.last < 10**6


def test_searches_end_on_overflow_tiny_buckets_and_huge_weight_ranges():
    # costs that overflow float32 stay unreached (inf, -1) instead of stalling the buckets
    lat = wd.Lattice((1, 3), weights=np.full((2, 1, 3), 2e38, np.float32))
    cf = wd.shortest_paths(lat, [[0, 0]])
    assert cf.dist[0, 1] == np.float32(2e38) and np.isinf(cf.dist[0, 2]) and cf.label[0, 2] == -1
    # a bucket width that vanishes next to the costs still moves at least one node per bucket
    cf = wd.shortest_paths(wd.Lattice((4, 4)), [[0, 0]], delta=1e-20)
    np.testing.assert_array_equal(cf.dist, np.add.outer(np.arange(4), np.arange(4)).astype(np.float32))
    w = np.full((2, 1, 4), 1e-9, np.float32)
    w[0, 0, 1] = 1e12
    cf = wd.shortest_paths(wd.Lattice((1, 4), weights=w), [[0, 0]])
    assert cf.dist[0, 3] == np.float32(1e12) and np.isfinite(cf.dist).all()


def test_unstored_map_weights_pick_their_own_bucket_width():
    sketch = np.linspace(0, 1, 40 * 30, dtype=np.float32).reshape(40, 30)
    dist = wd.weights.Uniform(seed=1) * wd.weights.Map(sketch, strength=3.0)
    hashed = wd.Lattice((40, 30), 8, weights=dist, store_weights=False)
    stored = wd.Lattice((40, 30), 8, weights=dist)
    a, b = wd.shortest_paths(hashed, [[5, 5]]), wd.shortest_paths(stored, [[5, 5]])
    assert a.dist.tobytes() == b.dist.tobytes()


def test_warm_start_and_trace_from_a_field_whose_records_were_reused():
    # a lattice's records hold one search's state at a time: an older cost field
    # is packed back into them from its dist and label when it is used again
    lat = wd.Lattice((40, 50), 8, weights=wd.weights.Uniform(r=10, seed=4))
    first = wd.shortest_paths(lat, [[3, 4]], limit=60.0)
    ends = np.argwhere(np.isfinite(first.dist))[::7]
    fresh = wd.trace(first, ends)
    other = wd.shortest_paths(lat, [[30, 40], [10, 45]])  # overwrites the records' state
    again = wd.trace(first, ends)
    np.testing.assert_array_equal(again.nodes, fresh.nodes)
    np.testing.assert_array_equal(again.parent, fresh.parent)
    wd.trace(other, [[0, 0]])
    warm = wd.shortest_paths(lat, [[3, 4], [30, 40]], limit=50.0, warm_start=first)
    cold = wd.shortest_paths(lat, [[3, 4], [30, 40]], limit=50.0)
    assert warm.dist.tobytes() == cold.dist.tobytes() and warm.label.tobytes() == cold.label.tobytes()


@pytest.mark.parametrize("shape,conn", [((60, 70), 8), ((20, 24, 22), 26), ((18, 20, 16), 6)])
@pytest.mark.parametrize("source", ["array", "distribution"])
def test_sparse_lattices_match_scipy(shape, conn, source):
    # fewer than a quarter of the nodes usable: records filled for usable nodes only and
    # passes over the usable list (as refinement's lattices are); limits and warm starts too
    rng = np.random.default_rng(len(shape) * conn)
    mask = rng.random(shape) < 0.2
    k = len(half_offsets(len(shape), conn))
    weights = (wd.weights.Uniform(r=10, seed=6) if source == "distribution"
               else rng.uniform(1, 11, size=(k, *shape)).astype(np.float32))
    lat = wd.Lattice(shape, conn, weights=weights, mask=mask)
    assert lat.device_arrays("cpu").usable is not None
    gens = np.argwhere(mask)[rng.choice(int(mask.sum()), 3, replace=False)]
    cf = wd.shortest_paths(lat, gens)
    _check_against_scipy(lat, gens, cf)
    capped = wd.shortest_paths(lat, gens[:1], limit=15.0)
    _check_against_scipy(lat, gens[:1], capped, limit=15.0)
    warm = wd.shortest_paths(lat, gens, warm_start=capped, limit=15.0)
    cold = wd.shortest_paths(lat, gens, limit=15.0)
    assert warm.dist.tobytes() == cold.dist.tobytes() and warm.label.tobytes() == cold.label.tobytes()
    # the band of costs read from the usable list equals the band of the unpacked array
    from wdendrite.sssp import band_nodes

    flat = cold.dist.reshape(-1)
    np.testing.assert_array_equal(band_nodes(cold, 5.0, 12.0), np.flatnonzero((flat > 5.0) & (flat < 12.0)))
    # a masked distribution's weights are computed on access: the same values the records hold
    np.testing.assert_array_equal(lat.weights, wd.Lattice(shape, conn, weights=weights).weights)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.floats(5.0, 60.0))
def test_costs_read_after_the_records_were_reused_match_scipy(problem, limit):
    # a search leaves its costs in the lattice's records and unpacks them only when they are
    # first read or when another search is about to reuse the records: reading late loses nothing
    lat, gens = problem
    first = wd.shortest_paths(lat, gens, limit=limit)
    assert first._fields.dist is None  # nothing unpacked yet
    second = wd.shortest_paths(lat, gens[::-1])  # cold: reuses the records
    third = wd.shortest_paths(lat, gens[::-1], limit=limit / 2, warm_start=second)  # warm: reuses them again
    _check_against_scipy(lat, gens, first, limit=limit)
    _check_against_scipy(lat, gens[::-1], second)
    _check_against_scipy(lat, gens[::-1], third, limit=limit / 2)


def test_a_consumed_warm_start_is_not_unpacked_and_says_so():
    lat = wd.Lattice((30, 40), 8, weights=wd.weights.Uniform(r=10, seed=3))
    ref = np.array(wd.shortest_paths(lat, [[5, 5]], limit=80.0).dist)
    first = wd.shortest_paths(lat, [[5, 5]], limit=80.0)
    kept = wd.shortest_paths(lat, [[5, 5], [20, 30]], limit=60.0, warm_start=first)
    # without the private flag a warm start keeps its costs
    np.testing.assert_array_equal(first.dist, ref)
    spent = _search(lat, [[5, 5], [20, 30], [25, 2]], limit=50.0, warm_start=kept,
                              consume_warm_start=True)
    assert kept._fields.dist is None and kept._fields.spent
    with pytest.raises(RuntimeError, match="warm start"):
        kept.dist
    _check_against_scipy(lat, np.array([[5, 5], [20, 30], [25, 2]]), spent, limit=50.0)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems(), st.floats(-5.0, 40.0), st.floats(0.5, 30.0), st.floats(5.0, 60.0))
def test_band_and_point_reads_from_the_records_equal_the_unpacked_arrays(problem, low, width, limit):
    from wdendrite.sssp import band_nodes, read_states

    lat, gens = problem
    # a wide search then a warm start with a lower limit: the records keep words above the limit
    wide = wd.shortest_paths(lat, gens[:1], limit=2 * limit)
    cf = wd.shortest_paths(lat, gens, limit=limit, warm_start=wide)
    band = band_nodes(cf, low, low + width)  # read from the records, before any unpacking
    arrays = lat.device_arrays(cf.device)
    usable = np.ones(lat.shape, bool) if lat.mask is None else lat.mask
    nodes = np.argwhere(usable)  # (masked nodes are never read: their records hold no state)
    with arrays.stamps.lock:
        cost, label = read_states(arrays, lat.padded_indices(nodes), cf.limit)
    assert cf._fields.dist is None
    dist = cf.dist.reshape(-1)
    np.testing.assert_array_equal(band, np.flatnonzero((dist > low) & (dist < low + width)))
    assert band.dtype == np.int32
    assert cost.tobytes() == cf.dist[usable].tobytes() and label.tobytes() == cf.label[usable].tobytes()
    # and once more from a field packed back into records another search had taken
    wd.shortest_paths(lat, gens[::-1])
    np.testing.assert_array_equal(band_nodes(cf, low, low + width), band)


@pytest.mark.parametrize("shape,conn", [((67, 71), 8), ((9, 23, 29), 26)])
def test_passes_over_many_rows_split_mid_row_match_scipy(shape, conn):
    # whole-lattice passes (unpacking, band lists) give each CPU thread 4096 consecutive nodes,
    # a row at a time: here threads start and stop in the middle of rows and planes
    from wdendrite.lattice import pass_chunk
    from wdendrite.sssp import band_nodes

    assert math.prod(shape) > 4096 and 4096 % shape[-1] and pass_chunk("cpu") == 4096
    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=10, seed=8))
    gens = np.array([[s // 3 for s in shape], [s - 1 for s in shape]])
    cf = wd.shortest_paths(lat, gens, limit=90.0)
    band = band_nodes(cf, 20.0, 60.0)
    _check_against_scipy(lat, gens, cf, limit=90.0)
    flat = cf.dist.reshape(-1)
    np.testing.assert_array_equal(band, np.flatnonzero((flat > 20.0) & (flat < 60.0)))


def test_searches_reusing_a_lattices_frontiers_and_launches_equal_fresh_ones():
    # the records keep their frontier lists and recorded launches for the next search, which must
    # start from empty lists and give the kept launches its own limit and search id
    shape, dist = (30, 41), wd.weights.Uniform(r=10, seed=6)
    lat = wd.Lattice(shape, 8, weights=dist)
    runs = [([[2, 3]], 60.0, True), ([[20, 30], [5, 5]], np.inf, True), ([[2, 3]], 25.0, False),
            ([[29, 40]], 90.0, True), ([[2, 3]], 25.0, True), ([[10, 10]], 12.0, False)]
    for gens, limit, fifo in runs:
        kept = _search(lat, gens, limit=limit, fifo=fifo)
        fresh = _search(wd.Lattice(shape, 8, weights=dist), gens, limit=limit, fifo=fifo)
        assert kept.dist.tobytes() == fresh.dist.tobytes() and kept.label.tobytes() == fresh.label.tobytes()
        assert (kept.rounds, kept.relaxed) == (fresh.rounds, fresh.relaxed)
        # as a search stopped halfway (an interrupt) would leave them: the next one must not care
        frontiers = lat.device_arrays().scratch["search"][0]
        frontiers.counts.fill_(7)
        frontiers.far_min.fill_(-1.0)


def test_big_lattices_keep_no_search_buffers_between_searches(monkeypatch):
    from wdendrite.lattice import LatticeArrays

    monkeypatch.setattr(LatticeArrays, "SCRATCH_LIMIT", 100)  # bytes: every buffer here is bigger
    dist = wd.weights.Uniform(r=10, seed=6)
    lat = wd.Lattice((30, 41), 8, weights=dist)
    cf = wd.shortest_paths(lat, [[2, 3]], limit=60.0)
    den = wd.trace(cf, np.argwhere(np.isfinite(cf.dist))[:5])
    assert wd.endpoints.in_band(cf, 5, 30.0, 10.0, seed=1).shape == (5, 2)
    assert lat.device_arrays().scratch == {}
    again = wd.shortest_paths(lat, [[2, 3]], limit=60.0)
    assert again.dist.tobytes() == cf.dist.tobytes() and len(wd.trace(again, den.nodes[den.endpoints])) == len(den)


def test_a_searched_lattice_is_freed_by_reference_counting():
    # the records keep search buffers; nothing in them may point back, or every lattice's
    # records would wait for the cycle collector
    import gc
    import weakref

    gc.disable()
    try:
        lat = wd.Lattice((20, 30), 8, weights=wd.weights.Uniform(seed=2))
        cf = wd.shortest_paths(lat, [[3, 4]])
        cf = wd.shortest_paths(lat, [[3, 4], [10, 20]], warm_start=cf)
        den = wd.trace(cf, [[19, 29], [0, 29]])
        records = weakref.ref(lat.device_arrays())
        assert "search" in records().scratch and "rows" in records().scratch
        del lat, cf, den
        assert records() is None
    finally:
        gc.enable()


@pytest.mark.parametrize("device", ["cuda:7", "gpu", 3] + ([] if wp.get_cuda_device_count() else ["cuda", "cuda:0"]))
def test_an_absent_device_is_a_value_error_naming_it(device):
    with pytest.raises(ValueError, match="'device'"):
        wd.shortest_paths(wd.Lattice((8, 8)), [[0, 0]], device=device)
    for ask in (wd.Lattice((8, 8)).device_arrays, wd.Lattice((8, 8)).search_bytes):  # (Warp's own error had shown)
        with pytest.raises(ValueError, match="'device'"):
            ask(device)


@pytest.mark.parametrize("limit", [True, "10"])
def test_limit_must_be_a_number(limit):
    with pytest.raises(TypeError, match="limit"):
        wd.shortest_paths(wd.Lattice((8, 8)), [[0, 0]], limit=limit)


def test_a_point_outside_whose_swap_is_outside_too_gets_no_hint():
    with pytest.raises(ValueError) as info:
        wd.shortest_paths(LAT, [[0, 7]])  # (7, 0) lies outside as well
    assert str(info.value).endswith("lies outside the lattice of shape (6, 7)")


def test_a_cost_field_cannot_be_remade_by_replace():
    # the copy had shared the records' costs, then failed to read them with an internal error
    import copy
    import dataclasses

    lat = wd.Lattice((8, 9))
    cf = wd.shortest_paths(lat, [[0, 0]])
    for change in ({}, {"limit": 5.0}):
        with pytest.raises(TypeError, match="cannot be remade with dataclasses.replace"):
            dataclasses.replace(cf, **change)
    twin = copy.copy(cf)
    assert np.array_equal(twin.dist, cf.dist) and twin.dist[7, 8] == 15.0


@pytest.mark.parametrize("chunk", [1, 7])
def test_the_gpus_launch_shapes_give_the_cpus_results(chunk, monkeypatch):
    # what a CUDA device runs, here on the CPU: one node (or a few) per thread in whole-lattice
    # passes, generation rounds driven from the host over many threads, counts read back
    import wdendrite.lattice as wl
    import wdendrite.sssp as ws

    masks = [None, np.zeros((40, 45), bool)]
    masks[1][5:9, 3:30] = True  # sparse: few usable nodes
    lats = [wd.Lattice((40, 45), 8, weights=wd.weights.Uniform(r=5, seed=3), mask=m) for m in masks]
    gens = [np.array([[0, 3], [39, 44]]), np.array([[6, 4]])]
    refs = [(wd.shortest_paths(lat, g), wd.shortest_paths(lat, np.vstack([g, [[7, 20]]]))) for lat, g in zip(lats, gens)]
    bands = [ws.band_nodes(warm, 1.0, 9.0) for _, warm in refs]
    monkeypatch.setattr(wl, "pass_chunk", lambda device: chunk)
    monkeypatch.setattr(ws, "pass_chunk", lambda device: chunk)
    real_init = ws._Frontiers.__init__

    def gpu_like(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        self._cpu = False  # counts through read-backs and set_count_kernel, as on a GPU

    monkeypatch.setattr(ws._Frontiers, "__init__", gpu_like)
    for (lat, g), (ref, ref_warm), band in zip(zip(lats, gens), refs, bands):
        lat = wd.Lattice(lat.shape, 8, weights=wd.weights.Uniform(r=5, seed=3), mask=lat.mask)  # fresh records
        cf = _search(lat, g, fifo=False, max_threads=5)
        _check_against_scipy(lat, g, cf)
        warm = _search(lat, np.vstack([g, [[7, 20]]]), warm_start=cf, fifo=False, max_threads=5)
        assert cf.dist.tobytes() == ref.dist.tobytes() and cf.label.tobytes() == ref.label.tobytes()
        assert warm.dist.tobytes() == ref_warm.dist.tobytes() and warm.label.tobytes() == ref_warm.label.tobytes()
        got = ws.band_nodes(warm, 1.0, 9.0)
        assert np.array_equal(got, band) and np.all(np.diff(got) > 0)
