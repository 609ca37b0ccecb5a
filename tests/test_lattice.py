"""Lattice construction, half-offsets, weights layout, edges and bad input."""

import itertools

import numpy as np
import pytest
import warp as wp

import wdendrite as wd
from wdendrite.lattice import half_offsets


def test_half_offsets_take_an_integer_connectivity_only():
    with pytest.raises(TypeError, match="'connectivity', but got 8.0"):
        half_offsets(2, 8.0)
    assert len(half_offsets(2, np.int64(8))) == 4


@pytest.mark.parametrize("ndim,conn,k", [(2, 4, 2), (2, 8, 4), (3, 6, 3), (3, 26, 13)])
def test_half_offsets_cover_every_direction_once(ndim, conn, k):
    off = half_offsets(ndim, conn)
    assert off.shape == (k, ndim)
    full = {tuple(o) for o in off} | {tuple(-o) for o in off}
    expected = {
        o for o in itertools.product((-1, 0, 1), repeat=ndim)
        if any(o) and (conn in (8, 26) or sum(map(abs, o)) == 1)
    }
    assert full == expected and len(full) == 2 * k


def test_default_weights_are_edge_lengths():
    lat = wd.Lattice((3, 4, 5), connectivity=26)
    assert lat.weights.shape == (13, 3, 4, 5) and lat.weights.dtype == np.float32
    lengths = np.sqrt((lat.offsets**2).sum(1))
    np.testing.assert_allclose(lat.weights[:, 1, 2, 3], lengths, rtol=1e-6)
    assert not lat.weights.flags.writeable


def test_default_connectivity():
    assert wd.Lattice((4, 4)).connectivity == 4
    assert wd.Lattice((2, 4, 4)).connectivity == 6


def _brute_edges(lat):
    out = set()
    for idx in itertools.product(*map(range, lat.shape)):
        for k, o in enumerate(lat.offsets):
            nb = tuple(np.add(idx, o))
            if all(0 <= c < n for c, n in zip(nb, lat.shape)):
                if lat.mask is None or (lat.mask[idx] and lat.mask[nb]):
                    u = np.ravel_multi_index(idx, lat.shape)
                    v = np.ravel_multi_index(nb, lat.shape)
                    out.add((int(u), int(v), float(lat.weights[(k,) + idx])))
    return out


@pytest.mark.parametrize("shape,conn", [((4, 5), 4), ((4, 5), 8), ((3, 3, 4), 6), ((3, 3, 4), 26)])
def test_edges_match_brute_force(shape, conn):
    rng = np.random.default_rng(0)
    k = len(half_offsets(len(shape), conn))
    w = rng.uniform(1, 5, size=(k, *shape)).astype(np.float32)
    mask = rng.random(shape) > 0.2
    lat = wd.Lattice(shape, conn, weights=w, mask=mask)
    u, v, ww = lat.edges()
    assert set(zip(u.tolist(), v.tolist(), ww.astype(float).tolist())) == _brute_edges(lat)
    g = lat.to_csgraph()
    assert (g != g.T).nnz == 0 and g.nnz == 2 * len(u)


@pytest.mark.parametrize(
    "kwargs,exc,words",
    [
        (dict(shape=(5,)), ValueError, "rank"),
        (dict(shape=(2, 3, 4, 5)), ValueError, "rank"),
        (dict(shape=(0, 4)), ValueError, "(0, 4)"),
        (dict(shape=(-2, 4)), ValueError, "(-2, 4)"),
        (dict(shape=(2.5, 4)), TypeError, "shape"),
        (dict(shape=5), TypeError, "shape"),
        (dict(shape=(4, 4), connectivity=6), ValueError, "(4, 8)"),
        # floats, bools and text had been taken as a connectivity, or as true
        (dict(shape=(4, 4), connectivity=4.0), TypeError, "'connectivity', but got 4.0"),
        (dict(shape=(4, 4), connectivity=True), TypeError, "'connectivity', but got True"),
        (dict(shape=(4, 4), weights=wd.weights.Uniform(), store_weights="no"), TypeError,
         "'store_weights', but got 'no'"),
        (dict(shape=(4, 4), weights=wd.weights.Uniform(), store_weights=0), TypeError, "'store_weights', but got 0"),
        (dict(shape=(4, 4, 4), connectivity=8), ValueError, "(6, 26)"),
        (dict(shape=(4, 4), weights=np.ones((3, 4, 4))), ValueError, "(2, 4, 4)"),
        (dict(shape=(4, 4), weights=np.ones((4, 4, 4))), ValueError,  # (one plane per direction is a common slip)
         "(K = 2: one plane per undirected edge direction, connectivity 4 / 2, in the order of Lattice.offsets)"),
        (dict(shape=(4, 4), weights=np.ones((2, 4, 4), dtype=bool)), TypeError, "bool"),
        (dict(shape=(4, 4), weights=np.full((2, 4, 4), "a")), TypeError, "weights"),
        (dict(shape=(4, 4), weights=-np.ones((2, 4, 4))), ValueError, "-1.0"),
        (dict(shape=(4, 4), weights=np.full((2, 4, 4), np.nan)), ValueError, "NaN"),
        (dict(shape=(4, 4), weights=np.full((2, 4, 4), -np.inf)), ValueError, "NaN, -inf or too large"),
        # values float32 cannot hold are quoted as given, with the reason
        (dict(shape=(4, 4), weights=np.full((2, 4, 4), 1e39)), ValueError, "1e+39 (too large for float32)"),
        (dict(shape=(4, 4), weights=np.full((2, 4, 4), 1e-50)), ValueError, "1e-50 (too small for float32"),
        (dict(shape=(4, 4), mask=np.ones((4, 5), bool)), ValueError, "(4, 5)"),
        (dict(shape=(4, 4), mask=np.ones((4, 4))), TypeError, "mask"),
        (dict(shape=(4, 4), mask=np.full((4, 4), 255, np.uint8)), TypeError, "(from a 0/1 or 0/255 image, pass mask > 0)"),
    ],
)
def test_bad_input(kwargs, exc, words):
    with pytest.raises(exc) as info:
        wd.Lattice(**kwargs)
    assert words in str(info.value)


