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
    grid = np.stack(np.meshgrid(*[(np.arange(f) + s - n // 2) / n for f, s in zip(fine_shape, start)], indexing="ij"))
    u = _reference_u(fine_shape, len(lat.lengths), 17)
    for k in range(len(lat.lengths)):
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
