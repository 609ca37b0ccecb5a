"""refine(): paths on sublattices stay in the coarse path's blocks, end where the coarse ones do, 2D and 3D."""

import numpy as np
import pytest

import wdendrite as wd


def _coarse(shape, conn, ends, seed=1):
    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=10, seed=seed))
    cf = wd.shortest_paths(lat, [[s // 2 for s in shape]])
    return lat, wd.trace(cf, wd.endpoints.random(lat, ends, seed=seed))


@pytest.mark.parametrize("shape,conn,n", [((40, 40), 8, 7), ((40, 40), 4, 9), ((14, 14, 14), 6, 5), ((12, 12, 12), 26, 3)])
def test_refined_paths_follow_the_coarse_dendrite(shape, conn, n):
    lat, den = _coarse(shape, conn, 5)
    fine, flat = wd.refine(den, lat, n=n, e=0.75, seed=0)
    assert fine.spacing == pytest.approx(1.0 / n)
    # every fine node lies in the block of a coarse dendrite node or of an axis neighbour a diagonal step passes
    coarse_of = np.floor((fine.positions + 0.5 / n) + 1e-9).astype(int)
    near = np.abs(coarse_of[:, None, :] - den.nodes[None, :, :]).max(axis=2).min(axis=1)
    assert near.max() <= 1
    assert flat.mask[tuple(fine.nodes.T)].all()
    # roots and endpoints sit exactly on the coarse ones (block centres)
    np.testing.assert_allclose(np.sort(fine.positions[fine.roots], axis=0), np.sort(den.positions[den.roots], axis=0))
    want = {tuple(np.round(p, 6)) for p in den.positions[den.endpoints].tolist()}
    got = {tuple(np.round(p, 6)) for p in fine.positions[fine.endpoints].tolist()}
    assert got == want
    # a forest of unit fine steps, with costs in the coarse units
    child = np.flatnonzero(fine.parent >= 0)
    assert np.abs(fine.nodes[fine.parent[child]] - fine.nodes[child]).max() == 1
    ratio = fine.cost[fine.endpoints].sum() / den.cost[den.endpoints].sum()
    assert 0.3 < ratio < 3.0


def test_refinement_repeats_and_is_reproducible():
    lat, den = _coarse((30, 30), 8, 4)
    a, la = wd.refine(den, lat, n=3, seed=5)
    b, _ = wd.refine(den, lat, n=3, seed=5)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    twice, _ = wd.refine(a, la, n=3, seed=6)
    assert twice.spacing == pytest.approx(1.0 / 9)
    assert len(twice) > 2 * len(a)


@pytest.mark.parametrize("kwargs,words", [(dict(n=4), "odd"), (dict(n=1), "odd"), (dict(n=3.0), "odd"),
                                          (dict(e=0.5), "(0.5, 1)"), (dict(e=1.0), "(0.5, 1)"), (dict(e=0.2), "(0.5, 1)")])
def test_bad_refinement_parameters(kwargs, words):
    lat, den = _coarse((10, 10), 4, 2)
    with pytest.raises(ValueError) as info:
        wd.refine(den, lat, **kwargs)
    assert words in str(info.value)


def test_refine_needs_the_matching_lattice():
    lat, den = _coarse((10, 10), 4, 2)
    with pytest.raises(ValueError, match="shape"):
        wd.refine(den, wd.Lattice((11, 10)))


def test_refined_weights_follow_the_thesis_formula():
    # independent reference: SciPy's linear interpolation and the NumPy version of the hash
    from scipy.ndimage import map_coordinates

    from test_weights import _reference_u

    from wdendrite.refine import Refined

    lat = wd.Lattice((9, 11), 8, weights=wd.weights.Uniform(r=20, seed=2))
    n, e, start = 5, 0.7, (3, 4)
    per_length = (lat.weights / lat.lengths[:, None, None]).astype(np.float32)
    dist = Refined(per_length, n, e, start, seed=17)
    fine_shape = (20, 25)
    got = dist.sample(fine_shape, lat.lengths, offsets=lat.offsets)
    # the random part hashes a node's index in the whole fine lattice (the coarse shape times n)
    whole = _reference_u((9 * n, 11 * n), len(lat.lengths), 17)
    u = whole[:, start[0]:start[0] + fine_shape[0], start[1]:start[1] + fine_shape[1]]
    for k, off in enumerate(lat.offsets):
        # a weight sits at its edge's midpoint: the fine edge's, (i + o/2 - n//2) / n in coarse units,
        # is placed among the coarse edges' midpoints, j + o/2
        grid = np.stack(np.meshgrid(*[(np.arange(f) + s + o / 2 - n // 2) / n - o / 2
                                      for f, s, o in zip(fine_shape, start, off)], indexing="ij"))
        w_int = map_coordinates(per_length[k].astype(np.float64), grid, order=1, mode="nearest")
        w_ran = 1 + (np.maximum(w_int, 1) - 1) * u[k]
        want = (e * w_int + (1 - e) * w_ran) * lat.lengths[k] / n
        np.testing.assert_allclose(got[k], want, rtol=2e-5)


def test_boxes_too_large_for_stored_records_recompute_weights_in_the_kernels():
    # a corner-to-corner path refined 13 times: a 520^3 box, 26-connected, whose stored
    # records would pass int32 indices; its weights are then computed when relaxed
    lat = wd.Lattice((40, 40, 40), 26, weights=wd.weights.Uniform(r=10, seed=1))
    den = wd.trace(wd.shortest_paths(lat, [[0, 0, 0]]), [[39, 39, 39]])
    fine, fine_lat = wd.refine(den, lat, n=13, e=0.75)
    assert fine_lat.shape == (520, 520, 520) and not fine_lat.stores_weights
    assert len(fine.endpoints) == 1 and len(fine.roots) == 1
    steps = np.abs(fine.nodes[fine.parent[fine.parent >= 0]] - fine.nodes[fine.parent >= 0]).max(axis=1)
    assert steps.max() == 1


def test_a_block_of_the_coarse_weights_gives_the_same_fine_weights():
    # refined_lattice hands the kernels only the coarse nodes around the dendrite's box:
    # interpolation is still clamped at the whole coarse lattice's edge, so weights match
    from wdendrite.refine import Refined

    lat = wd.Lattice((12, 14), 8, weights=wd.weights.Uniform(r=20, seed=2))
    per_length = (lat.weights / lat.lengths[:, None, None]).astype(np.float32)
    n, e = 3, 0.8
    for lo, hi in [((0, 0), (5, 6)), ((4, 7), (12, 14)), ((3, 2), (9, 11))]:
        near_lo = np.maximum(np.array(lo) - 1, 0)
        near_hi = np.minimum(np.array(hi) + 1, lat.shape)
        block = per_length[:, near_lo[0]:near_hi[0], near_lo[1]:near_hi[1]]
        start = tuple(int(v) * n for v in lo)
        fine_shape = tuple((b - a) * n for a, b in zip(lo, hi))
        whole = Refined(per_length, n, e, start, seed=3).sample(fine_shape, lat.lengths, offsets=lat.offsets)
        part = Refined(block, n, e, start, seed=3, lo=tuple(near_lo), grid=lat.shape).sample(
            fine_shape, lat.lengths, offsets=lat.offsets)
        np.testing.assert_array_equal(part, whole)


def test_unstored_coarse_weights_give_the_same_refinement_as_stored_ones():
    kw = dict(shape=(24, 30), connectivity=8, weights=wd.weights.Uniform(r=10, seed=8))
    out = []
    for store in (True, False):
        lat = wd.Lattice(kw["shape"], kw["connectivity"], weights=kw["weights"], store_weights=store)
        den = wd.trace(wd.shortest_paths(lat, [[12, 15]]), [[0, 0], [23, 29], [0, 29]])
        out.append(wd.refine(den, lat, n=5, seed=1)[0])
    for f in ("nodes", "parent", "cost"):
        np.testing.assert_array_equal(getattr(out[0], f), getattr(out[1], f))


@pytest.mark.parametrize("kwargs,error,words", [
    (dict(n=2, e=0.75), ValueError, "odd"), (dict(n=3, e=-1.0), ValueError, "'e'"),
    (dict(n=3, e=0.75, seed=-2), ValueError, "'seed'"), (dict(n=3, e=0.75, seed=0.5), TypeError, "'seed'")])
def test_refined_lattice_checks_its_parameters_too(kwargs, error, words):
    from wdendrite.refine import refined_lattice

    lat, den = _coarse((10, 10), 4, 2)
    with pytest.raises(error) as info:
        refined_lattice(den, lat, **kwargs)
    assert words in str(info.value)
    if "seed" in kwargs:
        with pytest.raises(error, match="'seed'"):
            wd.refine(den, lat, seed=kwargs["seed"])


def test_refined_weights_check_their_parameters():
    from wdendrite.refine import Refined

    w = np.ones((4, 5, 5), np.float32)
    for kwargs, words in [(dict(n=4, e=0.75), "odd"), (dict(n=3, e=3.0), "'e'"),
                          (dict(n=3, e=0.75, lo=(4, 0), grid=(6, 6)), "does not lie inside"),
                          (dict(n=3, e=0.75, links=np.zeros((5, 4), np.int32)), r"'links' of shape \(5, 5\)"),
                          (dict(n=3, e=0.75, links=np.zeros((5, 5))), r"integer 'links'")]:
        with pytest.raises(ValueError, match=words):
            Refined(w, start=(0, 0), **kwargs)


def test_refined_nodes_keep_their_generation_and_their_generators_label():
    lat = wd.Lattice((40, 40), 8, weights=wd.weights.Uniform(r=10, seed=3))
    # generator rows in another order than their coordinates: a fine root's own row (its place among the
    # fine roots, sorted by coordinates) would not be the coarse label
    gens = [[31, 30], [8, 8], [30, 5]]
    den = wd.grow(lat, gens, wd.FractalParams(count=3, d=60.0, alpha=2.0, beta=2.0, epsilon=12.0), seed=1)
    assert den.generation.max() >= 2 and set(den.label.tolist()) == {0, 1, 2}
    n = 3
    fine, _ = wd.refine(den, lat, n=n, seed=2)
    # the coarse node a fine node stands over (world positions), when that is a dendrite node
    coarse = np.rint(fine.positions).astype(int)
    where = {tuple(v): i for i, v in enumerate(den.nodes.tolist())}
    rows = np.array([where.get(tuple(c), -1) for c in coarse.tolist()])
    on = rows >= 0
    assert on.mean() > 0.5
    np.testing.assert_array_equal(fine.generation[on], den.generation[rows[on]])
    # every fine node carries the label of the coarse generator its own path ends at
    root_of = {i: tuple(np.rint(fine.positions[fine.path(i)[-1]]).astype(int).tolist()) for i in range(len(fine))}
    want = np.array([gens.index(list(root_of[i])) for i in range(len(fine))])
    np.testing.assert_array_equal(fine.label, want)
    assert set(fine.label.tolist()) == {0, 1, 2}


@pytest.mark.parametrize("shape,conn", [((30, 34), 8), ((14, 16, 15), 26)])
def test_the_refined_lattice_weighs_edges_as_the_whole_coarse_array_would(shape, conn):
    # refined_lattice hands the kernels only the coarse nodes around the dendrite: every usable fine
    # edge must weigh what interpolating the whole coarse array gives (a margin too narrow fails this)
    from wdendrite.refine import Refined, refined_lattice

    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=10, seed=4))
    mid = [s // 2 for s in shape]
    ends = [[s // 2 + 3 for s in shape], [s // 2 - 3 for s in shape]]
    den = wd.trace(wd.shortest_paths(lat, [mid]), ends)
    fine_lat, *_ = refined_lattice(den, lat, n=5, e=0.7, seed=np.random.default_rng(9))
    per_length = (lat.weights / lat.lengths.reshape((-1,) + (1,) * lat.ndim)).astype(np.float32)
    dist = fine_lat.distribution
    assert dist.lo != (0,) * lat.ndim and dist.coarse.shape[1:] != lat.shape  # a block, away from the border
    whole = Refined(per_length, dist.n, dist.e, dist.start, seed=dist.seed).sample(fine_lat.shape, fine_lat.lengths,
                                                                                   offsets=fine_lat.offsets)
    # the edges searches use: both ends inside the box and usable
    from wdendrite.lattice import edge_slices

    for k, off in enumerate(fine_lat.offsets):
        src, dst = edge_slices(off, fine_lat.shape)
        used = fine_lat.mask[src] & fine_lat.mask[dst]
        assert used.sum() > 100
        got = fine_lat.weights[k][src][used]
        joined = np.isfinite(got)  # (crossings between blocks of unrelated nodes weigh inf)
        assert joined.mean() > 0.8
        np.testing.assert_array_equal(got[joined], whole[k][src][used][joined])


def test_refined_weights_refuse_a_window_beyond_their_block():
    from wdendrite.refine import Refined

    lat = wd.Lattice((12, 14), 8, weights=wd.weights.Uniform(r=20, seed=2))
    per_length = (lat.weights / lat.lengths[:, None, None]).astype(np.float32)
    part = Refined(per_length[:, 5:8, 5:8], 3, 0.8, (15, 15), lo=(5, 5), grid=(12, 14))
    # fine nodes 15-20 sit between coarse nodes 4.67 and 6.33: node 4 is not in the block
    with pytest.raises(ValueError, match=r"coarse nodes \(4, 4\) to \(7, 7\), but 'coarse' holds \(5, 5\) to \(7, 7\)"):
        part.sample((6, 6), lat.lengths, offsets=lat.offsets)
    inside = Refined(per_length[:, 4:8, 4:8], 3, 0.8, (15, 15), lo=np.array([4, 4]), grid=np.array([12, 14]))
    whole = Refined(per_length, 3, 0.8, (15, 15))
    np.testing.assert_array_equal(inside.sample((6, 6), lat.lengths, offsets=lat.offsets),
                                  whole.sample((6, 6), lat.lengths, offsets=lat.offsets))


def _stays_on_its_coarse_path(fine, den, n):
    """Every fine path lies in the blocks its own coarse path passes: a coarse node of the path,
    or a node inside the box of one of its steps (where a diagonal step's blocks meet)."""
    # the coarse node whose block holds each fine node (coarse node c covers fine positions
    # c - (n // 2) / n to c + (n // 2) / n)
    coarse_of = np.floor(fine.positions + (n // 2) / n + 1e-9).astype(int)
    index = {tuple(v): i for i, v in enumerate(den.nodes.tolist())}
    strays = 0
    for tip in fine.endpoints:
        row = index[tuple(coarse_of[tip].tolist())]
        steps = []
        while row >= 0:
            up = den.parent[row]
            a = den.nodes[row]
            b = den.nodes[up] if up >= 0 else a
            steps.append((np.minimum(a, b), np.maximum(a, b)))
            row = up
        lo = np.array([s[0] for s in steps])
        hi = np.array([s[1] for s in steps])
        for i in fine.path(tip):
            c = coarse_of[i]
            strays += not ((lo <= c) & (c <= hi)).all(axis=1).any()
    return strays


@pytest.mark.parametrize("conn", [4, 8])
def test_a_refined_path_keeps_to_its_own_coarse_path(conn):
    # thesis Fig 4.15 stitches consecutive blocks of each path only: branches lying side by side
    # must not trade paths (they had, on 6-35 % of paths), nor competing dendrites their endpoints
    lat = wd.Lattice((30, 30), conn, weights=wd.weights.Uniform(r=10, seed=35))
    den = wd.trace(wd.shortest_paths(lat, [[15, 15]]), [[0, 0], [0, 8], [29, 3], [4, 29], [28, 27]])
    fine, _ = wd.refine(den, lat, n=3, seed=0)
    assert _stays_on_its_coarse_path(fine, den, 3) == 0
    gens = [[25, 10], [25, 40], [5, 25], [45, 25]]
    lat = wd.Lattice((50, 50), conn, weights=wd.weights.Uniform(r=10, seed=0))
    grown = wd.grow(lat, gens, wd.FractalParams(count=8, d=30.0, alpha=1.5, beta=3.0, epsilon=4.0), seed=0)
    fine, _ = wd.refine(grown, lat, n=3)
    assert _stays_on_its_coarse_path(fine, grown, 3) == 0
    label_at = {tuple(grown.nodes[i] * 3 + 1): grown.label[i] for i in grown.endpoints}
    assert [label_at[tuple(fine.nodes[i])] for i in fine.endpoints] == fine.label[fine.endpoints].tolist()


def test_a_refined_path_keeps_to_its_own_coarse_path_in_3d():
    lat, den = _coarse((14, 14, 14), 26, 12)
    fine, _ = wd.refine(den, lat, n=3, seed=0)
    assert _stays_on_its_coarse_path(fine, den, 3) == 0


def test_blocks_join_only_along_the_dendrites_steps():
    # 4-connected: no diagonal steps, so the blocks are the dendrite's nodes alone; a fine edge
    # between two blocks is usable (finite) exactly when one block's node is the other's parent
    from wdendrite.lattice import edge_slices

    lat, den = _coarse((24, 24), 4, 6)
    from wdendrite.refine import refined_lattice

    fine_lat, *_ = refined_lattice(den, lat, n=3, e=0.7)
    start = np.asarray(fine_lat.distribution.start)
    index = {tuple(v): i for i, v in enumerate(den.nodes.tolist())}
    pairs = {(i, p) for i, p in enumerate(den.parent) if p >= 0}
    grid = np.stack(np.meshgrid(*map(np.arange, fine_lat.shape), indexing="ij"), -1)
    seen = 0
    for k, off in enumerate(fine_lat.offsets):
        src, dst = edge_slices(off, fine_lat.shape)
        used = fine_lat.mask[src] & fine_lat.mask[dst]
        a = (grid[src][used] + start) // 3
        b = (grid[dst][used] + start) // 3
        w = fine_lat.weights[k][src][used]
        for ca, cb, wk in zip(a.tolist(), b.tolist(), w):
            if ca == cb:
                assert np.isfinite(wk)
                continue
            ia, ib = index[tuple(ca)], index[tuple(cb)]
            assert np.isfinite(wk) == ((ia, ib) in pairs or (ib, ia) in pairs), (ca, cb)
            seen += 1
    assert seen > 50


def test_whatever_masked_coarse_edges_hold_does_not_reach_the_fine_weights():
    # Lattice asks only usable edges for positive weights: edges touching masked nodes may hold
    # anything, and refinement must not interpolate it into the fine edges it uses
    mask = np.ones((20, 20), bool)
    mask[:, 10:] = False
    rng = np.random.default_rng(0)
    w = (1 + 10 * rng.random((2, 20, 20))).astype(np.float32)
    results = []
    for junk in (-50.0, 0.0, 1e6):
        wj = w.copy()
        wj[:, ~mask] = junk
        wj[0][:, 9] = junk  # x-edges from the last usable column into the wall
        lat = wd.Lattice((20, 20), 4, weights=wj, mask=mask)
        den = wd.trace(wd.shortest_paths(lat, [[0, 0]]), [[19, 9], [10, 9]])
        fine, fl = wd.refine(den, lat, n=5, seed=2)
        ok = np.isfinite(fl.weights) & (fl.weights > 0)
        results.append((fine.nodes, fl.weights[ok]))
        # usable fine edges all weigh more than 0 and no more than the usable coarse ones allow
        from wdendrite.lattice import edge_slices

        for k, off in enumerate(fl.offsets):
            src, dst = edge_slices(off, fl.shape)
            used = fl.mask[src] & fl.mask[dst]
            vals = fl.weights[k][src][used]
            vals = vals[np.isfinite(vals)]
            assert vals.min() > 0.1 / 5 and vals.max() <= 11.0 / 5 + 1e-5
    for nodes, weights in results[1:]:
        np.testing.assert_array_equal(nodes, results[0][0])
        np.testing.assert_array_equal(weights, results[0][1])


def _same_edges_in_both(la, lb) -> int:
    """Assert that the edges of refined lattice ``la``'s box usable in both ``la`` and ``lb`` (whose
    box holds ``la``'s) weigh the same in both; return how many were compared."""
    from wdendrite.lattice import edge_slices

    sa, sb = np.asarray(la.distribution.start), np.asarray(lb.distribution.start)
    box = tuple(slice(int(o), int(o) + s) for o, s in zip(sa - sb, la.shape))
    wb_box, mb = lb.weights[(slice(None),) + box], lb.mask[box]
    compared = 0
    for k, off in enumerate(la.offsets):
        src, dst = edge_slices(off, la.shape)
        use = la.mask[src] & la.mask[dst] & mb[src] & mb[dst]
        a, b = la.weights[k][src][use], wb_box[k][src][use]
        fin = np.isfinite(a) & np.isfinite(b)
        np.testing.assert_array_equal(a[fin], b[fin])
        compared += int(fin.sum())
    return compared


def test_a_nodes_fine_weights_do_not_depend_on_the_rest_of_the_dendrite():
    # the random part hashes the node's place in the whole fine lattice, not in the cropped box,
    # so refining a region alone gives that region's edges the weights they have in the whole
    lat = wd.Lattice((40, 40), 4, weights=wd.weights.Uniform(r=10, seed=1))
    cf = wd.shortest_paths(lat, [[20, 20]])
    _, la = wd.refine(wd.trace(cf, [[30, 30]]), lat, n=5, seed=3)
    _, lb = wd.refine(wd.trace(cf, [[30, 30], [2, 20]]), lat, n=5, seed=3)
    assert la.distribution.start != lb.distribution.start
    assert _same_edges_in_both(la, lb) > 500


def test_a_dendrite_on_masked_nodes_of_the_lattice_is_named_before_any_work():
    lat, den = _coarse((16, 16), 8, 3)
    mask = np.ones((16, 16), bool)
    mask[tuple(den.nodes[len(den) // 2])] = False
    with pytest.raises(ValueError, match=rf"'dendrite' row {len(den) // 2} = .* masked-out node of 'lattice'"):
        wd.refine(den, wd.Lattice((16, 16), 8, weights=lat.weights, mask=mask))


@pytest.mark.parametrize("n", [301, 2**31 + 1, np.int64(2**61 + 1), 46341])
def test_a_fine_box_beyond_the_kernels_names_n_before_any_work(n):
    lat = wd.Lattice((300, 300), 8, weights=wd.weights.Uniform(r=10, seed=1))
    den = wd.trace(wd.shortest_paths(lat, [[0, 0]]), [[299, 299]])
    with pytest.raises(ValueError, match=rf"'n' = {int(n)} makes a fine lattice of shape .* beyond the kernels"):
        wd.refine(den, lat, n=n)


def test_a_refined_lattice_pickles_grows_and_takes_new_weights_after_a_search():
    import copy
    import pickle

    lat, den = _coarse((20, 20), 8, 4)
    fine, fl = wd.refine(den, lat, n=3, seed=1)
    cf = wd.shortest_paths(fl, fine.nodes[fine.roots])  # (its distribution then caches device arrays)
    for twin in (pickle.loads(pickle.dumps(fl)), copy.deepcopy(fl)):
        again = wd.shortest_paths(twin, fine.nodes[fine.roots])
        assert again.dist.tobytes() == cf.dist.tobytes()
    # its inf crossings are edges never taken, which its users accept as such
    assert np.isposinf(fl.weights).any()
    same = fl.with_weights(fl.weights)
    assert wd.shortest_paths(same, fine.nodes[fine.roots]).dist.tobytes() == cf.dist.tobytes()
    grown = wd.grow(fl, fine.nodes[fine.roots], wd.FractalParams(count=4, d=1.5, alpha=2.0, beta=2.0, epsilon=0.5,
                                                                 cheap=0.5), start=fine, seed=0)
    assert len(grown) > len(fine) and fl.mask[tuple(grown.nodes.T)].all()


def test_entries_along_an_axis_of_size_one_are_interpolated():
    # the lattice keeps them (no edge inside stands in for them): refinement must use them
    w = np.ones((4, 20, 1), np.float32)
    lat0 = wd.Lattice((20, 1), 8)
    x = [k for k, off in enumerate(lat0.offsets.tolist()) if off == [0, 1]][0]
    w[x] = 50.0
    lat = wd.Lattice((20, 1), 8, weights=w * lat0.lengths[:, None, None])
    den = wd.trace(wd.shortest_paths(lat, [[0, 0]]), [[19, 0]])
    _, fl = wd.refine(den, lat, n=3, seed=0)
    xs = fl.weights[x][fl.mask]
    xs = xs[np.isfinite(xs)]
    # e W_int + (1 - e) W_ran with W_int = 50 per unit length and W_ran in [1, 50], over n = 3
    assert xs.min() > (0.75 * 50 + 0.25) / 3 - 1e-4


def test_fine_weights_by_the_border_do_not_depend_on_the_rest_of_the_dendrite():
    # entries beside the lattice's border take their surroundings' values: those must not
    # depend on which other nodes the dendrite has
    lat = wd.Lattice((40, 40), 8, weights=wd.weights.Uniform(r=10, seed=3))
    cf = wd.shortest_paths(lat, [[20, 0]])
    _, la = wd.refine(wd.trace(cf, [[2, 0]]), lat, n=3, seed=5)
    _, lb = wd.refine(wd.trace(cf, [[2, 0], [39, 0]]), lat, n=3, seed=5)
    assert _same_edges_in_both(la, lb) > 100


@pytest.mark.parametrize("shape, conn, n", [((20, 24), 8, 5), ((9, 10, 11), 26, 3), ((9, 10, 11), 6, 5)])
def test_refined_weights_computed_when_relaxed_equal_the_stored_ones(shape, conn, n):
    # a fine box too big for stored records has its weights computed in the search, edge by edge;
    # the same lattice with stored records must give the same costs and labels bit for bit
    from wdendrite.refine import refined_lattice

    lat = wd.Lattice(shape, conn, weights=wd.weights.Uniform(r=10, seed=6))
    far = tuple(s - 1 for s in shape)
    den = wd.trace(wd.shortest_paths(lat, [[0] * len(shape)]), [far, (0,) * (len(shape) - 1) + (shape[-1] - 1,)])
    fine_lat, roots, ends, _ = refined_lattice(den, lat, n=n, e=0.7, seed=2)
    assert fine_lat.stores_weights
    hashed = wd.Lattice(fine_lat.shape, conn, weights=fine_lat.distribution, mask=fine_lat.mask, store_weights=False)
    a = wd.shortest_paths(fine_lat, roots, device="cpu")
    b = wd.shortest_paths(hashed, roots, device="cpu")
    assert np.isfinite(a.dist).sum() > len(roots)
    np.testing.assert_array_equal(a.dist.view(np.uint32), b.dist.view(np.uint32))
    np.testing.assert_array_equal(a.label, b.label)
    # the stored records hold, on every edge between usable nodes, what the distribution's own
    # per-edge formula gives (sample(): one edge at a time, nothing shared between edges)
    from wdendrite.lattice import edge_slices

    stored = fine_lat.weights
    reference = fine_lat.distribution.sample(fine_lat.shape, fine_lat.lengths, offsets=fine_lat.offsets)
    for k, off in enumerate(fine_lat.offsets):
        head, tail = edge_slices(off, fine_lat.shape)
        both = fine_lat.mask[head] & fine_lat.mask[tail]
        assert both.any()
        np.testing.assert_array_equal(stored[k][head][both].view(np.uint32), reference[k][head][both].view(np.uint32))