def test_lattices_beyond_int32_record_indices_are_refused_before_work():
    with pytest.raises(ValueError, match="int32"):
        wd.Lattice((1100, 1100, 1100), 26, weights=wd.weights.Uniform(seed=0), store_weights=False)


@pytest.mark.parametrize("shape, conn, stored", [((30000, 30000), 8, True), ((20000, 30000), 4, False),
                                                  ((900, 900, 900), 26, True), ((1280, 1280, 1280), 6, False)])
def test_a_lattice_too_large_for_int32_records_is_told_the_largest_that_fits(shape, conn, stored):
    import re

    from wdendrite.lattice import half_offsets, record_words

    w = None if stored else wd.weights.Uniform(seed=0)
    with pytest.raises(ValueError) as info:
        wd.Lattice(shape, conn, weights=w, store_weights=stored)
    side = int(re.search(r"has (\d+) nodes a side", str(info.value)).group(1))
    n_weights = len(half_offsets(len(shape), conn)) if stored else 0
    assert record_words((side,) * len(shape), n_weights) < 2**31 <= record_words((side + 1,) * len(shape), n_weights)
    assert ("store_weights=False" in str(info.value)) == stored


def test_outside_entries_are_ignored_and_filled():
    rng = np.random.default_rng(0)
    w = rng.uniform(1, 2, size=(4, 6, 7)).astype(np.float32)
    w[0][:, -1] = np.nan  # the (0, 1) edges leaving the right border
    w[1][-1, :] = 0.0  # the (1, 0) edges leaving the bottom border
    lat = wd.Lattice((6, 7), 8, weights=w)
    assert np.isfinite(lat.weights).all() and (lat.weights > 0).all()
    np.testing.assert_array_equal(lat.weights[0][:, -1], w[0][:, -2])
    k = [tuple(o) for o in lat.offsets.tolist()].index((1, 1))
    np.testing.assert_array_equal(lat.weights[k][:-1, :-1], w[k][:-1, :-1])


def test_zero_weights_on_usable_edges_are_refused_but_allowed_next_to_masked_nodes():
    w = np.ones((2, 4, 4), np.float32)
    w[0, 1, 1] = 0.0
    with pytest.raises(ValueError, match="positive on usable edges"):
        wd.Lattice((4, 4), weights=w)
    mask = np.ones((4, 4), bool)
    mask[1, 2] = False  # the zero edge (1, 1) -> (1, 2) now touches a masked node
    wd.Lattice((4, 4), weights=w, mask=mask)


def test_lattice_keeps_its_own_copy_of_the_weights():
    w = np.random.default_rng(2).uniform(1, 3, size=(2, 9, 11)).astype(np.float32)
    lat = wd.Lattice((9, 11), 4, weights=w)
    before = wd.shortest_paths(lat, [[4, 5]]).dist.copy()
    w[:] = 100.0  # the caller's array changes afterwards; the lattice does not
    assert (lat.weights < 3).all() and not lat.weights.flags.writeable
    np.testing.assert_array_equal(wd.shortest_paths(lat, [[4, 5]]).dist, before)
    with pytest.raises(ValueError):
        lat.weights[0, 0, 0] = 1.0


@pytest.mark.parametrize("shape,conn", [((7, 10), 8), ((5, 6, 7), 26)])
def test_records_copied_for_another_device_search_the_same(shape, conn):
    # other devices get a copy of the host records with the search state cleared;
    # the copy is made here on the CPU, after searches left state and stamps behind
    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=5, seed=1))
    gens = [[0] * len(shape), [n - 1 for n in shape]]
    ref = wd.shortest_paths(lat, gens)
    wd.shortest_paths(lat, gens[:1])
    host = lat.device_arrays("cpu")
    copy = lat._copied_arrays(wp.get_device("cpu"))
    rec_h = host.records.numpy().reshape(-1, host.stride)
    rec_c = copy.records.numpy().reshape(-1, copy.stride)
    weights = slice(2, 2 + host.n_weights)
    np.testing.assert_array_equal(rec_c[:, weights], rec_h[:, weights])
    assert not rec_c[:, :2].any() and not rec_c[:, 2 + host.n_weights:].any()
    lat._device_arrays["cpu"] = copy
    again = wd.shortest_paths(lat, gens)
    assert again.dist.tobytes() == ref.dist.tobytes() and again.label.tobytes() == ref.label.tobytes()


@pytest.mark.parametrize("kind", ["array", "distribution", "unstored", "masked"])
def test_lattices_pickle(kind):
    import pickle

    mask = None
    if kind == "array":
        w = np.random.default_rng(5).uniform(1, 4, size=(4, 12, 13)).astype(np.float32)
    else:
        w = wd.weights.Uniform(r=4, seed=5)
    if kind == "masked":
        mask = np.random.default_rng(1).random((12, 13)) < 0.15
        mask[6, 6] = True
    lat = wd.Lattice((12, 13), 8, weights=w, mask=mask, store_weights=kind != "unstored")
    wd.shortest_paths(lat, [[6, 6]])  # the original holds device arrays by now
    copy = pickle.loads(pickle.dumps(lat))
    assert copy.stores_weights == lat.stores_weights and repr(copy) == repr(lat)
    a, b = wd.shortest_paths(lat, [[6, 6]]), wd.shortest_paths(copy, [[6, 6]])
    assert a.dist.tobytes() == b.dist.tobytes() and a.label.tobytes() == b.label.tobytes()


def test_infinite_weights_are_edges_never_taken():
    # +inf marks an edge no path takes (refined lattices hold them between unrelated blocks)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from wdendrite.lattice import edge_slices

    rng = np.random.default_rng(0)
    x = [k for k, off in enumerate(wd.Lattice((12, 12), 4).offsets.tolist()) if off == [0, 1]][0]
    w = (1 + rng.random((2, 12, 12))).astype(np.float32)
    w[x][:, 5] = np.inf  # the x-edges from column 5 to 6: a wall with one gap
    w[x][7, 5] = 1.0
    lat = wd.Lattice((12, 12), 4, weights=w)
    cf = wd.shortest_paths(lat, [[0, 0]])
    idx = np.arange(144).reshape(12, 12)
    ends = [edge_slices(off, (12, 12)) for off in lat.offsets]
    a = np.concatenate([idx[src].ravel() for src, _ in ends])
    b = np.concatenate([idx[dst].ravel() for _, dst in ends])
    c = np.concatenate([w[k][src].ravel() for k, (src, _) in enumerate(ends)]).astype(np.float64)
    keep = np.isfinite(c)
    ref = dijkstra(coo_matrix((c[keep], (a[keep], b[keep])), shape=(144, 144)).tocsr(), directed=False, indices=0)
    np.testing.assert_allclose(cf.dist.ravel(), ref, rtol=1e-6)
    den = wd.trace(cf, [[0, 11]])
    crossing = [tuple(den.nodes[i]) for i in range(len(den)) if den.parent[i] >= 0
                and {den.nodes[i][1], den.nodes[den.parent[i]][1]} == {5, 6}]
    assert crossing and all(r == 7 for r, _ in crossing)


@pytest.mark.parametrize("bad", [np.nan, -np.inf, 0.0, -1.0])
def test_weights_along_an_axis_of_size_one_are_checked(bad):
    # such entries have no edge inside to stand in for them, and refinement interpolates them
    w = np.ones((4, 1, 8), np.float32)
    w[1] = bad  # direction (1, 0) leaves the single row everywhere
    with pytest.raises(ValueError, match="direction 1"):
        wd.Lattice((1, 8), 8, weights=w)
    w[1] = 2.0
    np.testing.assert_array_equal(wd.Lattice((1, 8), 8, weights=w).weights[1], 2.0)


@pytest.mark.parametrize("shape,conn", [((67, 71), 8), ((9, 23, 29), 26), ((5, 40, 33), 6)])
@pytest.mark.parametrize("usable_share", [1.0, 0.6, 0.15])
def test_records_filled_from_a_distribution_equal_its_samples(shape, conn, usable_share):
    # the records' fill kernel visits every padded node, or the usable list of a sparse lattice,
    # and takes a shortcut for distributions without bias terms (scalars instead of the
    # parameter struct): every stored weight equals the distribution's own sample of that edge
    from wdendrite.lattice import _record_weights, fill_outside

    rng = np.random.default_rng(len(shape) * conn)
    mask = None if usable_share == 1.0 else rng.random(shape) < usable_share
    for dist in (wd.weights.Uniform(r=10, seed=3), wd.weights.Power(alpha=2.0, max=9.0, seed=4),
                 wd.weights.Uniform(r=4, seed=5) * wd.weights.Tropism("top", strength=2.0)):
        lat = wd.Lattice(shape, conn, weights=dist, mask=mask)
        arrays = lat.device_arrays("cpu")
        assert (arrays.usable is not None) == (usable_share < 0.25)
        got = _record_weights(arrays.records, arrays.padded_shape, arrays.stride, len(lat.offsets))
        want = fill_outside(dist.sample(shape, lat.lengths, offsets=lat.offsets), lat.offsets)
        usable = np.ones(shape, bool) if mask is None else mask
        padded = np.pad(usable, 1)  # (False outside: edges leaving the lattice are caught by ~inside below)
        for k, off in enumerate(lat.offsets):
            nb = tuple(slice(1 + o, n + 1 + o) for o, n in zip(off, shape))
            inside = np.ones(shape, bool)
            for axis, o in enumerate(off):
                idx = np.arange(shape[axis]) + o
                ok = (idx >= 0) & (idx < shape[axis])
                inside &= ok.reshape([-1 if a == axis else 1 for a in range(len(shape))])
            # stored: usable nodes whose neighbour is usable or outside the lattice
            stored = usable & (padded[nb] | ~inside)
            np.testing.assert_array_equal(got[k][stored], want[k][stored])
            assert (got[k][~usable] == 0).all()


def test_weights_across_an_axis_of_size_1_must_be_positive_and_the_message_says_why():
    # DESIGN: entries whose neighbour falls outside are ignored -- except along an axis of size 1,
    # where refinement interpolates them; the message must not leave a user guessing
    w = np.ones((2, 1, 5), np.float32)
    w[1] = 0.0  # direction (1, 0) leaves the 1 x 5 lattice everywhere
    with pytest.raises(ValueError, match=r"direction 1 \(1, 0\) leaves a lattice of shape \(1, 5\) along an axis "
                                         r"of size 1.*kept \(refinement interpolates them\)"):
        wd.Lattice((1, 5), 4, weights=w)
    w3 = np.ones((2, 3, 5), np.float32)
    w3[1, -1] = 0.0  # on a 3 x 5 lattice the outside row is ignored
    wd.Lattice((3, 5), 4, weights=w3)


def test_checking_mode_checks_a_lattice_and_stops_before_its_records():
    from wdendrite import _checks

    with _checks.checking_only():
        with pytest.raises(ValueError, match="connectivity"):
            wd.Lattice((16, 16), 5)
        with pytest.raises(ValueError, match="'r'"):
            wd.Lattice((16, 16), 8, weights=wd.weights.Uniform(r=-1.0))
        with pytest.raises(ValueError, match="2\\*\\*31"):
            wd.Lattice((30_000, 30_000), 8)  # too many record words for int32 indices
        with pytest.raises(_checks.Checked):
            wd.Lattice((2000, 2000), 8, weights=wd.weights.Uniform(seed=0))
    assert wd.Lattice((16, 16), 8).weights.shape == (4, 16, 16)  # outside it, lattices are built


def test_threads_asking_at_once_build_a_devices_arrays_once(monkeypatch):
    # (each thread had built its own records; searches stayed right, memory doubled)
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    lat = wd.Lattice((300, 300), 8, weights=wd.weights.Uniform(seed=1), store_weights=False)
    builds, real = [], wd.Lattice._make_arrays

    def counting(self, *args, **kwargs):
        builds.append(threading.get_ident())
        time.sleep(0.2)  # a build takes a while: the other threads ask meanwhile
        return real(self, *args, **kwargs)

    monkeypatch.setattr(wd.Lattice, "_make_arrays", counting)
    start = threading.Barrier(4)

    def search(i):
        start.wait()
        return wd.shortest_paths(lat, [[i, i]]).dist.copy()

    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(search, range(4)))
    assert len(builds) == 1
    for i, dist in enumerate(got):
        assert np.array_equal(dist, wd.shortest_paths(lat, [[i, i]]).dist)
